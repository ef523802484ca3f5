"""Training the low level in the setting the maze uses: random layouts, flip penalty (issue 16)."""

from pathlib import Path

import numpy as np
import pytest
from conftest import POINT_SUBGOALS_SEED_3, reset_subgoals

from antmaze_hirl.envs import ReachEnv
from antmaze_hirl.envs.layout_splits import wall_grid_split
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_hirl.envs.reach import flipped_flags
from antmaze_hirl.sb3_ext import load_config, make_model

ANT_MAZE_YML = Path(__file__).parents[1] / "scripts" / "configs" / "ant_maze.yml"


def walls_after_resets(env, resets):
    """The wall grid after each of ``resets`` plain resets (the env seeded already)."""
    walls = []
    for _ in range(resets):
        env.reset()
        walls.append(env.walls.copy())
    return walls


def flip(env):
    """Puts the ant on its back, at rest (torso above 0.2 m: only the orientation says it flipped)."""
    qpos = env.sim.data.qpos.copy()
    qpos[2], qpos[3:7] = 0.27, [0.0, 1.0, 0.0, 0.0]
    env.sim._mujoco_env.set_state(qpos, np.zeros_like(env.sim.data.qvel))


def test_maze_resets_draw_random_layouts_of_the_given_sizes_with_goals_in_sight():
    env = ReachEnv("point", maze_probability=1.0, maze_sizes=[2, np.int64(4)], sample_radius_m=3.0)
    env.reset(seed=0)
    shapes, layouts = set(), set()
    for _ in range(30):
        obs, _ = env.reset()
        shapes.add(env.walls.shape)
        layouts.add(env.walls.tobytes())
        geometry, start, goal = env.sim.geometry, obs["achieved_goal"], obs["desired_goal"]
        assert geometry.is_free(env.walls, start)
        assert geometry.segment_is_free(env.walls, start, goal)
        assert np.linalg.norm(goal - start) <= 3.0
    assert shapes == {(4, 4), (6, 6)}
    assert len(layouts) > 10
    assert env.render() is None  # the renderer follows the new geometry (rgb_array below)
    image = ReachEnv("point", maze_probability=1.0, maze_sizes=[4], render_mode="rgb_array")
    image.reset(seed=0)
    assert image.render().shape[:2] == image._renderer.rgb(image.walls, image.agent_xy, image.subgoal_xy).shape[:2]


def test_maze_resets_are_seeded_and_mix_with_the_base_map():
    first, second = (ReachEnv("point", maze_probability=0.5) for _ in range(2))
    open_walls = validate_maze_map("open")
    seen_open = seen_maze = False
    for seed in range(20):
        a, b = first.reset(seed=seed)[0], second.reset(seed=seed)[0]
        np.testing.assert_array_equal(first.walls, second.walls)
        np.testing.assert_array_equal(a["desired_goal"], b["desired_goal"])
        is_open = first.walls.shape == open_walls.shape and np.array_equal(first.walls, open_walls)
        seen_open, seen_maze = seen_open or is_open, seen_maze or not is_open
    assert seen_open and seen_maze


@pytest.mark.integration
def test_maze_split_draws_only_training_wall_grids_where_any_draw_would_not():
    def splits(**kwargs):
        env = ReachEnv("point", maze_probability=1.0, maze_sizes=[4], **kwargs)
        env.reset(seed=3)
        return [wall_grid_split(walls) for walls in walls_after_resets(env, 40)]

    assert set(splits(maze_split="train")) == {"train"}
    assert set(splits()) > {"train"}  # without the split, held-out wall grids come up in 40 draws


def test_mazes_off_keep_the_random_stream():
    np.testing.assert_allclose(
        reset_subgoals(ReachEnv("point", maze_probability=0.0)), POINT_SUBGOALS_SEED_3, rtol=1e-6
    )
    # The check can fail: mazes on at a chance that never gives one still take a draw per reset.
    assert not np.allclose(reset_subgoals(ReachEnv("point", maze_probability=1e-12)), POINT_SUBGOALS_SEED_3)


