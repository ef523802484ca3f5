"""Maze layouts, the low-level goal-reaching env and the high-level subgoal-selection env.

The bottom layer of the package: it imports nothing from ``experts``, ``sb3_ext``, ``dagger``,
``experiments`` or the CLI, and any controller (an SB3 model or a callable) can drive its high-level env.
"""

# First, before any module below imports gymnasium-robotics (see _notices).
from antmaze_hirl.envs import _notices  # noqa: F401
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

__all__ = [
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
    "shortest_path",
    "validate_maze_map",
]
