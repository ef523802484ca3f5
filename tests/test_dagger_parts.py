"""The dagger package's parts and contracts: dataset, policy, learner, state layout, task sampler, names."""

import dataclasses
import importlib
import inspect
import json
import pickle
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch as th
from conftest import point_maze

from antmaze_hirl import dagger
from antmaze_hirl.dagger import (
    STRATEGIES,
    DAggerQuery,
    Demonstration,
    DemonstrationDataset,
    HighLevelPolicy,
    InverseDecayBetaSchedule,
    LearnerSettings,
    OffsetLearner,
    QueryStrategy,
)
from antmaze_hirl.dagger.high_level_policy import ENV_SHAPE_KEYS, FILE_KEYS
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.profiles import BODY_PROFILES
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.envs.task import Task
from antmaze_hirl.experiments.config import LEARNERS

V2_ZIP = Path(__file__).parent / "data" / "high_level_policy_v2.zip"


def demo(episode, step, value=0.0):
    state = np.full(6, value, np.float32)
    return Demonstration(np.zeros((3, 8, 8), np.uint8), state, np.array([value, -value]), episode, step)


def test_dataset_removal_clears_the_mask_and_keeps_ids_of_the_rest():
    dataset = DemonstrationDataset()
    for step in range(100):  # past the first capacity, so the arrays grow once
        dataset.add(demo(episode=step // 10, step=step % 10, value=step))
    ids_before = dataset.ids()
    dataset.remove([1, 3, 50])
    assert len(dataset) == 97
    np.testing.assert_array_equal(dataset.ids(), np.delete(ids_before, [1, 3, 50]))
    np.testing.assert_array_equal(dataset.agent_xy()[:3, 0], [0.0, 2.0, 4.0])
    np.testing.assert_array_equal(dataset.subgoals([2])[0], [4.0, -4.0])
    assert dataset.episode_indices(0) == list(range(8))
    assert dataset.add(demo(episode=10, step=0, value=7)) == 97 and dataset.ids()[-1] == 100  # ids never reused
    with pytest.raises(ValueError, match="read-only"):
        dataset.states[0, 0] = 1.0
    with pytest.raises(IndexError, match=r"positions to remove must lie in \[0, 98\), got \[98\]"):
        dataset.remove([98])
    with pytest.raises(ValueError, match="does not match the dataset's image"):
        dataset.add(Demonstration(np.zeros((3, 4, 4), np.uint8), np.zeros(6, np.float32), np.zeros(2), 0, 0))


def test_learner_encodings_stay_right_after_removal():
    env = point_maze()
    policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0))
    dataset = DemonstrationDataset()
    observations = [env.reset(seed=seed)[0] for seed in range(4)]
    for step, obs in enumerate(observations):
        dataset.add(Demonstration(obs["image"], obs["state"], np.zeros(2), 0, step))
    policy.fit_dataset(dataset, 1)  # fills the encoding cache
    dataset.remove([0, 2])
    cached = policy.cache.encoded(policy.encoder, dataset, None)
    fresh = policy.encoder.encode_observations([observations[1], observations[3]])
    np.testing.assert_array_equal(cached.grids, fresh.grids)
    np.testing.assert_array_equal(cached.vectors, fresh.vectors)
    copy = pickle.loads(pickle.dumps(dataset))  # may grow apart from the original: a cache tells them apart
    assert copy.key != dataset.key and len(copy) == 2


def test_learner_and_policy_leave_torchs_global_rng_alone():
    env = point_maze()
    obs, _ = env.reset(seed=0)
    dataset = DemonstrationDataset()
    dataset.add(Demonstration(obs["image"], obs["state"], np.zeros(2), 0, 0))
    th.manual_seed(123)
    expected = th.rand(3)
    th.manual_seed(123)
    learner = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0))  # seeds its initialisation
    learner.fit_dataset(dataset, 3)
    th.testing.assert_close(th.rand(3), expected)


def test_bc_learner_leaves_torchs_global_rng_alone():
    pytest.importorskip("imitation", reason="the imitation extra is not installed")
    from antmaze_hirl.dagger.interop import BCLearner

    env = point_maze()
    dataset = DemonstrationDataset()
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        dataset.add(Demonstration(obs["image"], obs["state"], np.zeros(2), 0, seed))
    th.manual_seed(7)
    expected = th.rand(3)
    th.manual_seed(7)
    BCLearner(env, rng=np.random.default_rng(0), batch_size=2).fit_dataset(dataset, 2)
    th.testing.assert_close(th.rand(3), expected)


