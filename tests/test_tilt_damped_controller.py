"""TiltDampedController: the default-off safety filter that scales an ant's actions down while its torso tilts."""

import re

import numpy as np
import pytest

from antmaze_hirl.envs import TiltDampedController
from antmaze_hirl.envs.controllers import as_batch_controller


def tilted_observation(uprightness, dim=27):
    """An ant body observation whose torso quaternion (index 1) gives ``uprightness`` (a roll about x)."""
    angle = np.arccos(np.clip(uprightness, -1.0, 1.0))  # up axis at `angle` from vertical
    observation = np.zeros(dim)
    observation[1:5] = [np.cos(angle / 2), np.sin(angle / 2), 0.0, 0.0]
    return {"observation": observation, "achieved_goal": np.zeros(2), "desired_goal": np.ones(2)}


class Constant:
    """Always the same action; counts its calls and resets; acts in a batch too."""

    def __init__(self, action):
        self.action, self.calls, self.resets = np.asarray(action, dtype=float), 0, 0

    def __call__(self, observation):
        self.calls += 1
        return self.action

    def act_batch(self, observations):
        self.calls += 1
        return np.tile(self.action, (len(observations["observation"]), 1))

    def reset(self):
        self.resets += 1


def damped(inner, **settings):
    return TiltDampedController(
        inner, **{"upper_uprightness": 0.8, "lower_uprightness": 0.6, "min_scale": 0.3, **settings}
    )


@pytest.mark.parametrize(
    ("uprightness", "scale"), [(1.0, 1.0), (0.8, 1.0), (0.7, 0.65), (0.6, 0.3), (0.2, 0.3), (-0.5, 0.3)]
)
def test_actions_pass_upright_and_fall_linearly_to_the_floor_scale(uprightness, scale):
    controller = damped(Constant([0.5, -1.0, 2.0]))
    np.testing.assert_allclose(controller(tilted_observation(uprightness)), scale * np.array([0.5, -1.0, 1.0]))


def test_the_batch_form_damps_each_row_by_its_own_tilt_and_equals_one_by_one():
    inner = Constant([1.0, -0.5])
    controller = damped(inner)
    rows = [tilted_observation(u) for u in (1.0, 0.7, 0.5)]
    batch = {key: np.stack([row[key] for row in rows]) for key in rows[0]}
    batched = as_batch_controller(controller, 3)
    actions = batched(batch, np.arange(3))
    np.testing.assert_allclose(actions, [controller(row) for row in rows])
    np.testing.assert_allclose(actions[:, 0], [1.0, 0.65, 0.3])


def test_reset_reaches_the_inner_controller():
    inner = Constant([0.0])
    damped(inner).reset()
    assert inner.resets == 1


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"lower_uprightness": 0.8}, "lower 0.8 and upper 0.8"),
        ({"upper_uprightness": 1.5}, "lower 0.6 and upper 1.5"),
        ({"min_scale": 1.2}, "min_scale must lie in [0, 1], got 1.2"),
        ({"quaternion_index": -1}, "quaternion_index must be >= 0, got -1"),
    ],
)
def test_bad_settings_are_named(settings, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        damped(Constant([0.0]), **settings)
