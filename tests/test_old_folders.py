"""Folders written by older versions read as what they were made with (``experiments.old_folders``), while the
library's defaults are the current protocol: old keys (``expert_max_distance``) and protocol-1 folders, which
lack the settings whose defaults changed."""

import dataclasses
import json
import tarfile
from dataclasses import asdict, fields
from pathlib import Path

import pytest
from script_helpers import load_script

from antmaze_hirl.experiments.config import CURRENT_PROTOCOL, PROTOCOL_EVALUATION_ENVS, ExperimentConfig
from antmaze_hirl.experiments.old_folders import (
    OLD_KEYS,
    SETTINGS_BEFORE_PROTOCOL_2,
    current_settings,
    experiment_settings,
)
from antmaze_hirl.experiments.provenance import code_provenance
from antmaze_hirl.experiments.results_folder import check_resumable, read_summary

ROOT = Path(__file__).resolve().parents[1]
KNOWN = {field.name for field in fields(ExperimentConfig)}
PROTOCOL_1_ANT = ExperimentConfig(
    body="ant", maze_size=4, subgoal_reach_m=2.0, eval_episodes=50, held_out_layouts=True, protocol=1, evaluation_envs=1
)
"""Settings of the committed ``results/paper_experiment/ant`` folder."""


def recorded_config(config, *, old_keys=True, lacking=()):
    # config.json as an older runner wrote it: the reach under its old key, without the settings of `lacking`.
    settings = {**asdict(config), "low_level": "sha256:test"}
    if old_keys:
        new_names = {new: old for old, new in OLD_KEYS.items()}
        settings = {new_names.get(key, key): value for key, value in settings.items()}
    return {key: value for key, value in settings.items() if key not in lacking}


def old_folder(folder, recorded, provenance):
    (folder / "trials").mkdir(parents=True)
    (folder / "trials" / "dagger_seed0.csv").write_text("")
    (folder / "config.json").write_text(json.dumps(recorded))
    (folder / "provenance.json").write_text(json.dumps(provenance))
    return folder


def test_the_defaults_are_the_current_protocol():
    config = ExperimentConfig()
    assert (config.protocol, config.held_out_layouts, config.evaluation_envs) == (2, True, PROTOCOL_EVALUATION_ENVS)
    assert CURRENT_PROTOCOL == 2 and config.evaluates_untrained
    # Each setting the adapter fills is a setting whose default changed: otherwise the entry is not needed.
    assert set(SETTINGS_BEFORE_PROTOCOL_2) <= KNOWN
    assert all(getattr(config, key) != value for key, value in SETTINGS_BEFORE_PROTOCOL_2.items())
    assert not set(OLD_KEYS) & KNOWN and set(OLD_KEYS.values()) <= KNOWN  # new files are written with today's keys


def test_an_old_key_reads_under_the_settings_name_in_its_place():
    settings = current_settings(recorded_config(PROTOCOL_1_ANT), "config.json")
    assert list(settings) == [*asdict(PROTOCOL_1_ANT), "low_level"]
    assert settings["subgoal_reach_m"] == 2.0 and "expert_max_distance" not in settings
    assert current_settings({**settings, "expert_max_distance": 2.0}, "config.json") == settings  # one value twice


def test_both_keys_with_two_values_is_one_line_naming_both_and_the_file():
    with pytest.raises(ValueError) as error:
        current_settings({"expert_max_distance": 2.0, "subgoal_reach_m": 3.0}, "out/config.json")
    message = str(error.value)
    assert "\n" not in message and message.startswith("out/config.json: 'subgoal_reach_m' and its old name ")
    assert "'expert_max_distance' hold different values (3.0 against 2.0)" in message
    with pytest.raises(ValueError, match=r"out/config\.json holds a list, not an object of settings"):
        experiment_settings([], "out/config.json")


