"""The maze envs record every constructor parameter for EzPickle (pickles and lockstep copies rebuild from them)."""

import inspect

import numpy as np
import pytest

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


def test_a_positional_name_missing_from_the_parameters_is_refused():
    class Recorder:
        pass

    with pytest.raises(KeyError, match="maze_map"):
        record_constructor_arguments(Recorder(), {"self": None, "body": "ant"})  # type: ignore[arg-type]
