"""Background updates: the next maze starts at once, the learner lags one maze, and nothing is lost on a restart."""

import threading
import time

import pytest
import torch
from study_helpers import ClosingDisk, make_tiny_study, open_session, play_one_episode, play_to_episode_end, play_trial

from antmaze_hirl.dagger import DAggerTrainer
from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy
from antmaze_hirl.study import session as session_module
from antmaze_hirl.study.checkpoint import CHECKPOINT_FILE
from antmaze_hirl.study.consistency import check_records, check_study_files, closing_trials, read_progress
from antmaze_hirl.study.data import EPISODE_COLUMNS, read_episode_rows
from antmaze_hirl.study.logs import csv_cell, read_json_records
from antmaze_hirl.study.plan import load_plan
from antmaze_hirl.study.questionnaire import ITEM_KEYS
from antmaze_hirl.study.session import ParticipantSession, TrialClosing, _load_checkpoint
from antmaze_hirl.study.store import Study

GATE_SECONDS = 60.0
"""The longest a held update waits for its gate: a request that waited for the update would hang this long."""


def rows_of(folder):
    return read_episode_rows(folder / "participants" / "P01" / "episodes.csv")


class UpdateGate:
    """Learner updates that wait until the test opens the gate (an update slower than any maze), instead of a sleep.

    A request that waited for an update would hang until :data:`GATE_SECONDS`, so a test asserts that a request
    returned with the update still held (:attr:`finished` short), which does not depend on the machine's speed.
    A session's close opens the gate: a stop lets the update in progress finish (``UpdateQueue.stop``), so it
    would wait for it.
    """

    def __init__(self, monkeypatch):
        self.started, self.finished = [], []  # when each update reached the gate, and when it finished
        self._open = threading.Event()
        real_update, real_close = DAggerTrainer._update, ParticipantSession.close

        def held_update(trainer, steps):
            self.started.append(time.monotonic())
            assert self._open.wait(GATE_SECONDS), "the gate of the update was never opened"
            real_update(trainer, steps)
            self.finished.append(time.monotonic())

        def close(session):
            self.open()
            real_close(session)

        monkeypatch.setattr(DAggerTrainer, "_update", held_update)
        monkeypatch.setattr(ParticipantSession, "close", close)

    def open(self):
        self._open.set()

    def close(self):
        self._open.clear()


def test_next_does_not_wait_for_a_slow_update(tmp_path, monkeypatch):
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=3, practice=0, background_updates=True)
    gate = UpdateGate(monkeypatch)
    session = open_session(folder)
    for maze in range(2):  # the two mazes before the last, each played while the update before it runs
        play_to_episode_end(session)
        state = session.next_episode()
        assert state["phase"] == "label"
        assert len(gate.finished) == maze  # the maze is saved and the next built while its update is held
        gate.open()
        for job in session._updates.pending():  # a person whose maze lasts longer than the update
            job.wait()
        gate.close()
    assert len(gate.finished) == 2  # both updates ran, in the background
    gate.open()
    play_trial(session)
    assert session.wait_for_closed_trials(timeout=60)  # the last maze's update, after the trial closed
    session.close()
    assert [row["learner_updates"] for row in rows_of(folder)] == ["0", "0", "1"]  # the learner lags one maze


@pytest.mark.parametrize("background", [False, True])
def test_every_maze_records_its_learner_and_evaluations_land_on_the_schedule(tmp_path, background):
    folder = make_tiny_study(
        tmp_path / "study", methods=("dagger",), episodes=4, practice=0, background_updates=background
    )
    session = open_session(folder)
    play_trial(session)
    assert session.phase == "questionnaire"
    assert session.wait_for_closed_trials(timeout=60)
    session.close()
    rows = rows_of(folder)
    assert [row["episode"] for row in rows] == ["0", "1", "2", "3"]
    updates = [int(row["learner_updates"]) for row in rows]
    if background:  # a lag of at least one maze, more while updates queue (instant clicks here), never backwards
        assert updates[0] == 0 and all(0 <= u <= max(k - 1, 0) for k, u in enumerate(updates))
        assert updates == sorted(updates)
    else:
        assert updates == [0, 1, 2, 3]
    assert [row["eval_success"] != "" for row in rows] == [False, True, False, True]  # eval_every 2, and the end