def test_chained_and_placed_resets_keep_the_current_walls():
    env = ReachEnv("point", maze_probability=1.0, maze_sizes=[5], chain_probability=1.0)
    env.reset(seed=1)
    walls = env.walls.copy()
    for _ in range(5):
        env.step(np.ones(2))
    moved_to = env.agent_xy
    obs, _ = env.reset()  # chains: same walls, same body
    np.testing.assert_array_equal(env.walls, walls)
    np.testing.assert_array_equal(obs["achieved_goal"], moved_to)
    free = env.sim.geometry.cell_to_xy(np.argwhere(~walls)[0])
    env.reset(seed=2, options={"start_xy": free})  # a given start lies in the walls it was chosen for
    np.testing.assert_array_equal(env.walls, walls)
    np.testing.assert_array_equal(env.agent_xy, free)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"maze_probability": 1.5}, r"maze_probability must lie in \[0, 1\], got 1.5"),
        ({"maze_sizes": []}, r"maze_sizes must be a non-empty list of integers >= 2, got \[\]"),
        ({"maze_sizes": [3, 1]}, r"maze_sizes must be .* got \[3, 1\]"),
        ({"maze_sizes": [2.5]}, r"maze_sizes must be .* got \[2.5\]"),
        ({"maze_sizes": [True]}, r"maze_sizes must be .* got \[True\]"),
        ({"maze_wall_fraction": 1.0}, r"maze_wall_fraction must lie in \[0, 1\), got 1.0"),
        ({"flip_penalty": -0.5}, "flip_penalty must be >= 0, got -0.5"),
        ({"tilt_penalty": -1.0}, "tilt_penalty must be >= 0, got -1.0"),
        ({"tilt_penalty": float("nan")}, "tilt_penalty must be >= 0, got nan"),
        ({"upright_threshold": -1.0}, r"upright_threshold must lie in \(-1, 1\], got -1.0"),
        ({"upright_threshold": 1.5}, r"upright_threshold must lie in \(-1, 1\], got 1.5"),
        ({"maze_split": "test"}, "unknown layout split 'test'"),
    ],
)
def test_maze_training_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ReachEnv("point", **kwargs)


def test_flip_penalty_costs_the_flip_step_and_reaches_her_batches():
    env = ReachEnv("ant", terminate_on_flip=True, flip_penalty=1.0)
    env.reset(seed=0)
    _, reward, terminated, _, info = env.step(np.zeros(8))
    assert (reward, terminated, info["flipped"]) == (0.0, False, False)
    flip(env)
    _, reward, terminated, _, info = env.step(np.zeros(8))
    assert (reward, terminated, info["flipped"]) == (-1.0, True, True)
    # HER: a batch of goals with the stored infos (an object array when SB3 copies them).
    achieved, desired = np.zeros((3, 2)), np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 0.0]])
    infos = np.array([{"flipped": True}, {"flipped": False}, {}])
    np.testing.assert_array_equal(env.compute_reward(achieved, desired, infos), [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(env.compute_reward(achieved, desired, [{}, {"flipped": True}, {}]), [1.0, -1.0, 0.0])
    unpenalised = ReachEnv("ant", terminate_on_flip=True)
    unpenalised.reset(seed=0)
    flip(unpenalised)
    assert unpenalised.step(np.zeros(8))[1] == 0.0


@pytest.mark.parametrize(
    ("info", "message"),
    [
        ("flipped", "info must be a dict or a sequence of dicts, got str: 'flipped'"),
        ([{}, 3], r"info must be a dict or a sequence of dicts, got list: \[\{\}, 3\]"),
        ([{}, {}], r"info holds 2 dicts for 3 rewards of shape \(3,\)"),
    ],
)
def test_flipped_flags_bad_info(info, message):
    with pytest.raises(ValueError, match=message):
        flipped_flags(info, (3,))


def test_the_committed_maze_config_loads_and_trains_in_mazes():
    config = load_config("ant", ANT_MAZE_YML)
    env = ReachEnv("ant", **config.env_kwargs)
    assert env.maze_probability > 0 and env.flip_penalty > 0 and env.chain_probability >= 0.5
    env.reset(seed=0)
    shapes = {walls.shape for walls in walls_after_resets(env, 20)}
    assert len(shapes) > 1


def test_the_sac_maze_config_trains_in_the_same_setting_with_the_flip_penalty_relabelled():
    sac = load_config("ant", ANT_MAZE_YML.with_name("ant_maze_sac.yml"), algo="sac")
    assert sac.env_kwargs == load_config("ant", ANT_MAZE_YML).env_kwargs and sac.action_l2 == 0.0
    model = make_model("ant", "sac", sac.replace(buffer_size=1000), seed=0)
    assert model.replay_buffer.copy_info_dict and model.action_noise is None


def tilt(env, degrees):
    """Rolls the ant about x by ``degrees``, at rest, with its torso high enough not to count as flipped."""
    qpos = env.sim.data.qpos.copy()
    half = np.radians(degrees) / 2
    qpos[2], qpos[3:7] = 0.75, [np.cos(half), np.sin(half), 0.0, 0.0]
    env.sim._mujoco_env.set_state(qpos, np.zeros_like(env.sim.data.qvel))


def test_tilt_penalty_grows_below_the_upright_threshold_and_reaches_her_batches():
    env = ReachEnv("ant", tilt_penalty=2.0, upright_threshold=0.8)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.zeros(8))
    assert reward == 0.0 and info["uprightness"] > 0.8  # upright at rest: no penalty
    tilt(env, 90)  # on its side: uprightness 0, up to the step's own motion
    assert env.sim.uprightness == pytest.approx(0.0, abs=1e-12) and not env.sim.is_flipped
    _, reward, _, _, info = env.step(np.zeros(8))
    assert reward == pytest.approx(-2.0 * (0.8 - info["uprightness"])) and reward < -1.0
    # HER: the stored infos' uprightness is what counts; a missing entry counts as upright.
    achieved, desired = np.zeros((3, 2)), np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 0.0]])
    infos = np.array([{"uprightness": 0.3}, {"uprightness": 0.9}, {}])
    np.testing.assert_allclose(env.compute_reward(achieved, desired, infos), [1.0 - 1.0, 0.0, 0.0])
    plain = ReachEnv("ant")
    plain.reset(seed=0)
    tilt(plain, 90)
    assert plain.step(np.zeros(8))[1] == 0.0


