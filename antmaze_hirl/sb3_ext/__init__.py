"""What Stable-Baselines3 lacks for this job: low-level training helpers, checkpoints, evaluation, loading.

Exports are imported on first use (PEP 562): ``gym.make`` of a maze id imports
:mod:`antmaze_hirl.sb3_ext.shipped` through this package, and must not pay for training's imports.
"""

from antmaze_hirl._lazy import lazy_exports

_EXPORTS = {
    "CheckpointError": "antmaze_hirl.sb3_ext.checkpoint",
    "LowLevelConfig": "antmaze_hirl.sb3_ext.config",
    "RunCheckpointCallback": "antmaze_hirl.sb3_ext.checkpoint",
    "SuccessRateCallback": "antmaze_hirl.sb3_ext.evaluation",
    "evaluate_reach": "antmaze_hirl.sb3_ext.evaluation",
    "latest_checkpoint": "antmaze_hirl.sb3_ext.checkpoint",
    "load_config": "antmaze_hirl.sb3_ext.config",
    "load_low_level": "antmaze_hirl.sb3_ext.loading",
    "load_shipped_policy": "antmaze_hirl.sb3_ext.shipped",
    "make_model": "antmaze_hirl.sb3_ext.training",
    "save_checkpoint": "antmaze_hirl.sb3_ext.checkpoint",
    "save_policy": "antmaze_hirl.sb3_ext.loading",
    "train_low_level": "antmaze_hirl.sb3_ext.training",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS, globals())