def test_a_restart_while_an_update_runs_finishes_it_and_loses_no_maze(tmp_path):
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=3, practice=0, background_updates=True)
    session = open_session(folder)
    play_one_episode(session)  # maze 1 saved with its update still due; maze 2 is open
    session.close()  # a stop: the running update ends unused
    assert not (folder / "participants" / "P01" / "episodes.csv").exists()  # its row waits for the update
    restarted = open_session(folder)
    assert [row["episode"] for row in rows_of(folder)] == ["0"]  # the restore ran the update and wrote the row
    assert restarted.state()["episode"] == {"number": 2, "of": 3}
    play_trial(restarted)
    assert restarted.wait_for_closed_trials(timeout=60)
    restarted.close()
    assert [row["episode"] for row in rows_of(folder)] == ["0", "1", "2"]


def final_updates(folder):
    events = read_json_records(folder / "participants" / "P01" / "events.jsonl")
    return [record for _, record in events if record["event"] == "final_update"]


def play_to_the_last_maze(session, gate=None):
    """Plays every maze but the last (each update done before the next maze ends, as for a person).

    With a ``gate``, each update is let through once its next maze has started, and the gate is closed again
    at the last maze's end.
    """
    episodes = session.trial.episodes
    for _ in range(episodes - 1):
        play_to_episode_end(session)
        session.next_episode()
        if gate is not None:
            gate.open()
        for job in session._updates.pending():
            job.wait()
        if gate is not None:
            gate.close()
    play_to_episode_end(session)


def at_the_last_maze(tmp_path, monkeypatch, held=True, practice=0):
    """A 2-maze background-update study, its session at the end of the first part's last maze: the study folder,
    the session and the :class:`UpdateGate`, counting from here (closed: the updates from here on are held;
    ``held=False``: open)."""
    folder = make_tiny_study(
        tmp_path / "study", methods=("dagger",), episodes=2, practice=practice, background_updates=True
    )
    gate = UpdateGate(monkeypatch)
    session = open_session(folder)
    play_to_the_last_maze(session, gate)
    gate.started.clear()  # the gate counts the updates from here on
    gate.finished.clear()
    if not held:
        gate.open()
    return folder, session, gate


def test_the_last_maze_closes_the_part_at_once_and_its_update_finishes_after(tmp_path, monkeypatch):
    folder, session, gate = at_the_last_maze(tmp_path, monkeypatch)
    closing = time.monotonic()
    state = session.next_episode()
    closed = time.monotonic()
    assert state["phase"] == "questionnaire" and state["last_trial"]["episodes"] == 2
    assert gate.finished == []  # the part ends without its update (held until the gate opens below)
    trial = folder / "participants" / "P01" / "trial1"
    assert not (trial / "learner.zip").exists()  # the final learner is not written yet
    assert [row["episode"] for row in rows_of(folder)] == ["0"]  # its row waits for the final evaluation
    with pytest.raises(ValueError, match=r"trial1 has no learner\.zip yet"):  # analyze waits for it
        check_study_files(folder, load_plan(folder))
    assert Study(folder).progress("P01") == (0, "questionnaire")  # not damage: the picker lists it as it is
    answered = session.submit_questionnaire(1, {"ratings": dict.fromkeys(ITEM_KEYS, 3), "comment": ""})
    assert answered["phase"] == "done"  # answered while the update is held
    time.sleep(0.2)  # a lag the final_update event must show
    opened = time.monotonic()
    gate.open()
    assert session.wait_for_closed_trials(timeout=60)
    written = time.monotonic()
    session.close()
    rows = rows_of(folder)
    assert [row["episode"] for row in rows] == ["0", "1"] and rows[-1]["eval_success"] != ""  # the final evaluation
    assert (trial / "learner.zip").is_file()
    (event,) = final_updates(folder)
    assert event["updates"] == 1 and not event["resumed"]
    assert opened - closed - 0.001 <= event["lag_seconds"] <= written - closing + 0.001  # the data state the lag
    check_study_files(folder, load_plan(folder))


