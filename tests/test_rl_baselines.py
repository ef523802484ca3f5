"""scripts/rl_baselines.py: the flat goal env, the final-goal scoring policy, and the wall-time cap's record."""

import argparse
import json

import numpy as np
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
    args = argparse.Namespace(algo="ppo", steps=10_000, max_minutes=1e-9, num_envs=2, seed=0)
    record = rl_baselines.train(args, tmp_path / "m.zip", tmp_path / "m.training.json")
    assert record["stopped_by"] == "wall-time cap" and record["steps_reached"] == 2  # one vector step of 2 mazes
    assert json.loads((tmp_path / "m.training.json").read_text()) == record
    assert (tmp_path / "m.zip").is_file()
