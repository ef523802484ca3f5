"""The parts of an uncertainty gate: ensemble disagreement, a threshold from a target query rate, a risk model.

:class:`~antmaze_hirl.dagger.strategies.GatedQuery` (method ``gated``) puts them together, as
ThriftyDAgger (Hoque et al., 2021) does for flat policies: the expert is asked where the learner's
bagged ensemble disagrees more than usual (novelty), or, optionally, where a learned classifier expects
the low level to miss the learner's subgoal (risk).
"""

from __future__ import annotations

from collections import deque

import numpy as np
import torch as th
from torch import nn

from antmaze_hirl.dagger.features import EncodedBatch


def disagreement(outputs: np.ndarray) -> np.ndarray:
    """How far ensemble members' normalised offsets ``(B, members, 2)`` lie from their mean, on average: ``(B,)``.

    The offsets are in units of the learner's ``subgoal_reach_m``, so 0.5 means the members' subgoals lie, on
    average, half a maximal subgoal step from their mean subgoal.
    """
    outputs = np.asarray(outputs, dtype=np.float64)
    return np.linalg.norm(outputs - outputs.mean(axis=1, keepdims=True), axis=-1).mean(axis=1)


class QuantileThreshold:
    """A gate threshold from a target query rate: the ``1 - target_rate`` quantile of reference scores.

    ThriftyDAgger sets its novelty threshold this way, so that about ``target_rate`` of the states the
    reference set stands for open the gate. Refit after every learner update (the scores fall as the
    learner improves, and the threshold follows them). Before the first fit the gate opens everywhere.

    Args:
        target_rate: The share of states that should open the gate, in ``(0, 1)``.

    Raises:
        ValueError: If ``target_rate`` is not in ``(0, 1)``.
    """

    def __init__(self, target_rate: float) -> None:
        if not 0.0 < target_rate < 1.0:
            raise ValueError(f"target_rate must be in (0, 1), got {target_rate!r}")
        self.target_rate = float(target_rate)
        self.value = -np.inf

    def fit(self, scores: np.ndarray) -> float:
        """Sets the threshold from reference ``scores`` (unchanged when there are none); returns it."""
        scores = np.asarray(scores, dtype=np.float64).reshape(-1)
        if scores.size:
            self.value = float(np.quantile(scores, 1.0 - self.target_rate))
        return self.value

    def opens(self, score: float) -> bool:
        """Whether ``score`` is above the threshold."""
        return bool(score > self.value)


class ReferenceStates:
    """The encoded states of the last ``size`` high-level steps, asked or not: the threshold's reference set.

    They stand for the states the gate will see next, which the aggregated data does not: the ensemble
    was trained on those, so it agrees there more than on the learner's own states.

    Args:
        size: How many recent states to keep.

    Raises:
        ValueError: If ``size`` is below 1.
    """

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError(f"reference size must be >= 1, got {size}")
        self.rows: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=size)

    def __len__(self) -> int:
        return len(self.rows)

    def add(self, encoded: EncodedBatch) -> None:
        """Keeps the states of ``encoded`` (dropping the oldest beyond ``size``)."""
        self.rows.extend(zip(encoded.grids, encoded.vectors, strict=True))

    def batch(self) -> EncodedBatch:
        """The kept states as one batch.

        Raises:
            ValueError: If none is kept.
        """
        if not self.rows:
            raise ValueError("no reference states yet")
        grids, vectors = zip(*self.rows, strict=True)
        return EncodedBatch(np.stack(grids), np.stack(vectors))


class RiskModel:
    """A small classifier of ``P(the low level fails to reach the subgoal)`` from the state and the subgoal.

    An MLP on the flattened agent-centred grid, the state vector and the subgoal's normalised offset,
    trained by binary cross-entropy on the executed steps' outcomes (``info["subgoal_reached"]``; a step
    that reached the goal counts as reached). It reads only what the observation holds.

    Args:
        rng: Seeds the initialisation (torch's global RNG is left as it was) and draws the minibatches.
        hidden: Width of the hidden layer (Adam at 1e-3 on minibatches of 64, as the learner's defaults).

    Raises:
        ValueError: If ``hidden`` is below 1.
    """

    def __init__(self, *, rng: np.random.Generator, hidden: int = 64) -> None:
        if hidden < 1:
            raise ValueError(f"hidden must be >= 1, got {hidden}")
        self.rng = rng
        self.hidden = hidden
        self.network: nn.Module | None = None  # built at the first fit, when the input size is known
        self.optimizer: th.optim.Optimizer | None = None

    @staticmethod
    def features(encoded: EncodedBatch, offsets: np.ndarray) -> np.ndarray:
        """The classifier's inputs: flattened grids, vectors and normalised subgoal offsets, ``(B, F)`` float32."""
        flat = encoded.grids.reshape(len(encoded), -1)
        return np.concatenate([flat, encoded.vectors, np.asarray(offsets).reshape(len(encoded), 2)], axis=1).astype(
            np.float32
        )

    def fit(self, features: np.ndarray, failed: np.ndarray, steps: int) -> float:
        """Runs ``steps`` Adam steps of binary cross-entropy; returns the mean loss of the last 10 (``nan``: none)."""
        if steps <= 0 or len(features) == 0:
            return float("nan")
        if self.network is None:
            with th.random.fork_rng(devices=[]):  # seed the initialisation without touching torch's global RNG
                th.manual_seed(int(self.rng.integers(2**31)))
                self.network = nn.Sequential(
                    nn.Linear(features.shape[1], self.hidden), nn.ReLU(), nn.Linear(self.hidden, 1)
                )
            self.optimizer = th.optim.Adam(self.network.parameters(), lr=1e-3)
        assert self.optimizer is not None
        inputs, targets = th.from_numpy(features), th.from_numpy(np.asarray(failed, dtype=np.float32))
        self.network.train()
        losses = []
        for _ in range(steps):
            index = th.from_numpy(self.rng.integers(len(features), size=min(64, len(features))))
            logits = self.network(inputs[index]).squeeze(-1)
            loss = nn.functional.binary_cross_entropy_with_logits(logits, targets[index])
            self.optimizer.zero_grad()
            loss.backward()
            self.optimizer.step()
            losses.append(loss.item())
        return float(np.mean(losses[-10:]))

    def predict(self, features: np.ndarray) -> np.ndarray:
        """Failure probabilities ``(B,)``; 0 before the first fit (no evidence of risk yet)."""
        if self.network is None:
            return np.zeros(len(features))
        self.network.eval()
        with th.no_grad():
            return th.sigmoid(self.network(th.from_numpy(features)).squeeze(-1)).numpy().astype(np.float64)
