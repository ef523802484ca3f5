"""Every figure of ``docs/paper-claims.md``, printed from the committed results folders (issue 32).

The committed folders (``benchmarks/results/paper_experiment_{point,ant}``) were made with protocol 1
and its known flaws (issue 32's audit): held out by raw wall grid, not up to symmetry; the point's
default learner solves the mazes untrained; Alg. 2's score had no signal; the final set differs from the
periodic one. This prints, per body and method, what the claims table quotes: final success (median,
min-max over seeds, the paired Wilcoxon p against DAgger), labels per trial, labels to DAgger's median
final success and that ratio, the training episodes (and labels) at which each trial's learner first
scored >= 60% on a periodic evaluation, and the share of labels reward-based pruning removed.

Usage: python benchmarks/paper_claims.py [--folders benchmarks/results/paper_experiment_point,...]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from antmaze_hirl.experiments.results_folder import read_rows
from antmaze_hirl.experiments.summary import median_range, trials_by_method

RESULTS = Path(__file__).parent / "results"
FOLDERS = [RESULTS / "paper_experiment_point", RESULTS / "paper_experiment_ant"]


def first_at(trial: list[dict], target: float = 0.6) -> tuple[float, float] | None:
    """Training episodes and labels at the trial's first evaluation with success >= ``target``."""
    for row in trial:
        if not math.isnan(row["eval_success"]) and row["eval_success"] >= target:
            return float(row["episode"] + 1), float(row["cumulative_expert_cost"])
    return None


def claims(folder: Path) -> dict:
    """The figures of one results folder."""
    summary = json.loads((folder / "summary.json").read_text())
    rows = read_rows(folder / "episodes.csv")
    methods = [m for m, f in summary["methods"].items() if f.get("seeds")]
    grouped = trials_by_method(rows, methods)
    out = {"folder": str(folder), "config": summary["config"], "methods": {}}
    for method in methods:
        figures = summary["methods"][method]
        trials = grouped[method]
        reached = [first_at(trial) for trial in trials.values()]
        removed = sum(int(row["removed"]) for trial in trials.values() for row in trial)
        labels = sum(int(trial[-1]["cumulative_expert_cost"]) for trial in trials.values())
        match = figures.get("labels_to_match_dagger", {})
        out["methods"][method] = {
            "seeds": figures["seeds"],
            "final_success": {k: figures["final_success"][k] for k in ("median", "min", "max")},
            "final_success_p_vs_dagger": figures.get("vs_dagger", {}).get("final_success", {}).get("wilcoxon_p"),
            "total_labels": figures["total_labels"],
            "labels_to_match_dagger": {k: match.get(k) for k in ("target", "median", "seeds_reached")},
            "labels_ratio_vs_dagger": match.get("ratio_vs_dagger"),
            "episodes_to_60_percent": median_range([r[0] if r else None for r in reached]),
            "labels_to_60_percent": median_range([r[1] if r else None for r in reached]),
            "trials_reaching_60_percent": sum(r is not None for r in reached),
            "labels_removed_by_pruning": removed,
            "labels_spent": labels,
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--folders", default=",".join(str(f) for f in FOLDERS))
    args = parser.parse_args()
    for folder in [Path(f) for f in args.folders.split(",")]:
        result = claims(folder)
        print(f"== {folder.name} (body {result['config']['body']}, protocol 1)")
        for method, figures in result["methods"].items():
            print(method, json.dumps(figures, default=lambda v: None if isinstance(v, float) and np.isnan(v) else v))


if __name__ == "__main__":
    main()
