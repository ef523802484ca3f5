"""antmaze_hirl.rollout, the one home of the play loops: the policy adapter and the serial player's reset options."""

import gymnasium as gym
import numpy as np
import pytest

import antmaze_hirl  # noqa: F401 - registers the ids
from antmaze_hirl.envs.layouts import canonical_layout
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.rollout import play_episode, play_in_lockstep, subgoal_function


class Predicting:
    """An object with ``predict``, as an SB3 model: returns ``(subgoal, state)``."""

    def __init__(self, subgoal):
        self.subgoal = np.asarray(subgoal)
        self.seen = []

    def predict(self, observation):
        self.seen.append(observation)
        return self.subgoal, None


def test_a_callable_a_predict_and_sb3s_tuple_all_give_the_subgoal():
    observation = {"state": np.zeros(3)}
    assert subgoal_function(lambda obs: np.array([1.0, 2.0]))(observation).tolist() == [1.0, 2.0]
    model = Predicting([3.0, 4.0])
    assert subgoal_function(model)(observation).tolist() == [3.0, 4.0]
    assert model.seen == [observation]
    # A callable returning SB3's tuple is unwrapped too; predict wins over __call__.
    assert subgoal_function(lambda obs: (np.array([5.0, 6.0]), None))(observation).tolist() == [5.0, 6.0]


@pytest.mark.parametrize("policy", [None, 3, "oracle"])
def test_a_policy_that_cannot_act_is_refused_naming_its_type(policy):
    with pytest.raises(
        ValueError, match=rf"policy must be callable or have predict\(observation\), got {type(policy).__name__}"
    ):
        subgoal_function(policy)


def test_lockstep_play_refuses_such_a_policy_before_any_reset():
    with pytest.raises(ValueError, match=r"got int"):
        play_in_lockstep(3, [_EnvThatMustNotReset()], [0])


class _EnvThatMustNotReset:
    controller = object()

    def reset(self, **kwargs):
        raise AssertionError("reset before the policy was checked")


def test_the_serial_player_passes_its_reset_options_to_the_env():
    # A suite's task by option: the same task whatever the seed, as the benchmark plays it.
    env = gym.make(SUITE_SPECS["point5"].env_id)
    try:
        oracle = PathOracle.for_env(env)
        first = play_episode(env, oracle, seed=1, options={"task_id": 3})
        layout = canonical_layout(env.unwrapped.layout)
        again = play_episode(env, oracle, seed=2, options={"task_id": 3})
        assert canonical_layout(env.unwrapped.layout) == layout
        other = play_episode(env, oracle, seed=1, options={"task_id": 4})
        assert canonical_layout(env.unwrapped.layout) != layout
    finally:
        env.close()
    for episode in (first, again, other):
        assert episode.path.shape[1] == 2 and len(episode.subgoals) == episode.info["attempts"]
