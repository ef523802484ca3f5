"""The paper's experiment protocol: trials over methods and seeds, summary and panels."""

from antmaze_hirl.experiments.runner import ExperimentConfig, run_experiment, run_trial
from antmaze_hirl.experiments.summary import cost_to_reach, summarise

__all__ = ["ExperimentConfig", "cost_to_reach", "run_experiment", "run_trial", "summarise"]
