"""The aggregated DAgger dataset D: raw (observation, expert subgoal) rows in arrays, removed by mask."""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from typing import Any

import numpy as np

from antmaze_hirl.envs.state_layout import STATE_LAYOUT


@dataclass(frozen=True)
class Demonstration:
    """One expert label: the high-level observation and the subgoal the expert gave for it.

    Attributes:
        image: ``uint8 (3, H, W)`` bird's-eye image.
        state: ``float32`` state vector (laid out as :data:`~antmaze_hirl.envs.state_layout.STATE_LAYOUT`).
        subgoal: Expert subgoal xy, metres.
        episode: Index of the training episode it came from.
        high_level_step: High-level step within that episode, from 0 (not the label's index: a gating
            strategy leaves steps unasked).
    """

    image: np.ndarray
    state: np.ndarray
    subgoal: np.ndarray
    episode: int
    high_level_step: int

    def __post_init__(self) -> None:
        if self.image.ndim != 3 or self.image.dtype != np.uint8:
            raise ValueError(f"image must be uint8 (3, H, W), got {self.image.dtype} {self.image.shape}")
        if self.state.ndim != 1 or self.state.shape[0] < STATE_LAYOUT.positions_dim:
            raise ValueError(
                f"state must be a vector of at least {STATE_LAYOUT.positions_dim} values, got shape {self.state.shape}"
            )
        if self.subgoal.shape != (2,) or not np.all(np.isfinite(self.subgoal)):
            raise ValueError(f"subgoal must be 2 finite values, got {self.subgoal!r}")

    @property
    def observation(self) -> dict[str, np.ndarray]:
        """The high-level observation dict."""
        return {"image": self.image, "state": self.state}


