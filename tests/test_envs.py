import os
import pickle

import gymnasium as gym
import numpy as np
import pytest
from conftest import POINT_SUBGOALS_SEED_3, StillController, reset_subgoals
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from antmaze_hirl.envs import HighLevelMazeEnv, PointGoToController, ReachEnv
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.registration import ENV_IDS
from antmaze_hirl.sb3_ext import shipped


def make(env_id, **kwargs):
    if env_id == "antmaze_hirl/AntMaze-v0":
        kwargs.setdefault("low_level", StillController())
    return gym.make(env_id, **kwargs)


def rollout(env, seed, steps=5):
    """Observations of a short seeded rollout; actions drawn from a seeded action space."""
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    trace = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        trace.append(obs)
        trace.append(reward)
        if terminated or truncated:
            break
    return trace


def assert_same(trace_a, trace_b):
    assert len(trace_a) == len(trace_b)
    for a, b in zip(trace_a, trace_b, strict=True):
        if isinstance(a, dict):
            for key in a:
                np.testing.assert_array_equal(a[key], b[key])
        else:
            assert a == b


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_registered_env_passes_gymnasium_and_sb3_checkers(env_id):
    env = make(env_id)
    gym_check_env(env.unwrapped, skip_render_check=False)
    sb3_check_env(env.unwrapped, warn=False)
    env.close()


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_seeded_rollouts_are_deterministic(env_id):
    first, second = make(env_id), make(env_id)
    assert_same(rollout(first, seed=3), rollout(second, seed=3))
    with pytest.raises(AssertionError):
        assert_same(rollout(first, seed=4), rollout(second, seed=3))


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_pickle_round_trip(env_id):
    env = make(env_id)
    clone = pickle.loads(pickle.dumps(env))
    assert_same(rollout(env, seed=11), rollout(clone, seed=11))


def test_maze_without_low_level_or_shipped_policy_says_what_to_pass(monkeypatch, tmp_path):
    monkeypatch.setattr(shipped, "shipped_policy_path", lambda body: tmp_path / f"{body}_td3.zip")
    with pytest.raises(ValueError, match=r"AntMaze-v0 needs a low-level controller: pass low_level="):
        gym.make("antmaze_hirl/AntMaze-v0")


def test_the_env_class_itself_requires_a_controller_and_names_what_to_pass():
    with pytest.raises(ValueError, match=r"needs a low-level controller: pass low_level=.*PointMaze-v0"):
        HighLevelMazeEnv("point")


def test_a_maze_made_without_low_level_drives_the_shipped_policy_and_pickles_without_its_weights():
    env = gym.make("antmaze_hirl/PointMaze-v0")
    controller = env.unwrapped.controller
    assert isinstance(controller, shipped.ShippedPolicyController)
    assert controller.model is shipped.load_shipped_policy("point")
    assert len(pickle.dumps(controller)) < 200  # the body name, not the networks
    assert pickle.loads(pickle.dumps(controller)).model is controller.model


def test_the_names_removed_in_0_2_0_are_errors():
    with pytest.raises(TypeError, match="min_goal_distance"):
        HighLevelMazeEnv("point", min_goal_distance=4, low_level=PointGoToController())
    env = HighLevelMazeEnv("point", min_goal_cells=4, low_level=PointGoToController())
    assert env.min_goal_cells == 4 and not hasattr(env, "min_goal_distance")
    env.close()
    reach = ReachEnv("point", maze_map="u")
    obs, _ = reach.reset(seed=0, options={"subgoal_xy": [1.0, 1.0]})
    np.testing.assert_array_equal(obs["desired_goal"], [1.0, 1.0])
    np.testing.assert_array_equal(reach.subgoal_xy, [1.0, 1.0])
    # Other keys are refused, not ignored: ignoring one would draw a random subgoal instead of the one given.
    for key in ("goal", "goal_xy", "subgoal"):
        message = rf"^ReachEnv's reset options are \['start_xy', 'subgoal_xy'\]: got options\['{key}'\]=\[1.0, 1.0\]$"
        with pytest.raises(ValueError, match=message):
            reach.reset(seed=0, options={key: [1.0, 1.0]})
    assert not hasattr(reach, "goal") and not hasattr(reach, "set_goal")
    reach.close()


RENAMED_KEYWORDS = [
    (ReachEnv, "goal_radius", "sample_radius_m"),
    (ReachEnv, "min_goal_distance", "min_sample_radius_m"),
    (ReachEnv, "distance_threshold", "success_radius_m"),
    (HighLevelMazeEnv, "goal_threshold", "success_radius_m"),
]


