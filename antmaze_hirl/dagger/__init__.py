"""DAgger for the high level: trainer, beta schedules, active-learning strategies, data, the learner."""

from antmaze_hirl.dagger.dataset import Demonstration, DemonstrationDataset
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED, evaluate_high_level
from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy, LearnerSettings
from antmaze_hirl.dagger.protocols import Learner, OffsetLearner
from antmaze_hirl.dagger.schedules import (
    BetaSchedule,
    InverseDecayBetaSchedule,
    LinearBetaSchedule,
)
from antmaze_hirl.dagger.shipped import load_shipped_learner, shipped_learner_path, shipped_learner_record
from antmaze_hirl.dagger.strategies import (
    STRATEGIES,
    AggreVaTeQuery,
    DAggerQuery,
    GatedQuery,
    MultiPolicyQuery,
    NoiseQuery,
    QueryStrategy,
    RewardBasedQuery,
    RewardPerStepQuery,
    make_strategy,
)
from antmaze_hirl.dagger.trainer import DAggerTrainer, EpisodeRecord

__all__ = [
    "HELD_OUT_SEED",
    "STRATEGIES",
    "AggreVaTeQuery",
    "BetaSchedule",
    "DAggerQuery",
    "DAggerTrainer",
    "Demonstration",
    "DemonstrationDataset",
    "EpisodeRecord",
    "GatedQuery",
    "HighLevelPolicy",
    "InverseDecayBetaSchedule",
    "Learner",
    "LearnerSettings",
    "LinearBetaSchedule",
    "MultiPolicyQuery",
    "NoiseQuery",
    "OffsetLearner",
    "QueryStrategy",
    "RewardBasedQuery",
    "RewardPerStepQuery",
    "evaluate_high_level",
    "load_shipped_learner",
    "make_strategy",
    "shipped_learner_path",
    "shipped_learner_record",
]
