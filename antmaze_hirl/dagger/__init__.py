"""DAgger for the high level: trainer, beta schedules, active-learning strategies, policy."""

from antmaze_hirl.dagger.dataset import Demonstration, DemonstrationDataset
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED, evaluate_high_level
from antmaze_hirl.dagger.policy import HighLevelPolicy
from antmaze_hirl.dagger.schedules import BetaSchedule, ExponentialBetaSchedule, LinearBetaSchedule
from antmaze_hirl.dagger.strategies import (
    STRATEGIES,
    MultiPolicyQuery,
    NoiseQuery,
    QueryStrategy,
    RewardBasedQuery,
    make_strategy,
)
from antmaze_hirl.dagger.trainer import DAggerTrainer, EpisodeRecord

__all__ = [
    "HELD_OUT_SEED",
    "STRATEGIES",
    "BetaSchedule",
    "DAggerTrainer",
    "Demonstration",
    "DemonstrationDataset",
    "EpisodeRecord",
    "ExponentialBetaSchedule",
    "HighLevelPolicy",
    "LinearBetaSchedule",
    "MultiPolicyQuery",
    "NoiseQuery",
    "QueryStrategy",
    "RewardBasedQuery",
    "evaluate_high_level",
    "make_strategy",
]
