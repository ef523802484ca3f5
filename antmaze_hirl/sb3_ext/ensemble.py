"""Action ensembles of TD3 low-level policies, saved as one ordinary SB3 zip.

Against the ant's flips (issue 16): on the selection mazes, averaging the deterministic actions of
snapshots of *different* fine-tunes raised success and cut flips, where two snapshots of one run did not
raise the score (README "The ant in mazes"). Why is not measured; a guess is that each run rears the torso up
in its own states, and the mean damps a stride that only one member takes.

:class:`EnsemblePolicy` is SB3's TD3 ``MultiInputPolicy`` (with HER's action penalty, as the shipped
policies have) whose actor holds ``n_members`` output heads on one features extractor and acts with their
mean. Because it is a policy class, an ensemble is an SB3 ``TD3`` model like any other:
:func:`~antmaze_hirl.sb3_ext.loading.load_low_level` loads it, ``predict`` acts with it, and
:func:`~antmaze_hirl.sb3_ext.loading.policy_fingerprint` names it. :func:`build_ensemble` makes one from
member zips; a member may itself be an ensemble, whose heads then join the new one (so that a shipped ensemble
can take in a newly trained member without its own members' zips).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch as th
from stable_baselines3 import TD3
from stable_baselines3.td3.policies import Actor, MultiInputPolicy
from torch import nn

from antmaze_hirl.sb3_ext.action_penalty import ActionPenaltyPolicy
from antmaze_hirl.sb3_ext.loading import load_low_level, save_policy


class MeanOfHeads(nn.Module):
    """The mean of several heads' outputs on the same input.

    Args:
        heads: The heads (each maps features to a squashed action in ``[-1, 1]``).
    """

    def __init__(self, heads: Sequence[nn.Module]) -> None:
        super().__init__()
        self.heads = nn.ModuleList(heads)

    def forward(self, features: th.Tensor) -> th.Tensor:
        """Returns the heads' mean output, shape ``(batch, action_dim)``."""
        return th.stack([head(features) for head in self.heads]).mean(dim=0)


class EnsembleActor(Actor):
    """TD3's actor with ``n_members`` MLP heads, acting with their mean.

    The mean is taken in the squashed action space ``[-1, 1]``; SB3 maps it to the action space by an
    affine rescaling, so it equals the mean of the members' own actions.

    Args:
        *args: :class:`~stable_baselines3.td3.policies.Actor` arguments.
        n_members: Number of heads (>= 1).
        **kwargs: :class:`~stable_baselines3.td3.policies.Actor` keywords.
    """

    def __init__(self, *args: Any, n_members: int, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Same-shaped heads; their weights are loaded from the members afterwards.
        self.mu = MeanOfHeads([self.mu, *(copy.deepcopy(self.mu) for _ in range(n_members - 1))])
        self.n_members = n_members

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "n_members": self.n_members}


class EnsemblePolicy(ActionPenaltyPolicy):
    """TD3 ``MultiInputPolicy`` with HER's action penalty and an :class:`EnsembleActor`.

    The critic is an ordinary twin critic: :func:`build_ensemble` copies the first member's. Acting never
    uses it; it is there so that the zip stays a complete TD3 policy.

    Args:
        *args: :class:`~antmaze_hirl.sb3_ext.action_penalty.ActionPenaltyPolicy` arguments.
        n_members: Number of actor heads (>= 1).
        **kwargs: :class:`~antmaze_hirl.sb3_ext.action_penalty.ActionPenaltyPolicy` keywords.

    Raises:
        ValueError: If ``n_members`` < 1.
    """

    def __init__(self, *args: Any, n_members: int = 2, **kwargs: Any) -> None:
        if isinstance(n_members, bool) or not isinstance(n_members, int) or n_members < 1:
            raise ValueError(f"n_members must be an integer >= 1, got {n_members!r}")
        self.n_members = n_members  # read by make_actor, which the parent constructor calls
        super().__init__(*args, **kwargs)

    def make_actor(self, features_extractor: Any = None) -> EnsembleActor:
        """The actor with ``n_members`` heads."""
        actor_kwargs = self._update_features_extractor(self.actor_kwargs, features_extractor)
        return EnsembleActor(n_members=self.n_members, **actor_kwargs).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "n_members": self.n_members}


