"""scripts/rl_baselines.py: the flat goal env, the final-goal scoring policy, and the wall-time cap's record."""

import argparse
import json

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from script_helpers import load_script

from antmaze_hirl.envs.state_layout import STATE_LAYOUT

rl_baselines = load_script("scripts/rl_baselines.py")


def test_the_flat_env_is_a_goal_env_whose_goal_is_the_final_goal():
    env = rl_baselines.FlatMazeEnv()
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs["desired_goal"], env.high.goal_xy)  # the task's goal, not a nearby subgoal
    assert env.high.layout.walls.shape == (7, 7)  # a 5x5 maze of the train part
    reward = env.compute_reward(obs["desired_goal"][None], obs["desired_goal"][None], [{}])
    assert reward.tolist() == [1.0]
    steps = 0
    truncated = terminated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, _ = env.step(np.zeros(2))
        steps += 1
    assert truncated and steps == rl_baselines.FLAT_STEPS  # a still body never reaches a goal >= 3 cells away
    env.close()


def test_the_final_goal_policy_proposes_the_goal():
    state = np.zeros(6, dtype=np.float32)
    state[STATE_LAYOUT.goal_slice] = (1.5, -2.0)
    assert rl_baselines.FinalGoalPolicy()({"state": state}).tolist() == [1.5, -2.0]


def test_the_wall_time_cap_stops_training_and_the_record_gives_the_steps_reached(tmp_path):
    args = argparse.Namespace(algo="ppo", body="point", steps=10_000, max_minutes=1e-9, num_envs=2, seed=0)
    record = rl_baselines.train(args, tmp_path / "m.zip", tmp_path / "m.training.json")
    assert record["stopped_by"] == "wall-time cap" and record["steps_reached"] == 2  # one vector step of 2 mazes
    assert json.loads((tmp_path / "m.training.json").read_text()) == record
    assert (tmp_path / "m.zip").is_file()


def _args(algo, steps, **kw):
    return argparse.Namespace(
        algo=algo,
        body="point",
        steps=steps,
        max_minutes=60.0,
        num_envs=2,
        seed=0,
        checkpoint_every=4,
        resume=True,
        **kw,
    )


@pytest.fixture
def small_settings(monkeypatch):
    """PPO rollouts of 4 steps per maze and SAC learning from its first step: a few seconds of training."""
    monkeypatch.setitem(rl_baselines.SETTINGS, "ppo", {"n_steps": 4, "batch_size": 8, "n_epochs": 1})
    monkeypatch.setitem(rl_baselines.SETTINGS, "sac", {"buffer_size": 100, "learning_starts": 0, "batch_size": 8})


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_a_run_checkpoints_and_a_resumed_run_continues_from_the_last_checkpoint(tmp_path, algo, small_settings):
    model_path = tmp_path / "m.zip"
    first = rl_baselines.train(_args(algo, 8), model_path, tmp_path / "m.training.json")
    folder = rl_baselines.checkpoint_folder(model_path)
    assert first["steps_reached"] == 8 and first["resumed_at"] == []
    assert sorted(path.name for path in folder.glob("*.zip")) == ["4.zip", "8.zip"]  # every 4 steps of 2 mazes
    assert json.loads((folder / "latest.json").read_text())["model"] == "8.zip"
    buffers = sorted(path.name for path in folder.glob("replay_buffer*.pkl"))
    assert buffers == (["replay_buffer_8.pkl"] if algo == "sac" else [])  # the latest one only, the 4-step one gone
    assert json.loads((folder / "latest.json").read_text()).get("replay_buffer") == (buffers or [None])[0]
    second = rl_baselines.train(_args(algo, 16), model_path, tmp_path / "m.training.json")
    assert second["steps_reached"] == 16 and second["resumed_at"] == [8]  # 8 more steps, not 16 from scratch
    assert second["training_seconds"] >= first["training_seconds"]  # seconds add up over the runs
    model = (rl_baselines.PPO if algo == "ppo" else rl_baselines.SAC).load(model_path, device="cpu")
    assert model.num_timesteps == 16


def test_a_run_without_resume_starts_again_from_zero(tmp_path, small_settings):
    model_path = tmp_path / "m.zip"
    rl_baselines.train(_args("ppo", 8), model_path, tmp_path / "r.json")
    fresh = argparse.Namespace(**{**vars(_args("ppo", 4)), "resume": False})
    assert rl_baselines.train(fresh, model_path, tmp_path / "r.json")["resumed_at"] == []


def test_tensorboard_logs_the_training_run(tmp_path, small_settings):
    args = argparse.Namespace(**{**vars(_args("ppo", 8)), "tensorboard": str(tmp_path / "tb")})
    rl_baselines.train(args, tmp_path / "m.zip", tmp_path / "r.json")
    assert list((tmp_path / "tb").rglob("events.out.tfevents.*"))


def test_the_ant_baselines_train_on_the_ant_family_and_score_on_its_suite():
    assert rl_baselines.SUITES == {"point": "point5", "ant": "ant4"}
    env = rl_baselines.FlatMazeEnv("ant")
    env.reset(seed=0)
    assert env.high.layout.walls.shape == (6, 6)  # a 4x4 maze of the ant family's train part
    assert env.action_space.shape == (8,)  # the ant's eight joints, driven directly
    env.close()
