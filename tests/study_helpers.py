"""Tiny point-body studies for the study tests (a few episodes, so a whole study runs in seconds)."""

import errno
import os
import threading
from pathlib import Path

from antmaze_hirl.study.plan import make_plan, save_plan
from antmaze_hirl.study.settings import StudySettings, save_settings

TINY_SETTINGS = {
    "maze_size": 4,
    "eval_every": 2,
    "eval_episodes": 1,
    "final_eval_episodes": 2,
    "gradient_steps": 5,
    "background_updates": False,  # the experiments' order; tests of the background update turn it on
}


def make_tiny_study(
    folder: Path,
    *,
    participants: int = 1,
    methods=("dagger", "reward"),
    episodes: int = 2,
    practice: int = 1,
    **settings,
) -> Path:
    """A study folder: point body, 4x4 held-out mazes, ``episodes`` per trial, tiny evaluations.

    ``settings`` override :data:`TINY_SETTINGS` (4x4: the 3x3 family has no selection part once the
    layouts are split up to symmetry).
    """
    save_plan(make_plan("point", list(methods), participants, episodes=episodes, practice=practice, seed=0), folder)
    save_settings(StudySettings.for_body("point", **{**TINY_SETTINGS, **settings}), folder)
    return folder


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` with its bytes (to show a refused request changed nothing)."""
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


class FakeClock:
    """Wall-clock seconds that move only when a test says so."""

    def __init__(self, now: float = 1000.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


def open_session(folder: Path, participant_id: str = "P01", clock=None):
    """A participant's session built straight from the folder (no server), with an injectable clock."""
    import time

    from antmaze_hirl.study.plan import load_plan
    from antmaze_hirl.study.session import ParticipantSession
    from antmaze_hirl.study.settings import load_settings

    plan = load_plan(folder)
    participant = next(p for p in plan.participants if p.id == participant_id)
    timer = clock or time.monotonic  # a fake clock drives the durations too
    return ParticipantSession(folder, plan, participant, load_settings(folder), clock=clock or time.time, timer=timer)


def click_once(session, clock: FakeClock | None = None, seconds: float = 2.0) -> dict:
    """Answers the open query with the oracle's click, ``seconds`` after it was shown."""
    from antmaze_hirl.study.simulate import oracle_click

    state = session.state()
    if clock is not None:
        clock.advance(seconds)
    x, y = oracle_click(state)
    return session.label(state["query"]["id"], float(x), float(y))


def played_template(tmp_path_factory, play, **study) -> Path:
    """A study folder (:func:`make_tiny_study` with ``study``) whose P01 ``play`` played, the session closed.

    For module-scoped templates that each test gets a :func:`fresh_copy` of: playing is the slow part.
    """
    folder = make_tiny_study(tmp_path_factory.mktemp("template") / "study", **study)
    session = open_session(folder)
    play(session)
    session.close()
    return folder


def fresh_copy(template: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A copy of a played study ``template`` (made once per module) under ``tmp_path``: its folder and P01's."""
    import shutil

    folder = tmp_path / "study"
    shutil.copytree(template, folder)
    return folder, folder / "participants" / "P01"


def play_to_episode_end(session) -> None:
    """Starts the trial if at its intro, then clicks as the oracle until the maze ends."""
    if session.phase == "intro":
        session.start_trial()
    while session.phase == "label":
        click_once(session)


def play_one_episode(session) -> None:
    """:func:`play_to_episode_end`, then closes the maze (``next_episode``)."""
    play_to_episode_end(session)
    session.next_episode()


def play_trial(session) -> None:
    """Plays mazes until the trial closes (its questionnaire, or the next trial's intro after a practice)."""
    trial = session.trial_index
    while session.trial_index == trial and session.phase in ("intro", "label", "episode_over"):
        play_one_episode(session)


class ClosingDisk:
    """A full disk for the closing threads alone: their ``os.fsync`` of a matching file raises ENOSPC.

    ``fails`` is how many such fsyncs fail (``None``: every one, until :meth:`free`). fsync is the last step
    of every durable write (atomic replace and append), so the bytes may already be in the file, as after a
    real ENOSPC on flush; the writers must take them back.
    """

    def __init__(self, monkeypatch, matches, fails=None):
        self.matches, self.fails, self.failed = matches, fails, []
        real_fsync = os.fsync

        def fsync(fd):
            if self.fails is None or len(self.failed) < self.fails:
                path = Path(os.readlink(f"/proc/self/fd/{fd}"))
                if threading.current_thread().name.startswith("study-close-") and self.matches(path):
                    self.failed.append(path.name)
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return real_fsync(fd)

        monkeypatch.setattr(os, "fsync", fsync)

    def free(self):
        self.fails = len(self.failed)
