"""scripts/rewrite_reports.py: a folder's reports rewritten from its trials by this code, the source untouched."""

import gzip
import json
from pathlib import Path

import pytest
from conftest import copy_results
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (scripts/rewrite_reports.py): the integration tier

ROOT = Path(__file__).resolve().parents[1]
rewrite_reports = load_script("scripts/rewrite_reports.py")


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_rewritten_reports_equal_the_runs_own_and_record_this_code(finished_protocol2, tmp_path, capsys):
    source, files = finished_protocol2
    out = tmp_path / "rewritten"
    assert rewrite_reports.main([str(source), str(out), "--gzip"]) == 0
    assert "seeds per method {'dagger': 2}" in capsys.readouterr().out
    before = {path.name: path.read_bytes() for path in source.rglob("*") if path.is_file() and "tb" not in path.parts}
    assert before == files  # the source folder is read, never written
    old, new = json.loads(files["summary.json"]), json.loads((out / "summary.json").read_text())
    assert new["methods"] == old["methods"] and new["config"] == old["config"]
    assert set(new["reports_provenance"]) == {"git_commit", "git_dirty", "source_sha256"}
    assert gzip.decompress((out / "evaluations.csv.gz").read_bytes()) == files["evaluations.csv"]
    assert (out / "episodes.csv").read_bytes() == files["episodes.csv"]
    assert (out / "trials" / "dagger_seed0.csv").is_file()


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_without_trials_writes_the_same_reports_and_drops_the_copied_trials(finished_protocol2, tmp_path):
    source, _ = finished_protocol2
    kept, dropped = tmp_path / "kept", tmp_path / "dropped"
    assert rewrite_reports.main([str(source), str(kept), "--gzip"]) == 0
    assert rewrite_reports.main([str(source), str(dropped), "--gzip", "--without-trials"]) == 0
    assert not (dropped / "trials").exists() and (source / "trials").is_dir()
    reports = ("episodes.csv", "evaluations.csv.gz", "config.json")
    assert all((dropped / name).read_bytes() == (kept / name).read_bytes() for name in reports)
    summaries = [json.loads((folder / "summary.json").read_text()) for folder in (kept, dropped)]
    assert summaries[0]["methods"] == summaries[1]["methods"]


def settings_without_trials(tmp):
    folder = tmp / "empty"
    folder.mkdir()
    (folder / "config.json").write_text("{}")
    return folder


@pytest.mark.parametrize(
    ("make", "message"),
    [(lambda tmp: tmp / "absent", "no config.json in"), (settings_without_trials, "no finished trial in")],
)
def test_a_folder_without_settings_or_trials_is_one_line_naming_it(tmp_path, capsys, make, message):
    folder = make(tmp_path)
    with pytest.raises(SystemExit):
        rewrite_reports.main([str(folder), str(tmp_path / "out")])
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert message in error and str(folder) in error


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_a_non_empty_output_folder_is_refused(finished_protocol2, tmp_path, capsys):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine")
    with pytest.raises(SystemExit):
        rewrite_reports.main([str(finished_protocol2[0]), str(tmp_path / "out")])
    assert "is not empty: pass a new folder" in capsys.readouterr().err
    assert (tmp_path / "out" / "keep.txt").read_text() == "mine"


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_a_method_without_trials_is_one_line_naming_it_and_writes_nothing(finished_protocol2, tmp_path, capsys):
    # A misspelt --methods once wrote a folder of empty reports ("seeds per method {'dager': 0}").
    out = tmp_path / "out"
    with pytest.raises(SystemExit):
        rewrite_reports.main([str(finished_protocol2[0]), str(out), "--methods", "dagger,dager"])
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "no finished trial of ['dager']" in error and "on disk: ['dagger']" in error
    assert not out.exists()


def test_a_config_that_is_not_json_is_one_line_naming_the_file(tmp_path, capsys):
    folder = tmp_path / "broken"
    (folder / "trials").mkdir(parents=True)
    (folder / "config.json").write_text("{")
    (folder / "trials" / "dagger_seed0.json").write_text("{}")
    with pytest.raises(SystemExit):
        rewrite_reports.main([str(folder), str(tmp_path / "out")])
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert str(folder / "config.json") in error and "not JSON" in error
    assert not (tmp_path / "out").exists()


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_the_sources_oracle_success_is_kept_and_a_torn_summary_is_refused(finished_protocol2, tmp_path, capsys):
    source, _ = finished_protocol2
    folder = tmp_path / "source"
    copy_results(source, folder)
    summary = json.loads((folder / "summary.json").read_text())
    oracle = {"success_rate": 0.97, "episodes": 100, "wilson_95": [0.915, 0.99]}
    (folder / "summary.json").write_text(json.dumps({**summary, "oracle_success": oracle, "goals": {"stale": 1}}))
    assert rewrite_reports.main([str(folder), str(tmp_path / "out")]) == 0
    rewritten = json.loads((tmp_path / "out" / "summary.json").read_text())
    # The oracle's run is a measurement no trial holds; the goals are figures of the old code, so rewritten or gone.
    assert rewritten["oracle_success"] == oracle and "goals" not in rewritten
    (folder / "summary.json").write_text('{"methods": ')
    with pytest.raises(SystemExit):
        rewrite_reports.main([str(folder), str(tmp_path / "torn")])
    assert f"{folder / 'summary.json'} is not JSON" in capsys.readouterr().err
    assert not (tmp_path / "torn").exists()
