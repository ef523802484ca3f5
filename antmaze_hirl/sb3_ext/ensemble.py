"""Action ensembles of TD3 low-level policies, saved as one ordinary SB3 zip.

Against the ant's flips in mazes: on the selection mazes, averaging the deterministic actions of
snapshots of *different* fine-tunes raised success and cut flips, where two snapshots of one run did not
raise the score (docs/results/ant-in-mazes.md). Why is not measured; a guess is that each run rears the torso up
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
from gymnasium import spaces as gym_spaces
from stable_baselines3 import TD3
from stable_baselines3.common.preprocessing import is_image_space
from stable_baselines3.td3.policies import Actor, MultiInputPolicy
from torch import nn

from antmaze_hirl.sb3_ext.action_penalty import ActionPenaltyPolicy
from antmaze_hirl.sb3_ext.loading import load_low_level, save_policy


class MeanOfHeads(nn.Module):
    """The mean of several heads' outputs on the same input, one head after another.

    Args:
        heads: The heads (each maps features to a squashed action in ``[-1, 1]``).
    """

    def __init__(self, heads: Sequence[nn.Module]) -> None:
        super().__init__()
        self.heads = nn.ModuleList(heads)

    def forward(self, features: th.Tensor) -> th.Tensor:
        """Returns the heads' mean output, shape ``(batch, action_dim)``."""
        return th.stack([head(features) for head in self.heads]).mean(dim=0)

    def head_states(self) -> list[dict[str, th.Tensor]]:
        """Each head's weights, as the state dict of one member's output network."""
        return [head.state_dict() for head in self.heads]

    def load_head_states(self, states: Sequence[dict[str, th.Tensor]]) -> None:
        """Loads one member output network's state dict into each head, in order."""
        _check_head_count(len(self.heads), states)
        for head, state in zip(self.heads, states, strict=True):
            head.load_state_dict(state)


class BatchedMeanOfHeads(nn.Module):
    """The same mean as :class:`MeanOfHeads`, with one batched matrix product per layer for all heads.

    An ensemble acts once per low-level step, on a batch of one: one small product per head and layer costs more in
    call overhead than in arithmetic, so batching the heads makes acting faster (docs/guides/low-level.md has the
    timings of ``benchmarks/ensemble_speed.py``). The sums are the same but may be rounded differently in the last
    bits, and MuJoCo rollouts amplify such differences (docs/results/ant-in-mazes.md); so it is a class of its own,
    chosen when the ensemble is built and recorded in its zip, and an ensemble saved with :class:`MeanOfHeads`
    (stage 5) acts exactly as before.

    Args:
        heads: Two or more heads of one structure: ``nn.Sequential`` of ``nn.Linear`` layers (with bias) and
            parameter-free elementwise activations, as SB3's actor output networks are.

    Raises:
        ValueError: If a head is not such an ``nn.Sequential``, or the heads differ in structure.
    """

    def __init__(self, heads: Sequence[nn.Module]) -> None:
        super().__init__()
        template = heads[0]
        if not isinstance(template, nn.Sequential):
            raise ValueError(f"batched heads must be nn.Sequential, got {type(template).__name__}")
        self.n_heads = len(heads)
        self.order: list[str] = []
        self.linear_names: list[str] = []
        self.activations = nn.ModuleDict()
        for name, layer in template.named_children():
            self.order.append(name)
            if isinstance(layer, nn.Linear):
                if layer.bias is None:
                    raise ValueError(f"batched heads need Linear layers with bias; layer {name} has none")
                self.linear_names.append(name)
            elif any(True for _ in layer.parameters()):
                raise ValueError(f"batched heads hold only Linear layers and activations; layer {name} is {layer}")
            else:
                self.activations[name] = copy.deepcopy(layer)
        states = [head.state_dict() for head in heads]
        _check_head_keys(template.state_dict(), states)
        self.weights = nn.ParameterList(
            [nn.Parameter(th.stack([state[f"{name}.weight"] for state in states])) for name in self.linear_names]
        )
        self.biases = nn.ParameterList(
            [nn.Parameter(th.stack([state[f"{name}.bias"] for state in states])) for name in self.linear_names]
        )

    def forward(self, features: th.Tensor) -> th.Tensor:
        """Returns the heads' mean output, shape ``(batch, action_dim)``."""
        hidden = features.unsqueeze(0).expand(self.n_heads, *features.shape)  # (heads, batch, in)
        # The layers in order, each an activation module or a (weight, bias) pair. Looked up once per call:
        # indexing a ParameterList and a ModuleDict per layer cost more than a batch-1 layer's arithmetic.
        # The same torch calls on the same tensors, so the same actions bit for bit.
        activations = self.activations._modules
        linear = iter(zip(self.weights, self.biases, strict=True))
        for name in self.order:
            activation = activations.get(name)
            if activation is not None:
                hidden = activation(hidden)
            else:
                weight, bias = next(linear)
                hidden = th.baddbmm(bias.unsqueeze(1), hidden, weight.transpose(1, 2))
        return hidden.mean(dim=0)

    def head_states(self) -> list[dict[str, th.Tensor]]:
        """Each head's weights, as the state dict of one member's output network."""
        return [self._head_state(index) for index in range(self.n_heads)]

    def _head_state(self, index: int) -> dict[str, th.Tensor]:
        return {
            key: tensor[index].detach().clone()
            for name, weight, bias in zip(self.linear_names, self.weights, self.biases, strict=True)
            for key, tensor in ((f"{name}.weight", weight), (f"{name}.bias", bias))
        }

    def load_head_states(self, states: Sequence[dict[str, th.Tensor]]) -> None:
        """Loads one member output network's state dict into each head, in order."""
        _check_head_count(self.n_heads, states)
        _check_head_keys(self._head_state(0), states)  # one head's layout, not a copy of every head
        with th.no_grad():
            for name, weight, bias in zip(self.linear_names, self.weights, self.biases, strict=True):
                weight.copy_(th.stack([state[f"{name}.weight"] for state in states]))
                bias.copy_(th.stack([state[f"{name}.bias"] for state in states]))


