"""What Stable-Baselines3 lacks for this job: low-level training helpers, checkpoints, evaluation."""

from antmaze_hirl.sb3_ext.checkpoint import CheckpointCallback, CheckpointError, latest_checkpoint, save_checkpoint
from antmaze_hirl.sb3_ext.config import LowLevelConfig, load_config
from antmaze_hirl.sb3_ext.evaluation import SuccessRateCallback, evaluate_reach
from antmaze_hirl.sb3_ext.training import make_model, train_low_level

__all__ = [
    "CheckpointCallback",
    "CheckpointError",
    "LowLevelConfig",
    "SuccessRateCallback",
    "evaluate_reach",
    "latest_checkpoint",
    "load_config",
    "make_model",
    "save_checkpoint",
    "train_low_level",
]
