"""TD3/DDPG policy with HER's action L2 penalty on the actor (Andrychowicz et al. 2017; OpenAI baselines).

SB3's TD3 minimises ``-Q1(s, actor(s))`` only. With sparse rewards the ant's actor drifts to
saturated actions (every torque at +-1), where tanh's gradient vanishes and a deterministic policy
can lock the legs in a static pose for the whole horizon. HER's original DDPG adds
``action_l2 * mean(actor(s) ** 2)`` to the actor loss; here the critic's ``q1_forward`` (which SB3's
TD3 and DDPG use only for the actor loss) subtracts that term, so SB3's own ``train`` is unchanged.
"""

from __future__ import annotations

from typing import Any

import torch as th
from stable_baselines3.common.policies import ContinuousCritic
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.td3.policies import MultiInputPolicy


class ActionPenaltyCritic(ContinuousCritic):
    """Twin critic whose ``q1_forward`` (the actor's objective) is penalised by ``action_l2 * mean(a**2)``.

    Args:
        action_l2: Penalty weight (baselines' HER default: 1.0). 0 gives SB3's critic.
        **kwargs: :class:`~stable_baselines3.common.policies.ContinuousCritic` arguments.
    """

    def __init__(self, *, action_l2: float, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.action_l2 = action_l2

    def q1_forward(self, obs: th.Tensor, actions: th.Tensor) -> th.Tensor:
        """First critic's Q-value minus the action penalty, shape ``(batch, 1)``."""
        return super().q1_forward(obs, actions) - self.action_l2 * actions.pow(2).mean(dim=1, keepdim=True)


class ActionPenaltyPolicy(MultiInputPolicy):
    """SB3's TD3 ``MultiInputPolicy`` (also DDPG's) with :class:`ActionPenaltyCritic`.

    Args:
        *args: :class:`~stable_baselines3.td3.policies.MultiInputPolicy` arguments.
        action_l2: Weight of the actor's action penalty.
        **kwargs: :class:`~stable_baselines3.td3.policies.MultiInputPolicy` keywords.
    """

    def __init__(self, *args: Any, action_l2: float = 1.0, **kwargs: Any) -> None:
        if action_l2 < 0:
            raise ValueError(f"action_l2 must be >= 0, got {action_l2}")
        self.action_l2 = action_l2  # read by make_critic, which the parent constructor calls
        super().__init__(*args, **kwargs)

    def make_critic(self, features_extractor: BaseFeaturesExtractor | None = None) -> ActionPenaltyCritic:
        """The twin critic with the action penalty on ``q1_forward``."""
        critic_kwargs = self._update_features_extractor(self.critic_kwargs, features_extractor)
        return ActionPenaltyCritic(action_l2=self.action_l2, **critic_kwargs).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "action_l2": self.action_l2}