def test_a_closed_trials_rows_removed_after_its_final_update_are_damage_not_a_closing_to_resume(tmp_path, monkeypatch):
    # With learner.zip gone too the trial looks like a closing cut off before its last rows, but its
    # final_update is logged, which a closing writes only after them: the rows were removed, and the
    # participant is stopped (409) naming the file instead of being repaired from the checkpoint.
    folder, session, _ = at_the_last_maze(tmp_path, monkeypatch, held=False)
    assert session.next_episode()["phase"] == "questionnaire"
    assert session.wait_for_closed_trials(timeout=60)
    session.close()
    participant = folder / "participants" / "P01"
    (participant / "trial1" / "learner.zip").unlink()
    episodes = participant / "episodes.csv"
    episodes.write_text("".join(episodes.read_text().splitlines(keepends=True)[:-1]))  # its last row
    with pytest.raises(ValueError, match=r"episodes\.csv has 1 of the 2 rows of finished trial 1"):
        check_records(participant, load_plan(folder).participants[0], *read_progress(participant))
    assert closing_trials(participant, load_plan(folder).participants[0], *read_progress(participant))  # as before


def test_after_a_practice_the_next_part_opens_and_starts_while_the_practice_update_runs(tmp_path, monkeypatch):
    folder, session, gate = at_the_last_maze(tmp_path, monkeypatch, practice=2)
    assert session.next_episode()["phase"] == "intro"
    assert session.start_trial()["phase"] == "label"
    assert gate.finished == []  # neither waits for the practice's last update (held until here)
    gate.open()
    assert session.wait_for_closed_trials(timeout=60)  # the practice's closing, done within the maze as for a person
    play_trial(session)
    assert session.wait_for_closed_trials(timeout=60)
    session.close()
    assert [(row["trial"], row["episode"]) for row in rows_of(folder)] == [
        ("0", "0"),
        ("0", "1"),
        ("1", "0"),
        ("1", "1"),
    ]
    assert [event["trial"] for event in final_updates(folder)] == [0, 1]
    check_study_files(folder, load_plan(folder))


def test_a_stop_while_a_closed_trial_updates_is_resumed_when_the_server_starts(tmp_path, monkeypatch):
    folder, session, gate = at_the_last_maze(tmp_path, monkeypatch)
    assert session.next_episode()["phase"] == "questionnaire"
    assert gate.finished == []
    session.close()  # a stop while the update is held (the stop lets it end): it ends unused, nothing is written
    trial = folder / "participants" / "P01" / "trial1"
    assert not (trial / "learner.zip").exists() and len(rows_of(folder)) == 1 and not final_updates(folder)
    study = Study(folder)  # a server start: the participant need not come back for the update to finish
    resuming = study.resume_closing()
    assert resuming is not None
    resuming.join(60)
    assert study.wait_for_closed_trials(timeout=60)
    assert study.session("P01").phase == "questionnaire"
    study.close()
    assert [row["episode"] for row in rows_of(folder)] == ["0", "1"] and (trial / "learner.zip").is_file()
    (event,) = final_updates(folder)
    assert event["resumed"] and event["updates"] == 1
    assert Study(folder).resume_closing() is None  # nothing left


def test_a_failed_close_after_the_last_maze_is_closed_by_the_restart(tmp_path, monkeypatch):
    # A kill (here: a failed progress write, then a stop) after the last maze was saved, before the close.
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=2, practice=0, background_updates=True)
    session = open_session(folder)
    play_to_the_last_maze(session)
    real_save = ParticipantSession._save_progress

    def failing(self, trial_index, phase):
        if phase == "questionnaire":
            raise OSError("no space left on device")
        real_save(self, trial_index, phase)

    monkeypatch.setattr(ParticipantSession, "_save_progress", failing)
    with pytest.raises(OSError, match="no space"):
        session.next_episode()
    assert session.phase == "episode_over"
    session.close()
    monkeypatch.setattr(ParticipantSession, "_save_progress", real_save)
    restarted = open_session(folder)
    assert restarted.phase == "questionnaire"
    assert restarted.wait_for_closed_trials(timeout=60)
    restarted.close()
    rows = rows_of(folder)
    assert [row["episode"] for row in rows] == ["0", "1"] and rows[-1]["eval_success"] != ""
    assert (folder / "participants" / "P01" / "trial1" / "learner.zip").is_file()
    assert len(final_updates(folder)) == 1
    check_study_files(folder, load_plan(folder))


WRITES_OF_A_CLOSING = {  # each durable write a closing makes, by the fsync that ends it
    "checkpoint": lambda path: path.name.startswith(".checkpoint."),
    "checkpoint's rename": lambda path: path.name == "trial1",
    "rows": lambda path: path.name == "episodes.csv",
    "final_update event": lambda path: path.name == "events.jsonl",
    "learner": lambda path: path.name.startswith(".learner."),
}