def test_policy_is_a_module_and_loads_the_v2_zip_format(tmp_path):
    # Written by the code before the split (one HighLevelPolicy class); its prediction was recorded then.
    rng = np.random.default_rng(1)
    image = (rng.random((3, 12, 12)) > 0.5).astype(np.uint8) * 255
    obs = {"image": image, "state": np.array([0.1, -0.2, 0.9, 0.8, 0.3, -0.1], np.float32)}
    recorded = [0.5323548391461372, -0.3630983680486679]
    loaded = HighLevelPolicy.load(V2_ZIP)
    assert loaded.config()["learning_rate"] == 5e-4 and loaded.settings.batch_size == 16
    np.testing.assert_array_equal(loaded.predict(obs), recorded)
    assert isinstance(loaded.network, th.nn.Module) and isinstance(loaded, OffsetLearner)
    resaved = HighLevelPolicy.load(loaded.save(tmp_path / "again.zip"))
    assert resaved.config() == loaded.config()
    np.testing.assert_array_equal(resaved.predict(obs), recorded)
    # The file keeps format 2's key for the reach; Python reads it as subgoal_reach_m.
    with zipfile.ZipFile(tmp_path / "again.zip") as archive, zipfile.ZipFile(V2_ZIP) as original:
        written, shipped = (json.loads(z.read("meta.json"))["config"] for z in (archive, original))
    assert "subgoal_reach_m" not in written and written["max_offset"] == shipped["max_offset"]
    assert loaded.subgoal_reach_m == shipped["max_offset"] == loaded.config()["subgoal_reach_m"]


def test_state_layout_reads_agent_goal_and_body():
    state = np.arange(7, dtype=np.float32)
    np.testing.assert_array_equal(STATE_LAYOUT.agent_xy(state), [0, 1])
    np.testing.assert_array_equal(STATE_LAYOUT.goal_xy(state), [2, 3])
    np.testing.assert_array_equal(STATE_LAYOUT.body_observation(state), [4, 5, 6])
    np.testing.assert_array_equal(STATE_LAYOUT.agent_xy(np.stack([state, state + 10])), [[0, 1], [10, 11]])
    np.testing.assert_array_equal(STATE_LAYOUT.compose([0, 1], [2, 3], [4, 5, 6]), state)
    assert STATE_LAYOUT.body_dim(7) == 3 and STATE_LAYOUT.state_dim(3) == 7
    with pytest.raises(ValueError, match="at least 4 values, got 3"):
        STATE_LAYOUT.body_dim(3)
    env = point_maze()
    obs, _ = env.reset(seed=0)
    np.testing.assert_allclose(STATE_LAYOUT.agent_xy(obs["state"]), env.unwrapped.agent_xy, atol=1e-6)
    np.testing.assert_allclose(STATE_LAYOUT.goal_xy(obs["state"]), env.unwrapped.goal_xy, atol=1e-6)


def test_reset_draws_its_task_with_sample_task():
    env = point_maze()
    env.reset(seed=5)
    task = env.unwrapped.sample_task(np.random.default_rng(5))  # what reset(seed=5) drew from np_random
    assert isinstance(task, Task)
    np.testing.assert_array_equal(env.unwrapped.layout.walls, task.layout.walls)
    np.testing.assert_array_equal(env.unwrapped.goal_xy, task.goal_xy)
    np.testing.assert_allclose(env.unwrapped.agent_xy, task.start_xy, atol=1e-6)
    # Starting the task drawn without a start: layout and goal as given, the env places the start.
    bare = env.unwrapped.sample_task(np.random.default_rng(9), draw_start=False)
    assert bare.start_xy is None and "start_xy" not in bare.reset_options()
    env.reset(seed=1, options=bare.reset_options())
    np.testing.assert_array_equal(env.unwrapped.goal_xy, bare.goal_xy)
    with pytest.raises(ValueError, match=r"layout \(reset's options\['layout'\]\) must be a MazeLayout, got str"):
        env.unwrapped.sample_task(np.random.default_rng(0), layout="u")


def test_trainer_draws_its_task_with_sample_task():
    from antmaze_hirl import PathOracle
    from antmaze_hirl.dagger import DAggerTrainer

    env = point_maze()
    rng = np.random.default_rng(3)
    trainer = DAggerTrainer(
        env=env, expert=PathOracle.for_env(env), learner=HighLevelPolicy.for_env(env, rng=rng), rng=rng
    )
    drawn = []
    sample_task = env.unwrapped.sample_task

    def recording(*args, **kwargs):
        drawn.append(sample_task(*args, **kwargs))
        return drawn[-1]

    env.unwrapped.sample_task = recording
    run = trainer.start_episode()
    assert len(drawn) == 2  # the trainer's draw, then reset's (which keeps the given layout and goal)
    assert drawn[1].layout is drawn[0].layout
    np.testing.assert_array_equal(
        STATE_LAYOUT.goal_xy(run.request.observation["state"]), drawn[0].goal_xy.astype(np.float32)
    )


