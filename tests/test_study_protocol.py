"""The study protocol: one server per folder, nothing moves while paused, time on task counts only the episode."""

import csv
import os
import subprocess
import sys

import pytest
from study_helpers import FakeClock, click_once, make_tiny_study, open_session

from antmaze_hirl.cli import main
from antmaze_hirl.study.server import TOKEN_ENV, StudyServer
from antmaze_hirl.study.session import ProtocolError
from antmaze_hirl.study.store import StudyInUse


def rows_of(folder, participant="P01"):
    with (folder / "participants" / participant / "episodes.csv").open() as handle:
        return list(csv.DictReader(handle))


def test_a_second_server_on_one_folder_refuses_naming_the_holders_pid(tmp_path, monkeypatch, capsys):
    folder = make_tiny_study(tmp_path / "study")
    with StudyServer(folder).running():
        with pytest.raises(StudyInUse, match=f"already served by PID {os.getpid()}"):
            StudyServer(folder)
        monkeypatch.setenv(TOKEN_ENV, "a-long-enough-token-0123")
        with pytest.raises(SystemExit) as exited:  # the CLI in-process: one line, no traceback
            main(["study", "serve", str(folder), "--port", "0"])
        stderr = capsys.readouterr().err
        assert exited.value.code == 2
        assert stderr.count("\n") == 1 and f"PID {os.getpid()}" in stderr and "Traceback" not in stderr, stderr
    with StudyServer(folder).running():  # released on stop: the next server gets the folder
        pass


@pytest.mark.integration
def test_a_second_server_in_another_process_is_refused_naming_the_holders_pid(tmp_path):
    folder = make_tiny_study(tmp_path / "study")
    with StudyServer(folder).running():
        env = {**os.environ, TOKEN_ENV: "a-long-enough-token-0123"}
        command = [sys.executable, "-m", "antmaze_hirl.cli", "study", "serve", str(folder), "--port", "0"]
        second = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120)
        assert second.returncode == 2
        assert second.stderr.count("\n") == 1 and f"PID {os.getpid()}" in second.stderr, second.stderr
        assert "Traceback" not in second.stderr


def test_next_and_start_are_refused_while_paused(tmp_path):
    folder = make_tiny_study(tmp_path / "study")
    session = open_session(folder)
    session.set_paused(True)
    with pytest.raises(ProtocolError, match="paused"):
        session.start_trial()
    session.set_paused(False)
    session.start_trial()
    while session.phase == "label":
        click_once(session)
    assert session.phase == "episode_over"
    session.set_paused(True)
    with pytest.raises(ProtocolError, match="paused"):
        session.next_episode()
    assert session.phase == "episode_over" and not (folder / "participants" / "P01" / "episodes.csv").exists()
    session.set_paused(False)
    session.next_episode()
    assert len(rows_of(folder)) == 1
    session.close()


def test_time_on_task_counts_only_time_inside_the_episode_with_pauses_at_every_phase(tmp_path):
    folder = make_tiny_study(tmp_path / "study", episodes=2, practice=1)
    clock = FakeClock()
    session = open_session(folder, clock=clock)

    def pause(seconds):
        session.set_paused(True)
        clock.advance(seconds)
        session.set_paused(False)

    pause(100)  # at the intro: before the episode
    first_start = clock.now
    session.start_trial()
    click_once(session, clock, seconds=3)
    inside = 0.0
    if session.phase == "label":  # the episode goes on: a pause inside it is taken off
        pause(7)
        inside = 7.0
    while session.phase == "label":
        click_once(session, clock, seconds=3)
    ended = clock.now  # the last click
    pause(30)  # between mazes, after the episode's end (the case that went to -29.7 s)
    session.next_episode()  # the practice's only episode: the trial closes, the next one is at its intro
    assert session.phase == "intro"
    pause(50)  # at the next intro
    session.start_trial()
    while session.phase == "label":
        click_once(session, clock, seconds=1)
    pause(20)  # after the end again
    session.next_episode()
    rows = rows_of(folder)
    assert float(rows[0]["time_on_task"]) == pytest.approx(ended - first_start - inside)
    clicks = int(rows[1]["expert_cost"])
    assert float(rows[1]["time_on_task"]) == pytest.approx(clicks * 1.0)  # one second per click, no pause
    assert all(float(row["time_on_task"]) >= 0 for row in rows)
    session.close()
