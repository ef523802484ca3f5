"""The learner update after a maze, run in a background thread while the participant plays the next maze.

With a study's ``background_updates`` on, the page does not wait for the update (gradient steps, a
strategy's ensemble, an evaluation when one is due) between two mazes: :class:`BackgroundUpdate` copies
the trainer as the maze ended, runs the update that is due (and the evaluation) on the copy in a
thread, and the session moves the copy's new weights into the live trainer at the end of the next
maze (:meth:`BackgroundUpdate.apply_to`). The learner therefore lags one maze: maze ``k + 1`` is
played by the learner updated after maze ``k - 1``, not after maze ``k``. Each row of ``episodes.csv``
records the number of updates behind the learner that played it (``learner_updates``).

Why not the trainer's own update: :meth:`~antmaze_hirl.dagger.DAggerTrainer.start_episode` runs a due
update before the next maze, which is the wait this module removes. The copy runs the trainer's own
update code (``_update_if_due``), so the update is the method's; only when it takes effect changes.
"""

from __future__ import annotations

import copy
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from antmaze_hirl.dagger import DAggerTrainer

STRATEGY_MODELS = ("members", "risk_model", "threshold")
"""Attributes that a strategy's ``on_update`` sets (ensemble members, gating risk model and threshold): what
moves from the copy into the live strategy. The rest of a strategy's state (a gate's reference states and
outcomes, kept every step) stays the live one's."""

NESTED_STRATEGIES = ("inner", "ensemble")
"""Attributes holding a strategy's own parts (a gated strategy's inner strategy and ensemble)."""


def detached_copy(trainer: DAggerTrainer) -> DAggerTrainer:
    """A deep copy of ``trainer`` without its env and expert (``None`` on the copy): what an update needs."""
    env, expert = trainer.env, trainer.expert
    trainer.env = trainer.expert = None
    try:
        return copy.deepcopy(trainer)
    finally:
        trainer.env, trainer.expert = env, expert


class BackgroundUpdate:
    """The update due after a maze (and its evaluation), started at once on a copy of the trainer.

    Taking the update off the live trainer (its ``_update_due``) is what lets the next maze start at
    once; the update runs on the copy with a stream of its own for the strategy's draws (drawn once from
    the live stream), so the live episode and the update never share random numbers.

    Args:
        trainer: The live trainer, at the end of a maze.
        row: The maze's row for ``episodes.csv`` (evaluation columns are added to a copy).
        evaluate: ``learner -> evaluation columns``, called on the updated copy's learner; ``None`` when no
            evaluation is due.
    """

    def __init__(
        self,
        trainer: DAggerTrainer,
        row: dict[str, Any],
        evaluate: Callable[[Any], dict[str, Any]] | None,
    ) -> None:
        self.trainer = detached_copy(trainer)
        trainer._update_due = False  # the live trainer's next start_episode() does not wait for it
        seed = int(trainer.streams.strategy.integers(2**63))
        self.trainer.streams = self.trainer.streams._replace(strategy=np.random.default_rng(seed))
        self.row = dict(row)
        self.seconds: float | None = None
        self._evaluate = evaluate
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="study-background-update", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        started = time.monotonic()
        try:
            self.trainer._update_if_due()
            if self._evaluate is not None:
                self.row.update(self._evaluate(self.trainer.learner))
        except BaseException as error:  # handed to the request that waits for the result
            self._error = error
        self.seconds = time.monotonic() - started

    @property
    def done(self) -> bool:
        """Whether the thread has finished."""
        return not self._thread.is_alive()

    def result(self, timeout: float | None = None) -> dict[str, Any]:
        """Waits for the update; the maze's row with its evaluation columns.

        Raises:
            RuntimeError: If the update or evaluation failed (from the thread's error), or ``timeout`` passed.
        """
        self._thread.join(timeout)
        if self._thread.is_alive():
            raise RuntimeError(f"the background update is still running after {timeout} s")
        if self._error is not None:
            raise RuntimeError(f"the background learner update failed: {self._error!r}") from self._error
        return self.row

    def apply_to(self, live: DAggerTrainer) -> None:
        """Moves the copy's updated learner and strategy models into ``live`` (after :meth:`result`)."""
        vars(live.learner).update(vars(self.trainer.learner))
        _take_models(live.strategy, self.trainer.strategy, set())
        live.updates, live.last_loss = self.trainer.updates, self.trainer.last_loss


def _take_models(live: Any, updated: Any, seen: set[int]) -> None:
    if id(live) in seen:
        return
    seen.add(id(live))
    for name in STRATEGY_MODELS:
        if name in vars(updated):
            setattr(live, name, getattr(updated, name))
    for name in NESTED_STRATEGIES:
        if name in vars(updated):
            _take_models(getattr(live, name), getattr(updated, name), seen)
