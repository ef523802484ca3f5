"""Vector envs: Gymnasium's sync/async modes and the native lockstep vector env, batched controllers, threads."""

from __future__ import annotations

import multiprocessing
import warnings

import gymnasium as gym
import numpy as np
import pytest
import torch as th

import antmaze_hirl  # noqa: F401  (registers the ids)
from antmaze_hirl.dagger import HighLevelPolicy
from antmaze_hirl.dagger.evaluation import evaluate_high_level, evaluation_episodes
from antmaze_hirl.envs.controllers import (
    PointGoToController,
    PredictController,
    SmoothedController,
    as_batch_controller,
    inference_threads,
)
from antmaze_hirl.envs.high_level import AgentPath, HighLevelMazeEnv
from antmaze_hirl.envs.vector import HighLevelVectorEnv
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.registration import ENV_IDS
from antmaze_hirl.rollout import play_episode
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy

MAZE_IDS = ("antmaze_hirl/PointMaze-v0", "antmaze_hirl/AntMaze-v0")
SMALL = {"antmaze_hirl/AntMaze-v0": {"maze_size": 3}}  # the ant's smallest mazes: cheaper episodes


def goal_batch(rng: np.random.Generator, rows: int, observation_dim: int) -> dict[str, np.ndarray]:
    return {
        "observation": rng.standard_normal((rows, observation_dim)),
        "achieved_goal": rng.uniform(-4, 4, (rows, 2)),
        "desired_goal": rng.uniform(-4, 4, (rows, 2)),
    }


def rows_of(batch: dict[str, np.ndarray]) -> list[dict[str, np.ndarray]]:
    return [{key: value[index] for key, value in batch.items()} for index in range(len(batch["observation"]))]


@pytest.fixture
def two_threads():
    previous = th.get_num_threads()
    th.set_num_threads(2)
    yield
    th.set_num_threads(previous)


def test_inference_threads_is_scoped_and_restores_the_global_setting(two_threads):
    with inference_threads(4):
        assert th.get_num_threads() == 1
    assert th.get_num_threads() == 2
    with inference_threads(10_000):  # a large batch keeps the caller's threads
        assert th.get_num_threads() == 2
    controller = PredictController(load_shipped_policy("point"))
    obs = rows_of(goal_batch(np.random.default_rng(0), 1, 2))[0]
    controller(obs)
    controller.act_batch(goal_batch(np.random.default_rng(0), 3, 2))
    assert th.get_num_threads() == 2


@pytest.mark.parametrize(("body", "observation_dim"), [("point", 2), ("ant", 27)])
def test_batched_predict_equals_one_row_at_a_time(body, observation_dim):
    controller = PredictController(load_shipped_policy(body))  # the ant's is the seven-head batched ensemble
    batch = goal_batch(np.random.default_rng(1), 16, observation_dim)
    batched = as_batch_controller(controller, 16)(batch, np.arange(16))
    one_by_one = np.stack([controller(row) for row in rows_of(batch)])
    assert batched.shape == (16, 8 if body == "ant" else 2)
    np.testing.assert_allclose(batched, one_by_one, rtol=0, atol=1e-4)  # float32 rounding only


def test_point_go_to_batch_is_exact():
    controller = PointGoToController()
    batch = goal_batch(np.random.default_rng(2), 5, 2)
    assert np.array_equal(controller.act_batch(batch), np.stack([controller(row) for row in rows_of(batch)]))


def test_smoothed_batch_keeps_state_per_sub_env():
    inner = PointGoToController()
    batch = as_batch_controller(SmoothedController(inner, 0.5), 3)
    serial = [SmoothedController(inner, 0.5) for _ in range(3)]
    rng = np.random.default_rng(3)
    for step in range(4):
        active = np.array([0, 2]) if step % 2 else np.arange(3)  # sub-env 1 waits every other step
        obs = goal_batch(rng, len(active), 2)
        expected = np.stack([serial[index](row) for index, row in zip(active, rows_of(obs), strict=True)])
        assert np.array_equal(batch(obs, active), expected)
    batch.reset(0)
    serial[0].reset()
    obs = goal_batch(rng, 3, 2)
    assert np.array_equal(batch(obs, np.arange(3)), np.stack([c(r) for c, r in zip(serial, rows_of(obs), strict=True)]))


def test_a_plain_callable_loops_with_one_warning():
    def plain(observation):
        return np.clip(observation["desired_goal"] - observation["achieved_goal"], -1, 1)

    with pytest.warns(UserWarning, match="has no act_batch"):
        batch = as_batch_controller(plain, 2)
    obs = goal_batch(np.random.default_rng(4), 2, 2)
    assert np.array_equal(batch(obs, np.arange(2)), np.stack([plain(row) for row in rows_of(obs)]))


