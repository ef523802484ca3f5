"""A TD3 actor's deterministic forward pass in numpy, for batch-1 acting without torch's per-call overhead.

A low-level step asks the actor for one action. For the ant's small MLP (29 -> 256 -> 256 -> 8) torch spends
most of such a call in its dispatcher and SB3's observation handling, not in arithmetic
(``benchmarks/ensemble_speed.py`` times both). :class:`NumpyActor` holds the actor's weights as float32 arrays
(exported from the torch actor by :meth:`NumpyActor.from_model`) and computes the same function: the
:class:`~antmaze_hirl.sb3_ext.extractors.RelativeGoalExtractor` features, the MLP heads (one for a plain TD3
actor, several for an :class:`~antmaze_hirl.sb3_ext.ensemble.EnsemblePolicy`, averaged), and SB3's rescaling
to the action space.

Its actions equal the torch path's up to float rounding (``tests/test_numpy_actor.py``), not bit for bit: MuJoCo
can amplify a last-bit difference into another rollout, so committed results made through torch replay only
through torch. It acts as a low-level controller (``__call__`` for one goal observation, ``act_batch`` for a
batch), so it can be passed as ``low_level=`` to the maze envs.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from torch import nn

from antmaze_hirl.sb3_ext.ensemble import BatchedMeanOfHeads, MeanOfHeads
from antmaze_hirl.sb3_ext.extractors import RelativeGoalExtractor

ACTIVATIONS = {nn.ReLU: "relu", nn.Tanh: "tanh"}
"""The torch activations the numpy path computes, by name."""


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, np.float32(0.0), out=x)


def _tanh(x: np.ndarray) -> np.ndarray:
    return np.tanh(x, out=x)


_FUNCTIONS = {"relu": _relu, "tanh": _tanh}


class NumpyActor:
    """A deterministic TD3 actor (one head or the mean of several) computed in numpy float32.

    Args:
        weights: Per linear layer, the heads' weights stacked ``(heads, out, in)``.
        biases: Per linear layer, the heads' biases stacked ``(heads, out)``.
        activations: Per linear layer, the activation after it: ``"relu"``, ``"tanh"`` or ``None``.
        quaternion_index: Where the torso quaternion sits in ``observation`` (the goal offset is rotated into
            the body's heading frame), or ``None`` to keep the offset in the world frame.
        action_low: The action space's lower bounds (squashed outputs in ``[-1, 1]`` are rescaled to them).
        action_high: The action space's upper bounds.

    Raises:
        ValueError: If the layer lists differ in length, a layer's heads disagree, or an activation is unknown.
    """

    def __init__(
        self,
        weights: Sequence[np.ndarray],
        biases: Sequence[np.ndarray],
        activations: Sequence[str | None],
        *,
        quaternion_index: int | None,
        action_low: np.ndarray,
        action_high: np.ndarray,
    ) -> None:
        if not len(weights) == len(biases) == len(activations) or not weights:
            raise ValueError(
                f"need one weight, bias and activation per layer, got {len(weights)}, {len(biases)}, {len(activations)}"
            )
        unknown = [name for name in activations if name is not None and name not in _FUNCTIONS]
        if unknown:
            raise ValueError(f"unknown activations {unknown}; the numpy actor computes {sorted(_FUNCTIONS)}")
        # Transposed once, so that a batch is (heads, rows, in) @ (heads, in, out).
        self.weights = [np.ascontiguousarray(np.asarray(w, dtype=np.float32).transpose(0, 2, 1)) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float32)[:, None, :] for b in biases]
        for index, (weight, bias) in enumerate(zip(self.weights, self.biases, strict=True)):
            if weight.shape[0] != bias.shape[0] or weight.shape[2] != bias.shape[2]:
                raise ValueError(f"layer {index}: weights {weight.shape} and biases {bias.shape} do not match")
        self.activations = list(activations)
        self.n_heads = self.weights[0].shape[0]
        self.quaternion_index = quaternion_index
        self.action_low = np.asarray(action_low, dtype=np.float32)
        self.action_high = np.asarray(action_high, dtype=np.float32)

    @classmethod
    def from_model(cls, model: Any) -> NumpyActor:
        """The numpy copy of an SB3 TD3 model's (or TD3 policy's) actor: weights exported from torch.

        Raises:
            ValueError: If the actor's features extractor is not a
                :class:`~antmaze_hirl.sb3_ext.extractors.RelativeGoalExtractor`, or its output network is not
                linear layers with ReLU/Tanh activations (or an action ensemble of such heads).
        """
        policy = getattr(model, "policy", model)
        actor = policy.actor
        extractor = actor.features_extractor
        if not isinstance(extractor, RelativeGoalExtractor):
            raise ValueError(
                f"the numpy actor computes RelativeGoalExtractor features, not {type(extractor).__name__}'s"
            )
        mu = actor.mu
        states = mu.head_states() if isinstance(mu, MeanOfHeads | BatchedMeanOfHeads) else [mu.state_dict()]
        layers = mu.heads[0] if isinstance(mu, MeanOfHeads) else mu
        if isinstance(mu, BatchedMeanOfHeads):
            order = [(name, name in mu.activations) for name in mu.order]
            modules = {name: mu.activations[name] for name in mu.activations}
        else:
            order = [(name, not isinstance(layer, nn.Linear)) for name, layer in layers.named_children()]
            modules = dict(layers.named_children())
        linear_names, activations = [], []
        for name, is_activation in order:
            if not is_activation:
                linear_names.append(name)
                activations.append(None)
                continue
            kind = ACTIVATIONS.get(type(modules[name]))
            if kind is None or not activations or activations[-1] is not None:
                raise ValueError(f"the numpy actor cannot compute layer {name} ({modules[name]}) of this actor")
            activations[-1] = kind
        weights = [np.stack([state[f"{n}.weight"].detach().cpu().numpy() for state in states]) for n in linear_names]
        biases = [np.stack([state[f"{n}.bias"].detach().cpu().numpy() for state in states]) for n in linear_names]
        if not policy.squash_output:
            raise ValueError("the numpy actor rescales squashed actions; this policy does not squash its output")
        return cls(
            weights,
            biases,
            activations,
            quaternion_index=extractor.quaternion_index,
            action_low=policy.action_space.low,
            action_high=policy.action_space.high,
        )

    def features(self, observations: dict[str, np.ndarray]) -> np.ndarray:
        """The extractor's features ``[observation, offset]`` for a batch of goal observations, float32 ``(n, d)``.

        As SB3, observations are cast to float32 first, so the heading and the rotation are computed in float32.
        """
        body = np.asarray(observations["observation"], dtype=np.float32)
        body = body.reshape(-1, body.shape[-1])
        desired = np.asarray(observations["desired_goal"], dtype=np.float32).reshape(-1, 2)
        achieved = np.asarray(observations["achieved_goal"], dtype=np.float32).reshape(-1, 2)
        offset = desired - achieved
        if self.quaternion_index is not None:
            w, x, y, z = (body[:, self.quaternion_index + k] for k in range(4))
            yaw = np.arctan2(np.float32(2) * (w * z + x * y), np.float32(1) - np.float32(2) * (y * y + z * z))
            cos, sin = np.cos(yaw), np.sin(yaw)
            offset = np.stack([cos * offset[:, 0] + sin * offset[:, 1], -sin * offset[:, 0] + cos * offset[:, 1]], 1)
        return np.concatenate([body, offset], axis=1)

    def squashed(self, features: np.ndarray) -> np.ndarray:
        """The heads' mean output in ``[-1, 1]`` for a batch of features, float32 ``(n, action_dim)``."""
        hidden = np.asarray(features, dtype=np.float32)[None]  # (1, rows, in): broadcast over the heads
        for weight, bias, activation in zip(self.weights, self.biases, self.activations, strict=True):
            hidden = hidden @ weight
            hidden += bias
            if activation is not None:
                hidden = _FUNCTIONS[activation](hidden)
        return hidden[0] if self.n_heads == 1 else hidden.mean(axis=0)

    def act_batch(self, observations: dict[str, np.ndarray]) -> np.ndarray:
        """Actions ``(n, action_dim)`` for goal observations with a leading axis of ``n`` rows."""
        squashed = self.squashed(self.features(observations))
        return self.action_low + np.float32(0.5) * (squashed + np.float32(1.0)) * (self.action_high - self.action_low)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The action for one goal observation, ``(action_dim,)``."""
        return self.act_batch(observation)[0]