@pytest.mark.parametrize(("env_class", "old", "new"), RENAMED_KEYWORDS, ids=[old for _, old, _ in RENAMED_KEYWORDS])
def test_keywords_renamed_in_0_2_0_fail_with_a_type_error_naming_them(env_class, old, new):
    kwargs = {"low_level": PointGoToController()} if env_class is HighLevelMazeEnv else {}
    with pytest.raises(TypeError, match=old):
        env_class("point", **kwargs, **{old: 0.5})
    env = env_class("point", **kwargs, **{new: 0.5})
    assert getattr(env, new) == 0.5 and not hasattr(env, old)
    env.close()


@pytest.mark.parametrize("env_class", [ReachEnv, HighLevelMazeEnv])
def test_both_envs_default_to_the_point_body(env_class):
    kwargs = {"low_level": PointGoToController()} if env_class is HighLevelMazeEnv else {}
    assert env_class(**kwargs).body == "point"


@pytest.mark.parametrize("body", ["ant", "point"])
def test_reach_env_spaces_reward_and_success(body):
    env = ReachEnv(body)
    obs, info = env.reset(seed=0)
    assert obs["observation"].shape == ({"ant": 27, "point": 2}[body],)
    assert 0 < np.linalg.norm(obs["desired_goal"] - obs["achieved_goal"]) <= env.sample_radius_m
    assert info["is_success"] is False
    # vectorised compute_reward, as HER calls it on a batch
    achieved = np.zeros((5, 2))
    desired = np.stack([np.array([d, 0.0]) for d in (0.0, 0.1, 0.44, 0.46, 3.0)])
    rewards = env.compute_reward(achieved, desired, [{}] * 5)
    np.testing.assert_array_equal(rewards, (np.linalg.norm(desired, axis=1) <= env.success_radius_m).astype(float))
    dense = ReachEnv(body, reward_type="dense").compute_reward(achieved, desired, None)
    np.testing.assert_allclose(dense, np.exp(-np.linalg.norm(desired, axis=1)))
    env.reset(seed=0, options={"subgoal_xy": obs["achieved_goal"]})
    _, reward, _, _, info = env.step(np.zeros(env.action_space.shape))
    assert info["is_success"] and reward == 1.0


def test_reach_env_truncates_at_horizon_and_samples_subgoals_within_radius():
    env = ReachEnv("point", horizon=7, sample_radius_m=0.8)
    for seed in range(20):
        obs, _ = env.reset(seed=seed)
        distance = np.linalg.norm(obs["desired_goal"] - obs["achieved_goal"])
        assert env.min_sample_radius_m <= distance <= 0.8
        assert env.sim.geometry.segment_is_free(env.walls, obs["achieved_goal"], obs["desired_goal"])
    truncations = [env.step(np.zeros(2))[3] for _ in range(7)]
    assert truncations == [False] * 6 + [True]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda env: env.step(np.array([np.nan, 0.0])), r"action must be finite, got \[nan, 0.0\]"),
        (lambda env: env.step(np.zeros(3)), r"action must have shape \(2,\), got shape \(3,\)"),
        (
            lambda env: env.reset(options={"subgoal_xy": [100.0, 0.0]}),
            r"subgoal_xy \[100.0, 0.0\] is not in a free cell",
        ),
        (lambda env: env.reset(options={"start_xy": [0.0, -1.5]}), r"start_xy \[0.0, -1.5\] is not in a free cell"),
    ],
)
def test_reach_env_bad_input(call, message):
    env = ReachEnv("point", maze_map="u")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        call(env)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"body": "spider"}, "unknown body 'spider'"),
        ({"reward_type": "shaped"}, "reward_type must be one of"),
        ({"action_scale": 2.0}, r"action_scale must lie in \(0, 1\]"),
        ({"horizon": 0}, "horizon must be >= 1"),
        ({"chain_probability": 1.5}, r"chain_probability must lie in \[0, 1\]"),
        ({"maze_map": [[1, 1, 1], [1, 0, 0], [1, 1, 1]]}, "border must be all walls"),
    ],
)
def test_reach_env_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ReachEnv(**{"body": "point", **kwargs})


def test_action_scale_reaches_the_actuators():
    env = ReachEnv("ant", action_scale=0.25)
    env.reset(seed=1)
    action = np.linspace(-1, 1, 8)
    env.step(action)
    np.testing.assert_allclose(env.sim.data.ctrl, 0.25 * action)
    env.step(np.full(8, 3.0))  # out-of-range actions are clipped to the Box before scaling
    np.testing.assert_allclose(env.sim.data.ctrl, np.full(8, 0.25))


@pytest.mark.parametrize(("body", "scale"), [("ant", 0.5), ("point", 1.0)])
def test_default_action_scale_is_the_bodys(body, scale):
    env = ReachEnv(body)
    env.reset(seed=0)
    env.step(np.ones(env.action_space.shape))
    np.testing.assert_allclose(env.sim.data.ctrl, scale)