@pytest.mark.parametrize("num_envs", [0, -1, 1.5, True])
def test_num_envs_below_one_is_a_one_line_error(num_envs):
    with pytest.raises(ValueError, match=r"num_envs must be an integer >= 1, got"):
        gym.make_vec("antmaze_hirl/PointMaze-v0", num_envs=num_envs, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match=r"num_envs must be an integer >= 1, got"):
        as_batch_controller(PointGoToController(), num_envs)


def random_subgoals(env: gym.vector.VectorEnv, rng: np.random.Generator) -> np.ndarray:
    space = env.single_action_space
    return rng.uniform(space.low, space.high, size=(env.num_envs, *space.shape)).astype(np.float32)


def run_a_few_steps(env: gym.vector.VectorEnv, steps: int) -> None:
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    for _ in range(steps):
        if env.single_action_space.shape == (2,) and "image" in env.single_observation_space.spaces:
            action = random_subgoals(env, rng)
        else:
            action = env.action_space.sample()
        obs, rewards, terminated, truncated, infos = env.step(action)
        assert obs["observation" if "observation" in obs else "state"].shape[0] == 3
        assert rewards.shape == terminated.shape == truncated.shape == (3,)
    if "agent_path" in infos:  # variable-length paths, one object per sub-env
        assert infos["agent_path"].dtype == object and isinstance(infos["agent_path"][0], AgentPath)


def assert_no_live_workers() -> None:
    assert [child for child in multiprocessing.active_children() if child.is_alive()] == []


VECTOR_MODES = {
    "sync": ("sync", {}),
    "async-fork": ("async", {}),  # the default context on Linux
    "async-spawn": ("async", {"context": "spawn"}),
    "native": ("vector_entry_point", {}),
}


def vector_cases() -> list:
    # A spawned maze worker imports torch and loads the shipped policy afresh (about 45 s for three on two
    # cores): those two cases are marked slow. A spawned reach worker starts a fresh interpreter too (about
    # 5 s): integration. Every other id and mode runs in the unit tier.
    cases = []
    for env_id in sorted(ENV_IDS):
        for name, (mode, vector_kwargs) in VECTOR_MODES.items():
            spawned = name == "async-spawn"
            marks = [pytest.mark.slow if env_id in MAZE_IDS else pytest.mark.integration] if spawned else []
            cases.append(pytest.param(env_id, mode, vector_kwargs, id=f"{name}-{env_id}", marks=marks))
    return cases


@pytest.mark.parametrize(("env_id", "mode", "vector_kwargs"), vector_cases())
def test_every_id_runs_in_every_vector_mode(env_id, mode, vector_kwargs):
    steps = 1 if "Ant" in env_id else 3
    env = gym.make_vec(env_id, 3, vectorization_mode=mode, vector_kwargs=vector_kwargs, **SMALL.get(env_id, {}))
    try:
        run_a_few_steps(env, steps)
    finally:
        env.close()
    if mode == "async":
        assert all(not process.is_alive() for process in env.processes)
    assert_no_live_workers()


def test_make_vec_defaults_to_the_native_lockstep_env():
    env = gym.make_vec("antmaze_hirl/PointMaze-v0", 2)
    assert isinstance(env, HighLevelVectorEnv)
    assert env.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    env.close()


def oracle_actions(oracle: PathOracle, obs: dict[str, np.ndarray], num_envs: int) -> np.ndarray:
    return np.stack([oracle({key: value[index] for key, value in obs.items()}) for index in range(num_envs)])


def test_native_sub_envs_play_the_serial_episodes_with_a_row_by_row_controller():
    # PointGoToController batches elementwise, so the lockstep episodes must equal the serial ones exactly.
    seeds = [5, 6, 7]
    serial_env = HighLevelMazeEnv("point", low_level=PointGoToController(), maze_size=4)
    oracle = PathOracle.for_env(serial_env)
    serial = [play_episode(serial_env, oracle, seed=seed) for seed in seeds]
    vector = gym.make_vec(
        "antmaze_hirl/PointMaze-v0",
        3,
        vectorization_mode="vector_entry_point",
        low_level=PointGoToController(),
        maze_size=4,
        autoreset_mode="Disabled",
    )
    obs, _ = vector.reset(seed=seeds)
    paths: list[list[np.ndarray]] = [[] for _ in seeds]
    done = np.zeros(3, dtype=bool)
    last: dict[int, tuple] = {}
    while not done.all():
        obs, _, terminated, truncated, infos = vector.step(oracle_actions(oracle, obs, 3))
        for index in np.flatnonzero(~done):
            paths[index].append(np.asarray(infos["agent_path"][index]))
            last[index] = (bool(infos["is_success"][index]), int(infos["attempts"][index]))
        done |= terminated | truncated
    vector.close()
    for index, episode in enumerate(serial):
        assert np.array_equal(np.concatenate(paths[index]), episode.path)
        assert last[index] == (episode.success, episode.info["attempts"])


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_native_autoreset_follows_gymnasiums_modes(mode):
    env = gym.make_vec(
        "antmaze_hirl/PointMaze-v0", 2, low_level=PointGoToController(), max_steps=20, autoreset_mode=mode
    )
    obs, _ = env.reset(seed=1)
    oracle = PathOracle.for_env(env.envs[0])
    ended, first = False, -1
    for _ in range(30):
        obs, rewards, terminated, truncated, infos = env.step(oracle_actions(oracle, obs, 2))
        if ended:  # the step after an episode ended
            if mode == "NextStep":
                assert rewards[first] == 0 and not terminated[first] and not truncated[first]
                assert infos["attempts"][first] == 0  # the reset info of the new episode
            break
        if (terminated | truncated).any():
            first = int(np.flatnonzero(terminated | truncated)[0])
            ended = True
            if mode == "SameStep":
                assert infos["_final_obs"][first] and infos["final_info"]["attempts"][first] >= 1
    assert ended
    env.close()


