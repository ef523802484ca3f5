"""Maze layouts, the low-level goal-reaching env and the high-level subgoal-selection env."""

from antmaze_hirl.envs.birdseye import BirdseyeRenderer
from antmaze_hirl.envs.controllers import LowLevelController, PointGoToController, PredictController, as_controller
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.high_level import HighLevelMazeEnv
from antmaze_hirl.envs.layouts import (
    STANDARD_MAPS,
    MazeLayout,
    generate_layout,
    layout_from_map,
    shortest_path,
    validate_maze_map,
)
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.envs.registration import ENV_IDS, register_envs

__all__ = [
    "ENV_IDS",
    "STANDARD_MAPS",
    "BirdseyeRenderer",
    "HighLevelMazeEnv",
    "LowLevelController",
    "MazeGeometry",
    "MazeLayout",
    "PointGoToController",
    "PredictController",
    "ReachEnv",
    "as_controller",
    "generate_layout",
    "layout_from_map",
    "register_envs",
    "shortest_path",
    "validate_maze_map",
]
