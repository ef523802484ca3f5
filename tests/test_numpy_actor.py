"""The numpy inference path of a TD3 actor equals the torch path within float tolerance."""

import numpy as np
import pytest

from antmaze_hirl.envs.controllers import PredictController, as_batch_controller
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext import load_config, make_model
from antmaze_hirl.sb3_ext.distill import make_student
from antmaze_hirl.sb3_ext.ensemble import build_ensemble
from antmaze_hirl.sb3_ext.loading import load_low_level
from antmaze_hirl.sb3_ext.numpy_actor import NumpyActor
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

TOLERANCE = 1e-5
"""float32 arithmetic in another order: the actions (in [-1, 1]) agree to about 1e-6."""


def walk(body, steps, seed=0):
    """Goal observations of a seeded random-action walk (rotated torsos, varied subgoal offsets)."""
    env = ReachEnv(body)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    seen = []
    for _ in range(steps):
        seen.append(obs)
        obs, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
        if terminated or truncated:
            obs, _ = env.reset()
    env.close()
    return seen


def stacked(observations):
    return {key: np.stack([obs[key] for obs in observations]) for key in observations[0]}


@pytest.fixture(scope="module")
def ant_observations():
    return walk("ant", 120)


@pytest.mark.parametrize("layout", ["batched", "sequential", "single"])
def test_the_numpy_actor_equals_the_torch_actor_on_the_ant(ant_observations, layout):
    path = shipped_policy_path("ant")
    if layout == "single":
        model = make_student(path, "ant", init_head=3)
    else:
        model = build_ensemble([path], "ant", batched_heads=layout == "batched")
    torch_path, numpy_path = PredictController(model), NumpyActor.from_model(model)
    assert numpy_path.n_heads == (1 if layout == "single" else 7)
    one_by_one = np.stack([numpy_path(obs) for obs in ant_observations])
    expected = np.stack([torch_path(obs) for obs in ant_observations])
    assert np.abs(one_by_one - expected).max() < TOLERANCE
    batch = stacked(ant_observations)
    assert np.abs(numpy_path.act_batch(batch) - torch_path.act_batch(batch)).max() < TOLERANCE
    # Not trivially equal: the actions vary across the walk.
    assert expected.std(axis=0).min() > 0.01


def test_the_numpy_actor_equals_the_torch_actor_on_the_point():
    model = load_low_level("point")  # goal offset in the world frame (no quaternion)
    observations = walk("point", 60)
    numpy_path = NumpyActor.from_model(model)
    assert numpy_path.quaternion_index is None
    expected = np.stack([model.predict(obs, deterministic=True)[0] for obs in observations])
    assert np.abs(np.stack([numpy_path(obs) for obs in observations]) - expected).max() < TOLERANCE


def test_the_numpy_actor_is_a_batch_controller(ant_observations):
    actor = NumpyActor.from_model(load_low_level("ant"))
    batch = as_batch_controller(actor, 3)  # no warning: it has act_batch
    rows = stacked(ant_observations[:3])
    assert batch(rows, np.arange(3)).shape == (3, 8)


def test_an_actor_without_the_relative_goal_features_is_refused():
    config = load_config("point", algo="td3").replace(relative_goal=False, learning_starts=100, buffer_size=1_000)
    model = make_model("point", "td3", config, seed=0)
    with pytest.raises(ValueError, match="RelativeGoalExtractor"):
        NumpyActor.from_model(model)


def test_mismatched_layers_are_refused():
    with pytest.raises(ValueError, match="one weight, bias and activation per layer"):
        NumpyActor([np.zeros((1, 2, 3))], [], ["relu"], quaternion_index=None, action_low=-1, action_high=1)
    with pytest.raises(ValueError, match="unknown activations"):
        NumpyActor(
            [np.zeros((1, 2, 3))], [np.zeros((1, 2))], ["gelu"], quaternion_index=None, action_low=-1, action_high=1
        )
