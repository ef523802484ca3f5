import gymnasium as gym
import numpy as np
import pytest

from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.high_level import STATE_AGENT_XY, STATE_GOAL_XY
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_hirl.experts import PathOracle, plan_subgoal


def solve(env, oracle, seed):
    obs, _ = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(oracle.label(obs))
        done = terminated or truncated
    return info


@pytest.mark.integration
@pytest.mark.parametrize("low_level", [PointGoToController(), None], ids=["scripted", "shipped-td3"])
def test_oracle_with_point_solves_random_mazes(low_level):
    env = gym.make("antmaze_hirl/PointMaze-v0", low_level=low_level)
    oracle = PathOracle.for_env(env)
    results = [solve(env, oracle, seed) for seed in range(40)]
    assert sum(info["is_success"] for info in results) >= 39
    assert all(info["total_low_level_steps"] <= 500 for info in results)


def test_oracle_subgoals_stay_within_the_reach_and_free_space():
    env = gym.make("antmaze_hirl/PointMaze-v0")
    oracle = PathOracle.for_env(env, subgoal_reach_m=0.7)
    inner = env.unwrapped
    for seed in range(10):
        obs, _ = env.reset(seed=seed)
        for _ in range(5):
            subgoal = oracle.label(obs)
            assert np.linalg.norm(subgoal - inner.agent_xy) <= 0.7 + 1e-5  # state is float32
            assert inner.geometry.segment_is_free(inner.layout.walls, inner.agent_xy, subgoal, oracle.clearance_m)
            obs, _, terminated, truncated, _ = env.step(subgoal)
            if terminated or truncated:
                break


def test_plan_subgoal_turns_corners_along_the_shortest_path():
    walls = validate_maze_map("u")  # free: top row, right column, bottom row
    geometry = MazeGeometry(*walls.shape, scale=1.0)
    start, goal = geometry.cell_to_xy((1, 1)), geometry.cell_to_xy((3, 1))
    subgoal = plan_subgoal(walls, geometry, start, goal, subgoal_reach_m=10.0, clearance_m=0.2)
    # The goal is 2 m straight down but behind a wall; the plan heads right, to the corner cell (1, 3).
    np.testing.assert_allclose(subgoal, geometry.cell_to_xy((1, 3)))
    short = plan_subgoal(walls, geometry, start, goal, subgoal_reach_m=0.5, clearance_m=0.2)
    np.testing.assert_allclose(short, start + np.array([0.5, 0.0]))


def test_oracle_reads_observations_not_env_state():
    env = gym.make("antmaze_hirl/PointMaze-v0")
    oracle = PathOracle.for_env(env)
    obs_a, _ = env.reset(seed=1)
    label_a = oracle.label(obs_a)
    obs_b, _ = env.reset(seed=2)  # another maze, start and goal: the env now holds maze b
    label_b = oracle.label(obs_b)
    assert np.linalg.norm(label_a - label_b) > 0.5  # the two observations do call for different labels
    np.testing.assert_array_equal(oracle.label(obs_a), label_a)  # a stored observation keeps its own label
    # An observation no env produced: maze b's walls with maze a's agent and goal. Its label is planned on
    # what the observation shows, whichever maze the env (or an earlier call) held.
    mixed = {"image": obs_b["image"], "state": obs_a["state"]}
    walls_b = oracle.renderer.walls_from_image(obs_b["image"])
    state = obs_a["state"].astype(np.float64)
    expected = plan_subgoal(
        walls_b,
        oracle.geometry,
        state[STATE_AGENT_XY],
        state[STATE_GOAL_XY],
        subgoal_reach_m=oracle.subgoal_reach_m,
        clearance_m=oracle.clearance_m,
    )
    np.testing.assert_allclose(oracle.label(mixed), expected)
    assert not np.allclose(expected, label_a), "maze b's walls must change a's plan, or this check proves nothing"
    np.testing.assert_array_equal(walls_b, env.unwrapped.layout.walls)  # the decoded walls are maze b's


def test_oracle_noise_is_seeded():
    env = gym.make("antmaze_hirl/PointMaze-v0")
    obs, _ = env.reset(seed=0)
    clean = PathOracle.for_env(env).label(obs)
    noisy = [PathOracle.for_env(env, noise_std_m=0.1, rng=np.random.default_rng(5)).label(obs) for _ in range(2)]
    np.testing.assert_array_equal(noisy[0], noisy[1])
    assert 0 < np.linalg.norm(noisy[0] - clean) < 0.6


def test_oracle_rejects_bad_settings():
    geometry = MazeGeometry(7, 7, 1.0)
    with pytest.raises(ValueError, match="noise_std_m must be >= 0"):
        PathOracle(geometry, noise_std_m=-1.0)
    with pytest.raises(ValueError, match="noise_std_m > 0 needs an explicit rng"):
        PathOracle(geometry, noise_std_m=0.1)
    with pytest.raises(ValueError, match="subgoal_reach_m must be > 0"):
        PathOracle(geometry, subgoal_reach_m=0.0)
