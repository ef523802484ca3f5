"""Durable study logs: torn tails trimmed and logged, damaged lines named, damaged checkpoints stop one participant."""

import csv
import json
import pickle
import threading

import httpx
import numpy as np
import pandas as pd
import pytest
from study_helpers import fresh_copy, make_tiny_study, open_session, play_one_episode, played_template

from antmaze_hirl.study.checkpoint import load_checkpoint, save_checkpoint
from antmaze_hirl.study.data import CLICK_COLUMNS, EPISODE_COLUMNS, load_clicks, load_episodes
from antmaze_hirl.study.logs import DamagedLog, append_csv_row, append_json_record, read_csv_rows, read_json_records
from antmaze_hirl.study.plan import load_plan
from antmaze_hirl.study.server import StudyServer
from antmaze_hirl.study.session import DamagedRecords, DemonstrationLog, TrialState
from antmaze_hirl.study.store import Study

TOKEN = "durability-token-0123456789"


def events_of(participant):
    return [record for _, record in read_json_records(participant / "events.jsonl")]


@pytest.fixture(scope="module")
def one_episode_template(tmp_path_factory):
    """A participant one episode into a three-episode trial (no practice), session closed as after a kill."""
    return played_template(tmp_path_factory, play_one_episode, methods=("dagger",), episodes=3, practice=0)


@pytest.fixture
def one_episode_in(one_episode_template, tmp_path):
    """A fresh copy of :func:`one_episode_template` (played once per module): its folder and the participant's."""
    return fresh_copy(one_episode_template, tmp_path)


def test_a_torn_last_line_is_trimmed_on_restart_and_the_trim_logged(one_episode_in):
    folder, participant = one_episode_in
    intact = {name: (participant / name).read_bytes() for name in ("clicks.jsonl", "episodes.csv")}
    torn = {"clicks.jsonl": '{"participant": "P01", "trial": 1, "epis', "episodes.csv": "P01,1,dagger,"}
    for name, tail in torn.items():  # a power cut mid-append
        with (participant / name).open("a") as handle:
            handle.write(tail)
    session = open_session(folder)  # the restart
    for name, content in intact.items():
        assert (participant / name).read_bytes() == content, name  # the tail is gone, nothing else
    trims = [event for event in events_of(participant) if event["event"] == "torn_tail_trimmed"]
    assert {(event["file"], event["text"]) for event in trims} == set(torn.items())
    play_one_episode(session)  # the next records start on their own line
    session.close()
    episodes = load_episodes(folder, load_plan(folder))
    assert list(episodes["episode"]) == [0, 1]
    assert len(read_json_records(participant / "clicks.jsonl")) == int(episodes["expert_cost"].sum())


def test_readers_skip_a_torn_last_line_with_a_warning_naming_file_and_line(one_episode_in):
    _, participant = one_episode_in
    path = participant / "clicks.jsonl"
    lines = path.read_text().count("\n")
    with path.open("a") as handle:
        handle.write('{"participant": "P0')
    with pytest.warns(UserWarning, match=rf"clicks.jsonl:{lines + 1}: skipped a partial last line"):
        records = read_json_records(path)
    assert len(records) == lines


def test_readers_reject_a_changed_line_naming_file_and_line(one_episode_in):
    folder, participant = one_episode_in
    clicks = participant / "clicks.jsonl"
    lines = clicks.read_text().splitlines(keepends=True)
    lines[0] = lines[0].replace('"x": ', '"x": 1', 1)  # a changed digit: still JSON, no longer what was written
    clicks.write_text("".join(lines))
    with pytest.raises(DamagedLog, match=r"clicks.jsonl:1: checksum mismatch"):
        read_json_records(clicks)
    episodes = participant / "episodes.csv"
    rows = episodes.read_text().splitlines(keepends=True)
    rows[1] = rows[1].replace("dagger", "daggex", 1)
    episodes.write_text("".join(rows))
    with pytest.raises(ValueError, match=r"episodes.csv:2: checksum mismatch"):
        load_episodes(folder, load_plan(folder))
    lost = "".join([rows[0], rows[1].rsplit(",", 1)[0] + "\n"])  # a row whose checksum cell is gone
    episodes.write_text(lost)
    with pytest.raises(DamagedLog, match=r"episodes.csv:2: checksum mismatch"):
        read_csv_rows(episodes, EPISODE_COLUMNS)