@pytest.mark.parametrize(
    ("kwargs", "copies"), [({}, False), ({"tilt_penalty": 1.0}, True), ({"flip_penalty": 1.0}, True)]
)
def test_her_keeps_infos_for_either_penalty(kwargs, copies):
    config = load_config("ant").replace(buffer_size=1000, env_kwargs={"terminate_on_flip": True, **kwargs})
    assert make_model("ant", "td3", config, seed=0).replay_buffer.copy_info_dict is copies


@pytest.mark.parametrize(("penalty", "relabelled_reward"), [(0.0, 1.0), (1.0, 0.0)])
def test_her_relabelled_flip_steps_carry_the_penalty(penalty, relabelled_reward):
    config = load_config("ant").replace(
        buffer_size=100, env_kwargs={"terminate_on_flip": True, "flip_penalty": penalty}
    )
    model = make_model("ant", "td3", config, seed=0)
    buffer, dim = model.replay_buffer, model.observation_space["observation"].shape[0]

    def obs(x):
        return {"observation": np.full((1, dim), x), "achieved_goal": [[x, 0.0]], "desired_goal": [[9.0, 9.0]]}

    # One 3-step episode that ends in a flip; "future" relabelling of the flip step can only pick its own
    # next achieved goal, so its relabelled reward is 1 (reached) minus the penalty.
    for step in range(3):
        flipped = step == 2
        buffer.add(obs(step), obs(step + 1), np.zeros((1, 8)), np.zeros(1), np.array([flipped]), [{"flipped": flipped}])
    batch = buffer.sample(400, env=None)
    is_flip_step = batch.observations["achieved_goal"][:, 0].numpy() == 2.0
    relabelled = batch.observations["desired_goal"][:, 0].numpy() == 3.0
    rewards = batch.rewards[:, 0].numpy()[is_flip_step & relabelled]
    assert len(rewards) > 0
    np.testing.assert_array_equal(rewards, relabelled_reward)


def test_the_held_out_maze_config_trains_only_on_training_wall_grids_of_other_sizes_than_ant3():
    config = load_config("ant", ANT_MAZE_YML.with_name("ant_maze_held_out.yml"))
    env = ReachEnv("ant", **config.env_kwargs)
    env.reset(seed=0)
    mazes = walls_after_resets(env, 30)
    drawn = [walls for walls in mazes if walls.shape != env._base_walls.shape or (walls != env._base_walls).any()]
    assert drawn and {walls.shape for walls in drawn} <= {(6, 6), (7, 7)}  # 4x4 and 5x5 free cells, never 3x3
    assert {wall_grid_split(walls) for walls in drawn} == {"train"}


def test_the_smoothed_maze_config_is_the_maze_setting_with_smoothing_in_the_dynamics():
    smoothed = load_config("ant", ANT_MAZE_YML.with_name("ant_maze_smoothed.yml"))
    plain = load_config("ant", ANT_MAZE_YML)
    assert {**smoothed.env_kwargs, "action_smoothing": 0.0} == {**plain.env_kwargs, "action_smoothing": 0.0}
    assert ReachEnv("ant", **smoothed.env_kwargs).action_smoothing == 0.5
