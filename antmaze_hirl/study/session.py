"""One participant working through a study plan: trials, episodes, labels, questionnaires, all saved as they happen.

A :class:`ParticipantSession` is the protocol's state machine, independent of HTTP: the server and the
tests drive it with :meth:`~ParticipantSession.start_trial`, :meth:`~ParticipantSession.label` and
:meth:`~ParticipantSession.submit_questionnaire`. Each trial is a :class:`~antmaze_hirl.dagger.DAggerTrainer`
driven by ask/tell (:meth:`~antmaze_hirl.dagger.DAggerTrainer.start_episode`), so a person's click
takes the oracle's place in the very loop the experiments run.

On disk, per participant (``DIR/participants/<id>/``), everything is written when it happens:

* ``clicks.jsonl``: every accepted click (appended and fsynced before the step runs);
* ``episodes.csv``: one row per finished episode (:data:`EPISODE_COLUMNS`);
* ``answers.jsonl``: one questionnaire per analysed trial;
* ``events.jsonl``: trial starts and ends, final updates written after a trial closed, pauses, resumptions
  after a restart;
* ``progress.json``: where the participant is (atomically replaced);
* ``trial<k>/checkpoint.pt``: the trainer after the last finished episode, and the background updates still
  queued (atomically replaced; :mod:`antmaze_hirl.study.checkpoint`: loading it cannot run code);
* ``trial<k>/demonstrations.npz``: every labelled step of the trial so far (for ``study export``);
* ``trial<k>/learner.zip``: the learner's weights after the trial's final update (with background updates
  written after the trial closed, last of its files: :class:`TrialClosing`).

The logs carry a checksum per line (:mod:`antmaze_hirl.study.logs`); the checkpoint starts with a
SHA-256 of its content. Every step writes its records before it changes the session's memory, and
``progress.json`` last: a failed write (a full disk) leaves memory and disk as they were, and files that
disagree (:mod:`antmaze_hirl.study.consistency`) stop the participant. With ``background_updates`` the
learner updates run while the next mazes are played (:mod:`antmaze_hirl.study.background`).
A server killed mid-episode (even ``kill -9``) restarts the participant from the
checkpoint: only the episode in progress is lost, and it is replayed on the same maze (the trainer's
random state is saved). On that restart a partial last line of a log (a crash inside an append) is cut
off and the cut logged as a ``torn_tail_trimmed`` event. A damaged or missing checkpoint, a damaged log
or progress file stops that participant with :class:`DamagedRecords` naming the file: a trial is never
silently restarted, and the other participants go on.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_with, trim_torn_tail
from antmaze_hirl.dagger import DAggerTrainer
from antmaze_hirl.dagger.trainer import EpisodeRun, ExecutedStep
from antmaze_hirl.envs.layouts import canonical_layout
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.experiments.old_folders import current_study_record
from antmaze_hirl.experiments.runner import TrialEnvs, make_trainer
from antmaze_hirl.study.background import UpdateQueue
from antmaze_hirl.study.camera import AntCamera, CameraUnavailable
from antmaze_hirl.study.checkpoint import (
    CHECKPOINT_FILE,
    LEGACY_CHECKPOINT_FILE,
    CheckpointError,
    load_checkpoint,
    save_checkpoint,
)
from antmaze_hirl.study.consistency import (
    ParticipantRecords,
    check_records,
    closing_trials,
    participant_records,
    read_progress,
)
from antmaze_hirl.study.data import EPISODE_COLUMNS, read_episode_rows
from antmaze_hirl.study.logs import (
    DamagedLog,
    append_csv_row,
    append_json_record,
    csv_cell,
)
from antmaze_hirl.study.plan import ParticipantPlan, StudyPlan, TrialPlan
from antmaze_hirl.study.questionnaire import validate_answers
from antmaze_hirl.study.settings import QUESTIONNAIRE_SECONDS, SECONDS_PER_MAZE_PRIOR, StudySettings

logger = logging.getLogger(__name__)


class ProtocolError(Exception):
    """A request that the study protocol does not allow now (answered with HTTP 409)."""


class BadInput(ValueError):
    """A malformed or out-of-range value from a participant's page (answered with HTTP 400)."""


class TrialCannotStart(ProtocolError):
    """The study's settings give a trial that cannot be built (e.g. a maze family too small to hold out; HTTP 409).

    Nothing was written: the participant stays before the trial; the experimenter fixes the study's settings.
    """


class DamagedRecords(Exception):
    """A participant's saved files are damaged or missing, so their session cannot go on (HTTP 409).

    The message names the file; the experimenter repairs or removes it. Other participants are not affected.
    """


CLICK_SLACK_PIXELS = 3.0
"""Screen pixels past the reach circle a click may land and still count (study.js: the dashed line is 2 px)."""

MIN_CANVAS_SCREEN_PIXELS = 520.0
"""The smallest the page's 640-px canvas is shown (window 1024x640; study.css: max-height 100vh - 120px)."""

MAX_RESPONSE_SECONDS = 3600.0
"""Longest time a page may report for one click (an hour: longer is a broken clock, not a person thinking)."""

LOGS = ("events.jsonl", "clicks.jsonl", "answers.jsonl", "episodes.csv")
"""A participant's append-only logs (events first: it records the trims of the others)."""

PHASES = ("intro", "label", "questionnaire", "done")
"""The phases ``progress.json`` may hold (``episode_over`` is saved as ``label``: the episode is replayed)."""


