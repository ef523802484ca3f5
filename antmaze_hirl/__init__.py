"""antmaze_hirl: active hierarchical imitation and reinforcement learning on the MuJoCo Ant maze.

Importing the package registers its Gymnasium ids (antmaze_hirl/AntReach-v0, antmaze_hirl/PointReach-v0,
antmaze_hirl/AntMaze-v0, antmaze_hirl/PointMaze-v0, and the benchmark suites' ids of
:mod:`antmaze_hirl.envs.suite_specs`) and nothing more: the exports below are imported on
first use (PEP 562), so that registration, ``gym.make`` of a reach id and ``antmaze-hirl --help`` load
neither torch nor Stable-Baselines3.
"""

from antmaze_hirl._lazy import lazy_exports
from antmaze_hirl.registration import ENV_IDS, register_envs

__version__ = "0.2.0"

register_envs()

_EXPORTS = {
    "HierarchicalAgent": "antmaze_hirl.dagger.agent",
    "HighLevelMazeEnv": "antmaze_hirl.envs.high_level",
    "PathOracle": "antmaze_hirl.experts.oracle",
    "ReachEnv": "antmaze_hirl.envs.reach",
    "load_low_level": "antmaze_hirl.sb3_ext.loading",
}

__getattr__, __dir__, _lazy_all = lazy_exports(__name__, _EXPORTS, globals())

# Besides the lazy exports, the names defined or imported above. Written out, those three are what a static reader
# sees (ruff takes ENV_IDS and register_envs as re-exports); pyright and griffe do not evaluate *_lazy_all, so the
# lazy exports are listed for `import *` and dir() at run time only (test_layers checks them).
__all__ = ["ENV_IDS", "__version__", "register_envs", *_lazy_all]
