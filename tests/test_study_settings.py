"""A study's settings share the experiment's fields and defaults, and its settings.json keeps its keys."""

import ast
import json
from dataclasses import MISSING, asdict, fields
from pathlib import Path

import pytest

from antmaze_hirl.experiments.config import ExperimentConfig, TrialSettings
from antmaze_hirl.experiments.old_folders import SETTINGS_BEFORE_PROTOCOL_2
from antmaze_hirl.study import settings as settings_module
from antmaze_hirl.study.settings import (
    EXPERIMENT_FIELDS,
    SETTINGS_FILE,
    StudySettings,
    load_settings,
    save_settings,
)

SETTINGS_KEYS = [
    "body",
    "maze_size",
    "subgoal_reach_m",
    "eval_every",
    "eval_episodes",
    "final_eval_episodes",
    "gradient_steps",
    "decay",
    "held_out_layouts",
    "show_learner_subgoal",
    "background_updates",
]
"""The keys of a study folder's settings.json, in the order written since 0.2.0 (TrialSettings' first)."""


PAGE_KEYS = ("show_learner_subgoal", "background_updates")
"""The study's own settings: how the page and the server run a trial, not what the experiment is."""


def experiment_field(name):
    return next(field for field in fields(ExperimentConfig) if field.name == name)


def test_the_shared_fields_are_every_study_setting_but_the_page_one():
    assert list(EXPERIMENT_FIELDS) == [key for key in SETTINGS_KEYS if key not in PAGE_KEYS]


@pytest.mark.parametrize("name", EXPERIMENT_FIELDS)
def test_a_shared_fields_type_and_default_are_the_experiments(name):
    study = next(field for field in fields(StudySettings) if field.name == name)
    experiment = experiment_field(name)
    assert experiment.default is not MISSING
    # held_out_layouts: the experiment's default is the current protocol's (True); a study's stays False, what its
    # settings.json from before the setting existed ran (`study init` sets it True).
    default = False if name == "held_out_layouts" else experiment.default
    assert (study.type, study.default) == (experiment.type, default)


def test_the_study_declares_only_the_pages_setting_and_inherits_the_rest():
    # Equal fields would pass the test above even if typed twice: the class must declare none of them.
    source = Path(settings_module.__file__).read_text()
    study_class = next(
        node for node in ast.parse(source).body if isinstance(node, ast.ClassDef) and node.name == "StudySettings"
    )
    declared = [node.target.id for node in study_class.body if isinstance(node, ast.AnnAssign)]
    assert declared == list(PAGE_KEYS)
    assert issubclass(StudySettings, TrialSettings) and issubclass(ExperimentConfig, TrialSettings)
    assert EXPERIMENT_FIELDS == tuple(field.name for field in fields(TrialSettings))


def test_the_trials_experiment_config_carries_every_shared_setting():
    settings = StudySettings.for_body("ant", eval_every=3, gradient_steps=7, decay=1.5)
    config = settings.experiment_config(11)
    assert config.episodes == 11
    assert {name: getattr(config, name) for name in EXPERIMENT_FIELDS} == {
        name: getattr(settings, name) for name in EXPERIMENT_FIELDS
    }
    # What the study does not set is the experiment's default, but for protocol 1's evaluation, which it runs.
    others = [field for field in fields(ExperimentConfig) if field.name not in (*EXPERIMENT_FIELDS, "episodes")]
    protocol_1 = {"protocol": 1, "evaluation_envs": 1}
    assert {field.name: getattr(config, field.name) for field in others} == {
        field.name: protocol_1.get(field.name, field.default) for field in others
    }


def test_settings_json_keeps_its_keys_and_old_files_still_load(tmp_path):
    save_settings(StudySettings.for_body("point"), tmp_path)
    assert list(json.loads((tmp_path / SETTINGS_FILE).read_text())) == SETTINGS_KEYS
    # A settings.json written before held-out layouts existed (no held_out_layouts key) and before 0.2.0 (the
    # reach under its old key), as results/study/simulated_point/settings.json.
    old = {
        "body": "ant",
        "maze_size": 3,
        "expert_max_distance": 2.0,
        "eval_every": 10,
        "eval_episodes": 20,
        "final_eval_episodes": 100,
        "gradient_steps": 200,
        "decay": 2.0,
        "show_learner_subgoal": False,
    }
    (tmp_path / SETTINGS_FILE).write_text(json.dumps(old, indent=2))
    loaded = load_settings(tmp_path)
    renamed = {("subgoal_reach_m" if key == "expert_max_distance" else key): value for key, value in old.items()}
    assert asdict(loaded) == {**renamed, "held_out_layouts": False, "background_updates": False}  # as it ran
    expected = ExperimentConfig(body="ant", episodes=5, maze_size=3, subgoal_reach_m=2.0, **SETTINGS_BEFORE_PROTOCOL_2)
    assert loaded.experiment_config(5) == expected  # a study evaluates as protocol 1, one maze at a time


@pytest.mark.integration  # reads the committed results
def test_the_committed_studys_settings_load():
    settings = load_settings(Path(__file__).resolve().parents[1] / "results" / "study" / "simulated_point")
    assert (settings.body, settings.subgoal_reach_m, settings.eval_every) == ("point", None, 5)


def test_a_settings_file_with_the_reach_under_both_keys_is_one_line_naming_both(tmp_path):
    save_settings(StudySettings.for_body("ant"), tmp_path)
    written = json.loads((tmp_path / SETTINGS_FILE).read_text())
    (tmp_path / SETTINGS_FILE).write_text(json.dumps({**written, "expert_max_distance": 3.0}))
    with pytest.raises(ValueError) as error:
        load_settings(tmp_path)
    message = str(error.value)
    assert "\n" not in message and str(tmp_path / SETTINGS_FILE) in message
    assert "'subgoal_reach_m' and its old name 'expert_max_distance' hold different values (2.0 against 3.0)" in message


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [("decay", -1, "decay must be a finite number >= 1"), ("eval_every", 0, "eval_every must be an int in \\[1,")],
)
def test_a_settings_file_gets_the_command_lines_bounds(tmp_path, key, value, message):
    save_settings(StudySettings.for_body("point"), tmp_path)
    written = json.loads((tmp_path / SETTINGS_FILE).read_text())
    (tmp_path / SETTINGS_FILE).write_text(json.dumps({**written, key: value}))
    with pytest.raises(ValueError, match=message):
        load_settings(tmp_path)


def test_study_init_refuses_to_rewrite_a_started_studys_settings(tmp_path, capsys):
    from antmaze_hirl.cli import main

    folder = tmp_path / "study"
    assert main(["study", "init", str(folder), "--body", "point", "--participants", "1", "--eval-every", "2"]) == 0
    before = (folder / SETTINGS_FILE).read_bytes()
    (folder / "participants" / "P01").mkdir(parents=True)
    (folder / "participants" / "P01" / "progress.json").write_text('{"trial_index": 0, "phase": "label"}')
    with pytest.raises(SystemExit) as exit_code:
        main(["study", "init", str(folder), "--body", "point", "--participants", "1", "--eval-every", "99"])
    assert exit_code.value.code == 2
    assert "already holds participant data" in capsys.readouterr().err
    assert (folder / SETTINGS_FILE).read_bytes() == before
