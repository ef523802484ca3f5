"""PredictController's direct path: SB3's predict steps run in place, the same actions bit for bit."""

import numpy as np
import pytest

from antmaze_hirl.envs import controllers
from antmaze_hirl.envs.controllers import PredictController
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.loading import load_low_level


@pytest.mark.parametrize("body", ["ant", "point"])
def test_direct_actions_equal_sb3_predict_bit_for_bit(body):
    model = load_low_level(body)
    controller = PredictController(model)
    env = ReachEnv(body)
    observations = [env.reset(seed=seed)[0] for seed in range(5)]
    for _ in range(3):  # a few steps in, so the body is not at rest
        observations = [env.step(controller(observations[-1]))[0], *observations[:-1]]
    for observation in observations:
        expected, _ = model.predict(observation, deterministic=True)
        action = controller(observation)
        assert action.shape == expected.shape and action.dtype == expected.dtype
        np.testing.assert_array_equal(action, expected)
    batch = {key: np.stack([observation[key] for observation in observations]) for key in observations[0]}
    np.testing.assert_array_equal(controller.act_batch(batch), model.predict(batch, deterministic=True)[0])
    env.close()


def test_the_direct_path_puts_a_training_policy_in_eval_mode_as_predict_does(monkeypatch):
    model = load_low_level("point")
    model.policy.set_training_mode(True)
    observation = ReachEnv("point").reset(seed=1)[0]
    action = PredictController(model)(observation)
    assert not model.policy.training
    monkeypatch.setattr(controllers, "DIRECT_PREDICT", False)
    np.testing.assert_array_equal(PredictController(model)(observation), action)


class BoxModel:
    """A model with SB3's predict but no SB3 policy: the controller must call its predict."""

    def __init__(self):
        self.calls = 0

    def predict(self, observation, deterministic=True):
        self.calls += 1
        rows = observation["observation"].shape[:-1]
        return np.ones((*rows, 2)), None


def test_anything_else_goes_through_its_own_predict():
    model = BoxModel()
    controller = PredictController(model)
    observation = {"observation": np.zeros(3), "achieved_goal": np.zeros(2), "desired_goal": np.zeros(2)}
    assert controller(observation).shape == (2,)
    batch = {key: np.stack([value, value]) for key, value in observation.items()}
    assert controller.act_batch(batch).shape == (2, 2) and model.calls == 2
