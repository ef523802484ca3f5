"""Results folders that check themselves: each damaged trial is detected, named by file, and re-run on resume."""

import json
import warnings

import pytest
from conftest import TINY_PROTOCOL1, TINY_PROTOCOL2, copy_results, finished_experiment

from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.experiments.results_folder import DamagedTrial, check_trial, trial_path, trial_record, write_reports
from antmaze_hirl.experiments.runner import run_experiment

TINY = TINY_PROTOCOL1  # a protocol-1 folder
GO_TO = PointGoToController()
"""The protocol-1 folder's low level: the scripted go-to (what is checked here is the folder, not the walking)."""


def cut_line(text):
    return text[: len(text) - 25]  # mid-way through the last row


def duplicated_row(text):
    lines = text.splitlines(keepends=True)
    return "".join([*lines, lines[-1]])


def dropped_row(text):
    lines = text.splitlines(keepends=True)
    return "".join(lines[:2] + lines[3:])


DAMAGE = {
    "cut line": cut_line,
    "duplicated row": duplicated_row,
    "dropped row": dropped_row,
    "empty file": lambda text: "",
    "garbage": lambda text: "\x00\x01 not a csv at all \x7f\n" * 5,
}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished tiny experiment: its folder and its files' bytes."""
    return finished_experiment(tmp_path_factory, "results", TINY, low_level=GO_TO)


def test_each_trial_records_its_row_count_and_hash(finished):
    folder, _ = finished
    record = json.loads(trial_path(folder, "dagger", 0).with_suffix(".json").read_text())
    assert record["rows"] == TINY.episodes and len(record["sha256"]) == 64 and record["seconds"] > 0
    assert len(check_trial(trial_path(folder, "dagger", 0), TINY.episodes)) == TINY.episodes


@pytest.mark.parametrize("kind", sorted(DAMAGE))
def test_a_damaged_trial_is_named_by_file_with_and_without_its_hash(finished, tmp_path, kind):
    folder, _ = finished
    path = tmp_path / "trials" / "dagger_seed0.csv"
    path.parent.mkdir()
    original = trial_path(folder, "dagger", 0)
    path.write_text(DAMAGE[kind](original.read_text()))
    path.with_suffix(".json").write_text(original.with_suffix(".json").read_text())
    with pytest.raises(DamagedTrial, match=r"dagger_seed0\.csv"):
        check_trial(path, TINY.episodes)
    path.with_suffix(".json").write_text('{"seconds": 1.0}')  # a trial from before the hash: structure only
    with pytest.raises(DamagedTrial, match=r"dagger_seed0\.csv"):
        check_trial(path, TINY.episodes)


def integration_except(first, kinds):
    """``kinds`` for ``parametrize``: ``first`` in the unit tier, the others ``integration`` (same code path
    once detected; each kind's detection is checked in the unit tier by the tests above)."""
    return [kind if kind == first else pytest.param(kind, marks=pytest.mark.integration) for kind in sorted(kinds)]


@pytest.mark.parametrize("kind", integration_except("cut line", DAMAGE))
def test_a_damaged_trial_is_rerun_on_resume_and_nothing_is_overwritten_with_less(finished, tmp_path, kind):
    source, files = finished
    folder = tmp_path / "results"
    (folder / "trials").mkdir(parents=True)
    copy_results(source, folder)
    damaged = trial_path(folder, "dagger", 1)
    damaged.write_text(DAMAGE[kind](damaged.read_text()))
    damaged_bytes = damaged.read_bytes()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_experiment(["dagger"], 2, TINY, folder, low_level=GO_TO, progress_bar=False, tensorboard=False)
    named = [str(w.message) for w in caught if "dagger_seed1.csv" in str(w.message)]
    assert named and "runs again" in named[0], [str(w.message) for w in caught]
    assert (folder / "trials" / "dagger_seed1.csv.damaged").read_bytes() == damaged_bytes  # kept, not deleted
    # The re-run is seeded: the trial, the tables and the summary's figures come back as they were.
    assert damaged.read_bytes() == files["dagger_seed1.csv"]
    assert (folder / "episodes.csv").read_bytes() == files["episodes.csv"]
    summary, before = (json.loads(s) for s in ((folder / "summary.json").read_text(), files["summary.json"]))
    assert summary["methods"] == before["methods"]


def test_reports_are_not_replaced_with_fewer_trials_while_one_is_damaged(finished, tmp_path):
    from antmaze_hirl.experiments.results_folder import write_reports

    source, files = finished
    folder = tmp_path / "results"
    copy_results(source, folder)
    trial_path(folder, "dagger", 1).write_text("")
    with pytest.warns(UserWarning, match=r"dagger_seed1\.csv: its bytes do not match the SHA-256"):
        write_reports(folder, ["dagger"], 2, TINY)
    assert (folder / "episodes.csv").read_bytes() == files["episodes.csv"]
    assert (folder / "summary.json").read_bytes() == files["summary.json"]


