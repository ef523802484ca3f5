"""The maze envs record every constructor parameter for EzPickle (pickles and lockstep copies rebuild from them)."""

import inspect

import numpy as np
import pytest
from gymnasium.utils.ezpickle import EzPickle

from antmaze_hirl.envs._constructor_args import record_constructor_arguments
from antmaze_hirl.envs.high_level import HighLevelMazeEnv
from antmaze_hirl.envs.reach import ReachEnv


@pytest.mark.parametrize("env_class", [ReachEnv, HighLevelMazeEnv])
def test_every_parameter_is_recorded_body_and_map_by_position(env_class):
    low_level = (lambda obs: np.zeros(2)) if env_class is HighLevelMazeEnv else None
    kwargs = {"low_level": low_level} if low_level is not None else {}
    env = env_class("point", "open", horizon=7, **kwargs)
    names = [name for name in inspect.signature(env_class).parameters]
    assert env._ezpickle_args == ("point", "open")
    assert list(env._ezpickle_kwargs) == names[2:]
    assert env._ezpickle_kwargs["horizon"] == 7
    env.close()


class OnlyBody:
    def __init__(self, body):
        record_constructor_arguments(self, locals(), OnlyBody)  # type: ignore[arg-type]


class Late:
    def __init__(self, body, maze_map):
        size = 3  # bound before the call: locals() now holds more than the parameters
        record_constructor_arguments(self, locals(), Late)  # type: ignore[arg-type]
        self.size = size


class WithExtra(ReachEnv):
    """As the suite and split envs: the parent records its own parameters, then the subclass records again."""

    def __init__(self, body="point", maze_map="open", *, extra=1):
        super().__init__(body, maze_map)
        EzPickle.__init__(self, body, maze_map, extra=extra)


def test_a_positional_name_missing_from_the_parameters_is_refused():
    with pytest.raises(KeyError, match="maze_map"):
        OnlyBody("ant")


def test_a_call_after_the_constructor_bound_another_name_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"Late: not its parameters: extra \['size'\], missing \[\]"):
        Late("ant", "open")


def test_a_subclass_with_other_parameters_builds_its_parent_checked_against_the_parent():
    env = WithExtra(extra=2)
    assert env._ezpickle_args == ("point", "open") and env._ezpickle_kwargs == {"extra": 2}
    env.close()
