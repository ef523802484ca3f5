"""DAgger distillation of a teacher low level into one actor: it learns, it resumes exactly, its zip is a plain TD3."""

import json

import gymnasium as gym
import numpy as np
import pytest

import antmaze_hirl  # noqa: F401 - registers the ids
from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.sb3_ext import load_config, make_model
from antmaze_hirl.sb3_ext.distill import (
    Dataset,
    DistillSettings,
    Episode,
    HighLevelEpisodes,
    ReachEpisodes,
    RecordingController,
    distill,
    flip_weights,
    make_student,
)
from antmaze_hirl.sb3_ext.ensemble import EnsemblePolicy
from antmaze_hirl.sb3_ext.loading import load_low_level, policy_fingerprint
from antmaze_hirl.sb3_ext.numpy_actor import NumpyActor
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

# A fresh student (no teacher head to start from), so there is something to learn in a few hundred steps.
TINY = DistillSettings(
    iterations=2, steps_per_iteration=600, gradient_steps=300, batch_size=64, learning_rate=1e-3, init_head=None
)


# Resuming is about bookkeeping, not learning: fewer steps.
SHORT = DistillSettings(iterations=2, steps_per_iteration=150, gradient_steps=50, batch_size=32, init_head=None)


def point_sources(controller):
    return [ReachEpisodes(ReachEnv("point"), controller, subgoals=3)]


def held_out_states(count=200):
    """Point states of the shipped policy's own walks, from seeds the distillation never plays."""
    env = ReachEnv("point")
    teacher = load_low_level("point")
    states = []
    obs, _ = env.reset(seed=123_456)
    while len(states) < count:
        states.append(obs)
        obs, _, terminated, truncated, _ = env.step(teacher.predict(obs, deterministic=True)[0])
        if terminated or truncated:
            obs, _ = env.reset()
    env.close()
    return {key: np.stack([obs[key] for obs in states]) for key in states[0]}


def squashed_gap(student_path, states):
    teacher = NumpyActor.from_model(load_low_level("point"))
    student = NumpyActor.from_model(load_low_level("point", student_path))
    features = teacher.features(states)
    return float(np.mean((student.squashed(features) - teacher.squashed(features)) ** 2))


def test_the_student_moves_towards_the_teacher(tmp_path):
    teacher = shipped_policy_path("point")
    states = held_out_states()
    untrained = tmp_path / "untrained.zip"
    make_student(teacher, "point", init_head=None).save(untrained)
    before = squashed_gap(untrained, states)
    latest = distill(teacher, tmp_path / "run", point_sources, TINY, body="point", log=lambda line: None)
    after = squashed_gap(latest, states)
    assert before > 0.05  # a fresh actor is far from the teacher
    assert after < 0.5 * before  # 0.31-0.33x on seeds 0 and 1 here
    state = json.loads((tmp_path / "run" / "state.json").read_text())
    assert state["completed_iterations"] == 2
    assert [record["beta"] for record in state["history"]] == [1.0, 0.5]
    assert state["history"][0]["student"]["episodes"] == 0  # beta 1: the teacher drives every episode first
    assert sum(record["rows_new"] for record in state["history"]) == state["rows"] >= 1200


def test_a_resumed_run_repeats_an_uninterrupted_one(tmp_path):
    teacher = shipped_policy_path("point")
    whole = distill(teacher, tmp_path / "whole", point_sources, SHORT, body="point", log=lambda line: None)
    first = DistillSettings(**{**SHORT.__dict__, "iterations": 1})
    distill(teacher, tmp_path / "part", point_sources, first, body="point", log=lambda line: None)
    resumed = distill(
        teacher, tmp_path / "part", point_sources, SHORT, body="point", resume=True, log=lambda line: None
    )
    assert policy_fingerprint(load_low_level("point", resumed)) == policy_fingerprint(load_low_level("point", whole))
    with pytest.raises(FileExistsError, match="already holds a distillation run"):
        distill(teacher, tmp_path / "part", point_sources, SHORT, body="point", log=lambda line: None)
    other = DistillSettings(**{**SHORT.__dict__, "seed": 1})
    with pytest.raises(ValueError, match="seed 0 there, 1 now"):
        distill(teacher, tmp_path / "part", point_sources, other, body="point", resume=True)
    with pytest.raises(FileNotFoundError, match="no distillation run"):
        distill(teacher, tmp_path / "none", point_sources, SHORT, body="point", resume=True)


