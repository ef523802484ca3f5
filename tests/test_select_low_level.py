"""benchmarks/select_low_level.py: with --held-out-layouts its mazes are the layout partition's selection part."""

import sys
from pathlib import Path

import pytest
from conftest import StillController

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
import select_low_level

from antmaze_hirl.envs.layout_splits import layout_split
from antmaze_hirl.experiments import ExperimentConfig
from antmaze_hirl.experiments.config import body_settings
from antmaze_hirl.experiments.runner import make_env


@pytest.mark.parametrize("held_out_layouts", [False, True])
def test_score_asks_for_the_selection_part_only_with_held_out_layouts(monkeypatch, held_out_layouts):
    calls = []

    def fake_oracle_success(config, path, **kwargs):
        calls.append((config, kwargs))
        return {"low_level_id": "id", "success_rate": 0.5}

    monkeypatch.setattr(select_low_level, "oracle_success", fake_oracle_success)
    monkeypatch.setattr(select_low_level, "load_low_level", lambda body, path: None)
    reach_envs = []

    def fake_evaluate_reach(model, env, **kwargs):
        reach_envs.append(env)
        return {"success_rate": 1.0, "mean_steps": 9}

    monkeypatch.setattr(select_low_level, "evaluate_reach", fake_evaluate_reach)
    scores = select_low_level.score(
        Path("p.zip"), "ant", seed=100_000, episodes=2, mazes=3, held_out_layouts=held_out_layouts, action_smoothing=0.3
    )
    ((config, kwargs),) = calls
    assert scores["score"] == 0.75
    assert config.held_out_layouts is held_out_layouts
    assert kwargs["seed"] == select_low_level.SELECTION_MAZE_SEED and kwargs["episodes"] == 3
    assert kwargs.get("split") == ("selection" if held_out_layouts else None)
    assert config.maze_size == (4 if held_out_layouts else 3)
    assert kwargs["action_smoothing"] == 0.3 and reach_envs[0].action_smoothing == 0.3  # both figures smoothed


def test_held_out_selection_mazes_share_no_wall_grid_with_the_reported_ant4_mazes():
    config = ExperimentConfig(body="ant", held_out_layouts=True, **body_settings("ant", held_out_layouts=True))
    walls = {}
    for split, first_seed in (("selection", select_low_level.SELECTION_MAZE_SEED), ("eval", 1_000_000)):
        env = make_env(config, StillController(), split=split)
        walls[split] = set()
        for seed in range(first_seed, first_seed + 15):
            env.reset(seed=seed)
            assert layout_split(env.unwrapped.layout) == split
            walls[split].add(env.unwrapped.layout.walls.tobytes())
        env.close()
    assert walls["selection"] and walls["eval"] and not walls["selection"] & walls["eval"]


def test_oracle_success_drives_the_low_level_through_the_smoothing(monkeypatch):
    import paper_experiment

    from antmaze_hirl.envs import SmoothedController

    controllers = []
    real_make_env = paper_experiment.make_env

    def recording_make_env(config, low_level=None, **kwargs):
        controllers.append(low_level)
        return real_make_env(config, low_level, **kwargs)

    monkeypatch.setattr(paper_experiment, "make_env", recording_make_env)
    result = paper_experiment.oracle_success(ExperimentConfig(body="point"), episodes=1, action_smoothing=0.4)
    assert isinstance(controllers[0], SmoothedController) and controllers[0].alpha == 0.4
    assert result["action_smoothing"] == 0.4 and result["low_level_id"].startswith("sha256:")
