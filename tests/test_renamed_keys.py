"""Settings files written before 0.2.0 name the oracle's reach ``expert_max_distance``: they still load, as
``subgoal_reach_m``, and new files are written with the field's name (``RENAMED_KEYS``)."""

import json
import tarfile
from dataclasses import asdict, fields
from pathlib import Path

import pytest
from script_helpers import load_script

from antmaze_hirl.experiments.config import RENAMED_KEYS, ExperimentConfig, current_keys
from antmaze_hirl.experiments.provenance import code_provenance
from antmaze_hirl.experiments.results_folder import check_resumable, read_summary

ROOT = Path(__file__).resolve().parents[1]
KNOWN = {field.name for field in fields(ExperimentConfig)}
COMMITTED_CONFIGS = sorted((ROOT / "results").glob("**/config.json"))
COMMITTED_RUNS = sorted((ROOT / "results").glob("**/runs/*.tar.gz"))


def recorded_config(config, **old_keys):
    # config.json as the runner writes it, with the renamed settings under their old keys instead.
    settings = {**asdict(config), "low_level": "sha256:test"}
    for new, old in RENAMED_KEYS.items():
        if old in old_keys:
            settings = {old if key == new else key: value for key, value in settings.items()}
            settings[old] = old_keys[old]
    return settings


def test_the_map_renames_old_keys_to_fields_and_new_files_use_the_fields_names():
    assert set(RENAMED_KEYS) <= KNOWN
    assert not set(RENAMED_KEYS.values()) & KNOWN  # asdict (config.json, settings.json) writes no old key
    assert "subgoal_reach_m" in asdict(ExperimentConfig())


def test_an_old_key_loads_under_the_fields_name_in_its_place():
    old = recorded_config(ExperimentConfig(body="ant", maze_size=4), expert_max_distance=2.0)
    settings = current_keys(old, "config.json")
    assert list(settings) == [key for key in asdict(ExperimentConfig()) if key in settings] + ["low_level"]
    assert settings["subgoal_reach_m"] == 2.0 and "expert_max_distance" not in settings
    assert current_keys({**settings, "expert_max_distance": 2.0}, "config.json") == settings  # one value twice


def test_both_keys_with_two_values_is_one_line_naming_both_and_the_file():
    with pytest.raises(ValueError) as error:
        current_keys({"expert_max_distance": 2.0, "subgoal_reach_m": 3.0}, "out/config.json")
    message = str(error.value)
    assert "\n" not in message and message.startswith("out/config.json: 'subgoal_reach_m' and its old name ")
    assert "'expert_max_distance' hold different values (3.0 against 2.0)" in message
    with pytest.raises(ValueError, match=r"out/config\.json holds a list, not an object of settings"):
        current_keys([], "out/config.json")


@pytest.mark.parametrize("path", COMMITTED_CONFIGS, ids=lambda path: str(path.relative_to(ROOT)))
def test_every_committed_config_json_loads(path):
    recorded = json.loads(path.read_text())
    config = ExperimentConfig(**{key: value for key, value in current_keys(recorded, path).items() if key in KNOWN})
    reach = recorded.get("expert_max_distance", recorded.get("subgoal_reach_m"))
    assert config.subgoal_reach_m == reach


@pytest.mark.parametrize("path", COMMITTED_RUNS, ids=lambda path: str(path.relative_to(ROOT)))
def test_every_committed_runs_config_json_loads(path):
    with tarfile.open(path) as archive:
        member = next(member for member in archive.getmembers() if Path(member.name).name == "config.json")
        recorded = json.loads(archive.extractfile(member).read())
    config = ExperimentConfig(**{key: value for key, value in current_keys(recorded, path).items() if key in KNOWN})
    assert config.protocol == 2 and config.subgoal_reach_m == recorded.get("expert_max_distance")


def old_folder(tmp_path, config, provenance, **old_keys):
    (tmp_path / "trials").mkdir()
    (tmp_path / "trials" / "dagger_seed0.csv").write_text("")
    (tmp_path / "config.json").write_text(json.dumps(recorded_config(config, **old_keys)))
    (tmp_path / "provenance.json").write_text(json.dumps(provenance))
    return tmp_path


def test_a_folder_written_with_the_old_key_resumes_with_its_settings_only(tmp_path):
    provenance = code_provenance()
    ant = ExperimentConfig(body="ant", maze_size=4, held_out_layouts=True, protocol=2, subgoal_reach_m=2.0)
    folder = old_folder(tmp_path, ant, provenance, expert_max_distance=2.0)
    assert check_resumable(folder, ant, "sha256:test", provenance, False) == []
    other = ExperimentConfig(body="ant", maze_size=4, held_out_layouts=True, protocol=2, subgoal_reach_m=3.0)
    with pytest.raises(ValueError, match="holds results made with"):
        check_resumable(folder, other, "sha256:test", provenance, False)


def test_a_folder_with_the_reach_under_both_keys_is_refused_naming_both(tmp_path):
    provenance = code_provenance()
    folder = old_folder(tmp_path, ExperimentConfig(subgoal_reach_m=0.5), provenance, expert_max_distance=0.6)
    config = json.loads((folder / "config.json").read_text())
    (folder / "config.json").write_text(json.dumps({**config, "subgoal_reach_m": 0.5}))
    both = r"'subgoal_reach_m' and its old name 'expert_max_distance' hold different values \(0\.5 against 0\.6\)"
    with pytest.raises(ValueError, match=both):
        check_resumable(folder, ExperimentConfig(subgoal_reach_m=0.5), "sha256:test", provenance, False)


def test_an_old_summarys_config_reads_with_the_current_keys(tmp_path):
    recorded = recorded_config(ExperimentConfig(body="ant"), expert_max_distance=2.0)
    (tmp_path / "summary.json").write_text(json.dumps({"config": recorded, "methods": {}}))
    assert read_summary(tmp_path)["config"] == current_keys(recorded, "summary.json")


def test_rewrite_reports_runs_an_old_folder_with_its_recorded_reach(tmp_path, monkeypatch):
    rewrite_reports = load_script("scripts/rewrite_reports.py")
    source = tmp_path / "source"
    source.mkdir()
    old_folder(source, ExperimentConfig(body="ant", maze_size=3), code_provenance(), expert_max_distance=2.0)
    (source / "trials" / "dagger_seed0.json").write_text('{"seconds": 1.0}')
    seen = []
    monkeypatch.setattr(rewrite_reports, "write_reports", lambda *args: seen.append(args[-1]) or {"methods": {}})
    rewrite_reports.rewrite(source, tmp_path / "out")
    assert seen == [ExperimentConfig(body="ant", maze_size=3, subgoal_reach_m=2.0)]
