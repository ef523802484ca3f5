"""The benchmark suites: fixed task lists (checksums), held out under the 8 symmetries, and their registered ids."""

import functools
import json
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from antmaze_hirl.envs import suites
from antmaze_hirl.envs.high_level import DEFAULT_MIN_GOAL_CELLS
from antmaze_hirl.envs.layout_splits import sample_layout_in_split, wall_grid_split
from antmaze_hirl.envs.layouts import (
    SQUARE_SYMMETRIES,
    canonical_task,
    canonical_wall_grid,
    generate_layout,
    transform_wall_grid,
    validate_maze_map,
)
from antmaze_hirl.envs.suite_specs import SUITE_ENTRY_POINT, SUITE_SPECS, check_suite_name
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.registration import ENV_IDS
from tests.test_envs import assert_same, rollout
from tests.test_layers import LAYER, unit_of

RANDOM_SUITES = [name for name, spec in SUITE_SPECS.items() if spec.source == "random"]
FIXED_SUITES = [name for name, spec in SUITE_SPECS.items() if spec.source != "random"]


def family_sampler(maze_size):
    return functools.partial(
        generate_layout,
        n_rows=maze_size,
        n_cols=maze_size,
        wall_fraction=suites.WALL_FRACTION,
        min_goal_cells=DEFAULT_MIN_GOAL_CELLS,
    )


def test_the_committed_task_file_is_what_the_generator_draws_byte_for_byte():
    committed = suites.resources.files("antmaze_hirl.envs").joinpath(suites.SUITES_FILE).read_text()
    assert suites.suites_file_text() == committed


@pytest.mark.parametrize("name", list(SUITE_SPECS))
def test_every_suite_loads_with_its_documented_checksum_size_and_step_limit(name):
    spec = SUITE_SPECS[name]
    tasks = suites.suite_tasks(name)
    assert len(tasks) == spec.n_tasks
    assert suites.tasks_checksum(list(tasks)) == spec.checksum
    assert max(task.max_low_level_steps for task in tasks) == spec.max_low_level_steps
    assert len({task.layout.walls.shape for task in tasks}) == 1  # one maze shape, so one observation shape


def test_an_edited_task_list_is_refused_naming_the_suite(monkeypatch):
    stored = json.loads(json.dumps(suites._stored_suites()))
    stored["point5"]["tasks"][0]["goal_cell"] = stored["point5"]["tasks"][1]["goal_cell"]
    stored["point5"]["tasks"][0]["start_cell"] = stored["point5"]["tasks"][1]["start_cell"]
    stored["point5"]["tasks"][0]["walls"] = stored["point5"]["tasks"][1]["walls"]
    monkeypatch.setattr(suites, "_stored_suites", lambda: stored)
    with pytest.raises(ValueError, match=r"suite 'point5' has 100 tasks with checksum .* edited or damaged"):
        suites.suite_tasks.__wrapped__("point5")


@pytest.mark.parametrize("name", RANDOM_SUITES)
def test_random_family_tasks_are_held_out_under_all_eight_symmetries_and_distinct(name):
    tasks = suites.suite_tasks(name)
    for task in tasks:
        for k, flip in SQUARE_SYMMETRIES:
            assert wall_grid_split(transform_wall_grid(task.layout.walls, k, flip)) == "eval"
    assert len({canonical_task(task.layout) for task in tasks}) == len(tasks)
    # Against the family's own training part, drawn as a learner would draw it: no shared grid up to symmetry.
    suite_grids = {canonical_wall_grid(task.layout.walls) for task in tasks}
    rng = np.random.default_rng(0)
    sampler = family_sampler(SUITE_SPECS[name].maze_size)
    for _ in range(300):
        assert canonical_wall_grid(sample_layout_in_split(sampler, rng, "train").walls) not in suite_grids


@pytest.mark.parametrize("name", FIXED_SUITES)
def test_fixed_maps_are_grids_no_random_family_draws(name):
    walls = validate_maze_map(suites.fixed_map(SUITE_SPECS[name]))
    grid = canonical_wall_grid(walls)
    rng = np.random.default_rng(1)
    for maze_size in (3, 4, 5):
        sampler = family_sampler(maze_size)
        for _ in range(300):
            assert canonical_wall_grid(sampler(rng).walls) != grid
    if name == "u":  # the one map of a family's shape (3x3): U has 2 interior walls, the family places 3
        assert int(walls[1:-1, 1:-1].sum()) == 2
        assert all(int(family_sampler(3)(rng).walls[1:-1, 1:-1].sum()) == 3 for _ in range(200))


def test_medium_and_large_are_ogbenchs_navigate_tasks():
    assert suites.FIXED_MAP_TASKS["medium"][0] == ((1, 1), (6, 6))
    assert suites.FIXED_MAP_TASKS["large"][0] == ((1, 1), (7, 10))
    for name in FIXED_SUITES:  # the point's suites carry the same tasks as the ant's on the same map
        source = SUITE_SPECS[name].source
        assert [(t.layout.start_cell, t.layout.goal_cell) for t in suites.suite_tasks(name)] == suites.FIXED_MAP_TASKS[
            source
        ]