def test_high_level_step_info_and_subgoal_errors():
    env = gym.make("antmaze_hirl/PointMaze-v0", min_subgoal_distance_m=0.0)
    obs, info = env.reset(seed=0)
    inner = env.unwrapped
    assert obs["image"].shape == (3, 7 * 8, 7 * 8) and obs["image"].dtype == np.uint8
    np.testing.assert_array_equal(inner.renderer.walls_from_image(obs["image"]), inner.layout.walls)
    np.testing.assert_allclose(obs["state"][:2], inner.agent_xy, atol=1e-6)
    np.testing.assert_allclose(obs["state"][2:4], inner.goal_xy, atol=1e-6)
    near = inner.agent_xy + np.array([0.1, 0.0])
    _, reward, terminated, truncated, info = env.step(near)
    assert info["subgoal_reached"] and info["attempts"] == 1 and info["low_level_steps"] < inner.reach.horizon
    assert np.linalg.norm(info["agent_path"][-1] - near) <= inner.reach.success_radius_m
    assert info["agent_path"].shape == (info["low_level_steps"] + 1, 2)
    assert (reward, terminated, truncated) == (0.0, False, False)
    with pytest.raises(ValueError, match=r"subgoal must be finite, got \[nan, 0.0\]"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match=r"subgoal \[50.0, 0.0\] is outside the maze bounds"):
        env.step(np.array([50.0, 0.0]))


def test_subgoals_inside_the_reach_radius_are_pushed_out_along_their_heading(still_controller):
    env = gym.make("antmaze_hirl/AntMaze-v0", low_level=still_controller)
    env.reset(seed=0)
    agent = env.unwrapped.agent_xy
    assert env.unwrapped.min_subgoal_distance_m == 2 * env.unwrapped.reach.success_radius_m == 0.9
    info = env.step(agent + np.array([0.0, 0.1]))[4]
    assert info["subgoal_extended"] and not info["subgoal_reached"]
    np.testing.assert_allclose(info["subgoal"] - env.unwrapped.agent_xy, [0.0, 0.9], atol=0.02)
    far = env.step(env.unwrapped.agent_xy + np.array([0.0, 2.0]))[4]
    assert not far["subgoal_extended"]
    off = gym.make("antmaze_hirl/AntMaze-v0", low_level=still_controller, min_subgoal_distance_m=0.0)
    off.reset(seed=0)
    info = off.step(off.unwrapped.agent_xy + np.array([0.0, 0.1]))[4]
    assert not info["subgoal_extended"] and info["subgoal_reached"] and info["low_level_steps"] == 1
    with pytest.raises(ValueError, match=r"min_subgoal_distance_m must lie in \[0, 4.0\) metres \(one cell\), got 5.0"):
        gym.make("antmaze_hirl/AntMaze-v0", low_level=still_controller, min_subgoal_distance_m=5.0)


def test_high_level_clips_when_asked_and_flags_it():
    env = gym.make("antmaze_hirl/PointMaze-v0", clip_subgoals=True)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([50.0, 0.0]))
    assert info["subgoal_clipped"]
    assert info["subgoal"][0] == pytest.approx(env.unwrapped.action_space.high[0])


def test_high_level_truncates_at_step_budget_and_counts_attempts():
    env = gym.make("antmaze_hirl/PointMaze-v0", max_steps=60, horizon=25)
    env.reset(seed=2)
    far_wall_corner = env.unwrapped.action_space.low  # unreachable: the point pushes into a wall
    budget = [env.step(far_wall_corner) for _ in range(3)]
    assert [step[4]["low_level_steps"] for step in budget] == [25, 25, 10]
    assert [step[3] for step in budget] == [False, False, True]
    assert budget[-1][4]["attempts"] == 3 and budget[-1][4]["total_low_level_steps"] == 60


def test_high_level_fixed_map_and_layout_option():
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_map="u")
    env.reset(seed=0)
    np.testing.assert_array_equal(env.unwrapped.layout.walls, validate_maze_map("u"))
    with pytest.raises(ValueError, match="must be a MazeLayout"):
        env.reset(options={"layout": [[1]]})
    with pytest.raises(ValueError, match=r"goal_xy \[0.0, 0.0\] is not in a free cell"):
        env.reset(options={"goal_xy": [0.0, 0.0]})


def test_reaching_the_goal_terminates_with_reward(still_controller):
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_map="u")
    obs, _ = env.reset(seed=5)
    oracle = PathOracle.for_env(env)
    total_reward, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(oracle.label(obs))
        total_reward += reward
        done = terminated or truncated
    assert terminated and not truncated and total_reward == 1.0 and info["is_success"]
    assert np.linalg.norm(env.unwrapped.agent_xy - env.unwrapped.goal_xy) <= env.unwrapped.success_radius_m


