"""Schedules of the expert mixing weight beta (1: expert only, 0: learner only)."""

from __future__ import annotations

import abc


class BetaSchedule(abc.ABC):
    """Maps the number of completed learner updates to beta in ``[0, 1]``."""

    @abc.abstractmethod
    def __call__(self, updates: int) -> float:
        """Beta after ``updates`` learner updates."""


class InverseDecayBetaSchedule(BetaSchedule):
    """The paper's ``beta <- beta / d`` after every update: ``beta0 / d**updates``.

    Not ``imitation``'s ``ExponentialBetaSchedule(decay_probability)``, which multiplies by a
    probability in ``(0, 1]``: ``d`` here divides, so ``d = 2`` is that class's ``0.5``.

    Args:
        decay: The paper's ``d >= 1``.
        beta0: Initial beta in ``[0, 1]``.

    Raises:
        ValueError: If ``decay < 1`` (naming ``imitation``'s convention when it lies in ``(0, 1)``) or
            ``beta0`` is outside ``[0, 1]``.
    """

    def __init__(self, decay: float = 2.0, beta0: float = 1.0) -> None:
        if 0 < decay < 1:
            raise ValueError(
                f"decay d must be >= 1 (beta is divided by d), got {decay}: imitation's ExponentialBetaSchedule "
                f"multiplies by decay_probability in (0, 1]; its {decay} is d = {1 / decay:g} here"
            )
        if not decay >= 1:
            raise ValueError(f"decay d must be >= 1, got {decay}")
        if not 0 <= beta0 <= 1:
            raise ValueError(f"beta0 must lie in [0, 1], got {beta0}")
        self.decay = decay
        self.beta0 = beta0

    def __call__(self, updates: int) -> float:
        """Returns ``beta0 / decay**updates`` (0.0 once that underflows).

        As ``beta0 * decay**-updates``: ``decay**updates`` itself overflows a float (d = 2 after 1,024
        updates, which ``reward_per_step``'s update per high-level step reaches within a trial), while the
        negative power underflows quietly to 0.0, the limit beta has long reached by then.
        """
        return self.beta0 * self.decay ** -float(updates)


class LinearBetaSchedule(BetaSchedule):
    """imitation's default: beta falls linearly from 1 to 0 over ``rampdown_updates`` updates."""

    def __init__(self, rampdown_updates: int) -> None:
        if rampdown_updates < 1:
            raise ValueError(f"rampdown_updates must be >= 1, got {rampdown_updates}")
        self.rampdown_updates = rampdown_updates

    def __call__(self, updates: int) -> float:
        """Returns ``max(0, 1 - updates / rampdown_updates)``."""
        return max(0.0, 1.0 - updates / self.rampdown_updates)
