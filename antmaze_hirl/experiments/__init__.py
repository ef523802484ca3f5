"""The paper's experiment protocol: trials over methods and seeds, summary and panels."""

from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.curves import normalised_auc, success_at_labels
from antmaze_hirl.experiments.runner import run_experiment, run_trial
from antmaze_hirl.experiments.summary import cost_to_reach, summarise
from antmaze_hirl.experiments.uncertainty import paired_comparison, wilson_interval

__all__ = [
    "ExperimentConfig",
    "cost_to_reach",
    "normalised_auc",
    "paired_comparison",
    "run_experiment",
    "run_trial",
    "success_at_labels",
    "summarise",
    "wilson_interval",
]
