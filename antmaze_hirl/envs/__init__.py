"""Maze layouts, the low-level goal-reaching env and the high-level subgoal-selection env.

The bottom layer of the package: it imports nothing from ``experts``, ``sb3_ext``, ``dagger``,
``experiments`` or the CLI, and any controller (an SB3 model or a callable) can drive its high-level env.
Exports are imported on first use (PEP 562), so that :mod:`antmaze_hirl.envs.bodies` (the CLI's body
choices) is read without loading MuJoCo.
"""

# _notices runs before any module of this package imports gymnasium-robotics.
from antmaze_hirl._lazy import lazy_exports
from antmaze_hirl.envs import _notices  # noqa: F401

_EXPORTS = {
    "STANDARD_MAPS": "antmaze_hirl.envs.layouts",
    "ActionSmoother": "antmaze_hirl.envs.controllers",
    "AgentPath": "antmaze_hirl.envs.high_level",
    "BatchController": "antmaze_hirl.envs.controllers",
    "HighLevelVectorEnv": "antmaze_hirl.envs.vector",
    "as_batch_controller": "antmaze_hirl.envs.controllers",
    "inference_threads": "antmaze_hirl.envs.controllers",
    "BirdseyeRenderer": "antmaze_hirl.envs.birdseye",
    "HighLevelMazeEnv": "antmaze_hirl.envs.high_level",
    "LowLevelController": "antmaze_hirl.envs.controllers",
    "MazeEnvProtocol": "antmaze_hirl.envs.protocol",
    "MazeGeometry": "antmaze_hirl.envs.geometry",
    "MazeLayout": "antmaze_hirl.envs.layouts",
    "PointGoToController": "antmaze_hirl.envs.controllers",
    "PredictController": "antmaze_hirl.envs.controllers",
    "ReachEnv": "antmaze_hirl.envs.reach",
    "SmoothedController": "antmaze_hirl.envs.controllers",
    "TiltDampedController": "antmaze_hirl.envs.controllers",
    "STATE_LAYOUT": "antmaze_hirl.envs.state_layout",
    "HighLevelStateLayout": "antmaze_hirl.envs.state_layout",
    "Task": "antmaze_hirl.envs.task",
    "as_controller": "antmaze_hirl.envs.controllers",
    "generate_layout": "antmaze_hirl.envs.layouts",
    "layout_from_map": "antmaze_hirl.envs.layouts",
    "maze_env": "antmaze_hirl.envs.protocol",
    "shortest_path": "antmaze_hirl.envs.layouts",
    "validate_maze_map": "antmaze_hirl.envs.layouts",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS, globals())