def test_a_config_without_the_protocol_reads_as_protocol_1_what_it_was_made_with():
    # The committed protocol-1 folders' config.json: no protocol, learner or evaluation_envs.
    recorded = recorded_config(PROTOCOL_1_ANT, lacking=("protocol", "learner", "evaluation_envs"))
    settings = experiment_settings(recorded, "config.json")
    assert settings["protocol"] == 1 and settings["evaluation_envs"] == 1 and settings["held_out_layouts"]
    assert ExperimentConfig(**{key: value for key, value in settings.items() if key in KNOWN}) == PROTOCOL_1_ANT
    unheld = recorded_config(dataclasses.replace(PROTOCOL_1_ANT, held_out_layouts=False), lacking=("held_out_layouts",))
    assert experiment_settings(unheld, "config.json")["held_out_layouts"] is False  # before held-out layouts existed
    current = recorded_config(ExperimentConfig(body="ant", maze_size=4), old_keys=False)
    assert experiment_settings(current, "config.json") == current  # a file with every setting is read as it is


def test_a_protocol_1_folder_resumes_as_protocol_1_and_refuses_the_default(tmp_path):
    provenance = code_provenance()
    recorded = recorded_config(PROTOCOL_1_ANT, lacking=("protocol", "learner", "evaluation_envs"))
    folder = old_folder(tmp_path, recorded, provenance)
    assert check_resumable(folder, PROTOCOL_1_ANT, "sha256:test", provenance, False) == []
    default = ExperimentConfig(body="ant", maze_size=4, subgoal_reach_m=2.0, eval_episodes=50)
    with pytest.raises(ValueError, match="holds results made with"):
        check_resumable(folder, default, "sha256:test", provenance, False)
    with pytest.raises(ValueError, match="holds results made with"):
        check_resumable(
            folder, dataclasses.replace(PROTOCOL_1_ANT, subgoal_reach_m=3.0), "sha256:test", provenance, False
        )


def test_a_folder_with_the_reach_under_both_keys_is_refused_naming_both(tmp_path):
    provenance = code_provenance()
    recorded = {**recorded_config(PROTOCOL_1_ANT), "subgoal_reach_m": 0.5}
    folder = old_folder(tmp_path, recorded, provenance)
    both = r"'subgoal_reach_m' and its old name 'expert_max_distance' hold different values \(0\.5 against 2\.0\)"
    with pytest.raises(ValueError, match=both):
        check_resumable(folder, PROTOCOL_1_ANT, "sha256:test", provenance, False)


def test_an_old_summarys_config_reads_as_what_it_was_made_with(tmp_path):
    recorded = recorded_config(PROTOCOL_1_ANT, lacking=("protocol", "evaluation_envs"))
    (tmp_path / "summary.json").write_text(json.dumps({"config": recorded, "methods": {}}))
    assert read_summary(tmp_path)["config"] == {**asdict(PROTOCOL_1_ANT), "low_level": "sha256:test"}


@pytest.mark.integration  # a lab check (scripts/rewrite_reports.py)
def test_rewrite_reports_runs_an_old_folder_with_its_recorded_settings(tmp_path, monkeypatch):
    rewrite_reports = load_script("scripts/rewrite_reports.py")
    recorded = recorded_config(PROTOCOL_1_ANT, lacking=("protocol", "learner", "evaluation_envs"))
    source = old_folder(tmp_path / "source", recorded, code_provenance())
    (source / "trials" / "dagger_seed0.json").write_text('{"seconds": 1.0}')
    seen = []
    monkeypatch.setattr(rewrite_reports, "write_reports", lambda *args: seen.append(args[-1]) or {"methods": {}})
    rewrite_reports.rewrite(source, tmp_path / "out")
    assert seen == [PROTOCOL_1_ANT]


COMMITTED = sorted((ROOT / "results").glob("**/config.json")) + sorted((ROOT / "results").glob("**/runs/*.tar.gz"))
"""The committed results folders' settings files, and the trials packed beside them (listed, read in the test)."""


def read_config(path):
    if path.name == "config.json":
        return json.loads(path.read_text())
    with tarfile.open(path) as archive:
        member = next(member for member in archive.getmembers() if Path(member.name).name == "config.json")
        return json.loads(archive.extractfile(member).read())


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize("path", COMMITTED, ids=lambda path: str(path.relative_to(ROOT)))
def test_every_committed_config_reads_as_its_protocol(path):
    recorded = read_config(path)
    config = ExperimentConfig(**{k: v for k, v in experiment_settings(recorded, path).items() if k in KNOWN})
    assert config.protocol == (2 if "protocol2" in path.parts else 1)
    assert config.subgoal_reach_m == recorded.get("expert_max_distance", recorded.get("subgoal_reach_m"))
    assert config.evaluation_envs == recorded.get("evaluation_envs", 1)