class PageExpert:
    """The trainer's expert while a person answers through the page: never called directly.

    The session answers each :class:`~antmaze_hirl.dagger.trainer.LabelRequest` with the person's
    click via :meth:`~antmaze_hirl.dagger.trainer.EpisodeRun.answer`; a call here would be a bug.
    """

    def label(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Refuses: the page's clicks are the labels."""
        raise RuntimeError("a study trial is labelled by its participant through EpisodeRun.answer, not label()")


@dataclass
class DemonstrationLog:
    """Every labelled step of a trial, in order (what ``study export`` turns into a Minari dataset)."""

    images: list[np.ndarray] = field(default_factory=list)
    states: list[np.ndarray] = field(default_factory=list)
    executed: list[np.ndarray] = field(default_factory=list)
    labels: list[np.ndarray] = field(default_factory=list)
    labelled: list[bool] = field(default_factory=list)
    episode: list[int] = field(default_factory=list)
    high_level_step: list[int] = field(default_factory=list)
    terminal_success: list[bool] = field(default_factory=list)
    success: list[bool] = field(default_factory=list)

    def add(self, executed: ExecutedStep, episode: int) -> None:
        """Records one step: the state it started from, the label (NaN where not asked) and what the env executed."""
        observation = executed.observation
        self.images.append(np.asarray(observation["image"], dtype=np.uint8))
        self.states.append(np.asarray(observation["state"], dtype=np.float32))
        self.executed.append(np.asarray(executed.subgoal, dtype=np.float32))
        label = executed.expert_subgoal if executed.asked else np.full(2, np.nan)
        self.labels.append(np.asarray(label, dtype=np.float32))
        self.labelled.append(executed.asked)
        self.episode.append(episode)
        self.high_level_step.append(int(executed.info["attempts"]) - 1)  # asked or not
        self.terminal_success.append(bool(executed.done and executed.info["is_success"]))

    def save(self, path: Path) -> None:
        """Writes the log as ``.npz`` atomically."""
        arrays = {
            "images": np.stack(self.images) if self.images else np.zeros((0, 3, 1, 1), np.uint8),
            "states": np.stack(self.states) if self.states else np.zeros((0, 1), np.float32),
            "executed": np.asarray(self.executed, dtype=np.float32).reshape(-1, 2),
            "labels": np.asarray(self.labels, dtype=np.float32).reshape(-1, 2),
            "labelled": np.asarray(self.labelled, dtype=bool),
            "episode": np.asarray(self.episode, dtype=np.int64),
            "high_level_step": np.asarray(self.high_level_step, dtype=np.int64),
            "terminal_success": np.asarray(self.terminal_success, dtype=bool),
            "success": np.asarray(self.success, dtype=bool),
        }
        atomic_write_with(path, lambda tmp: tmp.write_bytes(_npz_bytes(arrays)))

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickles a checkpoint's log, also one pickled before ``high_level_step`` was renamed from ``step``.

        Raises:
            ValueError: If the state has neither name, or both with different values.
        """
        self.__dict__.update(current_study_record(state, "high_level_step", "the pickled DemonstrationLog"))


def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


@dataclass
class TrialState:
    """What a trial's checkpoint holds: the trainer (env and expert detached) and the trial's records."""

    trainer: DAggerTrainer
    rows: list[dict[str, Any]]
    demonstrations: DemonstrationLog
    successes: int = 0
    pending: list[dict[str, Any]] = field(default_factory=list)
    """With background updates: the mazes whose update and evaluation are not in ``trainer`` yet, in order,
    each ``{"row": ..., "update_due": bool}`` (a restore runs them before the next maze)."""


class ParticipantSession:
    """The study protocol for one participant: practice, counterbalanced trials, questionnaires.

    Phases: ``"intro"`` (a trial is about to start), ``"label"`` (a query waits for a click),
    ``"episode_over"`` (the last click ended an episode, or, with a gating method such as ``gated``, the
    learner walked a whole episode unasked; :meth:`next_episode` closes it),
    ``"questionnaire"`` (a trial ended; its questionnaire is due), ``"done"``.

    Args:
        study_dir: The study folder.
        plan: The study plan.
        participant: This participant's part of it.
        settings: The study's trial settings.
        clock: Wall-clock seconds, for the times in the records (injected by tests).
        timer: Monotonic seconds, for durations (time on task, seconds per label, pauses), which a change
            of the wall clock must not stretch (injected by tests).

    """

    def __init__(
        self,
        study_dir: Path,
        plan: StudyPlan,
        participant: ParticipantPlan,
        settings: StudySettings,
        *,
        clock: Any = time.time,
        timer: Any = time.monotonic,
    ) -> None:
        self.plan = plan
        self.participant = participant
        self.settings = settings
        self.clock = clock
        self.timer = timer
        self.folder = Path(study_dir) / "participants" / participant.id
        self.lock = threading.RLock()  # one request at a time per participant; the server has many threads
        self.trial_index = 0
        self.phase = "intro"
        self.paused_since: float | None = None
        self._trial: TrialState | None = None
        self._env: Any = None
        self._envs: TrialEnvs | None = None
        self._run: EpisodeRun | None = None
        self._query_id = 0
        self._query_shown_at = 0.0
        self._episode_started_at = 0.0
        self._episode_ended_at = 0.0
        self._episode_paused = 0.0
        self._episode_label_seconds: list[float] = []
        self._trail: list[list[float]] = []
        self._walk: list[dict[str, Any]] = []  # the learner's unasked steps the page has not shown yet
        self._camera: AntCamera | None = None
        self._last_trial: dict[str, Any] | None = None  # how the trial just closed went (the page's summary)
        self._episode_saved = False  # the ended episode's row and checkpoint are on disk; the trial is not closed
        self._updates = UpdateQueue()  # the updates after the last mazes, running meanwhile
        self._csv_rows = 0  # how many of the trial's rows episodes.csv holds
        self._episode_learner_updates = 0  # updates behind the learner that plays the current maze
        self._closing_row: dict[str, Any] | None = None  # the ended episode's row, kept while its save fails
        self._closing: list[TrialClosing] = []  # closed trials whose last updates are still running
        try:
            self._restore()
        except BaseException:
            self.close()
            raise

    # ----------------------------------------------------------------------------------- queries
    @property
    def trial(self) -> TrialPlan | None:
        """The current trial's plan (``None`` once every trial is done)."""
        trials = self.participant.trials
        return trials[self.trial_index] if self.trial_index < len(trials) else None

    @property
    def query_id(self) -> int | None:
        """Id of the query waiting for a click, if any (a click must name it: no double answers)."""
        return self._query_id if self.phase == "label" and self._run is not None else None

    def state(self) -> dict[str, Any]:
        """Everything the page shows, as JSON-ready data.

        ``unsaved`` is there while a closed part's final writes fail (:class:`TrialClosing`): ``parts`` (their
        labels), ``retrying`` (the server keeps trying) and ``error`` ("No space left on device"); asking for
        the state wakes those retries.
        """
        with self.lock:
            trial = self.trial
            state: dict[str, Any] = {
                "participant": self.participant.id,
                "phase": self.phase,
                "paused": self.paused_since is not None,
                "trials": len(self.participant.trials),
                "trial": None,
                "camera": self.settings.body == "ant" and bool(os.environ.get("MUJOCO_GL")),
                "learner_shown": self.settings.show_learner_subgoal,
            }
            if self._last_trial is not None and self.phase in ("intro", "questionnaire", "done"):
                state["last_trial"] = self._last_trial
            unsaved = [closing for closing in self._closing if closing.failing or closing.error is not None]
            if unsaved:  # a closed part's final writes fail: the participant's page says so
                for closing in unsaved:
                    closing.retry_now()  # this request is a reason to try again now
                errors = [closing.write_error or closing.error for closing in unsaved]
                state["unsaved"] = {
                    "parts": [closing.trial.label for closing in unsaved],
                    "retrying": all(closing.failing for closing in unsaved),
                    "error": _plain_error(errors[0]),
                }
            if trial is None:
                return state
            state["trial"] = {
                "number": self.trial_index + 1,
                "label": trial.label,
                "practice": trial.practice,
                "episodes": trial.episodes,
            }
            if self.phase == "intro":
                state["length"] = self._length_estimate()
            if self._trial is not None:
                ended = self._run is not None and self._run.done
                number = self._trial.trainer.episodes_done + (0 if ended else 1)
                state["episode"] = {"number": number, "of": trial.episodes}
                state["successes"] = self._trial.successes
                state["labels"] = int(self._trial.trainer.total_expert_cost + self._labels_this_episode())
            if self.phase == "label" and self._run is not None and self._run.request is not None:
                state.update(self._scene(self._run.request.observation, self._run.request))
            elif self.phase == "episode_over" and self._walk and self._run is not None and self._run.record:
                # An episode the learner walked unasked: the page shows the walk, then asks for the next maze.
                state.update(self._scene(self._run.executed[-1].observation, None))
                state["episode_end"] = {"number": number, "success": bool(self._run.record.success)}
            if self._walk:
                state["walk"] = self._walk
            return state

    def _length_estimate(self) -> dict[str, Any]:
        # How long this part and the rest take: the participant's own seconds per maze once they have some.
        seconds = SECONDS_PER_MAZE_PRIOR
        path = self.folder / "episodes.csv"
        with contextlib.suppress(OSError, ValueError):
            times = [float(row["time_on_task"]) for row in read_episode_rows(path) if row["time_on_task"]]
            if times:
                seconds = max(float(np.mean(times)), 5.0)
        trials = self.participant.trials[self.trial_index :]
        rated = sum(not trial.practice for trial in trials)
        rest = sum(trial.episodes for trial in trials) * seconds + rated * QUESTIONNAIRE_SECONDS
        return {
            "seconds_per_maze": round(seconds, 1),
            "part_minutes": max(1, round(trials[0].episodes * seconds / 60)),
            "parts_left": len(trials),
            "minutes_left": max(1, round(rest / 60)),
            "measured": seconds != SECONDS_PER_MAZE_PRIOR,
        }

    def _labels_this_episode(self) -> int:
        return 0 if self._run is None or self._run.request is None else self._run.request.label_index

    def _scene(self, observation: dict[str, np.ndarray], request: Any) -> dict[str, Any]:
        inner = self._env.unwrapped
        geometry = inner.geometry
        return {
            "query": (
                {"id": self._query_id, "label_index": request.label_index, "executes": request.executes}
                if request is not None
                else None
            ),
            "maze": {
                "rows": geometry.n_rows,
                "cols": geometry.n_cols,
                "scale": geometry.scale,
                "low": geometry.low.tolist(),
                "high": geometry.high.tolist(),
                "walls": inner.layout.walls.astype(int).tolist(),
                "bounds": [inner.action_space.low.tolist(), inner.action_space.high.tolist()],
            },
            "agent": [float(v) for v in STATE_LAYOUT.agent_xy(observation["state"])],
            "goal": [float(v) for v in STATE_LAYOUT.goal_xy(observation["state"])],
            "trail": self._trail,
            "subgoal_reach_m": self.subgoal_reach_m,
            "success_radius_m": float(inner.success_radius_m),
            "learner_subgoal": (
                [float(v) for v in request.learner_subgoal]
                if self.settings.show_learner_subgoal and request is not None
                else None
            ),
        }

    @property
    def subgoal_reach_m(self) -> float:
        """The circle around the agent: the farthest subgoal the expert is asked to click, metres."""
        distance = self.settings.subgoal_reach_m
        return float(distance if distance is not None else self._env.unwrapped.geometry.scale)

    # ---------------------------------------------------------------------------------- actions
    def start_trial(self) -> dict[str, Any]:
        """Starts the current trial (phase ``intro`` -> ``label``).

        Raises:
            ProtocolError: If no trial is to start now, or the study is paused.
            TrialCannotStart: If the settings give a trial that cannot be built (nothing written).
            OSError: If a write fails (a full disk): the participant stays at the intro; the call may be repeated.
        """
        with self.lock:
            if self.paused_since is not None:
                raise ProtocolError("the study is paused: resume before starting")
            if self.phase != "intro":
                raise ProtocolError(f"no trial to start: participant {self.participant.id} is at {self.phase!r}")
            trial = self.trial
            assert trial is not None  # "intro" is only set while a trial remains
            # Build the trial (envs, trainer, first maze: all in memory) before anything is written, so a
            # trial that cannot be built leaves the participant at "intro" with no trace on disk; then write,
            # and a failed write (a full disk) puts the participant back at "intro" too.
            self.phase = "label"
            try:
                self._open_trial(resume=False)
            except ValueError as error:
                self.phase, self._trial, self._run = "intro", None, None
                raise TrialCannotStart(
                    f"trial {trial.index} of participant {self.participant.id} cannot start: {error}"
                ) from error
            try:
                if trial.index not in self._records().started:  # logged by a start that failed
                    self._log_event("trial_start", trial=trial.index)
                self._save_progress(self.trial_index, "label")
            except BaseException:
                self.phase, self._trial, self._run = "intro", None, None
                raise
            return self.state()

    def label(self, query_id: Any, x: Any, y: Any, response_seconds: Any = None) -> dict[str, Any]:
        """A click: the subgoal ``(x, y)`` for query ``query_id``.

        Returns:
            ``{"walked": [...], "episode_end": {...} | None, "state": ...}``: what the low level did
            (paths to animate), how the episode ended if it did, and the next state.

        Raises:
            ProtocolError: If no label is asked now, or ``query_id`` is not the open query (a repeat).
            BadInput: If the click is not two finite numbers inside the maze.
        """
        with self.lock:
            if self.paused_since is not None:
                raise ProtocolError("the study is paused: resume before clicking")
            if self.query_id is None:
                raise ProtocolError(f"no label is asked now (participant {self.participant.id} is at {self.phase!r})")
            if isinstance(query_id, bool) or not isinstance(query_id, int):
                raise BadInput(f"query must be an integer id, got {query_id!r}")
            if query_id != self._query_id:
                raise ProtocolError(
                    f"query {query_id} is not open (the open query is {self._query_id}): already answered?"
                )
            seconds = self._check_response_seconds(response_seconds)
            subgoal = self._check_click(x, y)
            now, elapsed = self.clock(), self.timer()
            server_seconds = max(elapsed - self._query_shown_at, 0.0)
            assert self._run is not None and self._run.request is not None and self._trial is not None
            request = self._run.request
            append_json_record(
                self.folder / "clicks.jsonl",
                {
                    "participant": self.participant.id,
                    "trial": self.trial.index,
                    "episode": request.episode,
                    "label_index": request.label_index,
                    "query": query_id,
                    "time": now,
                    "x": subgoal[0],
                    "y": subgoal[1],
                    "response_seconds": seconds,
                    "server_seconds": server_seconds,
                },
            )
            self._episode_label_seconds.append(seconds if seconds is not None else server_seconds)
            executed = self._run.answer(np.asarray(subgoal))
            self._walk = []  # shown before this click
            walked = self._walked(executed, request.episode)
            episode_end = None
            if self._run.done:
                assert self._run.record is not None
                self.phase = "episode_over"  # the page calls next_episode() while it animates the last walk
                self._episode_ended_at = elapsed  # the person's time ends with their last click, not the update
                episode_end = {"number": len(self._trial.rows) + 1, "success": bool(self._run.record.success)}
            else:
                self._show_query()
            return {"walked": walked, "episode_end": episode_end, "state": self.state()}

    def next_episode(self) -> dict[str, Any]:
        """Closes the finished episode (learner update, evaluation when due, saving) and opens the next maze.

        Split from the click that ends an episode so that the page shows the end at once and this work
        runs while it animates the last walk.

        Raises:
            ProtocolError: If no episode has just ended, or the study is paused.
            OSError: If a write fails (a full disk): the episode stays open as it was (its update and
                evaluation are kept, not run again); the call may be repeated.
        """
        with self.lock:
            if self.paused_since is not None:
                raise ProtocolError("the study is paused: resume before the next maze")
            if self.phase != "episode_over":
                raise ProtocolError(
                    f"no episode has just ended (participant {self.participant.id} is at {self.phase!r})"
                )
            # Each step writes first and changes memory after, so a failed write (a full disk) leaves the
            # episode open, as it was, and a retry goes on from the step that failed.
            if not self._episode_saved:
                self._save_episode()
            assert self._trial is not None and self.trial is not None and self._run is not None
            if self._run.record.episode >= self.trial.episodes - 1:
                self._close_trial()
            else:
                self._walk = []  # shown
                self._run, self._episode_saved = None, False
                self.phase = "label"
                self._start_episode()
                self._show_query()
            return self.state()

    def submit_questionnaire(self, trial_number: Any, payload: Any) -> dict[str, Any]:
        """The questionnaire of trial ``trial_number`` (1-based, as the page shows it).

        Raises:
            ProtocolError: If no questionnaire is due, or it is for another trial.
            BadInput: If the answers are incomplete or out of range.
            OSError: If a write fails (a full disk): the questionnaire stays due (an answer already on disk is
                kept and not written again); the call may be repeated.
        """
        with self.lock:
            if self.phase != "questionnaire":
                raise ProtocolError(f"no questionnaire is due (participant {self.participant.id} is at {self.phase!r})")
            if isinstance(trial_number, bool) or trial_number != self.trial_index + 1:
                raise ProtocolError(
                    f"the questionnaire due is trial {self.trial_index + 1}'s, got trial {trial_number!r}"
                )
            if not isinstance(payload, dict):
                raise BadInput(f"answers must be a JSON object, got {type(payload).__name__}")
            try:
                answers = validate_answers(payload)
            except ValueError as error:
                raise BadInput(str(error)) from error
            trial = self.trial
            assert trial is not None
            record = {
                "participant": self.participant.id,
                "trial": trial.index,
                "method": trial.method,
                "label": trial.label,
                "ratings": dict(answers.ratings),
                "comment": answers.comment,
                "time": self.clock(),
            }
            if trial.index not in self._records().answered:  # kept by an answer that failed after
                append_json_record(self.folder / "answers.jsonl", record)
            self._next_trial()
            return self.state()

    def set_paused(self, paused: Any) -> dict[str, Any]:
        """Pauses or resumes (a key on the page): no clicks, starts or next mazes meanwhile.

        Paused time is not time on task: since nothing can start or end an episode while paused, a
        pause lies wholly inside an episode (phase ``label``) or wholly outside one, and only the first
        kind is taken off the episode's time.
        """
        with self.lock:
            if not isinstance(paused, bool):
                raise BadInput(f"paused must be true or false, got {paused!r}")
            now = self.timer()
            if paused and self.paused_since is None:
                self._log_event("pause")  # the record first: a failed write leaves the study running
                self.paused_since = now
            elif not paused and self.paused_since is not None:
                self._log_event("resume")
                if self.phase == "label" and self._run is not None:  # inside an episode
                    pause = max(now - max(self.paused_since, self._episode_started_at), 0.0)
                    self._episode_paused += pause
                    self._query_shown_at += pause  # a pause is not thinking time
                self.paused_since = None
            return self.state()

    def camera_frame(self) -> bytes:
        """The ant's camera view now, as PNG.

        Raises:
            CameraUnavailable: For the point, outside a trial, or where OpenGL rendering does not work.
        """
        with self.lock:
            if self.settings.body != "ant":
                raise CameraUnavailable("the camera view is for the ant; the point is shown from above only")
            if self._env is None:
                raise CameraUnavailable("no trial is running")
            if self._camera is None:
                self._camera = AntCamera()
            return self._camera.frame(self._env.unwrapped.reach.sim.data)

    def close(self) -> None:
        """Releases the trial's simulators and the camera, and stops the closed trials' final updates.

        A final update still running ends unused and nothing is written for it: the trial's checkpoint holds
        its mazes as pending, and the next restore runs them again (:class:`TrialClosing`).
        """
        with self.lock:
            closings, self._closing = self._closing, []
        for closing in closings:  # outside the lock: a closing takes it to append to the logs
            closing.stop()
        with self.lock:
            self._release_trial()

    def wait_for_closed_trials(self, timeout: float | None = None) -> bool:
        """Waits until every closed trial's final update and evaluation are written, or fail; whether they are.

        A closing whose writes fail does not hold this up: it raises while that closing goes on retrying
        (:class:`TrialClosing`), so a stop never waits on a full disk.

        Raises:
            RuntimeError: If one failed or its writes fail now (its error chained; a failed write is retried
                until the session closes, and the next restore runs whatever is left).
        """
        with self.lock:
            closings = list(self._closing)
        deadline = None if timeout is None else time.monotonic() + timeout
        for closing in closings:  # each one, before any error is raised: a caller may stop the others next
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            if not closing.wait(left):
                return False
        for closing in closings:
            error = closing.error or closing.write_error
            if error is not None:
                retrying = " (its writes are retried)" if closing.failing else ""
                raise RuntimeError(
                    f"participant {self.participant.id}, trial {closing.trial.index}: the final update failed"
                    f"{retrying}: {error!r}"
                ) from error
        return True

    def _release_trial(self) -> None:
        # The current trial's simulators, camera and update queue (a closed trial's are its TrialClosing's).
        with self.lock:
            self._updates.stop()  # nothing is lost: the checkpoint holds the unfinished updates as pending
            self._updates = UpdateQueue()
            if self._envs is not None:
                self._envs.close()
            self._envs = self._env = None
            if self._camera is not None:
                self._camera.close()
                self._camera = None

    # -------------------------------------------------------------------------------- internals
    def _check_click(self, x: Any, y: Any) -> tuple[float, float]:
        values = [_json_number(x, "click x"), _json_number(y, "click y")]
        low, high = self._env.unwrapped.action_space.low, self._env.unwrapped.action_space.high
        if not (low[0] <= values[0] <= high[0] and low[1] <= values[1] <= high[1]):
            raise BadInput(
                f"click ({values[0]:.3f}, {values[1]:.3f}) is outside the maze: x in [{low[0]:.2f}, {high[0]:.2f}], "
                f"y in [{low[1]:.2f}, {high[1]:.2f}]"
            )
        # The page's own checks (study.js, refusalOf), repeated: a request sent around the page is refused too.
        inner = self._env.unwrapped
        geometry = inner.geometry
        point = np.asarray(values)
        if not geometry.is_free(inner.layout.walls, point):
            raise BadInput(f"click ({values[0]:.3f}, {values[1]:.3f}) is on a wall: the subgoal must be on the floor")
        assert self._run is not None and self._run.request is not None
        agent = STATE_LAYOUT.agent_xy(self._run.request.observation["state"])
        distance = float(np.hypot(*(point - agent)))
        # The page counts 3 screen pixels past the circle as inside; in metres, at the smallest on-screen canvas.
        slack = CLICK_SLACK_PIXELS * float(np.max(geometry.high - geometry.low)) / MIN_CANVAS_SCREEN_PIXELS
        if distance > self.subgoal_reach_m + slack:
            raise BadInput(
                f"click ({values[0]:.3f}, {values[1]:.3f}) is {distance:.3f} m from the agent, beyond the reach "
                f"circle's {self.subgoal_reach_m:.3f} m (+{slack:.3f} m slack)"
            )
        return values[0], values[1]

    @staticmethod
    def _check_response_seconds(value: Any) -> float | None:
        if value is None:
            return None
        seconds = _json_number(value, "response_seconds", f"from 0 to {MAX_RESPONSE_SECONDS:g}")
        if not 0 <= seconds <= MAX_RESPONSE_SECONDS:
            raise BadInput(
                f"response_seconds must be a finite number from 0 to {MAX_RESPONSE_SECONDS:g}, got {value!r}"
            )
        return seconds

    def _make_trainer(self, trial: TrialPlan) -> DAggerTrainer:
        config = self.settings.experiment_config(trial.episodes)
        return make_trainer(trial.method, trial.seed, config, self._env, PageExpert())

    def _open_trial(self, *, resume: bool) -> None:
        trial = self.trial
        assert trial is not None
        config = self.settings.experiment_config(trial.episodes)
        if self._env is None:
            self._envs = TrialEnvs(config)
            self._env = self._envs.train
        checkpoint = self._trial_folder / CHECKPOINT_FILE
        legacy = self._trial_folder / LEGACY_CHECKPOINT_FILE
        if resume and not checkpoint.is_file() and legacy.is_file():
            checkpoint = legacy  # refused by _load_checkpoint, naming it
        if resume and checkpoint.is_file():
            self._trial = _load_checkpoint(checkpoint, self._env)
            self._repair_rows()
            self._log_event("restored", trial=trial.index, episodes_done=len(self._trial.rows))
            played = len(self._trial.rows) + len(self._trial.pending)
            if self._trial.pending and played < trial.episodes:  # stopped while updates ran in the background
                self._finish_pending_updates()  # (after the last maze, the close below hands them on)
        elif resume and (written := len(self._written_rows(trial))):
            raise DamagedRecords(
                f"{checkpoint} is missing, but {self.folder / 'episodes.csv'} has {written} episode(s) of trial "
                f"{trial.index}: participant {self.participant.id} cannot go on without it (restore it from a "
                "backup; a trial is never restarted silently)"
            )
        else:
            self._trial = TrialState(self._make_trainer(trial), [], DemonstrationLog())
        self._episode_saved = False
        self._csv_rows = len(self._trial.rows)
        if len(self._trial.rows) + len(self._trial.pending) >= trial.episodes:  # killed before the trial closed
            self._close_trial()
        else:
            self._start_episode()

    @property
    def _trial_folder(self) -> Path:
        assert self.trial is not None
        return self.folder / f"trial{self.trial.index}"

    def _start_episode(self) -> None:
        assert self._trial is not None
        self._run = self._trial.trainer.start_episode()
        self._episode_learner_updates = self._trial.trainer.updates
        # A gating method may let the learner walk before the first request (or the whole episode).
        first = self._run.executed[0].observation if self._run.executed else self._run.request.observation
        self._trail = [[round(float(v), 3) for v in STATE_LAYOUT.agent_xy(first["state"])]]
        self._walk = self._walked(self._run.executed, self._trial.trainer.episodes_done - int(self._run.done))
        self._episode_started_at = self.timer()
        self._episode_paused = 0.0
        self._episode_label_seconds = []
        if self._run.done:
            self.phase = "episode_over"  # nothing to ask: the page shows the walk, then calls next_episode()
            self._episode_ended_at = self._episode_started_at
        self._show_query()

    def _walked(self, executed: list[ExecutedStep], episode: int) -> list[dict[str, Any]]:
        # Logs the steps and extends the trail; returns what the page animates (asked: the expert's subgoal ran).
        assert self._trial is not None
        walked = []
        for step in executed:
            self._trial.demonstrations.add(step, episode)
            path = np.asarray(step.info["agent_path"], dtype=float)
            self._trail.extend(path[1:].round(3).tolist())
            walked.append(
                {
                    "subgoal": [float(v) for v in step.subgoal],
                    "path": path.round(3).tolist(),
                    "reached": bool(step.info["subgoal_reached"]),
                    "flipped": bool(step.info["flipped"]),
                    "asked": step.asked,
                }
            )
        return walked

    def _show_query(self) -> None:
        self._query_id += 1
        self._query_shown_at = self.timer()

    def _save_episode(self) -> None:
        # The ended episode's row, checkpoint and demonstrations, written before memory counts the episode.
        # With background updates (every maze but a trial's last), the episode is saved with its update still
        # due (in the pending list) and the update runs on a copy while the next mazes are played.
        trial, state, run = self.trial, self._trial, self._run
        assert trial is not None and state is not None and run is not None and run.record is not None
        final = run.record.episode >= trial.episodes - 1
        # The trial's last maze too: its update and the final evaluation run after the trial has closed
        # (_close_trial hands them to a TrialClosing), so the questionnaire or the next part opens at once.
        lagged = self.settings.background_updates
        self._take_updates(wait=not lagged)  # those finished while this maze was played
        if self._closing_row is None:  # kept across a failed save: the update and evaluation run once
            self._closing_row = self._episode_row(update=not lagged)
        row, success = self._closing_row, bool(run.record.success)
        queued = self._updates.pending()  # still running: saved as pending with this maze's own
        pending_before = state.pending
        if lagged:
            state.pending = [{"row": job.row, "update_due": job.update_due} for job in queued]
            state.pending.append({"row": row, "update_due": bool(state.trainer._update_due)})
        else:
            state.rows.append(row)
        state.successes += int(success)
        state.demonstrations.success.append(success)
        try:
            # Checkpoint first, then the rows: a crash between them is repaired from the checkpoint on restart.
            _save_checkpoint(state, self._trial_folder / CHECKPOINT_FILE)
            state.demonstrations.save(self._trial_folder / "demonstrations.npz")
            self._append_new_rows()
        except BaseException:
            if lagged:
                state.pending = pending_before
            else:
                state.rows.pop()
            state.successes -= int(success)
            state.demonstrations.success.pop()
            raise
        self._closing_row = None
        self._episode_saved = True
        if lagged:
            self._updates.submit(state.trainer, row, _evaluation(self._envs, self._evaluation_due(row, trial), final))

    def _take_updates(self, *, wait: bool) -> None:
        # The background updates that have finished (every one, with ``wait``): the newest one's weights go into
        # the live trainer and their rows join the trial's (written with this maze's save). Not a protocol step:
        # the pending list on disk holds the same updates, which a restore would run.
        state = self._trial
        assert state is not None
        finished = self._updates.take(wait=wait)
        if finished:
            finished[-1].apply_to(state.trainer)
            state.rows.extend({column: job.row.get(column, "") for column in EPISODE_COLUMNS} for job in finished)
            state.pending = state.pending[len(finished) :]

    def _finish_pending_updates(self) -> None:
        # A restore from a checkpoint saved while updates ran in the background: run them here, then save.
        state, trial = self._trial, self.trial
        assert state is not None and trial is not None
        _run_pending(state, self._envs, trial, self._evaluation_due)
        _save_checkpoint(state, self._trial_folder / CHECKPOINT_FILE)
        self._append_new_rows()

    def _evaluation_due(self, row: dict[str, Any], trial: TrialPlan) -> bool:
        # After every eval_every-th maze, and the trial's last (its final evaluation).
        episode = int(row["episode"])
        return (episode + 1) % self.settings.eval_every == 0 or episode == trial.episodes - 1

    def _append_new_rows(self) -> None:
        # The rows memory has and episodes.csv does not yet (each append is all or nothing).
        assert self._trial is not None
        for row in self._trial.rows[self._csv_rows :]:
            self._append_row(row)
            self._csv_rows += 1

    def _episode_row(self, *, update: bool) -> dict[str, Any]:
        # The ended episode's row; with ``update``, after the learner update and the evaluation when due.
        trial, state, run = self.trial, self._trial, self._run
        assert trial is not None and state is not None and run is not None and run.record is not None
        record = run.record
        if update:
            run.finish()  # the learner update, before the evaluation (as the experiment runner evaluates)
        episode = record.episode
        row: dict[str, Any] = {
            "participant": self.participant.id,
            "trial": trial.index,
            "method": trial.method,
            "label": trial.label,
            "practice": trial.practice,
            "seed": trial.seed,
            **record.to_dict(),
            "cumulative_expert_cost": state.trainer.total_expert_cost,
            "layout": canonical_layout(self._env.unwrapped.layout),  # still this episode's maze
            "seconds_per_label": (
                round(float(np.mean(self._episode_label_seconds)), 4) if self._episode_label_seconds else ""
            ),
            "time_on_task": round(
                max(self._episode_ended_at - self._episode_started_at - self._episode_paused, 0.0), 3
            ),
            "learner_updates": self._episode_learner_updates,
        }
        if update and self._evaluation_due(row, trial):
            row.update(self._envs.evaluate(state.trainer.learner, final=episode == trial.episodes - 1))
        return {column: row.get(column, "") for column in EPISODE_COLUMNS}

    def _close_trial(self) -> None:
        # Writes (learner, trial_end once, progress) first; memory moves on only once they are on disk. With
        # background updates the last mazes' updates and the final evaluation are still pending: the trial
        # closes now and a TrialClosing finishes them and writes the learner (the participant goes on).
        state, trial = self._trial, self.trial
        assert state is not None and trial is not None
        closing = None
        if state.pending:
            closing = TrialClosing(
                self, trial, state=state, csv_rows=self._csv_rows, envs=self._envs, queue=self._updates
            )
        else:
            state.trainer.learner.save(self._trial_folder / "learner.zip")
        episodes = len(state.rows) + len(state.pending)
        if trial.index not in self._records().ended:  # logged by a close that failed after it
            self._log_event("trial_end", trial=trial.index, episodes=episodes, successes=state.successes)
        summary = {
            "label": trial.label,
            "practice": trial.practice,
            "episodes": episodes,
            "successes": state.successes,
            "labels": int(state.trainer.total_expert_cost),
        }
        if trial.practice:
            self._next_trial(closing)  # the practice trial is recorded, not rated
        else:
            self._save_progress(self.trial_index, "questionnaire")
            self._hand_over(closing)
            self.phase = "questionnaire"
        self._last_trial = summary
        self._run, self._episode_saved, self._walk = None, False, []

    def _hand_over(self, closing: TrialClosing | None) -> None:
        # The closed trial's updates, evaluation envs and queue go to ``closing`` (once its close is on disk).
        if closing is None:
            return
        self._closing = [job for job in self._closing if not job.done or job.error or job.write_error]
        self._closing.append(closing)
        self._updates = UpdateQueue()
        self._envs = self._env = None  # the closing's now: the next trial builds its own
        closing.start()

    def _next_trial(self, closing: TrialClosing | None = None) -> None:
        following = self.trial_index + 1
        self._save_progress(following, "intro" if following < len(self.participant.trials) else "done")
        self._hand_over(closing)
        self.trial_index = following
        self._trial = None
        self._release_trial()
        self.phase = "intro" if self.trial is not None else "done"

    def _records(self) -> ParticipantRecords:
        try:
            return participant_records(self.folder)
        except ValueError as error:
            raise DamagedRecords(f"participant {self.participant.id}: {error}") from None

    def _append_row(self, row: dict[str, Any]) -> None:
        append_csv_row(self.folder / "episodes.csv", EPISODE_COLUMNS, row)

    def _written_rows(self, trial: TrialPlan) -> list[dict[str, str]]:
        # ``trial``'s rows in episodes.csv (a damaged file stops the participant, naming the line).
        path = self.folder / "episodes.csv"
        if not path.exists():
            return []
        try:
            rows = read_episode_rows(path)
        except DamagedLog as error:
            raise DamagedRecords(f"participant {self.participant.id}: {error}") from None
        return [row for row in rows if row["trial"] == str(trial.index)]

    def _checked_rows(self, trial: TrialPlan, state: TrialState) -> int:
        # How many of ``state``'s rows episodes.csv holds: a prefix of them, else the participant stops.
        written = self._written_rows(trial)
        saved = [{column: csv_cell(row.get(column)) for column in EPISODE_COLUMNS} for row in state.rows]
        if written != saved[: len(written)]:
            raise DamagedRecords(
                f"{self.folder / 'episodes.csv'} has {len(written)} row(s) of trial {trial.index} that do not "
                f"match the first {len(written)} of the {len(saved)} in its checkpoint: repeated or changed rows"
            )
        return len(written)

    def _repair_rows(self) -> None:
        # Rows the checkpoint has but the CSV lacks (killed between the two writes) are appended again.
        assert self._trial is not None and self.trial is not None
        self._csv_rows = self._checked_rows(self.trial, self._trial)
        self._append_new_rows()

    def _save_progress(self, trial_index: int, phase: str) -> None:
        # Called before memory changes (an episode that ended but is not closed is saved as "label": replayed).
        atomic_write_json(self.folder / "progress.json", {"trial_index": trial_index, "phase": phase}, allow_nan=False)

    def _log_event(self, kind: str, **details: Any) -> None:
        event = {"participant": self.participant.id, "event": kind, "time": self.clock(), **details}
        append_json_record(self.folder / "events.jsonl", event)

    def _restore(self) -> None:
        for name in LOGS:  # a crash inside an append leaves a partial last line: cut it before appending again
            tail = trim_torn_tail(self.folder / name)
            if tail:
                self._log_event(
                    "torn_tail_trimmed", file=name, bytes=len(tail), text=tail[:200].decode("utf-8", "replace")
                )
        try:
            self.trial_index, self.phase = read_progress(self.folder)
        except ValueError as error:
            raise DamagedRecords(f"participant {self.participant.id}: {error}") from None
        if not (0 <= self.trial_index <= len(self.participant.trials) and self.phase in PHASES) or (
            (self.trial_index == len(self.participant.trials)) != (self.phase == "done")
        ):
            raise DamagedRecords(
                f"{self.folder / 'progress.json'}: trial {self.trial_index} at {self.phase!r} is not a place in "
                f"participant {self.participant.id}'s {len(self.participant.trials)} trials"
            )
        try:
            answered = check_records(self.folder, self.participant, self.trial_index, self.phase)
        except ValueError as error:
            raise DamagedRecords(f"participant {self.participant.id}: {error}") from None
        # Closed trials whose final update was cut off (a stop or a kill): resumed from their checkpoints.
        closing = closing_trials(self.folder, self.participant, self.trial_index, self.phase)
        if self.phase == "questionnaire" and answered:  # killed between the answer and the progress file
            self._next_trial()
        for trial in closing:
            state = _load_checkpoint(self.folder / f"trial{trial.index}" / CHECKPOINT_FILE, None)
            written = self._checked_rows(trial, state)
            self._closing.append(TrialClosing(self, trial, state=state, csv_rows=written, resumed=True))
            self._closing[-1].start()
        if self.phase == "label":
            self._open_trial(resume=True)


class TrialClosing:
    """A closed trial's last background updates and final evaluation, finished in a thread of its own.

    With ``background_updates`` a trial's last maze closes the trial at once: the questionnaire or the next
    part opens while the updates still queued, the last maze's own and the final evaluation run here, in
    order, on the closed trial's trainer and evaluation simulators. Then, in this order: the checkpoint
    (nothing pending), the trial's rows still missing from ``episodes.csv``, a ``final_update`` event
    (``updates``: how many ran after the close; ``lag_seconds``: from the close, or from a restore, to this
    write; ``resumed``) and last ``learner.zip``. A closed trial with a checkpoint and no ``learner.zip`` is
    one whose closing has not finished (:func:`~antmaze_hirl.study.consistency.closing_trials`): a stop or a
    kill loses only the work in progress, and the next restore starts a closing from the checkpoint.

    **A write that fails** (a full disk, an I/O error: any ``OSError``) is retried by this thread, from the
    write that failed, with the updates' results kept in memory (nothing is computed again): after
    :attr:`RETRY_FIRST_SECONDS`, doubling up to :attr:`RETRY_MAX_SECONDS` between tries, until the writes
    succeed or :meth:`stop`. A request of the participant wakes it at once (:meth:`retry_now`), so a freed disk
    is written before the page's next answer when it can be. The thread, not the participant's requests, owns
    the retries because the participant may have no request left to make (the study's last part), and their
    data must not wait on a restart; while it fails, :attr:`failing` is true and the participant's page says
    so (``unsaved`` in :meth:`ParticipantSession.state`). The order of the writes, and so what a reader or a
    restore finds after any of them, is the same as without a failure. Any other error ends the closing (kept
    in :attr:`error`; the next restore runs it again).

    Args:
        session: The participant's session (its lock guards the shared logs).
        trial: The closed trial.
        state: Its trial state (the live one, or loaded from the checkpoint on a restore).
        csv_rows: How many of ``state.rows`` ``episodes.csv`` holds.
        envs: The trial's simulators (built here when ``None``; closed here when done).
        queue: The trial's update queue, still running (``None`` on a restore).
        resumed: Whether a restore started it.
    """

    def __init__(
        self,
        session: ParticipantSession,
        trial: TrialPlan,
        *,
        state: TrialState,
        csv_rows: int,
        envs: TrialEnvs | None = None,
        queue: UpdateQueue | None = None,
        resumed: bool = False,
    ) -> None:
        self.session, self.trial, self.resumed = session, trial, resumed
        self.folder = session.folder / f"trial{trial.index}"
        self.error: BaseException | None = None
        self.write_error: OSError | None = None
        """The last write's error while the writes fail (``None`` once they succeed)."""
        self.failed_writes = 0
        """How many tries of the writes failed (the ``final_update`` event logs those before it)."""
        self._state, self._csv_rows, self._envs, self._queue = state, csv_rows, envs, queue
        self._checkpoint_written = False  # the state does not change between tries: one good write is enough
        self._closed_at = session.timer()
        self._last_try = -math.inf
        self._trying = False  # a try of the writes runs now (guarded, with _last_try, by _changed's lock)
        self._stopping = threading.Event()
        self._wake = threading.Event()  # a retry now: a participant's request, or a stop
        self._done = threading.Event()
        self._changed = threading.Condition()  # done, or a write failed: what wait() waits for
        name = f"study-close-{session.participant.id}-{trial.index}"
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    RETRY_FIRST_SECONDS = 1.0
    """Seconds before the first retry of a failed write."""

    RETRY_GAP_SECONDS = 1.0
    """The least time from one try to the next that a request wakes (:meth:`retry_now`)."""

    RETRY_MAX_SECONDS = 30.0
    """The longest wait between two tries: data wait at most this long once the disk has room again."""

    @property
    def done(self) -> bool:
        """Whether it has finished (written, failed, or stopped)."""
        return self._done.is_set()

    @property
    def failing(self) -> bool:
        """Whether its writes fail and are being retried (:attr:`write_error` says why)."""
        return self.write_error is not None and not self.done

    def start(self) -> None:
        """Starts the thread."""
        self._thread.start()

    def wait(self, timeout: float | None = None) -> bool:
        """Waits until :attr:`done` or :attr:`failing`; whether either is (``False`` once ``timeout`` passed)."""
        with self._changed:
            return self._changed.wait_for(lambda: self.done or self.failing, timeout)

    def retry_now(self) -> None:
        """Wakes a failing closing to try its writes again now.

        At most once per :attr:`RETRY_GAP_SECONDS`, and not while a try runs: that try is the retry asked for, and
        a wake kept through it would start another at once after it.
        """
        with self._changed:
            if self.failing and not self._trying and self.session.timer() - self._last_try >= self.RETRY_GAP_SECONDS:
                self._wake.set()

    def stop(self) -> None:
        """Lets the update in progress end, writes nothing more (the next restore resumes), and waits."""
        self._stopping.set()
        self._wake.set()
        if self._queue is not None:
            self._queue.stop()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        try:
            updates = self._finish()
            if updates is not None:
                self._write_retrying(updates)
        except BaseException as error:  # kept for wait_for_closed_trials; the next restore runs it again
            self.error = error
            logger.error(
                "participant %s, trial %d: the final update failed (a restart runs it again): %r",
                self.session.participant.id,
                self.trial.index,
                error,
            )
        finally:
            if self._queue is not None:
                self._queue.stop()
            if self._envs is not None:
                self._envs.close()
            with self._changed:
                self._done.set()
                self._changed.notify_all()

    def _finish(self) -> int | None:
        # The updates and the final evaluation, in memory; how many updates ran (None: stopped meanwhile).
        session, trial, state = self.session, self.trial, self._state
        if self._envs is None:  # a restore: the trial's simulators again, for the evaluations
            self._envs = TrialEnvs(session.settings.experiment_config(trial.episodes))
            state.trainer.env = self._envs.train
        updates = 0
        if self._queue is not None:
            for job in self._queue.pending():
                while not job.wait(0.1):
                    if self._stopping.is_set():
                        return None
            finished = self._queue.take()
            if finished:
                with session.lock:  # the session shows this state's counts until the questionnaire is answered
                    finished[-1].apply_to(state.trainer)
                    state.rows.extend(
                        {column: job.row.get(column, "") for column in EPISODE_COLUMNS} for job in finished
                    )
                    state.pending = state.pending[len(finished) :]
            updates += len(finished)
        if self._stopping.is_set():
            return None
        updates += _run_pending(state, self._envs, trial, session._evaluation_due, self._stopping.is_set)
        return None if self._stopping.is_set() else updates

    def _write_retrying(self, updates: int) -> None:
        # The writes, again from the one that failed while they fail with an OSError (see the class docstring).
        delay = self.RETRY_FIRST_SECONDS
        while not self._stopping.is_set():
            with self._changed:  # a wake from before this try is answered by it (retry_now refuses one during it)
                self._trying, self._last_try = True, self.session.timer()
                self._wake.clear()
            try:
                self._write(updates)
            except OSError as error:
                self.failed_writes += 1
                with self._changed:
                    self.write_error, self._trying = error, False
                    self._changed.notify_all()
                logger.error(
                    "participant %s, trial %d: writing the final update failed (try %d; tried again within %g s, "
                    "or at the participant's next request): %r",
                    self.session.participant.id,
                    self.trial.index,
                    self.failed_writes,
                    delay,
                    error,
                )
            else:
                with self._changed:
                    self.write_error, self._trying = None, False
                return
            if not self._stopping.is_set():  # stop() sets _stopping before it wakes: a stop from here on wakes this
                self._wake.wait(delay)  # cleared only as the next try starts, so a wake after this try is never lost
            delay = min(delay * 2, self.RETRY_MAX_SECONDS)

    def _write(self, updates: int) -> None:
        # In order: checkpoint, missing rows, final_update, learner.zip. Each is whole or not at all (atomic
        # replace; an append that fails is cut back), and a try skips what an earlier one wrote.
        session, trial, state = self.session, self.trial, self._state
        if not self._checkpoint_written:  # the largest file: rewritten, it would take the room freed for the rest
            _save_checkpoint(state, self.folder / CHECKPOINT_FILE)
            self._checkpoint_written = True
        with session.lock:  # the live trial appends to the same logs
            for row in state.rows[self._csv_rows :]:
                session._append_row(row)
                self._csv_rows += 1
            if trial.index not in session._records().final_updates:  # logged by a closing cut off after it
                lag = round(max(session.timer() - self._closed_at, 0.0), 3)
                session._log_event(
                    "final_update",
                    trial=trial.index,
                    updates=updates,
                    lag_seconds=lag,
                    resumed=self.resumed,
                    failed_writes=self.failed_writes,
                )
        state.trainer.learner.save(self.folder / "learner.zip")


def _plain_error(error: BaseException | None) -> str:
    """An error as a short phrase for the page: an ``OSError``'s ``strerror`` ("No space left on device")."""
    if isinstance(error, OSError) and error.strerror:
        return error.strerror
    return type(error).__name__ if error is not None else ""


def _json_number(value: Any, name: str, bound: str = "") -> float:
    """``value`` from a request body as a finite float; JSON's true/false are not numbers here.

    Raises:
        BadInput: Naming ``name`` (and ``bound``, the range the caller checks next) and the value.
    """
    wanted = f"{name} must be a finite number{' ' + bound if bound else ''}"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise BadInput(f"{wanted}, got {value!r}"[:300])
    try:
        number = float(value)  # an int too large for a float raises OverflowError
    except OverflowError:
        raise BadInput(f"{wanted}, got an integer of {len(str(abs(value)))} digits") from None
    if not math.isfinite(number):
        raise BadInput(f"{wanted}, got {value!r}")
    return number


def _evaluation(envs: TrialEnvs | None, due: bool, final: bool) -> Callable[[Any], dict[str, Any]] | None:
    """The evaluation a background update runs after its maze (``None`` when none is due).

    Bound to ``envs`` now: the session's own may belong to the next trial by the time the update runs.
    """
    if not due:
        return None
    assert envs is not None
    return lambda learner: envs.evaluate(learner, final=final)


def _run_pending(
    state: TrialState,
    envs: TrialEnvs | None,
    trial: TrialPlan,
    due: Callable[[dict[str, Any], TrialPlan], bool],
    stopping: Callable[[], bool] = lambda: False,
) -> int:
    """Runs ``state``'s pending updates (and their evaluations) in order, here; how many there were.

    A restore's way: each runs on the data as saved, all of it (the mazes' data sets of then are not kept).
    Their rows join ``state.rows``; ``pending`` is emptied. Once ``stopping()``, the rest is left (and
    ``state`` half done: the caller writes nothing of it).
    """
    for entry in state.pending:
        if stopping():
            return 0
        if entry["update_due"]:
            state.trainer._update(state.trainer.gradient_steps)
        row = dict(entry["row"])
        evaluate = _evaluation(envs, due(row, trial), int(row["episode"]) == trial.episodes - 1)
        if evaluate is not None:
            row.update(evaluate(state.trainer.learner))
        state.rows.append({column: row.get(column, "") for column in EPISODE_COLUMNS})
    count = len(state.pending)
    state.trainer._update_due = False
    state.pending = []
    return count


def _save_checkpoint(state: TrialState, path: Path) -> None:
    trainer = state.trainer
    env, expert = trainer.env, trainer.expert
    factories = _spawn_factories(trainer)
    trainer.env = trainer.expert = None  # simulators are rebuilt on load; the expert is the page
    for holder in factories:  # a bound method is no class: the loader would refuse it; made again on load
        holder.make_policy = None
    try:
        save_checkpoint(state, path)
    finally:
        trainer.env, trainer.expert = env, expert
        for holder in factories:
            holder.make_policy = trainer.learner.spawn


def _spawn_factories(trainer: DAggerTrainer) -> list[Any]:
    """The strategy's parts whose ``make_policy`` is the learner's ``spawn`` (set by ``attach``)."""
    found, pending, seen = [], [trainer.strategy], set()
    while pending:
        part = pending.pop()
        if id(part) in seen or not type(part).__module__.startswith("antmaze_hirl."):
            continue
        seen.add(id(part))
        factory = getattr(part, "make_policy", None)
        if getattr(factory, "__self__", None) is trainer.learner and getattr(factory, "__name__", "") == "spawn":
            found.append(part)
        pending.extend(value for value in vars(part).values() if hasattr(value, "__dict__"))
    return found


def _load_checkpoint(path: Path, env: Any) -> TrialState:
    """The trial state saved at ``path`` (:mod:`antmaze_hirl.study.checkpoint`: nothing in it can run).

    Raises:
        DamagedRecords: If the file fails its hash, is an old pickled checkpoint or a bare pickle, holds a
            class off the allow-list or something else than a trial state (names the file).
    """
    try:
        state = load_checkpoint(path, extra_classes=(TrialState, DemonstrationLog))
    except (CheckpointError, ValueError) as error:  # ValueError: DemonstrationLog's renamed keys
        raise DamagedRecords(str(error) if isinstance(error, CheckpointError) else f"{path} {error}") from None
    if not isinstance(state, TrialState):
        raise DamagedRecords(f"{path} holds {type(state).__name__}, not a trial checkpoint")
    state.trainer.env, state.trainer.expert = env, PageExpert()
    state.trainer.strategy.attach(state.trainer.learner)  # make_policy again (left None by the save)
    return state
