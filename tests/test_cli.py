import json
import subprocess
import sys
from pathlib import Path

import pytest

from antmaze_hirl import load_low_level
from antmaze_hirl.cli import build_parser, main
from antmaze_hirl.sb3_ext import CheckpointError


@pytest.mark.parametrize("command", ["demo", "train-low", "eval-low", "experiment"])
def test_every_subcommand_has_help(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    assert f"antmaze-hirl {command}" in capsys.readouterr().out


def test_demo_writes_picture_and_reports(tmp_path, capsys):
    assert main(["demo", "--seed", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("success:") and "subgoals" in out
    picture = tmp_path / "demo.png"
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


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
    from antmaze_hirl.sb3_ext import evaluate_reach

    out = tmp_path / "deep" / "eval.json"
    args = ["eval-low", "--body", "point", "--episodes", "6", "--seed", "3", "--max-distance", "0.6"]
    assert main([*args, "--json", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.splitlines()[-1])
    expected = evaluate_reach(load_low_level("point"), ReachEnv("point", goal_radius=0.6), episodes=6, seed=3)
    assert printed == json.loads(out.read_text()) == expected
    assert set(printed) == {"success_rate", "episodes", "mean_steps"}


def test_bad_input_exits_with_one_line_naming_it(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["eval-low", "--body", "ant", "--episodes", "2", "--max-distance", "0.3"])
    assert exit_info.value.code == 2
    assert "eval-low: error: --max-distance 0.3: goal_radius 0.3 m leaves no room" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["train-low", "--body", "point", "--timesteps", "100", "--out", str(tmp_path), "--resume"])
    assert "train-low: error: no checkpoint to resume in" in capsys.readouterr().err
    with pytest.raises(CheckpointError, match="no checkpoint to resume"):
        main(["--traceback", "train-low", "--body", "point", "--timesteps", "100", "--out", str(tmp_path), "--resume"])