@pytest.mark.parametrize("body", ["ant", "point"])
def test_no_temporary_maze_xml_is_left_behind(body):
    env = ReachEnv(body)
    high = gym.make(maze_env_id(body), low_level=StillController())
    high.reset(seed=0)
    high.reset(seed=1)  # a new layout rebuilds the model
    for simulator in (env.sim, high.unwrapped.reach.sim):
        assert not os.path.exists(simulator._maze_env.tmp_xml_file_path)


def test_terminate_on_flip_catches_an_ant_on_its_back():
    env = ReachEnv("ant", terminate_on_flip=True)
    env.reset(seed=0)
    assert not env.step(np.zeros(8))[2]
    data = env.sim.data
    qpos, qvel = data.qpos.copy(), np.zeros_like(data.qvel)
    qpos[2], qpos[3:7] = 0.27, [0.0, 1.0, 0.0, 0.0]  # rolled 180 degrees about x: on its back, torso above 0.2 m
    env.sim._mujoco_env.set_state(qpos, qvel)
    assert env.sim.is_flipped
    assert env.step(np.zeros(8))[2]


def test_chained_reset_keeps_the_moving_body_and_draws_a_new_subgoal():
    env = ReachEnv("ant", chain_probability=1.0)
    env.reset(seed=0)
    for _ in range(20):
        env.step(env.action_space.sample())
    qpos, qvel, old_goal = env.sim.data.qpos.copy(), env.sim.data.qvel.copy(), env.subgoal_xy
    obs, _ = env.reset()
    np.testing.assert_array_equal(env.sim.data.qpos, qpos)
    np.testing.assert_array_equal(env.sim.data.qvel, qvel)
    assert not np.array_equal(obs["desired_goal"], old_goal)
    truncations = [env.step(np.zeros(8))[3] for _ in range(env.horizon)]
    assert truncations.index(True) == env.horizon - 1  # a full H-step sub-episode again
    env.reset(seed=0)  # a seed (or options) always starts afresh
    assert not np.array_equal(env.sim.data.qpos, qpos)


def test_chaining_never_continues_a_flipped_ant():
    env = ReachEnv("ant", chain_probability=1.0, terminate_on_flip=True)
    env.reset(seed=0)
    qpos = env.sim.data.qpos.copy()
    qpos[2], qpos[3:7] = 0.27, [0.0, 1.0, 0.0, 0.0]
    env.sim._mujoco_env.set_state(qpos, np.zeros_like(env.sim.data.qvel))
    assert env.sim.is_flipped
    env.reset()
    assert not env.sim.is_flipped


def test_chaining_off_keeps_the_random_stream_and_a_new_layout_starts_afresh():
    np.testing.assert_allclose(
        reset_subgoals(ReachEnv("point", chain_probability=0.0)), POINT_SUBGOALS_SEED_3, rtol=1e-6
    )
    # The check can fail: chaining on at a chance that never chains still takes a draw per plain reset.
    assert not np.allclose(reset_subgoals(ReachEnv("point", chain_probability=1e-12)), POINT_SUBGOALS_SEED_3)
    chained = ReachEnv("point", "u", chain_probability=1.0)
    chained.reset(seed=0)
    for _ in range(10):
        chained.step(np.ones(2))
    moved_to = chained.agent_xy
    other = validate_maze_map("u").copy()
    other[2, 2] = False  # open the U's middle wall: a new MuJoCo model with no body state to chain from
    chained.set_walls(other)
    start = chained.reset()[0]["achieved_goal"]
    assert not np.array_equal(start, moved_to)
    np.testing.assert_array_equal(chained.reset()[0]["achieved_goal"], start)  # and chains again from there


@pytest.mark.parametrize("terminate_on_flip", [True, False])
def test_high_level_episode_ends_when_the_ant_flips(terminate_on_flip):
    env = gym.make("antmaze_hirl/AntMaze-v0", low_level=StillController(), terminate_on_flip=terminate_on_flip)
    env.reset(seed=0)
    inner = env.unwrapped
    qpos = inner.reach.sim.data.qpos.copy()
    qpos[2], qpos[3:7] = 0.27, [0.0, 1.0, 0.0, 0.0]  # on its back
    inner.reach.sim._mujoco_env.set_state(qpos, np.zeros_like(inner.reach.sim.data.qvel))
    _, reward, terminated, _, info = env.step(inner.agent_xy + np.array([2.0, 0.0]))
    assert reward == 0.0 and not info["is_success"]
    assert terminated == info["flipped"] == terminate_on_flip
    assert info["low_level_steps"] == (1 if terminate_on_flip else inner.reach.horizon)