def test_a_bad_subgoal_moves_no_sub_env():
    env = gym.make_vec("antmaze_hirl/PointMaze-v0", 2, low_level=PointGoToController())
    env.reset(seed=0)
    before = [inner.agent_xy.copy() for inner in env.envs]
    actions = np.zeros((2, 2), dtype=np.float32)
    actions[1] = np.nan
    with pytest.raises(ValueError, match="subgoal must be finite"):
        env.step(actions)
    assert all(np.array_equal(inner.agent_xy, xy) for inner, xy in zip(env.envs, before, strict=True))
    assert all(inner.attempts == 0 for inner in env.envs)
    env.close()


def test_sub_envs_with_their_own_controllers_warn_and_still_step():
    envs = [HighLevelMazeEnv("point", low_level=PointGoToController()) for _ in range(2)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vector = HighLevelVectorEnv(envs)
    assert any("controllers of their own" in str(warning.message) for warning in caught)
    obs, _ = vector.reset(seed=0)
    vector.step(oracle_actions(PathOracle.for_env(envs[0]), obs, 2))
    vector.close()


def test_lockstep_evaluation_plays_the_serial_episodes():
    # PointGoToController acts elementwise and the oracle row by row: lockstep must replay serial exactly.
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, min_goal_cells=2, low_level=PointGoToController())
    oracle = PathOracle.for_env(env)
    serial = evaluation_episodes(oracle, env, episodes=7, seed=100)
    lockstep = evaluation_episodes(oracle, env, episodes=7, seed=100, num_envs=3)  # 3 does not divide 7
    fields = ("is_success", "attempts", "total_low_level_steps", "flipped")
    assert [[info[key] for key in fields] for info in lockstep] == [[info[key] for key in fields] for info in serial]
    assert evaluate_high_level(oracle, env, episodes=7, seed=100, num_envs=3) == evaluate_high_level(
        oracle, env, episodes=7, seed=100
    )
    env.close()


def test_lockstep_evaluation_batches_a_learner():
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, min_goal_cells=2, low_level=PointGoToController())
    policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0))
    calls = []
    original = policy.predict_batch

    def counted(observations):
        calls.append(len(observations))
        return original(observations)

    policy.predict_batch = counted
    lockstep = evaluate_high_level(policy, env, episodes=6, seed=200, num_envs=6)
    assert calls and calls[0] == 6  # one batch for all six mazes at their first subgoal
    del policy.predict_batch
    assert lockstep == evaluate_high_level(policy, env, episodes=6, seed=200)
    env.close()


@pytest.mark.parametrize("num_envs", [0, 2.0])
def test_evaluation_num_envs_is_checked(num_envs):
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, low_level=PointGoToController())
    with pytest.raises(ValueError, match="num_envs must be an integer >= 1"):
        evaluate_high_level(PathOracle.for_env(env), env, episodes=2, num_envs=num_envs)
    env.close()


def test_sb3_trains_on_the_lockstep_env_through_the_adapter():
    from stable_baselines3 import PPO

    from antmaze_hirl.sb3_ext.vec_env import GymnasiumVecEnv, make_sb3_vec_env

    venv = make_sb3_vec_env(
        "antmaze_hirl/PointMaze-v0", 2, maze_size=3, max_steps=60, clip_subgoals=True, low_level=PointGoToController()
    )
    obs = venv.reset()
    assert obs["state"].shape[0] == 2
    dones_seen = []
    for _ in range(12):
        obs, _, dones, infos = venv.step(np.stack([venv.action_space.sample() for _ in range(2)]))
        for index in np.flatnonzero(dones):
            dones_seen.append(index)
            assert "terminal_observation" in infos[index] and "is_success" in infos[index]
    assert dones_seen  # 60 low-level steps end an episode within a few subgoals
    PPO("MultiInputPolicy", venv, n_steps=8, batch_size=8, n_epochs=1, seed=0).learn(16)
    venv.close()
    with pytest.raises(ValueError, match="autoreset_mode 'SameStep'"):
        GymnasiumVecEnv(gym.make_vec("antmaze_hirl/PointMaze-v0", 2, low_level=PointGoToController()))
