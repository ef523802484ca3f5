"""``python -m antmaze_lab.low_level --algorithms``: two algorithms trained side by side, resumed, scored in one run."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from antmaze_lab import low_level

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

ROOT = Path(__file__).parents[1]
SCRIPT = [sys.executable, "-m", "antmaze_lab.low_level"]
"""Run from the repository root, as the docs give it (the lab is importable from there)."""


def test_bad_algorithm_lists_get_one_line_errors(tmp_path):
    config = tmp_path / "a.yml"
    config.write_text("ant: {}\n")
    with pytest.raises(ValueError, match="at least two"):
        low_level.parse_algorithms(f"td3={config}")
    with pytest.raises(ValueError, match=r"'ppo=.*' must be ALGO=FILE"):
        low_level.parse_algorithms(f"ppo={config},td3={config}")
    with pytest.raises(ValueError, match="each once"):
        low_level.parse_algorithms(f"td3={config},td3={config}")
    with pytest.raises(ValueError, match=r"no hyperparameter file at nowhere\.yml"):
        low_level.parse_algorithms(f"td3={config},sac=nowhere.yml")
    assert list(low_level.parse_algorithms(f"sac={config}, td3={config}")) == ["sac", "td3"]
    run = subprocess.run(
        [*SCRIPT, "--algorithms", f"td3={config}"], cwd=ROOT, capture_output=True, text=True, check=False
    )
    assert run.returncode == 2 and run.stderr.strip().splitlines()[-1].endswith(f"got 'td3={config}'")


def test_a_runs_dir_of_other_settings_is_refused_before_any_training(tmp_path):
    config = tmp_path / "a.yml"
    config.write_text("ant: {}\n")
    algorithms = low_level.parse_algorithms(f"td3={config},sac={config}")
    saved = {"settings": {"seed": 1, "chunk": 100, "hyperparams": {"td3": str(config)}}, "chunks": {}}
    (tmp_path / "timing.json").write_text(json.dumps(saved))
    with pytest.raises(ValueError, match=r"holds runs of .*'seed': 1.*use another --runs-dir"):
        low_level.train_side_by_side(algorithms, budget=200, chunk=100, runs_dir=tmp_path, seed=0, eval_episodes=1)
    assert not (tmp_path / "td3").exists()


@pytest.mark.slow
def test_two_algorithms_train_in_turns_resume_and_are_scored_beside_the_shipped_ant(tmp_path):
    config = tmp_path / "tiny.yml"
    config.write_text("ant:\n  learning_starts: 100\n  buffer_size: 2000\n")
    out = tmp_path / "algorithms.json"
    command = [*SCRIPT, "--algorithms", f"td3={config},sac={config}", "--budget", "400"]
    command += ["--chunk", "200", "--episodes", "2", "--curve-episodes", "1", "--maze-episodes", "1"]
    command += ["--families", "ant4", "--runs-dir", str(tmp_path / "runs"), "--out", str(out)]
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True, text=True)
    result = json.loads(out.read_text())
    assert list(result["training"]) == ["td3", "sac"]
    for figures in result["training"].values():
        assert figures["steps"] == 400
        assert [(chunk["from"], chunk["to"]) for chunk in figures["chunks"]] == [(0, 200), (200, 400)]
    assert result["training"]["td3"]["steps_per_s_ratio_to_first"] == 1.0
    assert set(result["eval_low"]) == {"shipped", "td3", "sac"}  # every final policy beside the shipped one
    assert all(row["episodes"] == 2 and len(row["wilson_95"]) == 2 for row in result["eval_low"].values())
    assert len(result["in_maze"]) == 3 and Path(result["learning_curves_png"]).is_file()
    timing = (tmp_path / "runs" / "timing.json").read_text()
    subprocess.run(
        command, cwd=ROOT, check=True, capture_output=True, text=True
    )  # at the budget already: no new chunks
    assert (tmp_path / "runs" / "timing.json").read_text() == timing