def test_old_format_logs_without_checksums_still_load_and_keep_their_format(tmp_path):
    legacy = tmp_path / "episodes.csv"
    row = {column: str(index) for index, column in enumerate(EPISODE_COLUMNS)}
    with legacy.open("w", newline="") as handle:  # as the kit wrote it before checksums: csv.DictWriter
        writer = csv.DictWriter(handle, fieldnames=EPISODE_COLUMNS)
        writer.writeheader()
        writer.writerow(row)
    append_csv_row(legacy, EPISODE_COLUMNS, row)  # appending to a legacy file keeps it legacy
    assert read_csv_rows(legacy, EPISODE_COLUMNS) == [row, row]
    assert "crc32" not in legacy.read_text()
    answers = tmp_path / "events.jsonl"
    answers.write_text(json.dumps({"event": "trial_start"}) + "\n")  # a legacy line, then a checksummed one
    append_json_record(answers, {"event": "pause"})
    assert [record["event"] for _, record in read_json_records(answers)] == ["trial_start", "pause"]
    answers.write_text(answers.read_text() + json.dumps({"event": "resume"}) + "\n")  # unsealed after sealed
    with pytest.raises(DamagedLog, match=r"events.jsonl:3: the line has no checksum"):
        read_json_records(answers)


def test_a_checkpoint_with_flipped_bytes_stops_the_participant_naming_the_file(one_episode_in):
    folder, participant = one_episode_in
    checkpoint = participant / "trial1" / "checkpoint.pt"
    data = bytearray(checkpoint.read_bytes())
    for offset in range(200, 220):  # 20 flipped bytes inside the archive
        data[offset] ^= 0xFF
    checkpoint.write_bytes(bytes(data))
    before = (participant / "episodes.csv").read_bytes()
    with pytest.raises(DamagedRecords, match=r"trial1/checkpoint.pt is damaged"):
        open_session(folder)
    assert (participant / "episodes.csv").read_bytes() == before


@pytest.mark.parametrize("header", [b"", b"antmaze_hirl trial checkpoint v2\n" + b"0" * 64 + b"\n"], ids=["bare", "v2"])
def test_an_old_pickled_checkpoint_is_refused_with_a_message_and_never_unpickled(one_episode_in, tmp_path, header):
    folder, participant = one_episode_in
    marker = tmp_path / "payload-ran"

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    (participant / "trial1" / "checkpoint.pt").unlink()
    legacy = participant / "trial1" / "checkpoint.pkl"  # what versions before the torch format wrote
    legacy.write_bytes(header + pickle.dumps(Payload()))
    with pytest.raises(DamagedRecords, match=r"trial1/checkpoint.pkl is a pickled checkpoint .* can run code"):
        open_session(folder)
    assert not marker.exists() and legacy.read_bytes().endswith(pickle.dumps(Payload()))


def test_a_missing_checkpoint_stops_the_participant_instead_of_restarting_the_trial(one_episode_in):
    folder, participant = one_episode_in
    (participant / "trial1" / "checkpoint.pt").unlink()
    before = (participant / "episodes.csv").read_bytes()
    with pytest.raises(DamagedRecords, match=r"trial1/checkpoint.pt is missing.*1 episode"):
        open_session(folder)
    assert (participant / "episodes.csv").read_bytes() == before  # no episode 0 written again


def test_a_repeated_row_in_episodes_csv_stops_the_participant(one_episode_in):
    folder, participant = one_episode_in
    episodes = participant / "episodes.csv"
    lines = episodes.read_text().splitlines(keepends=True)
    episodes.write_text("".join([*lines, lines[-1]]))
    with pytest.raises(DamagedRecords, match="do not match"):
        open_session(folder)


def test_one_participants_damage_never_breaks_the_others(tmp_path):
    folder = make_tiny_study(tmp_path / "study", participants=2)
    (folder / "participants" / "P01").mkdir(parents=True)
    (folder / "participants" / "P01" / "progress.json").write_text('{"trial_index": 0, "pha')
    with StudyServer(folder, token=TOKEN).running() as server:
        with httpx.Client(base_url=server.base_url, headers={"X-Study-Token": TOKEN}, timeout=120) as client:
            overview = client.get("/api/study")
            assert overview.status_code == 200
            first, second = overview.json()["participants"]
            assert first["phase"] == "damaged" and "progress.json" in first["error"]
            assert second["phase"] == "intro"
            damaged = client.get("/api/participants/P01/state")
            assert damaged.status_code == 409 and "progress.json" in damaged.json()["error"]
            assert client.post("/api/participants/P02/start", json={}).status_code == 200


