"""The high-level maze env's protocol: every way of making one provides it, and the layers above read it only."""

import ast
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from conftest import TINY_PROTOCOL2, StillController

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import DAggerTrainer
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.envs.high_level import HighLevelMazeEnv
from antmaze_hirl.envs.profiles import maze_env_id, reach_env_id
from antmaze_hirl.envs.protocol import MAZE_ENV_MEMBERS, MazeEnvProtocol, maze_env
from antmaze_hirl.envs.split_env import SplitMazeEnv
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments import ExperimentConfig
from antmaze_hirl.experiments.old_folders import SETTINGS_BEFORE_PROTOCOL_2
from antmaze_hirl.experiments.runner import make_env
from antmaze_hirl.sb3_ext.shipped import make_maze_vector_env

DAGGER = Path(__file__).resolve().parents[1] / "antmaze_hirl" / "dagger"


def low_level(body):
    return PointGoToController() if body == "point" else StillController()


@pytest.mark.parametrize("body", ["point", "ant"])
def test_the_registered_maze_ids_provide_the_protocol_under_their_wrappers(body):
    env = gym.make(maze_env_id(body), maze_size=3, low_level=low_level(body))
    assert not isinstance(env, MazeEnvProtocol)  # gym.make wraps it: the wrappers forward no attributes
    assert isinstance(env.unwrapped, MazeEnvProtocol)
    assert maze_env(env) is env.unwrapped
    assert maze_env(env.unwrapped) is env.unwrapped
    env.close()


def test_the_split_env_provides_the_protocol_made_directly_or_through_the_maze_id():
    direct = SplitMazeEnv("point", split="eval", maze_size=4, low_level=PointGoToController())
    made = gym.make(maze_env_id("point"), maze_size=4, low_level=PointGoToController(), split="eval")
    for env in (direct, made):
        maze = maze_env(env)
        assert isinstance(maze, SplitMazeEnv) and maze.split == "eval"
        assert isinstance(maze, MazeEnvProtocol)
        env.close()


def test_the_suite_ids_provide_the_protocol():
    spec = next(iter(SUITE_SPECS.values()))
    env = gym.make(spec.env_id, low_level=low_level(spec.body))
    assert isinstance(maze_env(env), HighLevelMazeEnv)
    env.close()


def test_the_experiment_makes_every_env_with_gym_make_split_or_not():
    held_out = make_env(TINY_PROTOCOL2, PointGoToController(), split="train")
    assert isinstance(held_out, gym.Wrapper) and type(held_out.unwrapped) is SplitMazeEnv
    assert held_out.unwrapped.split == "train"
    whole = make_env(ExperimentConfig(maze_size=3, **SETTINGS_BEFORE_PROTOCOL_2), PointGoToController(), split="train")
    assert isinstance(whole, gym.Wrapper) and type(whole.unwrapped) is HighLevelMazeEnv  # split ignored
    held_out.close()
    whole.close()


def test_the_vector_factory_draws_from_a_split_as_the_single_one():
    vector = make_maze_vector_env(2, "point", low_level=PointGoToController(), split="selection", maze_size=4)
    assert [type(env) for env in vector.envs] == [SplitMazeEnv, SplitMazeEnv]
    assert {env.split for env in vector.envs} == {"selection"}
    vector.close()


def test_an_env_without_the_protocol_is_refused_in_one_line_naming_its_type():
    reach = gym.make(reach_env_id("point"))
    with pytest.raises(TypeError, match=r"got ReachEnv without .*goal_xy") as error:
        maze_env(reach)
    assert "\n" not in str(error.value)
    with pytest.raises(TypeError, match="got ReachEnv"):
        PathOracle.for_env(reach)
    rng = np.random.default_rng(0)
    with pytest.raises(TypeError, match="got ReachEnv"):
        DAggerTrainer(env=reach, expert=None, learner=None, rng=rng)
    with pytest.raises(TypeError, match="got NoneType without action_space, body, geometry"):
        maze_env(None)
    reach.close()


def test_the_listed_members_are_the_protocols():
    hints = MazeEnvProtocol.__annotations__
    methods = {name for name, value in vars(MazeEnvProtocol).items() if not name.startswith("_") and callable(value)}
    properties = {name for name, value in vars(MazeEnvProtocol).items() if isinstance(value, property)}
    assert set(MAZE_ENV_MEMBERS) == set(hints) | methods | properties
    assert list(MAZE_ENV_MEMBERS) == sorted(MAZE_ENV_MEMBERS)


def unwrapped_reads(path):
    tree = ast.parse(path.read_text(), filename=str(path))
    return [node.lineno for node in ast.walk(tree) if isinstance(node, ast.Attribute) and node.attr == "unwrapped"]


def test_the_dagger_layer_reads_the_env_through_the_protocol_only():
    reads = {path.name: unwrapped_reads(path) for path in sorted(DAGGER.glob("*.py"))}
    offending = {name: lines for name, lines in reads.items() if lines}
    assert not offending, f"read maze_env(env) instead of env.unwrapped: {offending}"