def _check_head_count(expected: int, states: Sequence[dict[str, th.Tensor]]) -> None:
    if len(states) != expected:
        raise ValueError(f"an ensemble of {expected} heads cannot load {len(states)} head states")


def _check_head_keys(template: dict[str, th.Tensor], states: Sequence[dict[str, th.Tensor]]) -> None:
    # Same layer names and shapes in every head; stacking would otherwise fail with a bare shape error.
    shapes = {key: tuple(tensor.shape) for key, tensor in template.items()}
    for index, state in enumerate(states):
        found = {key: tuple(tensor.shape) for key, tensor in state.items()}
        if found != shapes:
            raise ValueError(f"head {index} has layers {found}, unlike the ensemble's {shapes}")


class EnsembleActor(Actor):
    """TD3's actor with ``n_members`` MLP heads, acting with their mean.

    The mean is taken in the squashed action space ``[-1, 1]``; SB3 maps it to the action space by an
    affine rescaling, so it equals the mean of the members' own actions.

    Args:
        *args: :class:`~stable_baselines3.td3.policies.Actor` arguments.
        n_members: Number of heads (>= 1).
        batched_heads: Compute the heads with :class:`BatchedMeanOfHeads` (faster) instead of
            :class:`MeanOfHeads` (the default, so that zips saved before the option act as they did).
        **kwargs: :class:`~stable_baselines3.td3.policies.Actor` keywords.
    """

    def __init__(self, *args: Any, n_members: int, batched_heads: bool = False, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Same-shaped heads; their weights are loaded from the members afterwards.
        heads = [self.mu, *(copy.deepcopy(self.mu) for _ in range(n_members - 1))]
        self.mu = BatchedMeanOfHeads(heads) if batched_heads else MeanOfHeads(heads)
        self.n_members = n_members
        self.batched_heads = batched_heads
        space = self.observation_space
        # Whether SB3's preprocess_obs is only .float() on each key (see forward): a Dict of Box spaces, none
        # an image as preprocess_obs tells one.
        self.float_only_observations = isinstance(space, gym_spaces.Dict) and all(
            isinstance(sub, gym_spaces.Box) and not (self.normalize_images and is_image_space(sub))
            for sub in space.spaces.values()
        )

    def forward(self, obs: Any) -> th.Tensor:
        """The mean action (squashed) for a batch of observations, as SB3's ``Actor.forward``.

        SB3's ``extract_features`` first passes each observation through ``preprocess_obs``, which for a
        ``Dict`` of ``Box`` spaces that are not images is ``.float()`` after a dozen type and shape checks per
        key: a tenth of a batch-1 action's time. Where every space is such a ``Box``, this calls ``.float()``
        itself; the same tensors reach the same extractor, so the actions are the same bit for bit.
        """
        if self.float_only_observations:
            return self.mu(self.features_extractor({key: value.float() for key, value in obs.items()}))
        return super().forward(obs)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {
            **super()._get_constructor_parameters(),
            "n_members": self.n_members,
            "batched_heads": self.batched_heads,
        }


class EnsemblePolicy(ActionPenaltyPolicy):
    """TD3 ``MultiInputPolicy`` with HER's action penalty and an :class:`EnsembleActor`.

    The critic is an ordinary twin critic: :func:`build_ensemble` copies the first member's. Acting never
    uses it; it is there so that the zip stays a complete TD3 policy.

    Args:
        *args: :class:`~antmaze_hirl.sb3_ext.action_penalty.ActionPenaltyPolicy` arguments.
        n_members: Number of actor heads (>= 1).
        batched_heads: See :class:`EnsembleActor`; saved in the zip, so a loaded ensemble acts as it was built.
        **kwargs: :class:`~antmaze_hirl.sb3_ext.action_penalty.ActionPenaltyPolicy` keywords.

    Raises:
        ValueError: If ``n_members`` < 1.
    """

    def __init__(self, *args: Any, n_members: int = 2, batched_heads: bool = False, **kwargs: Any) -> None:
        if isinstance(n_members, bool) or not isinstance(n_members, int) or n_members < 1:
            raise ValueError(f"n_members must be an integer >= 1, got {n_members!r}")
        # Read by make_actor, which the parent constructor calls.
        self.n_members = n_members
        self.batched_heads = bool(batched_heads)
        super().__init__(*args, **kwargs)

    def make_actor(self, features_extractor: Any = None) -> EnsembleActor:
        """The actor with ``n_members`` heads."""
        actor_kwargs = self._update_features_extractor(self.actor_kwargs, features_extractor)
        return EnsembleActor(n_members=self.n_members, batched_heads=self.batched_heads, **actor_kwargs).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {
            **super()._get_constructor_parameters(),
            "n_members": self.n_members,
            "batched_heads": self.batched_heads,
        }


def build_ensemble(members: Sequence[str | Path], body: str = "ant", *, batched_heads: bool = True) -> TD3:
    """An :class:`EnsemblePolicy` TD3 model acting with the mean action of the TD3 policies at ``members``.

    Args:
        members: TD3 (or DDPG) zips of ``body`` holding two or more heads in all (one ensemble alone rebuilds
            it with another ``batched_heads``), with the same network shape and features
            extractor (the critic of the first is kept). A member that is itself an ensemble contributes each
            of its heads in order, so the mean weighs every head alike: ``[a, ensemble(b, c)]`` acts as
            ``[a, b, c]``.
        body: The body the members were trained for.
        batched_heads: Act with :class:`BatchedMeanOfHeads` (the default: faster) or, with ``False``, with
            :class:`MeanOfHeads`, as ensembles built before the option (stage 5) do. The two give the same
            mean up to float rounding, which can change MuJoCo rollouts.

    Returns:
        The model; save it with :func:`~antmaze_hirl.sb3_ext.loading.save_policy`.

    Raises:
        ValueError: With fewer than two heads in all, a member that is not a TD3 policy, or members whose
            networks or features differ (naming the member).
    """
    models = [load_low_level(body, path) for path in members]
    first, first_kwargs = models[0], _policy_settings(models[0], members[0])
    for path, model in zip(members[1:], models[1:], strict=True):
        settings = _policy_settings(model, path)
        if settings != first_kwargs:
            raise ValueError(
                f"member {path} has policy settings {settings}, unlike {members[0]}'s "
                f"{first_kwargs}: every member needs the same networks and features"
            )
    heads = [state for model in models for state in _head_states(model)]
    if len(heads) < 2:
        raise ValueError(f"an ensemble needs at least two member policies (heads), got {len(heads)}")
    ensemble = EnsemblePolicy(
        first.observation_space,
        first.action_space,
        first.lr_schedule,
        n_members=len(heads),
        batched_heads=batched_heads,
        **first_kwargs,
    )
    ensemble.actor.mu.load_head_states(heads)
    ensemble.actor_target.load_state_dict(ensemble.actor.state_dict())
    ensemble.critic.load_state_dict(first.policy.critic.state_dict())
    ensemble.critic_target.load_state_dict(first.policy.critic_target.state_dict())
    first.policy = ensemble
    first.policy_class = EnsemblePolicy
    first.policy_kwargs = {**first_kwargs, "n_members": len(heads), "batched_heads": batched_heads}
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
    # An ensemble member's head count and head layout are not network settings: its heads are flattened
    # into the new ensemble, which has a layout of its own.
    settings = {key: value for key, value in model.policy_kwargs.items() if key not in ("n_members", "batched_heads")}
    return {**settings, "action_l2": getattr(model.policy, "action_l2", 0.0)}


def _head_states(model: Any) -> list[dict[str, th.Tensor]]:
    # An ensemble's heads in order; an ordinary actor's one output network.
    mu = model.policy.actor.mu
    return mu.head_states() if isinstance(mu, (MeanOfHeads, BatchedMeanOfHeads)) else [mu.state_dict()]


def save_ensemble(
    members: Sequence[str | Path], out: str | Path, body: str = "ant", *, batched_heads: bool = True
) -> Path:
    """Builds the ensemble of ``members`` (:func:`build_ensemble`) and saves it atomically at ``out``."""
    return save_policy(build_ensemble(members, body, batched_heads=batched_heads), out)