def until(condition, seconds=60.0):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def assert_closed_trial_complete(folder):
    """The start-up checks pass with nothing left to close, and the files hold every maze of trial 1 once."""
    plan = load_plan(folder)
    participant, path = plan.participants[0], folder / "participants" / "P01"
    check_records(path, participant, *read_progress(path))
    assert closing_trials(path, participant, *read_progress(path)) == []
    rows = rows_of(folder)
    assert [row["episode"] for row in rows] == ["0", "1"] and rows[-1]["eval_success"] != ""  # the final evaluation
    saved = _load_checkpoint(path / "trial1" / CHECKPOINT_FILE, None)
    assert saved.pending == []  # the checkpoint holds every maze done, and the rows are its rows
    assert [{column: csv_cell(row.get(column)) for column in EPISODE_COLUMNS} for row in saved.rows] == rows
    learner = HighLevelPolicy.load(path / "trial1" / "learner.zip")  # the learner after every update
    for name, weights in saved.trainer.learner.network.state_dict().items():
        assert torch.equal(learner.network.state_dict()[name], weights), name
    assert Study(folder).resume_closing() is None  # a restart finds nothing to finish


@pytest.mark.parametrize("write", list(WRITES_OF_A_CLOSING))
def test_a_closed_trials_write_that_fails_once_is_retried_without_a_restart(tmp_path, monkeypatch, write):
    folder, session, _ = at_the_last_maze(tmp_path, monkeypatch, held=False)
    monkeypatch.setattr(TrialClosing, "RETRY_FIRST_SECONDS", 0.1)
    checkpoints = []
    real_save = session_module._save_checkpoint

    def counted_save(*args):
        checkpoints.extend([1] if threading.current_thread().name.startswith("study-close-") else [])
        real_save(*args)

    monkeypatch.setattr(session_module, "_save_checkpoint", counted_save)
    disk = ClosingDisk(monkeypatch, WRITES_OF_A_CLOSING[write], fails=1)
    assert session.next_episode()["phase"] == "questionnaire"
    (closing,) = session._closing
    until(lambda: closing.done)  # no request, no restart: the closing's own retry
    assert len(checkpoints) == (2 if write.startswith("checkpoint") else 1)  # a retry starts at the failed write
    assert len(disk.failed) == 1 and closing.failed_writes == 1
    assert closing.error is None and closing.write_error is None and "unsaved" not in session.state()
    assert_closed_trial_complete(folder)
    (event,) = final_updates(folder)
    assert event["failed_writes"] == (write != "learner") and event["updates"] == 1  # learner.zip comes after it
    session.submit_questionnaire(1, {"ratings": dict.fromkeys(ITEM_KEYS, 3), "comment": ""})
    session.close()
    check_study_files(folder, load_plan(folder))  # study analyze's checks


def test_while_a_closed_trials_writes_fail_the_page_says_so_and_a_request_retries_them(tmp_path, monkeypatch):
    folder, session, _ = at_the_last_maze(tmp_path, monkeypatch, held=False)
    monkeypatch.setattr(TrialClosing, "RETRY_FIRST_SECONDS", 3600.0)  # only a request wakes it here
    monkeypatch.setattr(TrialClosing, "RETRY_GAP_SECONDS", 0.0)
    disk = ClosingDisk(monkeypatch, lambda path: True)  # every write of the closing fails
    tries_begun = []
    real_write = TrialClosing._write

    def counted_write(self, updates):
        tries_begun.append(updates)
        real_write(self, updates)

    monkeypatch.setattr(TrialClosing, "_write", counted_write)
    session.next_episode()
    (closing,) = session._closing
    until(lambda: closing.failing)
    state = session.state()
    assert state["phase"] == "questionnaire"
    assert state["unsaved"] == {"parts": [session.trial.label], "retrying": True, "error": "No space left on device"}
    until(lambda: session.state() and len(disk.failed) >= 3)  # each request is another try
    with pytest.raises(RuntimeError, match="its writes are retried"):  # a stop does not wait on a full disk
        session.wait_for_closed_trials(timeout=60)

    def idle():  # every try begun has failed and none is woken: it waits out the hour
        return len(tries_begun) == len(disk.failed) and not closing._wake.is_set()

    until(lambda: idle() and time.sleep(0.2) is None and idle())
    tries = len(disk.failed)
    disk.free()
    time.sleep(0.3)
    assert len(disk.failed) == tries and not closing.done  # waiting out the hour
    assert "unsaved" in session.state()  # this request wakes it
    until(lambda: closing.done, 10.0)
    assert "unsaved" not in session.state() and closing.write_error is None
    assert final_updates(folder)[0]["failed_writes"] == tries
    session.close()
    assert_closed_trial_complete(folder)


