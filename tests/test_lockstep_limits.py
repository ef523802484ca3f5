"""Lockstep copies are unwrapped, so the tools apply the wrapped env's limits and build copies from its inner env."""

import gymnasium as gym
import numpy as np

import antmaze_hirl  # noqa: F401 - registers the ids
from antmaze_hirl.dagger.evaluation import evaluation_outcomes
from antmaze_hirl.envs.controllers import PointGoToController
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.rollout import release_copies
from antmaze_hirl.sb3_ext.evaluation import reach_outcomes


def test_lockstep_evaluation_stops_at_the_spec_time_limit_as_serial_does():
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0", max_episode_steps=2)
    oracle = PathOracle.for_env(env)
    serial = [info["attempts"] for _, info in evaluation_outcomes(oracle, env, episodes=4, seed=0)]
    lockstep = [info["attempts"] for _, info in evaluation_outcomes(oracle, env, episodes=4, seed=0, num_envs=3)]
    release_copies(env)
    env.close()
    assert serial == lockstep
    assert max(lockstep) == 2  # the oracle needs more than 2 subgoals on these mazes: the limit cut them


def test_lockstep_reach_evaluation_takes_a_gym_make_env():
    env = gym.make("antmaze_hirl/PointReach-v0")
    controller = PointGoToController()
    serial = reach_outcomes(controller, env, episodes=4, seed=3)
    lockstep = reach_outcomes(controller, env, episodes=4, seed=3, num_envs=2)
    env.close()
    assert serial == lockstep
    assert all(steps is None or isinstance(steps, (int, np.integer)) for steps in lockstep)
