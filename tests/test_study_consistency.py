"""A failed write changes nothing; a participant whose files disagree is stopped, naming the file.

Disk full is a patched ``os.fsync`` (the atomic writer's and the appender's last step before a write counts):
the bytes may already be in the file, as after a real ENOSPC on flush, and the session must take them back.
"""

import errno
import json
import os
import pickle

import pytest
from study_helpers import (
    click_once,
    fresh_copy,
    make_tiny_study,
    open_session,
    play_one_episode,
    play_to_episode_end,
    play_trial,
    played_template,
    snapshot,
)

from antmaze_hirl.study.data import EPISODE_COLUMNS
from antmaze_hirl.study.logs import read_csv_rows, read_json_records
from antmaze_hirl.study.questionnaire import ITEM_KEYS
from antmaze_hirl.study.session import DamagedRecords
from antmaze_hirl.study.store import Study

ANSWERS = {"ratings": dict.fromkeys(ITEM_KEYS, 3), "comment": ""}


@pytest.fixture
def disk_full(monkeypatch):
    """Call ``disk_full()`` to make every durable write fail with ENOSPC until ``disk_full.free()``."""

    real_fsync = os.fsync

    def no_space(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    class Disk:
        def __call__(self):
            monkeypatch.setattr(os, "fsync", no_space)

        def free(self):
            monkeypatch.setattr(os, "fsync", real_fsync)

    return Disk()


@pytest.fixture(scope="module")
def in_trial_two_template(tmp_path_factory):
    """Two compared trials of two episodes (no practice): trial 1 done and rated, trial 2 one episode in."""

    def play(session):
        play_trial(session)
        session.submit_questionnaire(1, ANSWERS)
        play_one_episode(session)

    return played_template(tmp_path_factory, play, methods=("dagger", "reward"), practice=0)


@pytest.fixture
def in_trial_two(in_trial_two_template, tmp_path):
    return fresh_copy(in_trial_two_template, tmp_path)


def episode_rows(participant):
    return [(row["trial"], row["episode"]) for row in read_csv_rows(participant / "episodes.csv", EPISODE_COLUMNS)]


@pytest.mark.parametrize("background", [False, True], ids=["update-first", "background-update"])
def test_disk_full_during_next_changes_nothing_and_a_retry_closes_the_episode_once(tmp_path, disk_full, background):
    # 2 mazes: the failed "next" is the first maze's, which leaves one to play after it (a third maze would
    # play as the second did).
    folder = make_tiny_study(
        tmp_path / "study", methods=("dagger",), episodes=2, practice=0, background_updates=background
    )
    session = open_session(folder)
    play_to_episode_end(session)
    before_state, before_files = session.state(), snapshot(folder)
    disk_full()
    for _ in range(3):  # a participant who clicks "next" again and again
        with pytest.raises(OSError, match="No space left"):
            session.next_episode()
        assert session.state() == before_state
        assert snapshot(folder) == before_files
    disk_full.free()
    assert session.next_episode()["episode"] == {"number": 2, "of": 2}
    play_trial(session)
    assert session.wait_for_closed_trials(timeout=60)
    session.close()
    participant = folder / "participants" / "P01"
    assert episode_rows(participant) == [("1", "0"), ("1", "1")]
    ends = [record for _, record in read_json_records(participant / "events.jsonl") if record["event"] == "trial_end"]
    assert [end["episodes"] for end in ends] == [2]


def test_disk_full_while_closing_a_trial_leaves_it_open_and_a_retry_closes_it_once(tmp_path, disk_full):
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=1, practice=0)
    session = open_session(folder)
    play_to_episode_end(session)
    before_state, before_files = session.state(), snapshot(folder)
    disk_full()
    with pytest.raises(OSError, match="No space left"):
        session.next_episode()
    assert session.state() == before_state and snapshot(folder) == before_files
    disk_full.free()
    assert session.next_episode()["phase"] == "questionnaire"
    participant = folder / "participants" / "P01"
    assert episode_rows(participant) == [("1", "0")]
    events = [record["event"] for _, record in read_json_records(participant / "events.jsonl")]
    assert events.count("trial_end") == 1


def test_disk_full_during_start_leaves_the_participant_at_the_intro(tmp_path, disk_full):
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), practice=0)
    session = open_session(folder)
    before_files = snapshot(folder)
    disk_full()
    with pytest.raises(OSError, match="No space left"):
        session.start_trial()
    assert session.phase == "intro" and snapshot(folder) == before_files
    session.close()
    disk_full.free()
    restarted = open_session(folder)
    assert restarted.phase == "intro"
    assert restarted.start_trial()["phase"] == "label"
    restarted.close()


def test_disk_full_during_the_questionnaire_keeps_it_due_and_a_retry_records_it_once(tmp_path, disk_full):
    folder = make_tiny_study(tmp_path / "study", methods=("dagger", "reward"), episodes=1, practice=0)
    session = open_session(folder)
    play_trial(session)
    before_files = snapshot(folder)
    disk_full()
    with pytest.raises(OSError, match="No space left"):
        session.submit_questionnaire(1, ANSWERS)
    assert session.phase == "questionnaire" and snapshot(folder) == before_files
    disk_full.free()
    assert session.submit_questionnaire(1, ANSWERS)["phase"] == "intro"
    session.close()
    assert len(read_json_records(folder / "participants" / "P01" / "answers.jsonl")) == 1


