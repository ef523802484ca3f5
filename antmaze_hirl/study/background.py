"""The learner updates after mazes, run in a background thread while the participant plays on.

With a study's ``background_updates`` on, the page never waits between two mazes for an update (gradient
steps, a strategy's ensemble, an evaluation when one is due). At the end of maze ``k`` the session hands
:meth:`UpdateQueue.submit` a copy of the trainer as the maze ended, and the next maze starts at once with
the learner as it is. One worker thread per participant runs the updates in order, each on its copy
and starting from the weights of the update before it, so update ``k`` is the method's own update on
the data of mazes ``0..k``. At the end of each maze the session takes the updates that have finished
(:meth:`UpdateQueue.take`, without waiting) and moves the newest one's weights into the live trainer.

So the learner that plays a maze lags: by one maze when each update finishes within the next maze (the
usual case), by more when updates take longer than mazes (several participants on few cores). Each row
of ``episodes.csv`` records how many updates the learner that played it had had (``learner_updates``).
A trial's last maze waits for none of them either: the trial closes at once, and its queued updates, the
last maze's own and the final evaluation run after it, still in order, followed by the trial's last files
(:class:`~antmaze_hirl.study.session.TrialClosing`; the final evaluation is of the learner after every update,
as in the experiments).

Why not the trainer's own update: :meth:`~antmaze_hirl.dagger.DAggerTrainer.start_episode` runs a due
update before the next maze, which is the wait this module removes. The copies run the trainer's own
update code (``_update_if_due``); only when the result takes effect changes.
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
moves from an updated copy into the live strategy. The rest of a strategy's state (a gate's reference states
and outcomes, kept every step) stays the live one's."""

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
    """The update due after one maze (and its evaluation), on a copy of the trainer.

    Attributes:
        trainer: The copy (updated once :attr:`done`).
        row: The maze's row for ``episodes.csv``, with its evaluation columns once :attr:`done`.
        update_due: Whether an update was due after the maze (else only the evaluation, if any, runs).
        seconds: How long the update and evaluation took (``None`` until done).
    """

    def __init__(
        self,
        trainer: DAggerTrainer,
        row: dict[str, Any],
        evaluate: Callable[[Any], dict[str, Any]] | None,
        base: BackgroundUpdate | None,
    ) -> None:
        self.update_due = bool(trainer._update_due)
        self.trainer = detached_copy(trainer)
        trainer._update_due = False  # the live trainer's next start_episode() does not wait for it
        # A stream of its own for the strategy's draws (drawn once from the live one): the live episode and
        # the update never share random numbers.
        seed = int(trainer.streams.strategy.integers(2**63))
        self.trainer.streams = self.trainer.streams._replace(strategy=np.random.default_rng(seed))
        self.row = dict(row)
        self.seconds: float | None = None
        self.error: BaseException | None = None
        self._evaluate = evaluate
        self._base = base  # the update before this one, not yet in the live trainer when this copy was taken
        self._done = threading.Event()

    @property
    def done(self) -> bool:
        """Whether the update (and evaluation) has finished, or failed."""
        return self._done.is_set()

    def run(self) -> None:
        """Runs the update, from the weights of the update before it when those were not in the copy yet."""
        started = time.monotonic()
        try:
            if self._base is not None:
                self._base.apply_to(self.trainer)
                self._base = None
            self.trainer._update_if_due()
            if self._evaluate is not None:
                self.row.update(self._evaluate(self.trainer.learner))
        except BaseException as error:  # handed to the request that takes the result
            self.error = error
        self.seconds = time.monotonic() - started
        self._done.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Waits until :attr:`done`; whether it is."""
        return self._done.wait(timeout)

    def apply_to(self, target: DAggerTrainer) -> None:
        """Copies the updated learner and strategy models into ``target`` (the live trainer or a later copy).

        Deep copies, so that ``target`` shares no module with this update's copy, which a later update reads.
        """
        source = self.trainer
        memo: dict[int, Any] = {}
        vars(target.learner).update(copy.deepcopy(vars(source.learner), memo))
        _take_models(target.strategy, source.strategy, memo, set())
        target.updates, target.last_loss = source.updates, source.last_loss


def _take_models(target: Any, source: Any, memo: dict[int, Any], seen: set[int]) -> None:
    if id(target) in seen:
        return
    seen.add(id(target))
    for name in STRATEGY_MODELS:
        if name in vars(source):
            setattr(target, name, copy.deepcopy(getattr(source, name), memo))
    for name in NESTED_STRATEGIES:
        if name in vars(source):
            _take_models(getattr(target, name), getattr(source, name), memo, seen)


class UpdateQueue:
    """One participant's updates, run in order by one worker thread (started with the first update)."""

    def __init__(self) -> None:
        self._jobs: list[BackgroundUpdate] = []  # submitted and not yet taken, in order
        self._cond = threading.Condition()
        self._started = 0  # how many of _jobs the worker has begun
        self._stopping = False
        self._thread: threading.Thread | None = None

    def __len__(self) -> int:
        with self._cond:
            return len(self._jobs)

    def submit(
        self, trainer: DAggerTrainer, row: dict[str, Any], evaluate: Callable[[Any], dict[str, Any]] | None
    ) -> BackgroundUpdate:
        """Queues the update due after the maze that just ended in ``trainer`` (its copy is taken now)."""
        with self._cond:
            base = self._jobs[-1] if self._jobs else None  # not yet in the live trainer: the copy starts from it
            job = BackgroundUpdate(trainer, row, evaluate, base)
            self._jobs.append(job)
            if self._thread is None:
                self._thread = threading.Thread(target=self._work, name="study-updates", daemon=True)
                self._thread.start()
            self._cond.notify()
        return job

    def take(self, *, wait: bool = False) -> list[BackgroundUpdate]:
        """The finished updates from the front of the queue, in order (every one, after waiting, with ``wait``).

        Raises:
            RuntimeError: If an update failed (its error chained); it stays queued.
        """
        with self._cond:
            jobs = list(self._jobs)
        finished = []
        for job in jobs:
            if wait:
                job.wait()
            if not job.done:
                break
            if job.error is not None:
                raise RuntimeError(f"a background learner update failed: {job.error!r}") from job.error
            finished.append(job)
        with self._cond:
            del self._jobs[: len(finished)]
            self._started -= len(finished)
        return finished

    def pending(self) -> list[BackgroundUpdate]:
        """The updates submitted and not yet taken, in order."""
        with self._cond:
            return list(self._jobs)

    def stop(self) -> None:
        """Lets the update in progress finish, runs no other, and drops the queue (a restore runs them again)."""
        with self._cond:
            self._stopping = True
            self._cond.notify()
            thread = self._thread
        if thread is not None:
            thread.join()
        with self._cond:
            self._jobs.clear()
            self._started = 0

    def _work(self) -> None:
        while True:
            with self._cond:
                while not self._stopping and self._started >= len(self._jobs):
                    self._cond.wait()
                if self._stopping:
                    return
                job = self._jobs[self._started]
                self._started += 1
            job.run()
