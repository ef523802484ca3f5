"""The paper's experiment protocol: trials over methods and seeds, summary and panels.

Exports are imported on first use (PEP 562): the CLI reads :class:`ExperimentConfig`'s defaults for its
help without loading torch.
"""

from antmaze_hirl._lazy import lazy_exports

_EXPORTS = {
    "DAggerTensorBoard": "antmaze_hirl.experiments.tensorboard",
    "ExperimentConfig": "antmaze_hirl.experiments.config",
    "cost_to_reach": "antmaze_hirl.experiments.summary",
    "normalised_auc": "antmaze_hirl.experiments.curves",
    "paired_comparison": "antmaze_hirl.experiments.uncertainty",
    "run_experiment": "antmaze_hirl.experiments.runner",
    "run_trial": "antmaze_hirl.experiments.runner",
    "success_at_labels": "antmaze_hirl.experiments.curves",
    "summarise": "antmaze_hirl.experiments.summary",
    "wilson_interval": "antmaze_hirl.experiments.uncertainty",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS, globals())