def test_the_ant_student_is_a_plain_td3_zip_that_a_fine_tune_can_start_from(tmp_path):
    ensemble = load_low_level("ant")
    student = make_student(shipped_policy_path("ant"), "ant", init_head=2)
    path = tmp_path / "student.zip"
    student.save(path)
    loaded = load_low_level("ant", path)
    assert not isinstance(loaded.policy, EnsemblePolicy)
    # Head 2 of the ensemble, and the ensemble's critic.
    head = ensemble.policy.actor.mu.head_states()[2]
    for key, tensor in loaded.policy.actor.mu.state_dict().items():
        assert np.array_equal(tensor.numpy(), head[key].numpy())
    assert policy_fingerprint(loaded.policy.critic) == policy_fingerprint(ensemble.policy.critic)
    # train-low --init-from loads the zip into a fresh model of the ant's config with exact_match.
    config = load_config("ant", algo="td3").replace(buffer_size=1_000, learning_starts=100)
    fine_tune = make_model("ant", "td3", config, seed=0)
    fine_tune.set_parameters(str(path), exact_match=True, device="cpu")
    with pytest.raises(ValueError, match=r"heads 0\.\.6"):
        make_student(shipped_policy_path("ant"), "ant", init_head=7)


def test_flip_weights_mark_the_steps_before_a_flip():
    weights = flip_weights([Episode(4, True, False), Episode(5, False, True)], window=2, weight=3.0)
    assert weights.tolist() == [1, 1, 1, 1, 1, 1, 1, 3, 3]
    assert flip_weights([Episode(3, False, True)], window=0, weight=3.0).tolist() == [1, 1, 1]


def test_the_dataset_keeps_the_newest_rows():
    dataset = Dataset(max_rows=5)
    for start in (0, 3, 6):
        rows = np.arange(start, start + 3, dtype=np.float32)[:, None]
        dataset.add(rows, rows, rows[:, 0])
    features, labels, weights = dataset.arrays()
    assert features[:, 0].tolist() == [4, 5, 6, 7, 8] and len(dataset) == 5
    assert labels.shape == (5, 1) and weights.shape == (5,)


@pytest.mark.parametrize(
    ("changes", "message"),
    [({"iterations": 0}, "iterations"), ({"beta_decay": 1.5}, "beta0 and beta_decay"), ({"flip_window": -1}, "window")],
)
def test_bad_settings_are_named(changes, message):
    with pytest.raises(ValueError, match=message):
        DistillSettings(**changes)


def test_a_new_run_can_start_from_an_earlier_student(tmp_path):
    teacher = shipped_policy_path("point")
    earlier = distill(teacher, tmp_path / "a", point_sources, SHORT, body="point", log=lambda line: None)
    # A step too small to move the weights: the new run's student is the earlier one, not a fresh actor.
    still = DistillSettings(**{**SHORT.__dict__, "iterations": 1, "gradient_steps": 1, "learning_rate": 1e-12})
    later = distill(
        teacher, tmp_path / "b", point_sources, still, body="point", init_student=earlier, log=lambda line: None
    )
    before = load_low_level("point", earlier).policy.actor.state_dict()
    after = load_low_level("point", later).policy.actor.state_dict()
    assert all(np.allclose(before[key].numpy(), after[key].numpy(), atol=1e-6) for key in before)
    assert json.loads((tmp_path / "b" / "state.json").read_text())["init_student"] == str(earlier)
    with pytest.raises(ValueError, match="not a plain single-actor TD3 policy"):
        ensemble = shipped_policy_path("ant")
        distill(ensemble, tmp_path / "c", point_sources, still, body="ant", init_student=ensemble)


def test_a_maze_source_sets_the_step_limit_from_the_layout_its_reset_drew():
    controller = RecordingController()
    controller.driver = lambda observation: np.zeros(2)  # the point stands still: only the limit ends the episode
    env = gym.make(maze_env_id("point"), low_level=controller)
    layouts = []

    def limit(maze):
        layouts.append(maze.layout)
        return 7

    source = HighLevelEpisodes(env, PathOracle.for_env(env), limit)
    try:
        assert source.play(3) == Episode(7, False, False) and controller.rows == 7
        assert len(layouts) == 1 and layouts[0] is env.unwrapped.layout  # after the reset, not before
    finally:
        source.close()