def test_a_request_during_a_retry_is_that_retry_and_does_not_start_another_after_it(tmp_path, monkeypatch):
    folder, session, _ = at_the_last_maze(tmp_path, monkeypatch, held=False)
    monkeypatch.setattr(TrialClosing, "RETRY_FIRST_SECONDS", 3600.0)  # only a request wakes it here
    monkeypatch.setattr(TrialClosing, "RETRY_GAP_SECONDS", 0.0)
    disk = ClosingDisk(monkeypatch, lambda path: True)
    in_second_try, release = threading.Event(), threading.Event()
    tries_begun = []
    real_write = TrialClosing._write

    def held_write(self, updates):  # the second try (the first retry) waits for the test's request
        tries_begun.append(updates)
        if len(tries_begun) == 2:
            in_second_try.set()
            release.wait(30)
        real_write(self, updates)

    monkeypatch.setattr(TrialClosing, "_write", held_write)
    session.next_episode()
    (closing,) = session._closing
    until(lambda: closing.failing)
    assert "unsaved" in session.state()  # wakes the first retry
    assert in_second_try.wait(30)
    assert "unsaved" in session.state()  # asked while that retry runs: it is the retry asked for
    release.set()
    until(lambda: len(disk.failed) == 2)
    time.sleep(0.5)
    assert len(tries_begun) == 2 and not closing._wake.is_set()  # no third try until the hour or a request
    disk.free()
    assert "unsaved" in session.state()  # a request after the retry wakes the next
    until(lambda: closing.done, 10.0)
    assert len(tries_begun) == 3 and closing.write_error is None
    session.close()
    assert_closed_trial_complete(folder)


def test_a_stop_while_a_closed_trials_writes_fail_is_prompt_and_the_restart_finishes_them(tmp_path, monkeypatch):
    folder, session, _ = at_the_last_maze(tmp_path, monkeypatch, held=False)
    monkeypatch.setattr(TrialClosing, "RETRY_FIRST_SECONDS", 3600.0)
    disk = ClosingDisk(monkeypatch, lambda path: True)
    session.next_episode()
    until(lambda: disk.failed)
    started = time.monotonic()
    session.close()  # wakes the waiting closing: nothing more is written
    assert time.monotonic() - started < 5.0
    disk.free()
    restarted = open_session(folder)  # the next start resumes it from the checkpoint
    assert restarted.wait_for_closed_trials(timeout=60)
    restarted.close()
    assert_closed_trial_complete(folder)


def test_one_participants_failing_writes_do_not_cut_short_anothers_closing(tmp_path, monkeypatch):
    # The study waits on every participant before it raises, so a stop that follows leaves the healthy
    # (slow) closing written instead of ending it unwritten.
    folder = make_tiny_study(
        tmp_path / "study", participants=2, methods=("dagger",), episodes=2, practice=0, background_updates=True
    )
    gate = UpdateGate(monkeypatch)
    monkeypatch.setattr(TrialClosing, "RETRY_FIRST_SECONDS", 3600.0)
    disk = ClosingDisk(monkeypatch, lambda path: "P01" in path.parts)  # P01's disk is full, P02's is not
    study = Study(folder)
    waited_on = []
    real_wait = TrialClosing.wait

    def wait(closing, timeout=None):  # P02's final update is held until the study waits on its closing
        waited_on.append(closing.session.participant.id)
        if closing.session.participant.id == "P02":
            gate.open()
        return real_wait(closing, timeout)

    try:
        for participant in ("P01", "P02"):
            session = study.session(participant)
            session.start_trial()
            play_to_the_last_maze(session, gate)  # P02's first update lets P01's final update through
            assert session.next_episode()["phase"] == "questionnaire"
        monkeypatch.setattr(TrialClosing, "wait", wait)
        with pytest.raises(RuntimeError, match=r"participant P01, trial 1: .*its writes are retried"):
            study.wait_for_closed_trials(timeout=60)
        assert waited_on == ["P01", "P02"]  # P01's failing writes did not stop the study before it waited on P02
        assert disk.failed
        assert (folder / "participants" / "P02" / "trial1" / "learner.zip").is_file()  # waited on, not cut short
    finally:
        study.close()
