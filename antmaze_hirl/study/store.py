"""A study folder opened for serving: its plan, settings and the participants' sessions, and its server lock."""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import threading
import time
from pathlib import Path

from antmaze_hirl.study.consistency import check_records, closing_trials, read_progress
from antmaze_hirl.study.plan import StudyPlan, load_plan
from antmaze_hirl.study.session import DamagedRecords, ParticipantSession
from antmaze_hirl.study.settings import StudySettings, load_settings

logger = logging.getLogger(__name__)


class UnknownParticipant(KeyError):
    """A participant id that the plan does not have (answered with HTTP 404)."""

    def __str__(self) -> str:
        return str(self.args[0])


class StudyInUse(OSError):
    """Another server already serves this study folder (the message names its PID)."""

    def __str__(self) -> str:
        return str(self.args[0])


class StudyLock:
    """An exclusive OS lock (``flock``) on the study folder itself and on ``DIR/server.lock``: one server per folder.

    Two servers on one folder would both append every click and event. The lock is the kernel's, so
    it goes with the process that holds it, even after ``kill -9``. The folder's lock is the truth: deleting
    ``server.lock`` (which keeps the holder's PID for the message a second server gives) lets no second
    server in; the file's lock keeps out servers of earlier versions, which lock only the file.

    Args:
        study_dir: The study folder.

    Raises:
        StudyInUse: If another process (or another server in this one) holds the lock.
    """

    FILE_NAME = "server.lock"

    def __init__(self, study_dir: str | Path) -> None:
        self.path = Path(study_dir) / self.FILE_NAME
        if not Path(study_dir).is_dir():
            raise FileNotFoundError(f"{study_dir} is not a study folder (run 'antmaze-hirl study init' first)")
        self._folder_fd: int | None = os.open(study_dir, os.O_RDONLY | os.O_DIRECTORY)
        self._fd: int | None = None
        try:
            fcntl.flock(self._folder_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = "unknown"
            with contextlib.suppress(OSError):
                holder = self.path.read_bytes()[:32].decode("ascii", "replace").strip() or holder
            self.release()
            raise StudyInUse(
                f"{study_dir} is already served by PID {holder} (it holds a lock on the folder); stop that server first"
            ) from None
        os.ftruncate(self._fd, 0)
        os.pwrite(self._fd, f"{os.getpid()}\n".encode(), 0)

    def release(self) -> None:
        """Releases the locks (the file stays; its PID line is stale until the next server writes its own)."""
        for fd in (self._fd, self._folder_fd):
            if fd is not None:
                with contextlib.suppress(OSError):
                    fcntl.flock(fd, fcntl.LOCK_UN)
                os.close(fd)
        self._fd = self._folder_fd = None


class Study:
    """The sessions of a study folder, made on first use and resumed from disk.

    Args:
        study_dir: A folder made by ``antmaze-hirl study init``.

    Raises:
        FileNotFoundError: If the folder has no plan or settings.
        ValueError: If they are malformed.
    """

    def __init__(self, study_dir: str | Path) -> None:
        self.folder = Path(study_dir)
        self.plan: StudyPlan = load_plan(self.folder)
        self.settings: StudySettings = load_settings(self.folder)
        if self.settings.body != self.plan.body:
            raise ValueError(
                f"{self.folder}: the plan is for body {self.plan.body!r} but settings.json says {self.settings.body!r}"
            )
        self._participants = {participant.id: participant for participant in self.plan.participants}
        self._sessions: dict[str, ParticipantSession] = {}
        self._lock = threading.Lock()  # guards the dicts, never held while a session is restored
        self._restoring = {participant_id: threading.Lock() for participant_id in self._participants}

    @property
    def participant_ids(self) -> list[str]:
        """The plan's participant ids, in order."""
        return list(self._participants)

    def session(self, participant_id: str) -> ParticipantSession:
        """The session of ``participant_id`` (restored from disk the first time).

        Restoring one participant (simulators, checkpoint: seconds) holds only that participant's lock,
        so the others are served meanwhile. A failed restore is not kept: the next request tries again.

        Raises:
            UnknownParticipant: If the plan has no such participant.
            DamagedRecords: If the participant's files are damaged or missing (names the file).
        """
        self._check_known(participant_id)
        with self._restoring[participant_id]:
            with self._lock:
                session = self._sessions.get(participant_id)
            if session is None:
                session = ParticipantSession(self.folder, self.plan, self._participants[participant_id], self.settings)
                with self._lock:
                    self._sessions[participant_id] = session
            return session

    def progress(self, participant_id: str) -> tuple[int, str]:
        """``(trial_index, phase)`` of ``participant_id``, without restoring a session (no simulators built).

        Raises:
            UnknownParticipant: If the plan has no such participant.
            ValueError: If its ``progress.json`` is malformed, or its files are damaged or disagree (names the file).
        """
        self._check_known(participant_id)
        with self._lock:
            session = self._sessions.get(participant_id)
        if session is not None:
            return session.trial_index, session.phase
        folder = self.folder / "participants" / participant_id
        trial_index, phase = read_progress(folder)
        if folder.is_dir():  # files that disagree show as damaged here too, not as a fresh participant
            check_records(folder, self._participants[participant_id], trial_index, phase)
        return trial_index, phase

    def resume_closing(self) -> threading.Thread | None:
        """Restores, in a background thread, the participants with a closed trial whose final update was cut off.

        A stop or a kill during a :class:`~antmaze_hirl.study.session.TrialClosing` leaves a closed trial with
        a checkpoint and no ``learner.zip``; restoring the participant's session resumes it, whether or not the
        participant comes back. A participant whose files are damaged is left for their next request (409).

        Returns:
            The thread, or ``None`` when no participant has such a trial.
        """
        waiting = []
        for participant in self.plan.participants:
            folder = self.folder / "participants" / participant.id
            with contextlib.suppress(ValueError):
                if folder.is_dir() and closing_trials(folder, participant, *read_progress(folder)):
                    waiting.append(participant.id)
        if not waiting:
            return None

        def restore() -> None:
            for participant_id in waiting:
                try:
                    self.session(participant_id)
                except (DamagedRecords, ValueError, OSError) as error:
                    logger.warning("participant %s not restored at start: %s", participant_id, error)

        thread = threading.Thread(target=restore, name="study-resume-closing", daemon=True)
        thread.start()
        return thread

    def wait_for_closed_trials(self, timeout: float | None = None) -> bool:
        """Waits until every open session's closed trials have their final updates written; whether they have.

        Every session is waited on before any error is raised: one participant's failing writes (a full disk)
        must not cut short another's healthy closing, which a caller that stops next would end unwritten.

        Raises:
            RuntimeError: If one or more failed, naming each
                (:meth:`~antmaze_hirl.study.session.ParticipantSession.wait_for_closed_trials`); the first chained.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._lock:
            sessions = list(self._sessions.values())
        errors: list[RuntimeError] = []
        finished = True
        for session in sessions:
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            try:
                finished = session.wait_for_closed_trials(left) and finished
            except RuntimeError as error:
                errors.append(error)
        if errors:
            raise RuntimeError("; ".join(str(error) for error in errors)) from errors[0]
        return finished

    def _check_known(self, participant_id: str) -> None:
        if participant_id not in self._participants:
            raise UnknownParticipant(f"unknown participant {participant_id!r}; the plan has {self.participant_ids}")

    def close(self) -> None:
        """Releases every session's simulators and stops the final updates still running (a restart resumes them)."""
        with self._lock:
            sessions = list(self._sessions.values())
        for session in sessions:
            session.close()
