"""antmaze_hirl.envs.profiles, the one home of the fixed facts: the values every reader had before it (0.2.0).

A one-off regression guard: the literals below are the values the modules restated before they read them from
``profiles``. A change to one of them is a change of committed figures, so it must be made here on purpose.
"""

import ast
import inspect
from pathlib import Path

import pytest

from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED
from antmaze_hirl.dagger.high_level_policy import LearnerSettings
from antmaze_hirl.envs import profiles, suite_specs
from antmaze_hirl.envs.bodies import BODY_SPECS, BodySpec
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.high_level import HighLevelMazeEnv
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments.config import BODY_DEFAULTS, HELD_OUT_MAZE_SIZE, SELECTION_SEED, body_settings
from antmaze_hirl.registration import ENV_IDS, VECTOR_ENTRY_POINTS

ROOT = Path(__file__).parents[1]


def test_the_body_facts_are_the_values_of_before():
    assert BODY_SPECS == {
        "ant": BodySpec(scale=4.0, success_radius_m=0.45, default_horizon=100, dt=0.05, default_action_scale=0.5),
        "point": BodySpec(scale=1.0, success_radius_m=0.2, default_horizon=50, dt=0.01, default_action_scale=1.0),
    }
    assert BODY_DEFAULTS == {
        "point": {"maze_size": 5, "subgoal_reach_m": None},
        "ant": {"maze_size": 3, "subgoal_reach_m": 2.0},
    }
    assert HELD_OUT_MAZE_SIZE == {"point": 5, "ant": 4}
    assert body_settings("ant", held_out_layouts=True) == {"maze_size": 4, "subgoal_reach_m": 2.0}
    for body, profile in profiles.BODY_PROFILES.items():
        assert profile.body == body and profile.spec is BODY_SPECS[body]
    point_map, ant_map = MazeGeometry(7, 7, 1.0), MazeGeometry(6, 6, 4.0)
    assert LearnerSettings.for_body("point", point_map) == LearnerSettings(
        head="next_cell", planning_iterations=16, block_walls=True
    )
    assert LearnerSettings.for_body("ant", ant_map) == LearnerSettings(head="next_cell")
    assert LearnerSettings.for_body(None, point_map) == LearnerSettings()


def test_the_seed_table_is_the_values_of_before():
    assert (HELD_OUT_SEED, SELECTION_SEED) == (1_000_000, 3_000_000)
    assert profiles.SEEDS == profiles.SeedTable(1_000_000, 2_000_000, 3_000_000, 10_000, 100_000, 0, 4_000_000)
    from antmaze_hirl.sb3_ext.evaluation import SuccessRateCallback

    assert inspect.signature(SuccessRateCallback).parameters["seed"].default == 10_000
    from antmaze_hirl.cli import build_parser

    # eval-low's --seed default restates the table's value (left in cli.py while eval-low is being edited).
    assert build_parser().parse_args(["eval-low", "--body", "point"]).seed == profiles.SEEDS.low_level_report_subgoals


@pytest.mark.integration  # a lab check: reads antmaze_lab's families and selection seeds
def test_the_ids_and_the_maze_families_are_the_values_of_before():
    ids = [
        "antmaze_hirl/AntReach-v0",
        "antmaze_hirl/PointReach-v0",
        "antmaze_hirl/AntMaze-v0",
        "antmaze_hirl/PointMaze-v0",
    ]
    assert sorted(ENV_IDS) == sorted(VECTOR_ENTRY_POINTS) == sorted(ids)
    assert [profiles.BODY_PROFILES[body].reach_env_id for body in ("ant", "point")] == ids[:2]
    assert [profiles.maze_env_id(body) for body in ("ant", "point")] == ids[2:]
    assert ENV_IDS["antmaze_hirl/PointMaze-v0"] == ("antmaze_hirl.sb3_ext.shipped:make_maze_env", {"body": "point"})
    assert inspect.signature(HighLevelMazeEnv).parameters["max_steps"].default == 500
    from antmaze_lab import in_maze_protocol as in_maze
    from antmaze_lab import select_low_level

    assert in_maze.FAMILIES == ("ant3", "ant4", "u", "medium", "large")
    assert in_maze.SELECTION_FAMILIES == {"select4": 4, "select6": 6}
    assert (in_maze.STEPS_PER_METRE, in_maze.MIN_STEPS) == (40, 500)
    scaled = {name: family.step_limit is None for name, family in profiles.MAZE_FAMILIES.items()}
    assert scaled == {
        "ant3": False,
        "ant4": False,
        "u": True,
        "medium": True,
        "large": True,
        "select4": False,
        "select6": True,
    }
    assert select_low_level.SELECTION_MAZE_SEED == 2_000_000
    assert select_low_level.RESERVED_SUBGOAL_SEEDS == (range(0, 1_000), range(10_000, 20_000))


def test_the_suites_read_their_ids_and_step_limits_from_their_families_with_the_values_of_before():
    assert list(profiles.SUITE_FAMILIES) == list(SUITE_SPECS)  # the order sets each suite's seed
    assert {
        name: (spec.env_id, spec.body, spec.maze_size, spec.max_low_level_steps) for name, spec in SUITE_SPECS.items()
    } == {
        "point5": ("antmaze_hirl/PointMaze-5x5-v0", "point", 5, 500),
        "ant4": ("antmaze_hirl/AntMaze-4x4-v0", "ant", 4, 500),
        "u": ("antmaze_hirl/AntMaze-u-v0", "ant", None, 960),
        "medium": ("antmaze_hirl/AntMaze-medium-v0", "ant", None, 1600),
        "large": ("antmaze_hirl/AntMaze-large-v0", "ant", None, 3040),
        "giant": ("antmaze_hirl/AntMaze-giant-v0", "ant", None, 4800),
        # The point's 1 m cells: 40 steps a metre of path, at least 500.
        "point-u": ("antmaze_hirl/PointMaze-u-v0", "point", None, 500),
        "point-medium": ("antmaze_hirl/PointMaze-medium-v0", "point", None, 500),
        "point-large": ("antmaze_hirl/PointMaze-large-v0", "point", None, 760),
        "point-giant": ("antmaze_hirl/PointMaze-giant-v0", "point", None, 1200),
    }
    assert profiles.path_scaled_step_limit(4.0) == 500 and profiles.path_scaled_step_limit(24.1) == 964


def test_a_suite_spec_without_the_longest_path_its_family_needs_is_refused_naming_the_suite():
    with pytest.raises(ValueError, match=r"^suite 'u': longest_path_cells=None; give it exactly for a path-scaled"):
        suite_specs._suite_spec("u", 5, "0" * 64)
    with pytest.raises(ValueError, match=r"^suite 'ant4': longest_path_cells=3;"):
        suite_specs._suite_spec("ant4", 100, "0" * 64, longest_path_cells=3)


def test_profiles_imports_only_the_standard_library():
    tree = ast.parse((ROOT / "antmaze_hirl" / "envs" / "profiles.py").read_text())
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    assert imported == {"__future__", "dataclasses", "math", "typing"}


def test_the_profiles_reach_has_the_one_name_of_the_oracles_reach():
    # subgoal_reach_m everywhere in the API (PathOracle, the learner, --subgoal-reach-m); no fourth spelling.
    ant, point = profiles.BODY_PROFILES["ant"], profiles.BODY_PROFILES["point"]
    assert ant.subgoal_reach_m == 2.0 and point.subgoal_reach_m is None
    assert not hasattr(ant, "oracle_reach_m")