TINY2 = TINY_PROTOCOL2


def changed_value(text):
    return text.replace(",True", ",False", 1) if ",True" in text else text.replace(",False", ",True", 1)


PART_DAMAGE = {
    "missing part": None,
    "cut line": cut_line,
    "changed value": changed_value,
}


@pytest.fixture
def finished2(finished_protocol2):
    """A finished tiny protocol-2 experiment (conftest's, shared with test_protocol2): its folder and files' bytes."""
    return finished_protocol2


def damage_part(part, kind):
    if PART_DAMAGE[kind] is None:
        part.unlink()
    else:
        damaged = PART_DAMAGE[kind](part.read_text())
        assert damaged != part.read_text()
        part.write_text(damaged)


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_a_protocol_2_record_holds_its_evaluations_part_and_older_records_still_load(finished2, tmp_path):
    folder, files = finished2
    path = trial_path(folder, "dagger", 0)
    record = json.loads(path.with_suffix(".json").read_text())
    part = files["dagger_seed0.evaluations.csv"].decode()
    assert record["evaluations"]["rows"] == part.count("\n") - 1 == 3 * TINY2.final_eval_episodes
    assert len(record["evaluations"]["sha256"]) == 64
    assert len(check_trial(path, TINY2.episodes)) == TINY2.episodes
    # A record from before the part was recorded loads, part or no part (structure of the rows only).
    copy_results(folder, tmp_path)
    old = trial_path(tmp_path, "dagger", 0)
    old.with_suffix(".json").write_text(json.dumps({k: v for k, v in record.items() if k != "evaluations"}))
    old.with_suffix(".evaluations.csv").unlink()
    assert len(check_trial(old, TINY2.episodes)) == TINY2.episodes
    # Protocol 1 records have no "evaluations" entry.
    assert "evaluations" not in trial_record("a\n1\n", 1.0)


def damaged_part_folder(source, folder, kind):
    """A copy of ``source`` with seed 1's evaluations part damaged by ``kind``: trial csv, part, damaged bytes."""
    copy_results(source, folder)
    rows_csv = trial_path(folder, "dagger", 1)
    part = rows_csv.with_suffix(".evaluations.csv")
    damage_part(part, kind)
    return rows_csv, part, (part.read_bytes() if part.exists() else None)


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
@pytest.mark.parametrize("kind", sorted(PART_DAMAGE))
def test_a_damaged_evaluations_part_is_named_and_the_old_reports_kept(finished2, tmp_path, kind):
    source, files = finished2
    folder = tmp_path / "results"
    rows_csv, _, _ = damaged_part_folder(source, folder, kind)
    with pytest.raises(DamagedTrial, match=r"dagger_seed1\.evaluations\.csv"):
        check_trial(rows_csv, TINY2.episodes)
    with pytest.warns(UserWarning, match=r"left out of the reports: .*dagger_seed1\.evaluations\.csv"):
        write_reports(folder, ["dagger"], 2, TINY2)  # no bare ValueError from summarise; old reports kept
    assert (folder / "summary.json").read_bytes() == files["summary.json"]


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
@pytest.mark.parametrize("kind", integration_except("missing part", PART_DAMAGE))
def test_a_damaged_evaluations_part_is_named_and_its_trial_rerun_on_resume(finished2, tmp_path, kind):
    source, files = finished2
    folder = tmp_path / "results"
    rows_csv, part, damaged_bytes = damaged_part_folder(source, folder, kind)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_experiment(["dagger"], 2, TINY2, folder, progress_bar=False, tensorboard=False)
    named = [str(w.message) for w in caught if "dagger_seed1.evaluations.csv" in str(w.message)]
    assert named and "runs again" in named[0], [str(w.message) for w in caught]
    assert (folder / "trials" / "dagger_seed1.csv.damaged").exists()
    if damaged_bytes is not None:  # the damaged part's bytes are kept, not deleted
        assert (folder / "trials" / "dagger_seed1.evaluations.csv.damaged").read_bytes() == damaged_bytes
    # The seeded re-run writes the part, the trial and the reports back as they were.
    assert part.read_bytes() == files["dagger_seed1.evaluations.csv"]
    assert rows_csv.read_bytes() == files["dagger_seed1.csv"]
    assert (folder / "evaluations.csv").read_bytes() == files["evaluations.csv"]
    summary, before = (json.loads(s) for s in ((folder / "summary.json").read_text(), files["summary.json"]))
    assert summary["methods"] == before["methods"]
