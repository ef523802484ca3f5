"""Scoring on the lockstep vector env: the same episodes and outcomes as serial scoring, on the point."""

import gymnasium as gym
import numpy as np
import pytest

from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy
from antmaze_hirl.experiments.benchmark import score_policy
from antmaze_hirl.rollout import play_on_copies, release_copies

TASKS = list(range(6))


def test_the_oracle_scores_the_same_episodes_in_lockstep_as_serially():
    serial = score_policy("point5", "oracle", task_ids=TASKS, num_envs=1)
    lockstep = score_policy("point5", "oracle", task_ids=TASKS, num_envs=4)
    assert lockstep["episode_outcomes"] == serial["episode_outcomes"]  # success, subgoals and steps, per episode
    assert (serial["num_envs"], lockstep["num_envs"]) == (1, 4)


def test_a_batched_learner_scores_the_same_episodes_in_lockstep_as_serially(tmp_path):
    # An untrained learner wanders: long episodes, many subgoals, batched predictions (predict_batch).
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    path = tmp_path / "learner.zip"
    HighLevelPolicy.for_env(env, rng=np.random.default_rng(0)).save(path)
    env.close()
    serial = score_policy("point5", str(path), task_ids=TASKS[:4], num_envs=1)
    lockstep = score_policy("point5", str(path), task_ids=TASKS[:4], num_envs=3)
    assert lockstep["episode_outcomes"] == serial["episode_outcomes"]
    assert serial["mean_attempts"] > 3  # long enough to compare many lockstep rounds


def test_lockstep_truncates_at_the_time_limit_as_gyms_time_limit_does():
    from antmaze_hirl.experts import PathOracle

    env = gym.make("antmaze_hirl/PointMaze-5x5-v0", max_episode_steps=2)
    oracle = PathOracle.for_env(env)
    serial = []
    for task_id in TASKS:
        obs, _ = env.reset(seed=task_id, options={"task_id": task_id})
        for _ in range(2):
            obs, _, terminated, truncated, info = env.step(oracle(obs))
            if terminated or truncated:
                break
        serial.append((info["attempts"], info["total_low_level_steps"], info["is_success"]))
    resets = [{"seed": task_id, "options": {"task_id": task_id}} for task_id in TASKS]
    played = play_on_copies(oracle, env.unwrapped, resets, num_envs=4, max_subgoals=2)
    release_copies(env.unwrapped)
    env.close()
    infos = [episode.info for episode in played]
    assert [(i["attempts"], i["total_low_level_steps"], i["is_success"]) for i in infos] == serial
    assert all(attempts == 2 for attempts, _, _ in serial)  # every oracle episode needs more than 2 subgoals


def test_num_envs_below_one_is_refused_naming_the_value():
    with pytest.raises(ValueError, match="num_envs must be an integer >= 1, got 0"):
        score_policy("point5", "oracle", task_ids=[0], num_envs=0)
