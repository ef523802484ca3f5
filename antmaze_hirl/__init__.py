"""antmaze_hirl: active hierarchical imitation and reinforcement learning on the MuJoCo Ant maze.

Importing the package registers its Gymnasium ids (``antmaze_hirl/AntReach-v0``,
``antmaze_hirl/PointReach-v0``, ``antmaze_hirl/AntMaze-v0``, ``antmaze_hirl/PointMaze-v0``).
"""

from antmaze_hirl.envs import HighLevelMazeEnv, ReachEnv, register_envs
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.sb3_ext.policies import load_low_level

__version__ = "0.1.0"

register_envs()

__all__ = ["HighLevelMazeEnv", "PathOracle", "ReachEnv", "__version__", "load_low_level", "register_envs"]
