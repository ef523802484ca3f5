"""What the DAgger trainer and the query strategies need of a learner, as protocols."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.dagger.features import EncodedBatch, ObservationEncoder


@runtime_checkable
class Learner(Protocol):
    """What the trainer needs of a learner (:class:`~antmaze_hirl.dagger.HighLevelPolicy`, ``interop.BCLearner``)."""

    def predict(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The learner's subgoal for ``observation``."""
        ...

    def fit_dataset(self, dataset: DemonstrationDataset, steps: int) -> Any:
        """Trains ``steps`` minibatch steps on the aggregated dataset."""
        ...


@runtime_checkable
class OffsetLearner(Protocol):
    """A learner whose normalised subgoal offsets the start-selecting strategies read and compare.

    :class:`~antmaze_hirl.dagger.HighLevelPolicy` is one.
    """

    encoder: ObservationEncoder

    def predict(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The learner's subgoal for ``observation``."""
        ...

    def fit_dataset(self, dataset: DemonstrationDataset, steps: int, indices: np.ndarray | None = None) -> Any:
        """Trains ``steps`` minibatch steps on the dataset (or the positions ``indices``, repeats allowed)."""
        ...

    def offsets(self, batch: EncodedBatch) -> np.ndarray:
        """Normalised ``(B, 2)`` subgoal offsets for an encoded batch."""
        ...

    def spawn(self, rng: np.random.Generator) -> OffsetLearner:
        """A fresh, untrained learner of the same settings (an ensemble member), initialised from ``rng``."""
        ...