def test_no_op_subgoal_check_matches_the_push_out():
    env = point_maze(min_subgoal_distance_m=0.4)
    env.reset(seed=0)
    inner = env.unwrapped
    assert inner.is_no_op_subgoal(inner.agent_xy + np.array([0.3, 0.0]))
    assert not inner.is_no_op_subgoal(inner.agent_xy + np.array([0.0, 0.4]))
    _, _, _, _, info = env.step(
        np.clip(inner.agent_xy + np.array([0.2, 0.0]), env.action_space.low, env.action_space.high)
    )
    assert info["subgoal_extended"]


def test_inverse_decay_beta_schedule_and_the_removed_alias():
    assert [InverseDecayBetaSchedule(2.0)(k) for k in range(3)] == [1.0, 0.5, 0.25]
    assert InverseDecayBetaSchedule(3.0)(2) == 1 / 9
    with pytest.raises(ValueError, match=r"imitation's ExponentialBetaSchedule .* its 0.5 is d = 2 here"):
        InverseDecayBetaSchedule(0.5)
    with pytest.raises(ValueError, match="decay d must be >= 1, got -1"):
        InverseDecayBetaSchedule(-1)
    import antmaze_hirl.dagger.schedules as schedules

    assert not hasattr(dagger, "ExponentialBetaSchedule") and not hasattr(schedules, "ExponentialBetaSchedule")


def test_query_strategy_is_the_base_and_dagger_query_plain_dagger():
    assert STRATEGIES["dagger"] is DAggerQuery and issubclass(DAggerQuery, QueryStrategy)
    assert type(QueryStrategy()) is QueryStrategy and QueryStrategy.name == ""  # no longer turned into DAgger
    assert DAggerQuery().name == "dagger"


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        ({"batch_size": 0}, "batch_size must be >= 1, got 0"),
        ({"n_directions": 6}, "n_directions must be a positive multiple of 4, got 6"),
        ({"learning_rate": 0.0}, "learning_rate must be > 0, got 0.0"),
        ({"subgoal_reach_m": -2.0}, "subgoal_reach_m must be > 0 or None, got -2.0"),
        ({"hidden": 0}, "hidden must be >= 1, got 0"),
        ({"channels": -1}, "channels must be >= 1, got -1"),
        ({"head": "cells"}, r"head must be one of \['heading', 'next_cell'\], got 'cells'"),
        ({"planning_iterations": -1}, "planning_iterations must be >= 0, got -1"),
        ({"block_walls": True}, "block_walls needs head='next_cell' and planning_iterations > 0"),
    ],
)
def test_learner_settings_are_checked(bad, message):
    with pytest.raises(ValueError, match=f"^{message}$"):
        LearnerSettings(**bad)
    with pytest.raises(ValueError, match=message):  # a file's settings are checked as a caller's are
        LearnerSettings().replace(**bad)


def test_unknown_settings_and_bodies_are_named():
    with pytest.raises(ValueError, match=r"unknown learner settings \['hiden'\]; choose from \['subgoal_reach_m', "):
        LearnerSettings().replace(hiden=64)
    with pytest.raises(ValueError, match=r"unknown learner settings \['max_offset'\]"):  # the file's key is no keyword
        HighLevelPolicy.for_env(point_maze(), rng=np.random.default_rng(0), max_offset=1.0)
    with pytest.raises(ValueError, match=r"unknown body 'cat'; choose from \['ant', 'point'\]"):
        LearnerSettings.for_body("cat", MazeGeometry(3, 3, 1.0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        LearnerSettings().hidden = 3  # type: ignore[misc]


def test_the_settings_are_the_one_list_of_the_constructor_the_file_and_the_body_defaults(tmp_path):
    names = [field.name for field in dataclasses.fields(LearnerSettings)]
    assert list(LearnerSettings.names()) == names
    assert list(inspect.signature(HighLevelPolicy).parameters) == [*ENV_SHAPE_KEYS, "rng", "settings"]
    learner = HighLevelPolicy(MazeGeometry(3, 3, 1.0), pixels_per_cell=4, body_dim=2, rng=np.random.default_rng(0))
    assert learner.settings == LearnerSettings(subgoal_reach_m=1.0)  # None resolved to one cell
    assert list(learner.config()) == [*ENV_SHAPE_KEYS, *names]
    with zipfile.ZipFile(learner.save(tmp_path / "l.zip")) as archive:
        stored = json.loads(archive.read("meta.json"))["config"]
    assert list(stored) == [*ENV_SHAPE_KEYS, *(FILE_KEYS.get(name, name) for name in names)]
    for named in LEARNERS.values():
        assert set(named) <= set(names)
    assert LearnerSettings.for_body("ant", MazeGeometry(6, 6, 4.0)).head == BODY_PROFILES["ant"].learner_head
    # One learner class: the parts it was split into before 0.2.0 are gone, with no alias.
    for removed in ("SubgoalPolicy", "SubgoalLearner"):
        assert not hasattr(dagger, removed)
    for module in ("antmaze_hirl.dagger.policy", "antmaze_hirl.dagger.learner"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(module)
