"""The aggregated DAgger dataset D of (observation, expert subgoal) pairs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from antmaze_hirl.dagger.features import EncodedBatch


@dataclass(frozen=True)
class Demonstration:
    """One expert label: the high-level observation and the subgoal the expert gave for it.

    Attributes:
        image: ``uint8 (3, H, W)`` bird's-eye image.
        state: ``float32`` state vector ``[agent_xy, goal_xy, body...]``.
        subgoal: Expert subgoal xy, metres.
        episode: Index of the training episode it came from.
        step: High-level step within that episode.
    """

    image: np.ndarray
    state: np.ndarray
    subgoal: np.ndarray
    episode: int
    step: int

    def __post_init__(self) -> None:
        if self.image.ndim != 3 or self.image.dtype != np.uint8:
            raise ValueError(f"image must be uint8 (3, H, W), got {self.image.dtype} {self.image.shape}")
        if self.state.ndim != 1 or self.state.shape[0] < 4:
            raise ValueError(f"state must be a vector of at least 4 values, got shape {self.state.shape}")
        if self.subgoal.shape != (2,) or not np.all(np.isfinite(self.subgoal)):
            raise ValueError(f"subgoal must be 2 finite values, got {self.subgoal!r}")

    @property
    def observation(self) -> dict[str, np.ndarray]:
        """The high-level observation dict."""
        return {"image": self.image, "state": self.state}


class DemonstrationDataset:
    """Aggregated labels with their encodings; samples can be removed (reward-based active learning)."""

    def __init__(self) -> None:
        self.demonstrations: list[Demonstration] = []
        self._grids: list[np.ndarray] = []
        self._vectors: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self.demonstrations)

    def add(self, demonstration: Demonstration, encoded: EncodedBatch) -> int:
        """Appends one demonstration with its one-row encoding; returns its index."""
        if len(encoded) != 1:
            raise ValueError(f"expected the encoding of one observation, got {len(encoded)}")
        self.demonstrations.append(demonstration)
        self._grids.append(encoded.grids[0])
        self._vectors.append(encoded.vectors[0])
        return len(self.demonstrations) - 1

    def remove(self, indices: list[int] | np.ndarray) -> None:
        """Drops the samples at ``indices``."""
        drop = set(int(index) for index in indices)
        keep = [index for index in range(len(self)) if index not in drop]
        self.demonstrations = [self.demonstrations[index] for index in keep]
        self._grids = [self._grids[index] for index in keep]
        self._vectors = [self._vectors[index] for index in keep]

    def episode_indices(self, episode: int) -> list[int]:
        """Indices of the samples from training episode ``episode``, in step order."""
        return [index for index, demo in enumerate(self.demonstrations) if demo.episode == episode]

    def encoded(self, indices: np.ndarray | None = None) -> EncodedBatch:
        """Encodings of all samples (or of ``indices``, repeats allowed)."""
        if len(self) == 0:
            raise ValueError("the dataset is empty")
        rows = range(len(self)) if indices is None else indices
        return EncodedBatch(np.stack([self._grids[i] for i in rows]), np.stack([self._vectors[i] for i in rows]))

    def agent_xy(self, indices: np.ndarray | None = None) -> np.ndarray:
        """Agent xy of all samples (or of ``indices``)."""
        rows = range(len(self)) if indices is None else indices
        return np.stack([self.demonstrations[i].state[:2].astype(np.float64) for i in rows])

    def subgoals(self, indices: np.ndarray | None = None) -> np.ndarray:
        """Expert subgoals of all samples (or of ``indices``)."""
        rows = range(len(self)) if indices is None else indices
        return np.stack([self.demonstrations[i].subgoal for i in rows])
