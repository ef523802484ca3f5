import argparse
import base64
import dataclasses
import importlib.util
import json
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import tiny_sac_her
from stable_baselines3 import PPO, SAC

from antmaze_hirl import load_low_level
from antmaze_hirl.cli import SUBCOMMANDS, build_parser, main
from antmaze_hirl.cli_validation import (
    INIT_FROM_VALUE,
    LOW_LEVEL_VALUE,
    SB3_PICKLE_WARNING,
    SB3_ZIP_WARNING,
    all_options,
)
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experiments.config import DEFAULT_METHODS, ExperimentConfig, body_settings
from antmaze_hirl.sb3_ext import CheckpointError
from antmaze_hirl.sb3_ext.loading import LOW_LEVEL_NAMES

COMMANDS = ["demo", "train-low", "eval-low", "ensemble-low", "experiment", "study", "benchmark", "submit"]
STUDY_COMMANDS = ["init", "serve", "simulate", "analyze", "export"]


def help_text(argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--help"])
    assert exit_info.value.code == 0
    return capsys.readouterr().out


def test_the_subcommand_list_is_the_one_the_parser_builds():
    assert len(SUBCOMMANDS) == len(COMMANDS)
    assert set(build_parser()._subparsers._group_actions[0].choices) == set(COMMANDS)


@pytest.mark.parametrize("command", STUDY_COMMANDS)
def test_every_study_command_help_has_an_example_and_no_markup(command, capsys):
    text = help_text(["study", command], capsys)
    assert f"usage: antmaze-hirl study {command}" in text
    assert "``" not in text
    assert "example:\n  " in text and f"antmaze-hirl study {command} " in text.split("example:")[1]


@pytest.mark.parametrize("command", COMMANDS)
def test_every_subcommand_help_shows_defaults_an_example_and_no_markup(command, capsys):
    text = help_text([command], capsys)
    assert f"usage: antmaze-hirl {command}" in text
    assert "``" not in text
    assert f"example:\n  antmaze-hirl {command} " in text
    subparser = build_parser()._subparsers._group_actions[0].choices[command]
    for action in subparser._actions:
        if action.dest == "help" or action.help == argparse.SUPPRESS:  # help itself; hidden options
            continue
        assert action.help, f"{command} {action.option_strings} has no help line"
        # Every option says its default: argparse's "(default: X)", or "(required)" / its own "(default: ...)".
        shown = subparser._get_formatter()._get_help_string(action)
        assert "(default:" in shown or "(required)" in shown, f"{command} {action.option_strings}: {shown!r}"
        # Whitespace-blind: argparse wraps lines, and breaks a word longer than the column (a long default).
        assert "".join((shown % {"default": action.default}).split()) in "".join(text.split())


LOADING_OPTIONS = {
    ("train-low", "--init-from"): SB3_ZIP_WARNING,
    ("train-low", "--init-buffer"): SB3_PICKLE_WARNING,
    ("eval-low", "--policy"): SB3_ZIP_WARNING,
    ("ensemble-low", "members"): SB3_ZIP_WARNING,
    ("benchmark", "--policy"): SB3_ZIP_WARNING,
    ("benchmark", "--low-level"): SB3_ZIP_WARNING,
}
"""Every option that loads an SB3 zip or pickle, with the warning its help must carry."""

WRITTEN_NOT_LOADED = {("train-low", "--out"), ("ensemble-low", "--out")}
"""Options whose help names a zip that the command writes, not loads."""


def _named_options():
    return {
        (command, (action.option_strings or [action.dest])[0]): action
        for command, action in all_options(build_parser())
    }


def test_every_option_that_loads_a_zip_or_pickle_warns_in_its_help():
    options = _named_options()
    for key, warning in LOADING_OPTIONS.items():
        assert key in options, f"{key} is listed but the parsers have no such option"
        assert warning in options[key].help, f"{key}: {options[key].help!r}"
    # An option added later that names a zip or pickle must join one of the two lists.
    mentions = re.compile(r"zip|\.pkl|pickle|replay buffer", re.IGNORECASE)
    named = {key for key, action in options.items() if action.help and mentions.search(action.help)}
    assert named - LOADING_OPTIONS.keys() - WRITTEN_NOT_LOADED == set()
    assert WRITTEN_NOT_LOADED <= named  # the exemptions still exist and still name a zip


LOW_LEVEL_OPTIONS = {
    ("eval-low", "--policy"): LOW_LEVEL_VALUE,
    ("benchmark", "--low-level"): LOW_LEVEL_VALUE,
    ("train-low", "--init-from"): INIT_FROM_VALUE,
}
"""Options that load a low level by path or name (``low_level_path``), with what their help says they take."""


def test_options_that_load_a_low_level_say_which_names_they_take():
    options = _named_options()
    for key, value in LOW_LEVEL_OPTIONS.items():
        assert value in options[key].help, f"{key}: {options[key].help!r}"
    # The help's words are written out (loading's module imports SB3): a name added there must join them.
    for name in {name for names in LOW_LEVEL_NAMES.values() for name in names}:
        assert re.search(rf"\b{name}\b", LOW_LEVEL_VALUE), f"LOW_LEVEL_VALUE does not name {name!r}"


def test_init_froms_help_names_exactly_the_low_level_names_a_warm_start_accepts():
    # A warm start copies one actor: a name that stands for an action ensemble is refused, so the help names the
    # others, each as "the BODY's NAME".
    from antmaze_hirl.sb3_ext.training import warm_start_parameters

    for body, names in LOW_LEVEL_NAMES.items():
        for name in names:
            try:
                warm_start_parameters(body, "td3", name)
                accepted = True
            except ValueError as error:
                assert "is an action ensemble" in str(error), error
                accepted = False
            assert (f"the {body}'s {name}" in INIT_FROM_VALUE) is accepted, (body, name, INIT_FROM_VALUE)


def test_top_level_help_has_no_markup(capsys):
    text = help_text([], capsys)
    assert "``" not in text and "antmaze-hirl demo --body ant" in text


def test_the_default_methods_are_every_query_strategy_but_gated():
    from antmaze_hirl.dagger.strategies import STRATEGIES

    # gated runs on request (--methods gated,...) until its results join the committed folders.
    assert set(DEFAULT_METHODS) == set(STRATEGIES) - {"gated"}


def test_demo_writes_picture_and_reports(tmp_path, capsys):
    assert main(["demo", "--seed", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("success:") and "subgoals" in out
    picture = tmp_path / "demo.png"
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.integration
def test_console_script_is_installed():
    script = Path(sys.executable).parent / "antmaze-hirl"
    result = subprocess.run([str(script), "--help"], capture_output=True, text=True, check=True)
    assert "demo" in result.stdout and "train-low" in result.stdout


def test_unknown_body_is_rejected(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["demo", "--body", "spider"])
    assert "invalid choice: 'spider'" in capsys.readouterr().err


def test_train_low_reads_a_hyperparams_override(tmp_path, capsys):
    overrides = tmp_path / "tiny.yml"
    overrides.write_text("point:\n  gamma: 0.9\n  learning_starts: 100\n  buffer_size: 5000\n")
    args = ["train-low", "--body", "point", "--timesteps", "200", "--out", str(tmp_path / "run"), "--no-progress"]
    assert main([*args, "--hyperparams", str(overrides), "--eval-freq", "1000", "--eval-episodes", "2"]) == 0
    assert "trained 200 steps" in capsys.readouterr().out
    assert load_low_level("point", tmp_path / "run" / "policy.zip").gamma == 0.9


def test_eval_low_prints_and_writes_the_figures_of_seeded_subgoals(tmp_path, capsys):
    from antmaze_hirl.envs.reach import ReachEnv
    from antmaze_hirl.experiments.runner import low_level_identity
    from antmaze_hirl.sb3_ext import evaluate_reach

    out = tmp_path / "deep" / "eval.json"
    args = ["eval-low", "--body", "point", "--episodes", "6", "--seed", "3", "--sample-radius-m", "0.6"]
    assert main([*args, "--json", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.splitlines()[-1])
    shipped = load_low_level("point")
    expected = evaluate_reach(shipped, ReachEnv("point", sample_radius_m=0.6), episodes=6, seed=3)
    identity = low_level_identity("point", shipped)
    recorded = {"num_envs": 1, "low_level_id": identity, "seed": 3, "sample_radius_m": 0.6}  # the set it played
    assert printed == json.loads(out.read_text()) == {**expected, **recorded}
    assert printed["low_level_id"].startswith("sha256:")
    assert main(["eval-low", "--body", "point", "--episodes", "1"]) == 0
    default = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert (default["seed"], default["sample_radius_m"]) == (0, ReachEnv("point").sample_radius_m)  # the radius used


def test_eval_low_in_lockstep_tries_the_serial_subgoals(capsys):
    # The point's PD controller acts row by row, so lockstep must give the serial figures exactly.
    from antmaze_hirl.envs.controllers import PointGoToController
    from antmaze_hirl.envs.reach import ReachEnv
    from antmaze_hirl.sb3_ext import evaluate_reach

    serial = evaluate_reach(PointGoToController(kp=2.0), ReachEnv("point"), episodes=7, seed=11)
    lockstep = evaluate_reach(PointGoToController(kp=2.0), ReachEnv("point"), episodes=7, seed=11, num_envs=3)
    assert lockstep == serial and 0 < serial["success_rate"] < 1
    assert main(["eval-low", "--body", "point", "--episodes", "4", "--num-envs", "3"]) == 0
    assert json.loads(capsys.readouterr().out.splitlines()[-1])["num_envs"] == 3
    with pytest.raises(ValueError, match="num_envs must be an integer >= 1, got 0"):
        evaluate_reach(PointGoToController(), ReachEnv("point"), episodes=2, seed=0, num_envs=0)


def test_bad_input_exits_with_one_line_naming_it(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["eval-low", "--body", "ant", "--episodes", "2", "--sample-radius-m", "0.3"])
    assert exit_info.value.code == 2
    assert "eval-low: error: --sample-radius-m 0.3: sample_radius_m 0.3 m leaves no room" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["train-low", "--body", "point", "--timesteps", "100", "--out", str(tmp_path), "--resume"])
    assert "train-low: error: no checkpoint to resume in" in capsys.readouterr().err
    with pytest.raises(CheckpointError, match="no checkpoint to resume"):
        main(["--traceback", "train-low", "--body", "point", "--timesteps", "100", "--out", str(tmp_path), "--resume"])


@pytest.mark.parametrize(
    ("argv", "body", "protocol", "held_out", "evaluation_envs"),
    [
        ([], "point", 2, True, 25),  # no options but --out: the current protocol
        (["--body", "ant"], "ant", 2, True, 25),
        (["--body", "ant", "--protocol", "1"], "ant", 1, False, 1),  # protocol 1 evaluates one maze at a time
        (["--protocol", "1", "--held-out-layouts", "--evaluation-envs", "5"], "point", 1, True, 5),
    ],
)
def test_experiment_runs_the_current_protocol_unless_told_otherwise(
    argv, body, protocol, held_out, evaluation_envs, tmp_path, monkeypatch, capsys
):
    from antmaze_hirl.experiments import runner

    seen = []
    monkeypatch.setattr(runner, "run_experiment", lambda *args, **_: seen.append(args[2]) or {"methods": {}})
    assert main(["experiment", "--out", str(tmp_path), *argv]) == 0
    settings = body_settings(body, held_out_layouts=held_out)
    expected = ExperimentConfig(
        body=body, protocol=protocol, held_out_layouts=held_out, evaluation_envs=evaluation_envs, **settings
    )
    assert seen == [expected]
    if not argv:
        assert seen == [dataclasses.replace(ExperimentConfig(), **settings)]  # the library's defaults
    text = help_text(["experiment"], capsys)
    assert "by default in the current protocol (protocol 2:" in " ".join(text.split())


@pytest.mark.integration
def test_eval_low_loads_a_sac_with_her_zip(tmp_path, capsys):
    model = tiny_sac_her(ReachEnv("point"))
    model.learn(300)
    path = tmp_path / "sac.zip"
    model.save(path)
    assert isinstance(load_low_level("point", path), SAC)
    assert main(["eval-low", "--body", "point", "--policy", str(path), "--episodes", "3"]) == 0
    printed = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert printed["episodes"] == 3 and 0.0 <= printed["success_rate"] <= 1.0


def test_eval_low_rejects_an_on_policy_zip_or_a_non_zip_in_one_line(tmp_path, capsys):
    ppo = tmp_path / "ppo.zip"
    PPO("MultiInputPolicy", ReachEnv("point"), n_steps=16, batch_size=16, seed=0).save(ppo)
    garbage = tmp_path / "garbage.zip"
    garbage.write_text("not a zip")
    for path, message in ((ppo, "MultiInputActorCriticPolicy, not a policy of an off-policy"), (garbage, "not an SB3")):
        with pytest.raises(SystemExit) as exit_info:
            main(["eval-low", "--body", "point", "--policy", str(path), "--episodes", "2"])
        assert exit_info.value.code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("antmaze-hirl eval-low: error: ") and message in err


def test_eval_low_says_when_a_zips_policy_needs_a_package_that_is_missing(tmp_path, capsys):
    if importlib.util.find_spec("sb3_contrib") is not None:
        pytest.skip("sb3-contrib is installed: a TQC zip loads")
    # What an SB3 TQC zip's "data" holds for its policy class: a pickled reference to sb3_contrib's class.
    reference = base64.b64encode(b"csb3_contrib.tqc.policies\nMultiInputPolicy\n.").decode()
    entry = {":type:": "<class 'abc.ABCMeta'>", ":serialized:": reference, "__module__": "sb3_contrib.tqc.policies"}
    path = tmp_path / "tqc.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", json.dumps({"policy_class": entry}))
    with pytest.raises(SystemExit) as exit_info:
        main(["eval-low", "--body", "point", "--policy", str(path)])
    assert exit_info.value.code == 2
    assert "holds a policy from sb3_contrib.tqc.policies, which this Python cannot import" in capsys.readouterr().err


@pytest.mark.slow
def test_ant_demo_succeeds_on_its_default_seed(tmp_path, capsys):
    assert main(["demo", "--body", "ant", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.startswith("success:")


def test_a_failed_demo_says_why(tmp_path, monkeypatch):
    from antmaze_hirl import demo

    titles = []
    monkeypatch.setattr(demo, "plot_played_episode", lambda env, episode, out, title: titles.append(title) or out)
    result = demo.run_demo("point", seed=0, out_dir=tmp_path, max_steps=5)
    assert (result.success, result.outcome, result.low_level_steps) == (False, "timeout", 5)
    assert titles == ["point, seed 0: timeout, 1 subgoals, 5 steps"]


@pytest.mark.parametrize(
    ("info", "truncated", "outcome"),
    [
        ({"is_success": True, "flipped": False}, False, "success"),
        ({"is_success": False, "flipped": True}, False, "flip"),
        ({"is_success": False, "flipped": False}, True, "timeout"),
    ],
)
def test_episode_outcome_names_why_it_ended(info, truncated, outcome):
    from antmaze_hirl.rollout import HighLevelEpisode

    assert HighLevelEpisode(np.zeros((1, 2)), np.zeros((0, 2)), info, truncated=truncated).outcome == outcome
