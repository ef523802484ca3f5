"""Every registered id vectorizes natively; the SB3 helper seeds, monitors and (opt-in) normalises actions."""

from __future__ import annotations

import csv
import threading
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import SyncVectorEnv
from stable_baselines3.common.env_checker import check_env

import antmaze_hirl  # noqa: F401  (registers the ids)
from antmaze_hirl.envs.controllers import PointGoToController
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.envs.vector import HighLevelVectorEnv
from antmaze_hirl.sb3_ext.vec_env import make_sb3_vec_env

REGISTERED_IDS = sorted(env_id for env_id in gym.registry if env_id.startswith("antmaze_hirl/"))
REACH_IDS = {"antmaze_hirl/AntReach-v0", "antmaze_hirl/PointReach-v0"}
POINT_SUITE_ID = SUITE_SPECS["point5"].env_id


def test_the_fourteen_ids_are_registered():
    assert len(REGISTERED_IDS) == 14  # 4 env ids and 10 suites
    assert {spec.env_id for spec in SUITE_SPECS.values()} <= set(REGISTERED_IDS)


@pytest.mark.parametrize("env_id", REGISTERED_IDS)
def test_every_id_makes_its_native_vector_env(env_id):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    single = gym.make(env_id)
    try:
        assert isinstance(envs.unwrapped, SyncVectorEnv if env_id in REACH_IDS else HighLevelVectorEnv)
        assert envs.single_observation_space == single.observation_space
        assert envs.single_action_space == single.action_space
        if env_id not in REACH_IDS:  # a registered step limit reaches the vector env, as gym.make's TimeLimit
            assert envs.unwrapped.max_episode_steps == gym.spec(env_id).max_episode_steps
        obs, _ = envs.reset(seed=7)
        first, _ = single.reset(seed=7)
        for key, value in first.items():  # sub-env 0 is seeded 7 + 0: the single env's episode
            np.testing.assert_array_equal(obs[key][0], value)
        envs.action_space.seed(0)
        obs, rewards, terminated, truncated, _ = envs.step(envs.action_space.sample())
        assert rewards.shape == terminated.shape == truncated.shape == (2,)
        assert envs.observation_space.contains(obs)
    finally:
        envs.close()
        single.close()


def test_a_suite_vector_env_truncates_at_its_step_limit_like_time_limit():
    kwargs = {"low_level": PointGoToController(), "max_episode_steps": 2}
    envs = gym.make_vec(POINT_SUITE_ID, num_envs=3, autoreset_mode="SameStep", **kwargs)
    single = gym.make(POINT_SUITE_ID, **kwargs)
    envs.reset(seed=0)
    single.reset(seed=0)
    centre = np.zeros((3, 2), dtype=np.float32)  # a subgoal in the maze's middle: no episode ends by success
    envs.step(centre)
    single.step(centre[0])
    *_, terminated, truncated, infos = envs.step(centre)
    *_, single_terminated, single_truncated, _ = single.step(centre[0])
    assert single_truncated and bool(truncated[0])
    assert bool(terminated[0]) == single_terminated
    assert truncated.all() and "final_obs" in infos  # SameStep: every sub-env reset within that step
    with pytest.raises(ValueError, match="max_episode_steps must be None or an integer >= 1, got 0"):
        gym.make_vec(POINT_SUITE_ID, num_envs=1, low_level=PointGoToController(), max_episode_steps=0)
    envs.close()
    single.close()


def small_point_venv(seed, **kwargs):
    settings = {"maze_size": 3, "max_steps": 60, "clip_subgoals": True, "low_level": PointGoToController()}
    return make_sb3_vec_env("antmaze_hirl/PointMaze-v0", 2, seed=seed, **settings, **kwargs)


def test_the_sb3_helper_with_a_seed_gives_the_same_first_observations_twice():
    first = [small_point_venv(123).reset() for _ in range(2)]
    other = small_point_venv(124).reset()
    for key in first[0]:
        np.testing.assert_array_equal(first[0][key], first[1][key])
    assert not all(np.array_equal(first[0][key], other[key]) for key in other)


def test_the_sb3_helper_logs_episode_reward_and_length(tmp_path):
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import configure

    venv = small_point_venv(0, monitor_dir=str(tmp_path / "monitor"))
    model = PPO("MultiInputPolicy", venv, n_steps=16, batch_size=16, n_epochs=1, seed=0)
    model.set_logger(configure(str(tmp_path / "log"), ["csv"]))
    model.learn(64)
    venv.close()
    with open(tmp_path / "log" / "progress.csv") as handle:
        rows = list(csv.DictReader(handle))
    logged = [row for row in rows if row.get("rollout/ep_rew_mean")]
    assert logged, f"no rollout/ep_rew_mean in {list(rows[0])}"
    assert float(logged[-1]["rollout/ep_len_mean"]) >= 1
    assert (tmp_path / "monitor" / "monitor.csv").read_text().count("\n") >= 3  # header lines + an episode


@pytest.mark.parametrize("env_id", ["antmaze_hirl/PointMaze-v0", POINT_SUITE_ID])
def test_normalised_actions_pass_check_env_without_warnings(env_id):
    env = gym.make(env_id, low_level=PointGoToController(), normalize_actions=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env)
    assert env.action_space == gym.spaces.Box(-1, 1, (2,), np.float32)
    env.close()
    plain = gym.make(env_id, low_level=PointGoToController())
    with pytest.warns(UserWarning, match="normalized Box action space"):
        check_env(plain)
    plain.close()


def test_a_normalised_subgoal_is_the_metres_one_rescaled_to_the_maze_edges():
    unit = gym.make("antmaze_hirl/PointMaze-v0", low_level=PointGoToController(), normalize_actions=True)
    metres = gym.make("antmaze_hirl/PointMaze-v0", low_level=PointGoToController())
    unit.reset(seed=3)
    metres.reset(seed=3)
    low, high = metres.action_space.low, metres.action_space.high
    subgoal_m = low + 0.3 * (high - low)
    obs_unit, *_ = unit.step(np.full(2, -0.4, dtype=np.float32))  # -1 + 2 * 0.3
    obs_metres, *_ = metres.step(subgoal_m.astype(np.float32))
    np.testing.assert_allclose(obs_unit["state"], obs_metres["state"], atol=1e-5)
    venv = small_point_venv(0, normalize_actions=True)
    assert venv.action_space == gym.spaces.Box(-1, 1, (2,), np.float32)
    assert len(venv.get_attr("body")) == 2  # the sub-envs are reached under the vector wrapper
    venv.close()


class LockedController(PointGoToController):
    """A low level holding a lock, as a model with a logger or a thread pool does: it cannot be deep-copied."""

    def __init__(self):
        super().__init__()
        self.lock = threading.Lock()


def test_ones_own_low_level_that_cannot_be_copied_plays_a_suite_in_lockstep_without_warnings():
    from antmaze_hirl.dagger import evaluate_high_level
    from antmaze_hirl.experiments.benchmark import score_policy
    from antmaze_hirl.experts.oracle import PathOracle

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # Gymnasium warned "cannot pickle '_thread.lock'" copying the spec
        report = score_policy("point5", "oracle", low_level=LockedController(), task_ids=[0, 1], num_envs=2)
        env = gym.make(POINT_SUITE_ID, low_level=LockedController())
        played = evaluate_high_level(PathOracle.for_env(env), env, episodes=2, num_envs=2)
    assert report["episodes"] == 2 and played["episodes"] == 2
    env.close()