class DemonstrationDataset:
    """Aggregated labels in growing arrays; removal clears a keep mask (reward-based active learning).

    Rows are never changed or moved once added: each keeps a stable id (its storage row), so a learner
    may cache what it derives from a row (its encoding) under that id. Positions (``indices``) count the
    kept rows in the order they were added, as ``len`` does. Read accessors return read-only arrays.

    Attributes:
        key: A random name of this dataset, so caches keyed by row id tell it from another dataset.
    """

    def __init__(self) -> None:
        self.key = uuid.uuid4().hex
        self._size = 0  # storage rows in use, kept or removed
        self._kept = np.zeros(0, dtype=bool)
        self._images = np.zeros((0, 0, 0, 0), dtype=np.uint8)
        self._states = np.zeros((0, 0), dtype=np.float32)
        self._subgoals = np.zeros((0, 2), dtype=np.float64)
        self._episodes = np.zeros(0, dtype=np.int64)
        self._steps = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return int(np.count_nonzero(self._kept[: self._size]))

    def __setstate__(self, state: dict[str, Any]) -> None:
        # A copy (unpickled or deep-copied) may grow apart from its original: caches must not mix them up.
        self.__dict__.update(state)
        self.key = uuid.uuid4().hex

    def add(self, demonstration: Demonstration) -> int:
        """Appends one demonstration (copied); returns its position.

        Raises:
            ValueError: If its image or state shape differs from the rows already held.
        """
        if self._size == 0 and len(self._kept) == 0:
            self._allocate(demonstration, capacity=64)
        if demonstration.image.shape != self._images.shape[1:] or demonstration.state.shape != self._states.shape[1:]:
            raise ValueError(
                f"demonstration of image {demonstration.image.shape} and state {demonstration.state.shape} does not "
                f"match the dataset's image {self._images.shape[1:]} and state {self._states.shape[1:]}"
            )
        if self._size == len(self._kept):
            self._grow(2 * self._size)
        row = self._size
        self._images[row] = demonstration.image
        self._states[row] = demonstration.state
        self._subgoals[row] = demonstration.subgoal
        self._episodes[row] = demonstration.episode
        self._steps[row] = demonstration.high_level_step
        self._kept[row] = True
        self._size += 1
        return len(self) - 1

    def remove(self, indices: list[int] | np.ndarray) -> None:
        """Drops the rows at positions ``indices`` (clears their keep flags; nothing is copied).

        Raises:
            IndexError: If a position is outside ``[0, len)``.
        """
        positions = np.asarray(indices, dtype=np.int64).reshape(-1)
        if positions.size and (positions.min() < 0 or positions.max() >= len(self)):
            raise IndexError(f"positions to remove must lie in [0, {len(self)}), got {positions.tolist()}")
        self._kept[self.ids(positions)] = False

    def ids(self, indices: np.ndarray | list[int] | None = None) -> np.ndarray:
        """Stable row ids of the kept rows (or of the positions ``indices``, repeats allowed)."""
        kept = np.flatnonzero(self._kept[: self._size])
        return kept if indices is None else kept[np.asarray(indices, dtype=np.int64)]

    def episode_indices(self, episode: int) -> list[int]:
        """Positions of the rows from training episode ``episode``, in step order."""
        return np.flatnonzero(self.episodes == episode).tolist()

    def observations_by_id(self, ids: list[int] | np.ndarray) -> list[dict[str, np.ndarray]]:
        """The observation dicts of rows by stable id (removed rows included, for caches keyed by id)."""
        return [{"image": self._images[row], "state": self._states[row]} for row in ids]

    @property
    def images(self) -> np.ndarray:
        """``uint8 (n, 3, H, W)`` images of the kept rows."""
        return self._read(self._images)

    @property
    def states(self) -> np.ndarray:
        """``float32 (n, d)`` states of the kept rows."""
        return self._read(self._states)

    @property
    def episodes(self) -> np.ndarray:
        """Training episode of each kept row."""
        return self._read(self._episodes)

    @property
    def high_level_steps(self) -> np.ndarray:
        """High-level step (within its episode) of each kept row."""
        return self._read(self._steps)

    @property
    def demonstrations(self) -> list[Demonstration]:
        """The kept rows as :class:`Demonstration` objects (copies; for reading, not for changing D)."""
        return [
            Demonstration(
                self._images[row], self._states[row], self._subgoals[row], int(self._episodes[row]), int(step)
            )
            for row, step in zip(self.ids(), self.high_level_steps, strict=True)
        ]

    def agent_xy(self, indices: np.ndarray | None = None) -> np.ndarray:
        """Agent xy (float64) of the kept rows (or of the positions ``indices``)."""
        return STATE_LAYOUT.agent_xy(self._states[self.ids(indices)]).astype(np.float64)

    def subgoals(self, indices: np.ndarray | None = None) -> np.ndarray:
        """Expert subgoals of the kept rows (or of the positions ``indices``)."""
        return self._subgoals[self.ids(indices)]

    def _read(self, storage: np.ndarray) -> np.ndarray:
        rows = storage[self.ids()]
        rows.flags.writeable = False
        return rows

    def _allocate(self, first: Demonstration, capacity: int) -> None:
        self._kept = np.zeros(capacity, dtype=bool)
        self._images = np.zeros((capacity, *first.image.shape), dtype=np.uint8)
        self._states = np.zeros((capacity, *first.state.shape), dtype=np.float32)
        self._subgoals = np.zeros((capacity, 2), dtype=np.float64)
        self._episodes = np.zeros(capacity, dtype=np.int64)
        self._steps = np.zeros(capacity, dtype=np.int64)

    def _grow(self, capacity: int) -> None:
        # Doubling keeps appends amortised O(1); rows keep their storage index, hence their id.
        for name in ("_kept", "_images", "_states", "_subgoals", "_episodes", "_steps"):
            old = getattr(self, name)
            new = np.zeros((capacity, *old.shape[1:]), dtype=old.dtype)
            new[: len(old)] = old
            setattr(self, name, new)
