"""The learner that fits a :class:`~antmaze_hirl.dagger.policy.SubgoalPolicy` to expert subgoals."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from torch import nn

from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.dagger.features import EncodedBatch, augment
from antmaze_hirl.dagger.network import direction_bins, next_cell_classes
from antmaze_hirl.dagger.policy import SubgoalPolicy

LEARNER_SETTINGS = ("learning_rate", "batch_size", "augment_symmetries")
"""The :class:`SubgoalLearner` settings stored in a saved policy's ``config``."""


class EncodingCache:
    """The policy inputs of a dataset's rows, encoded once per row.

    Keyed by the dataset's stable row ids, which removal never reuses, so entries stay right after
    labels are removed; a different dataset starts the cache afresh.
    """

    def __init__(self) -> None:
        self._dataset_key: str | None = None
        self._rows: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def encoded(self, policy: SubgoalPolicy, dataset: DemonstrationDataset, indices: np.ndarray | None) -> EncodedBatch:
        """Encodings of the dataset's rows (or of the positions ``indices``, repeats allowed).

        Raises:
            ValueError: If the dataset is empty.
        """
        if len(dataset) == 0:
            raise ValueError("the dataset is empty")
        if self._dataset_key != dataset.key:
            self._dataset_key, self._rows = dataset.key, {}
        ids = dataset.ids(indices)
        missing = [int(row) for row in dict.fromkeys(ids.tolist()) if row not in self._rows]
        if missing:
            new = policy.encoder.encode_observations(dataset.observations_by_id(missing))
            self._rows.update(zip(missing, zip(new.grids, new.vectors, strict=True), strict=True))
        return EncodedBatch(
            np.stack([self._rows[int(row)][0] for row in ids]), np.stack([self._rows[int(row)][1] for row in ids])
        )


class SubgoalLearner:
    """Adam on heading cross-entropy plus squared distance error, with random symmetries of the square.

    A ``"next_cell"`` policy is trained on cross-entropy over the cell each label's subgoal lies in instead.

    Args:
        policy: The policy it trains.
        rng: Draws minibatches and augmentations (torch's global RNG is not used).
        learning_rate: Adam step size.
        batch_size: Minibatch size of :meth:`fit`.
        augment_symmetries: Train on random rotations/mirrors of each sample.

    Raises:
        ValueError: If ``batch_size`` is below 1 or ``learning_rate`` is not positive.
    """

    def __init__(
        self,
        policy: SubgoalPolicy,
        *,
        rng: np.random.Generator,
        learning_rate: float = 1e-3,
        batch_size: int = 64,
        augment_symmetries: bool = True,
    ) -> None:
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        if not learning_rate > 0:
            raise ValueError(f"learning_rate must be > 0, got {learning_rate}")
        self.policy = policy
        self.rng = rng
        self.learning_rate = learning_rate
        self.batch_size = batch_size
        self.augment_symmetries = augment_symmetries
        # foreach: one kernel per update op over all tensors instead of a loop of small ones; the same
        # elementwise math, so the same weights bit for bit (benchmarks/trial_speed.py checks a trial's outcomes).
        self.optimizer = th.optim.Adam(policy.network.parameters(), lr=learning_rate, foreach=True)
        self.gradient_steps = 0
        self.cache = EncodingCache()

    def config(self) -> dict[str, Any]:
        """The training settings (stored with saved weights)."""
        return {
            "learning_rate": self.learning_rate,
            "batch_size": self.batch_size,
            "augment_symmetries": self.augment_symmetries,
        }

    def targets(self, agent_xy: np.ndarray, subgoals: np.ndarray) -> np.ndarray:
        """Training targets: expert offsets in units of ``subgoal_reach_m``, shortened to length 1 at most.

        For a ``"next_cell"`` policy: the ``(dx, dy)`` cell steps to the labels' cells
        (:meth:`SubgoalPolicy.cell_steps`), which the square's symmetries map as they map xy offsets.
        """
        if self.policy.head == "next_cell":
            return self.policy.cell_steps(agent_xy, subgoals)
        offsets = (subgoals - agent_xy) / self.policy.subgoal_reach_m
        lengths = np.linalg.norm(offsets, axis=1, keepdims=True)
        return (offsets / np.maximum(lengths, 1.0)).astype(np.float32)

    def fit(self, batch: EncodedBatch, targets: np.ndarray, steps: int) -> float:
        """Runs ``steps`` Adam steps on minibatches: cross-entropy on the heading bin plus squared distance error.

        Returns:
            The mean loss of the last 10 steps (``nan`` if ``steps`` is 0 or the batch is empty).
        """
        if steps <= 0 or len(batch) == 0:
            return float("nan")
        network = self.policy.network
        network.train()
        losses = []
        for _ in range(steps):
            index = self.rng.integers(len(batch), size=min(self.batch_size, len(batch)))
            minibatch = EncodedBatch(batch.grids[index], batch.vectors[index])
            labels = targets[index]
            if self.augment_symmetries:
                minibatch, labels = augment(
                    minibatch, labels, self.rng, planar_feature_dim=self.policy.planar_feature_dim
                )
            outputs = network(th.from_numpy(minibatch.grids), th.from_numpy(minibatch.vectors))
            if self.policy.head == "next_cell":
                loss = nn.functional.cross_entropy(outputs, th.from_numpy(next_cell_classes(labels)))
            else:
                logits, distance = outputs
                bins = th.from_numpy(direction_bins(labels, self.policy.n_directions))
                lengths = th.from_numpy(np.linalg.norm(labels, axis=1))
                loss = nn.functional.cross_entropy(logits, bins) + th.mean((distance - lengths) ** 2)
            self.optimizer.zero_grad()
            loss.backward()
            self.optimizer.step()
            losses.append(loss.item())
        self.gradient_steps += steps
        return float(np.mean(losses[-10:]))

    def fit_dataset(self, dataset: DemonstrationDataset, steps: int, indices: np.ndarray | None = None) -> float:
        """Runs :meth:`fit` on the dataset's labels (or the positions ``indices``, repeats allowed)."""
        targets = self.targets(dataset.agent_xy(indices), dataset.subgoals(indices))
        return self.fit(self.cache.encoded(self.policy, dataset, indices), targets, steps)