def test_every_suite_id_is_registered_with_its_step_limit_and_entry_point_below_the_registration():
    assert LAYER[unit_of(SUITE_ENTRY_POINT.split(":")[0])] < LAYER["registration"]
    for spec in SUITE_SPECS.values():
        registered = gym.spec(spec.env_id)
        assert registered.max_episode_steps == -(-spec.max_low_level_steps // 5)
        assert registered.max_episode_steps * 5 >= max(t.max_low_level_steps for t in suites.suite_tasks(spec.name))
        assert registered.kwargs == {"suite": spec.name}
        assert spec.env_id not in ENV_IDS  # the plain ids are untouched


def test_an_unknown_suite_is_one_line_naming_the_value_and_the_choices():
    with pytest.raises(ValueError, match=r"^unknown benchmark suite 'giant2'; choose one of \['point5'"):
        check_suite_name("giant2")


@pytest.mark.parametrize("name", list(SUITE_SPECS))
def test_suite_ids_pass_gymnasiums_checker(name, still_controller):
    # The ant ids drive a zero-torque controller: the checker's steps then cost no network forwards.
    low_level = still_controller if SUITE_SPECS[name].body == "ant" else None
    env = gym.make(SUITE_SPECS[name].env_id, low_level=low_level)
    check_env(env.unwrapped, skip_render_check=True)
    rows, cols = suites.suite_tasks(name)[0].layout.walls.shape
    assert env.observation_space["image"].shape == (3, rows * 8, cols * 8)
    env.close()


def test_the_shipped_ant_low_level_plugs_into_every_ant_suite():
    for name in ("ant4", "large"):
        env = gym.make(SUITE_SPECS[name].env_id)
        assert type(env.unwrapped.controller).__name__ == "ShippedPolicyController"
        env.close()


def play(env, policy, seed, task_id):
    obs, info = env.reset(seed=seed, options={"task_id": task_id})
    trace, done = [obs["state"].copy()], False
    while not done:
        obs, _reward, terminated, truncated, info = env.step(policy(obs))
        trace.append(obs["state"].copy())
        done = terminated or truncated
    return np.array(trace), info


def test_task_id_selects_the_task_and_a_plain_reset_draws_one_with_np_random():
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    inner = env.unwrapped
    for task_id in (0, 57, 99):
        _obs, info = env.reset(seed=0, options={"task_id": task_id})
        task = suites.suite_tasks("point5")[task_id]
        assert info["task_id"] == task_id and inner.layout == task.layout
        assert inner.geometry.xy_to_cell(inner.agent_xy) == task.layout.start_cell
        assert inner.geometry.xy_to_cell(inner.goal_xy) == task.layout.goal_cell
    drawn = [env.reset(seed=seed)[1]["task_id"] for seed in range(10)]  # each new layout compiles a model
    assert drawn == [env.reset(seed=seed)[1]["task_id"] for seed in range(10)]
    assert len(set(drawn)) > 5


@pytest.mark.parametrize("bad", [-1, 100])
def test_a_task_id_out_of_range_is_one_line_naming_the_value_and_the_range(bad):
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    with pytest.raises(ValueError, match=rf"^task_id {bad!r} is out of range for suite 'point5': .* \[0, 99\]$"):
        env.reset(options={"task_id": bad})


@pytest.mark.parametrize("bad", [1.5, True, "3", None])
def test_a_task_id_that_is_no_integer_is_one_line_naming_the_value_and_its_type(bad):
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    kind = type(bad).__name__
    with pytest.raises(ValueError, match=rf"^task_id {bad!r} is not an integer \({kind}\); .* in \[0, 99\]$"):
        env.reset(options={"task_id": bad})


def test_other_reset_options_are_refused_since_tasks_are_fixed():
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    with pytest.raises(ValueError, match=r"takes only options\['task_id'\], got \['layout'\]"):
        env.reset(options={"task_id": 0, "layout": None})


def test_seeded_episodes_are_deterministic_and_survive_pickling():
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    oracle = PathOracle.for_env(env)
    first, info = play(env, oracle, seed=5, task_id=3)
    again, _ = play(gym.make("antmaze_hirl/PointMaze-5x5-v0"), oracle, seed=5, task_id=3)
    np.testing.assert_array_equal(first, again)
    clone = pickle.loads(pickle.dumps(env))
    np.testing.assert_array_equal(play(clone, oracle, seed=5, task_id=3)[0], first)
    other, _ = play(env, oracle, seed=6, task_id=3)
    assert not np.array_equal(other, first)  # start and goal noise follow the seed
    assert not np.array_equal(other[0], first[0])
    assert info["is_success"]


def test_the_time_limit_is_in_subgoals_and_the_low_level_budget_is_the_tasks():
    env = gym.make("antmaze_hirl/AntMaze-large-v0", low_level=lambda obs: np.zeros(8))
    for task_id, task in enumerate(suites.suite_tasks("large")):
        env.reset(seed=0, options={"task_id": task_id})
        assert env.unwrapped.max_steps == task.max_low_level_steps
    assert env.spec.max_episode_steps == 608
    env.close()


@pytest.mark.parametrize("task_id", range(0, 100, 10))
def test_the_oracle_solves_point_tasks(task_id):
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    _, info = play(env, PathOracle.for_env(env), seed=task_id, task_id=task_id)
    assert info["is_success"], info


@pytest.mark.slow
def test_the_oracle_solves_every_point_task():
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    oracle = PathOracle.for_env(env)
    failed = [k for k in range(100) if not play(env, oracle, seed=k, task_id=k)[1]["is_success"]]
    assert failed == []


@pytest.mark.parametrize("name", list(SUITE_SPECS))
def test_every_suite_id_is_deterministic_and_pickles(name, still_controller):
    low_level = still_controller if SUITE_SPECS[name].body == "ant" else None
    env = gym.make(SUITE_SPECS[name].env_id, low_level=low_level)
    # test_envs' seeded rollout: a plain reset, so the task too is drawn from the seed.
    first = rollout(env, seed=7)
    assert_same(first, rollout(gym.make(SUITE_SPECS[name].env_id, low_level=low_level), seed=7))
    assert_same(first, rollout(pickle.loads(pickle.dumps(env)), seed=7))
    env.close()