def test_a_missing_progress_file_with_data_present_stops_the_participant(in_trial_two):
    folder, participant = in_trial_two
    (participant / "progress.json").unlink()
    before = snapshot(folder)
    with pytest.raises(DamagedRecords, match=r"progress.json is missing"):
        open_session(folder)
    with pytest.raises(ValueError, match=r"progress.json is missing"):  # the picker lists them as damaged
        Study(folder).progress("P01")
    assert snapshot(folder) == before  # trial 1's checkpoint and rows untouched


def test_a_rolled_back_progress_file_stops_the_participant_instead_of_re_closing_a_trial(in_trial_two):
    folder, participant = in_trial_two
    (participant / "progress.json").write_text(json.dumps({"trial_index": 0, "phase": "label"}))
    before = snapshot(folder)
    with pytest.raises(DamagedRecords, match=r"progress.json .*behind"):
        open_session(folder)
    assert snapshot(folder) == before


@pytest.mark.parametrize("damage", ["deleted", "trial one's rows removed"])
def test_missing_rows_of_a_finished_trial_stop_the_participant(in_trial_two, damage):
    folder, participant = in_trial_two
    episodes = participant / "episodes.csv"
    if damage == "deleted":
        episodes.unlink()
    else:
        lines = episodes.read_text().splitlines(keepends=True)
        episodes.write_text("".join([lines[0], *(line for line in lines[1:] if ",1," not in line[:12])]))
    before = snapshot(folder)
    with pytest.raises(DamagedRecords, match=r"episodes.csv"):
        open_session(folder)
    assert snapshot(folder) == before


def test_a_bare_pickle_in_place_of_a_checkpoint_is_refused_without_running_it(in_trial_two, tmp_path):
    folder, participant = in_trial_two
    marker = tmp_path / "payload-ran"

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    for checkpoint in (participant / "trial2").iterdir():
        if checkpoint.name.startswith("checkpoint"):
            checkpoint.write_bytes(pickle.dumps(Payload()))
    with pytest.raises(DamagedRecords, match=r"trial2/checkpoint.* (pickle|not a trial checkpoint)"):
        open_session(folder)
    assert not marker.exists()


def test_a_checkpoint_round_trips_and_the_participant_goes_on(in_trial_two):
    folder, participant = in_trial_two
    session = open_session(folder)
    assert session.state()["episode"]["number"] == 2
    play_trial(session)
    session.close()
    assert episode_rows(participant) == [("1", "0"), ("1", "1"), ("2", "0"), ("2", "1")]


def test_a_wall_clock_jump_does_not_stretch_the_durations(tmp_path):
    from study_helpers import FakeClock

    from antmaze_hirl.study.data import read_episode_rows
    from antmaze_hirl.study.plan import load_plan
    from antmaze_hirl.study.session import ParticipantSession
    from antmaze_hirl.study.settings import load_settings

    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=1, practice=0)
    plan = load_plan(folder)
    wall, timer = FakeClock(), FakeClock()
    session = ParticipantSession(folder, plan, plan.participants[0], load_settings(folder), clock=wall, timer=timer)
    session.start_trial()
    clicks = 0
    while session.phase == "label":
        wall.advance(86_400)  # the machine's clock is set a day ahead between two clicks
        click_once(session, timer, seconds=2.0)
        clicks += 1
    session.next_episode()
    session.close()
    (row,) = read_episode_rows(folder / "participants" / "P01" / "episodes.csv")
    assert float(row["time_on_task"]) == pytest.approx(2.0 * clicks)
    assert float(row["seconds_per_label"]) == pytest.approx(2.0)


@pytest.mark.parametrize("name", ["clicks.jsonl", "events.jsonl", "answers.jsonl", "episodes.csv"])
@pytest.mark.parametrize("damage", ["changed", "repeated"])
def test_each_logs_damage_is_reported_by_the_server_and_by_analyze(in_trial_two, name, damage):
    from antmaze_hirl.study.analysis import analyze

    folder, participant = in_trial_two
    path = participant / name
    lines = path.read_text().splitlines(keepends=True)
    if damage == "changed":
        lines[-1] = lines[-1].replace('"trial": 1', '"trial": 2', 1) if name != "episodes.csv" else lines[-1]
        lines[-1] = lines[-1].replace(",dagger,", ",daggex,", 1).replace(",reward,", ",rewarx,", 1)
        if lines[-1] == path.read_text().splitlines(keepends=True)[-1]:
            lines[-1] = lines[-1].replace('"participant": "P01"', '"participant": "P02"', 1)
    else:
        lines.append(lines[-1])
    path.write_text("".join(lines))
    with pytest.raises(DamagedRecords, match=name):
        open_session(folder)
    with pytest.raises(ValueError, match=name):
        analyze(folder)
