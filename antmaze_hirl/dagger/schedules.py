"""Schedules of the expert mixing weight beta (1: expert only, 0: learner only)."""

from __future__ import annotations

import abc


class BetaSchedule(abc.ABC):
    """Maps the number of completed learner updates to beta in ``[0, 1]``."""

    @abc.abstractmethod
    def __call__(self, updates: int) -> float:
        """Beta after ``updates`` learner updates."""


class ExponentialBetaSchedule(BetaSchedule):
    """The paper's ``beta <- beta / d`` after every update: ``beta0 / d**updates``.

    Args:
        decay: ``d >= 1``.
        beta0: Initial beta in ``[0, 1]``.
    """

    def __init__(self, decay: float = 2.0, beta0: float = 1.0) -> None:
        if decay < 1:
            raise ValueError(f"decay d must be >= 1, got {decay}")
        if not 0 <= beta0 <= 1:
            raise ValueError(f"beta0 must lie in [0, 1], got {beta0}")
        self.decay = decay
        self.beta0 = beta0

    def __call__(self, updates: int) -> float:
        """Returns ``beta0 / decay**updates``."""
        return self.beta0 / self.decay**updates


class LinearBetaSchedule(BetaSchedule):
    """imitation's default: beta falls linearly from 1 to 0 over ``rampdown_updates`` updates."""

    def __init__(self, rampdown_updates: int) -> None:
        if rampdown_updates < 1:
            raise ValueError(f"rampdown_updates must be >= 1, got {rampdown_updates}")
        self.rampdown_updates = rampdown_updates

    def __call__(self, updates: int) -> float:
        """Returns ``max(0, 1 - updates / rampdown_updates)``."""
        return max(0.0, 1.0 - updates / self.rampdown_updates)
