"""A study folder opened for serving: its plan, settings and the participants' sessions."""

from __future__ import annotations

import threading
from pathlib import Path

from antmaze_hirl.study.plan import StudyPlan, load_plan
from antmaze_hirl.study.session import ParticipantSession, read_progress
from antmaze_hirl.study.settings import StudySettings, load_settings


class UnknownParticipant(KeyError):
    """A participant id that the plan does not have (answered with HTTP 404)."""

    def __str__(self) -> str:
        return str(self.args[0])


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
        self._lock = threading.Lock()

    @property
    def participant_ids(self) -> list[str]:
        """The plan's participant ids, in order."""
        return list(self._participants)

    def session(self, participant_id: str) -> ParticipantSession:
        """The session of ``participant_id`` (restored from disk the first time).

        Raises:
            UnknownParticipant: If the plan has no such participant.
        """
        self._check_known(participant_id)
        with self._lock:
            if participant_id not in self._sessions:
                self._sessions[participant_id] = ParticipantSession(
                    self.folder, self.plan, self._participants[participant_id], self.settings
                )
            return self._sessions[participant_id]

    def progress(self, participant_id: str) -> tuple[int, str]:
        """``(trial_index, phase)`` of ``participant_id``, without restoring a session (no simulators built).

        Raises:
            UnknownParticipant: If the plan has no such participant.
        """
        self._check_known(participant_id)
        with self._lock:
            session = self._sessions.get(participant_id)
        if session is not None:
            return session.trial_index, session.phase
        return read_progress(self.folder / "participants" / participant_id)

    def _check_known(self, participant_id: str) -> None:
        if participant_id not in self._participants:
            raise UnknownParticipant(f"unknown participant {participant_id!r}; the plan has {self.participant_ids}")

    def close(self) -> None:
        """Releases every session's simulators."""
        with self._lock:
            for session in self._sessions.values():
                session.close()