def test_restoring_a_session_runs_off_the_event_loop(tmp_path, monkeypatch):
    folder = make_tiny_study(tmp_path / "study", participants=2)
    restoring, restored = threading.Event(), threading.Event()
    slow = Study.session

    def slow_session(self, participant_id):  # a restore that lasts until the test lets it end
        if participant_id == "P01":
            restoring.set()
            assert restored.wait(60), "the restore was never let through"
        return slow(self, participant_id)

    monkeypatch.setattr(Study, "session", slow_session)
    with StudyServer(folder, token=TOKEN).running() as server:
        headers = {"X-Study-Token": TOKEN}
        worker = threading.Thread(
            target=httpx.get,
            args=(f"{server.base_url}/api/participants/P01/state",),
            kwargs={"headers": headers, "timeout": 90},
        )
        worker.start()
        try:
            assert restoring.wait(30)
            # Served while P01's restore is still held: a server that waited for it would time out here.
            assert httpx.get(f"{server.base_url}/api/study", headers=headers, timeout=30).status_code == 200
        finally:
            restored.set()
            worker.join()


def _rewrite_clicks(path, rename):
    """Rewrites ``clicks.jsonl`` with each record passed through ``rename`` (sealed again, as if written so)."""
    records = [rename(record) for _, record in read_json_records(path)]
    path.unlink()
    for record in records:
        append_json_record(path, record)


def _as_before_the_rename(record):
    return {("step" if key == "label_index" else key): value for key, value in record.items()}


def test_new_logs_write_label_index_and_high_level_step_and_never_step(one_episode_in):
    folder, participant = one_episode_in
    records = [record for _, record in read_json_records(participant / "clicks.jsonl")]
    assert records and all(tuple(record) == CLICK_COLUMNS for record in records)
    assert [record["label_index"] for record in records] == list(range(len(records)))  # one episode
    with np.load(participant / "trial1" / "demonstrations.npz") as log:
        assert "high_level_step" in log.files and "step" not in log.files
        np.testing.assert_array_equal(log["high_level_step"], np.arange(len(log["episode"])))
    clicks = load_clicks(folder, load_plan(folder))
    assert list(clicks.columns) == list(CLICK_COLUMNS) and list(clicks["label_index"]) == list(range(len(records)))


def test_an_old_clicks_log_with_step_loads_as_the_new_one(one_episode_in):
    folder, participant = one_episode_in
    plan = load_plan(folder)
    new = load_clicks(folder, plan)
    _rewrite_clicks(participant / "clicks.jsonl", _as_before_the_rename)
    assert '"step": ' in (participant / "clicks.jsonl").read_text()
    pd.testing.assert_frame_equal(load_clicks(folder, plan), new)
    _rewrite_clicks(participant / "clicks.jsonl", lambda record: {**record, "label_index": record["step"]})
    pd.testing.assert_frame_equal(load_clicks(folder, plan), new)  # both names, one value: read


@pytest.mark.parametrize(
    ("rename", "error"),
    [
        (
            lambda record: {**record, "step": record["label_index"] + 1},
            "'label_index' and its old name 'step' hold different values \\(0 against 1\\)",
        ),
        (
            lambda record: {k: v for k, v in record.items() if k != "label_index"},
            "no 'label_index' \\(nor its old name",
        ),
    ],
    ids=["both-differing", "neither"],
)
def test_a_click_with_neither_name_or_both_differing_is_refused_naming_file_and_key(one_episode_in, rename, error):
    folder, participant = one_episode_in
    _rewrite_clicks(participant / "clicks.jsonl", rename)
    with pytest.raises(ValueError, match=rf"clicks\.jsonl:1: {error}"):
        load_clicks(folder, load_plan(folder))


def _rewrite_checkpoint(checkpoint, change):
    """Saves the checkpoint's trial state again after ``change(demonstrations.__dict__)``."""
    state = load_checkpoint(checkpoint, extra_classes=(TrialState, DemonstrationLog))
    change(state.demonstrations.__dict__)
    save_checkpoint(state, checkpoint)


def test_a_checkpoint_pickled_with_step_resumes_and_saves_high_level_step(one_episode_in):
    folder, participant = one_episode_in
    checkpoint = participant / "trial1" / "checkpoint.pt"
    _rewrite_checkpoint(checkpoint, lambda log: log.update(step=log.pop("high_level_step")))
    session = open_session(folder)
    play_one_episode(session)
    session.close()
    with np.load(participant / "trial1" / "demonstrations.npz") as log:
        assert "step" not in log.files
        for episode in (0, 1):
            steps = log["high_level_step"][log["episode"] == episode]
            np.testing.assert_array_equal(steps, np.arange(len(steps)))


def test_a_checkpoint_with_both_step_names_differing_stops_the_participant_naming_file_and_key(one_episode_in):
    folder, participant = one_episode_in
    checkpoint = participant / "trial1" / "checkpoint.pt"
    _rewrite_checkpoint(checkpoint, lambda log: log.update(step=[s + 1 for s in log["high_level_step"]]))
    with pytest.raises(DamagedRecords, match=r"trial1/checkpoint.pt .*'high_level_step' and its old name 'step'"):
        open_session(folder)
