"""Fine-tuning a warm-started off-policy model: policy-driven warm-up and a critic-only start.

A fine-tune copies an actor and a critic into a model with an empty replay buffer and, often, a new reward.
SB3 then does two things that undo the warm start:

- Until ``learning_starts`` it acts with uniformly random actions: the buffer the critic first learns from holds
  none of the warm actor's behaviour, and an ant flailing at random flips and falls (states the actor never meets).
- From the first gradient step the actor climbs a critic fitted to another actor and another reward.

:class:`WarmStartMixin` adds two options over SB3's TD3/DDPG (and SAC/TQC for the warm-up alone):

- ``warmup_actions="policy"``: before ``learning_starts`` act as after it, with the policy's own action
  (plus the algorithm's usual exploration: TD3's action noise, SAC's sampling) instead of a uniform one.
- ``actor_frozen_steps=N``: the model's first ``N`` gradient steps (SB3's ``_n_updates``, which a checkpoint
  keeps) update the critics and the critics' targets only; the actor, its Adam state and its target stay as
  they are, so the critic first fits the new reward under the actor it is about to improve. After the freeze
  the actor resumes with the Adam moments the warm start brought (fitted to another objective; with Adam's
  default beta2 of 0.999 they fade over about a thousand actor updates). That is left so on purpose: it is the
  state a fine-tune without the freeze starts from too, so the freeze changes when the actor starts to learn,
  not how.

Both are plain attributes of the model, so ``model.save`` keeps them and ``load`` restores them.
"""

from __future__ import annotations

import copy
import itertools
from typing import Any

import numpy as np
from stable_baselines3 import DDPG, SAC, TD3
from stable_baselines3.common.noise import ActionNoise
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from antmaze_hirl.sb3_ext.config import check_warm_start_options


class WarmStartMixin(OffPolicyAlgorithm):
    """Policy-driven warm-up and a critic-only start over an SB3 off-policy algorithm (mix in before it).

    Args:
        *args: The algorithm's arguments.
        warmup_actions: ``"uniform"`` (SB3's behaviour) or ``"policy"``: what the model does while
            ``num_timesteps < learning_starts``.
        actor_frozen_steps: Gradient steps, counted from the model's first (``_n_updates``), during which
            only the critics and their targets learn. TD3 and DDPG only (a SAC actor's entropy coefficient
            would drift while the actor it tunes stands still); 0 = SB3's behaviour.
        **kwargs: The algorithm's keywords.

    Raises:
        ValueError: On an unknown ``warmup_actions``, a negative ``actor_frozen_steps``, or
            ``actor_frozen_steps > 0`` on an algorithm other than TD3/DDPG.

    """

    def __init__(self, *args: Any, warmup_actions: str = "uniform", actor_frozen_steps: int = 0, **kwargs: Any) -> None:
        check_warm_start_options(warmup_actions, actor_frozen_steps)
        if actor_frozen_steps > 0 and not isinstance(self, TD3):
            raise ValueError(f"actor_frozen_steps is for TD3/DDPG; {type(self).__name__} does not support it")
        self.warmup_actions = warmup_actions
        self.actor_frozen_steps = int(actor_frozen_steps)
        super().__init__(*args, **kwargs)

    def _sample_action(
        self, learning_starts: int, action_noise: ActionNoise | None = None, n_envs: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        # SB3 acts uniformly while num_timesteps < learning_starts; a zero threshold makes it act as it does
        # after, with the same noise, clipping and scaling.
        return super()._sample_action(0 if self.warmup_actions == "policy" else learning_starts, action_noise, n_envs)

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        """SB3's ``train``, with the steps that fall in the first ``actor_frozen_steps`` leaving the actor alone."""
        frozen = min(gradient_steps, max(0, self.actor_frozen_steps - self._n_updates))
        if frozen > 0:
            self._train_critics_only(frozen, batch_size)
        if gradient_steps > frozen:
            super().train(gradient_steps - frozen, batch_size)
        if self.actor_frozen_steps > 0 and gradient_steps > 0:
            # The share of this call's steps that left the actor alone: 1 while frozen, 0 after, a fraction in the
            # call that crosses the boundary (a flag would call that call all frozen or all not).
            self.logger.record("train/actor_frozen", frozen / gradient_steps)

    def _train_critics_only(self, gradient_steps: int, batch_size: int) -> None:
        # SB3's own update, with the actor's parameters out of autograd: the actor loss still backpropagates
        # into the critic (whose optimiser clears those gradients before its next step, as always), the actor
        # gets no gradient, so Adam skips it (weights and moments unchanged). The actor target's Polyak step
        # and any running statistics are undone afterwards. The critic target moves as usual.
        actor, actor_target = self.actor, self.actor_target  # type: ignore[attr-defined]
        kept = (copy.deepcopy(actor.state_dict()), copy.deepcopy(actor_target.state_dict()))
        flags = [(parameter, parameter.requires_grad) for parameter in actor.parameters()]
        for parameter, _ in flags:
            parameter.requires_grad_(False)
        try:
            super().train(gradient_steps, batch_size)
        finally:
            for parameter, flag in flags:
                parameter.requires_grad_(flag)
            actor.load_state_dict(kept[0])
            actor_target.load_state_dict(kept[1])


class WarmStartTD3(WarmStartMixin, TD3):
    """SB3's TD3 with :class:`WarmStartMixin`'s options (``with_warm_start(TD3)``)."""


class WarmStartDDPG(WarmStartMixin, DDPG):
    """SB3's DDPG with :class:`WarmStartMixin`'s options (``with_warm_start(DDPG)``)."""


class WarmStartSAC(WarmStartMixin, SAC):
    """SB3's SAC with :class:`WarmStartMixin`'s options, the warm-up alone (``with_warm_start(SAC)``)."""


_WARM_STARTS: dict[type, type] = {TD3: WarmStartTD3, DDPG: WarmStartDDPG, SAC: WarmStartSAC}


def with_warm_start(algorithm: type[OffPolicyAlgorithm]) -> type[OffPolicyAlgorithm]:
    """``algorithm`` (TD3, DDPG, SAC, TQC, ...) with :class:`WarmStartMixin`'s options; the same class each call.

    The class is an attribute of this module under its own name (``WarmStartTD3``; another algorithm's class is
    made on its first call, ``WarmStartTQC``, with a number added where two algorithms share a name), so pickle,
    multiprocessing and Ray find it by reference.
    """
    made = _WARM_STARTS.get(algorithm)
    if made is None:
        name = f"WarmStart{algorithm.__name__}"
        for number in itertools.count(2):
            if name not in globals():
                break
            name = f"WarmStart{algorithm.__name__}{number}"
        made = type(name, (WarmStartMixin, algorithm), {"__module__": __name__, "__qualname__": name})
        globals()[name] = _WARM_STARTS[algorithm] = made
    return made


__all__ = ["WarmStartDDPG", "WarmStartMixin", "WarmStartSAC", "WarmStartTD3", "with_warm_start"]
