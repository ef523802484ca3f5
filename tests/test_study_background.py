"""Background updates: the next maze starts at once, the learner lags one maze, and nothing is lost on a restart."""

import time

import pytest
from study_helpers import make_tiny_study, open_session, play_to_episode_end, play_trial

from antmaze_hirl.dagger import DAggerTrainer
from antmaze_hirl.study.data import read_episode_rows

SLOW_UPDATE_SECONDS = 5.0


def rows_of(folder):
    return read_episode_rows(folder / "participants" / "P01" / "episodes.csv")


def test_next_does_not_wait_for_a_slow_update(tmp_path, monkeypatch):
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=3, practice=0, background_updates=True)
    real_update = DAggerTrainer._update
    updating = []

    def slow_update(self, steps):
        updating.append(time.monotonic())
        time.sleep(SLOW_UPDATE_SECONDS)
        real_update(self, steps)

    monkeypatch.setattr(DAggerTrainer, "_update", slow_update)
    session = open_session(folder)
    waits = []
    for _ in range(2):  # the two mazes before the last, each played while the update before it runs
        play_to_episode_end(session)
        started = time.monotonic()
        state = session.next_episode()
        waits.append(time.monotonic() - started)
        assert state["phase"] == "label"
        for job in session._updates.pending():  # a person whose maze lasts longer than the update
            job.wait()
    assert len(updating) == 2  # both updates ran, in the background
    assert max(waits) < SLOW_UPDATE_SECONDS - 1.5, waits  # the maze is saved and the next built, no more
    play_trial(session)  # the last maze waits for its own update and the final evaluation
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
    play_to_episode_end(session)
    session.next_episode()  # maze 1 saved with its update still due; maze 2 is open
    session.close()  # a stop: the running update ends unused
    assert not (folder / "participants" / "P01" / "episodes.csv").exists()  # its row waits for the update
    restarted = open_session(folder)
    assert [row["episode"] for row in rows_of(folder)] == ["0"]  # the restore ran the update and wrote the row
    assert restarted.state()["episode"] == {"number": 2, "of": 3}
    play_trial(restarted)
    restarted.close()
    assert [row["episode"] for row in rows_of(folder)] == ["0", "1", "2"]