def build_ensemble(members: Sequence[str | Path], body: str = "ant") -> TD3:
    """An :class:`EnsemblePolicy` TD3 model acting with the mean action of the TD3 policies at ``members``.

    Args:
        members: Two or more TD3 (or DDPG) zips of ``body``, with the same network shape and features
            extractor (the critic of the first is kept). A member that is itself an ensemble contributes each
            of its heads in order, so the mean weighs every head alike: ``[a, ensemble(b, c)]`` acts as
            ``[a, b, c]``.
        body: The body the members were trained for.

    Returns:
        The model; save it with :func:`~antmaze_hirl.sb3_ext.loading.save_policy`.

    Raises:
        ValueError: With fewer than two members, a member that is not a TD3 policy, or members whose
            networks or features differ (naming the member).
    """
    if len(members) < 2:
        raise ValueError(f"an ensemble needs at least two member policies, got {len(members)}")
    models = [load_low_level(body, path) for path in members]
    first, first_kwargs = models[0], _policy_settings(models[0], members[0])
    for path, model in zip(members[1:], models[1:], strict=True):
        settings = _policy_settings(model, path)
        if settings != first_kwargs:
            raise ValueError(
                f"member {path} has policy settings {settings}, unlike {members[0]}'s "
                f"{first_kwargs}: every member needs the same networks and features"
            )
    heads = [head for model in models for head in _heads(model)]
    ensemble = EnsemblePolicy(
        first.observation_space,
        first.action_space,
        first.lr_schedule,
        n_members=len(heads),
        **first_kwargs,
    )
    for target, member_head in zip(ensemble.actor.mu.heads, heads, strict=True):
        target.load_state_dict(member_head.state_dict())
    ensemble.actor_target.load_state_dict(ensemble.actor.state_dict())
    ensemble.critic.load_state_dict(first.policy.critic.state_dict())
    ensemble.critic_target.load_state_dict(first.policy.critic_target.state_dict())
    first.policy = ensemble
    first.policy_class = EnsemblePolicy
    first.policy_kwargs = {**first_kwargs, "n_members": len(heads)}
    first._create_aliases()  # TD3's actor/critic attributes point into the new policy
    return first


def _policy_settings(model: Any, path: str | Path) -> dict[str, Any]:
    # The keywords an EnsemblePolicy needs to match a member: the member's own, with its action penalty.
    if not isinstance(model, TD3) or not isinstance(model.policy, MultiInputPolicy):
        raise ValueError(
            f"member {path} holds a {type(model).__name__} {type(model.policy).__name__}; "
            "ensembles average the actors of TD3 (or DDPG) MultiInputPolicy policies"
        )
    if any(True for _ in model.policy.actor.features_extractor.parameters()):
        raise ValueError(f"member {path} has a trained features extractor; the heads of an ensemble share one")
    # An ensemble member's head count is not a network setting: its heads are flattened into the new one.
    settings = {key: value for key, value in model.policy_kwargs.items() if key != "n_members"}
    return {**settings, "action_l2": getattr(model.policy, "action_l2", 0.0)}


def _heads(model: Any) -> list[nn.Module]:
    # An ensemble's heads in order; an ordinary actor's one output network.
    mu = model.policy.actor.mu
    return list(mu.heads) if isinstance(mu, MeanOfHeads) else [mu]


def save_ensemble(members: Sequence[str | Path], out: str | Path, body: str = "ant") -> Path:
    """Builds the ensemble of ``members`` (:func:`build_ensemble`) and saves it atomically at ``out``."""
    return save_policy(build_ensemble(members, body), out)
