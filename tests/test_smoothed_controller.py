"""Action smoothing: SmoothedController (the controller side) and ReachEnv(action_smoothing) (the env side)."""

import re

import gymnasium as gym
import numpy as np
import pytest

from antmaze_hirl.envs import ActionSmoother, ReachEnv, SmoothedController


class Sequence:
    """Returns the given actions in turn and counts its resets."""

    def __init__(self, actions):
        self.actions, self.calls, self.resets = [np.asarray(a, dtype=float) for a in actions], 0, 0

    def __call__(self, observation):
        action = self.actions[self.calls % len(self.actions)]
        self.calls += 1
        return action

    def reset(self):
        self.resets += 1


def test_actions_are_an_exponential_average_of_the_raw_ones():
    controller = SmoothedController(Sequence([[1.0, -1.0], [0.0, 0.0], [0.0, 1.0]]), alpha=0.5)
    actions = [controller({}) for _ in range(3)]
    np.testing.assert_allclose(actions, [[1.0, -1.0], [0.5, -0.5], [0.25, 0.25]])


def test_reset_forgets_the_previous_action_and_resets_the_inner_controller():
    inner = Sequence([[1.0], [0.0]])
    controller = SmoothedController(inner, alpha=0.9)
    controller({})
    controller.reset()
    assert inner.resets == 1
    np.testing.assert_allclose(controller({}), [0.0])  # raw, not 0.9 * 1.0


def test_zero_alpha_passes_actions_through():
    controller = SmoothedController(Sequence([[0.3], [-0.7]]), alpha=0.0)
    np.testing.assert_allclose([controller({}), controller({})], [[0.3], [-0.7]])


@pytest.mark.parametrize("alpha", [-0.1, 1.0, float("nan"), "0.5"])
def test_alpha_outside_zero_one_is_named(alpha):
    with pytest.raises(ValueError, match=re.escape(f"alpha must lie in [0, 1), got {alpha!r}")):
        SmoothedController(Sequence([[0.0]]), alpha=alpha)


def test_the_smoother_keeps_its_own_copy_of_the_previous_action():
    smoother, buffer = ActionSmoother(0.5), np.ones(2)
    smoother(buffer)
    buffer[:] = 0.0  # a controller reusing its output buffer
    np.testing.assert_allclose(smoother(np.zeros(2)), [0.5, 0.5])


def test_the_controller_side_clips_before_smoothing_as_the_env_side_does():
    controller = SmoothedController(Sequence([[3.0], [-3.0]]), alpha=0.5)
    np.testing.assert_allclose([controller({}), controller({})], [[1.0], [0.0]])


def test_the_high_level_env_resets_the_controller_at_every_episode():
    inner = Sequence([np.zeros(2)])
    env = gym.make("antmaze_hirl/PointMaze-v0", low_level=SmoothedController(inner, alpha=0.5))
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.reset(seed=1)
    env.close()
    assert inner.resets == 2 and inner.calls > 0


def test_reach_env_applies_the_smoothed_action_and_restarts_it_from_rest():
    env = ReachEnv("ant", action_smoothing=0.5, chain_probability=1.0)
    env.reset(seed=0)
    first, second = np.full(8, 0.8), np.full(8, -0.4)
    env.step(first)
    env.step(second)
    np.testing.assert_allclose(env.sim.data.ctrl, (0.5 * first + 0.5 * second) * env.action_scale)
    env.reset()  # chained: the legs keep their torques
    env.step(first)
    np.testing.assert_allclose(env.sim.data.ctrl, (0.5 * 0.2 + 0.5 * 0.8) * env.action_scale)
    env.reset(seed=1)  # from rest: the first action is applied as it is
    env.step(second)
    np.testing.assert_allclose(env.sim.data.ctrl, second * env.action_scale)


def test_reach_env_names_a_bad_smoothing_weight():
    with pytest.raises(ValueError, match=r"alpha must lie in \[0, 1\), got 1\.5"):
        ReachEnv("ant", action_smoothing=1.5)


def test_the_high_level_env_passes_smoothing_to_its_reach_env():
    env = gym.make("antmaze_hirl/AntMaze-v0", low_level=Sequence([np.zeros(8)]), reach_kwargs={"action_smoothing": 0.5})
    assert env.unwrapped.reach.action_smoothing == 0.5
    env.close()
