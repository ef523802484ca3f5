"""Per-method figures of an experiment: final success over seeds, expert cost, attempts."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

TARGET_SUCCESS = 0.6


def _spread(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"median": None, "min": None, "max": None}
    return {"median": float(np.median(values)), "min": float(np.min(values)), "max": float(np.max(values))}


def cost_to_reach(rows: Sequence[dict[str, Any]], target: float = TARGET_SUCCESS) -> float | None:
    """Cumulative expert cost at the first learner-only evaluation with success >= ``target`` (one trial)."""
    for row in rows:
        if not math.isnan(row["eval_success"]) and row["eval_success"] >= target:
            return float(row["cumulative_expert_cost"])
    return None


def summarise(rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Summary per method over seeds.

    For each method: final learner-only success (median, min, max over seeds), mean expert cost per
    episode, mean attempts per episode, and the cumulative expert cost to first reach 60% learner-only
    success (median over the seeds that reached it, and how many did).
    """
    summary = {}
    for method in methods:
        trials: dict[float, list[dict[str, Any]]] = {}
        for row in rows:
            if row["method"] == method:
                trials.setdefault(row["seed"], []).append(row)
        if not trials:
            summary[method] = {"seeds": 0}
            continue
        finals = [trial[-1]["eval_success"] for trial in trials.values()]
        costs = [cost for trial in trials.values() if (cost := cost_to_reach(trial)) is not None]
        method_rows = [row for trial in trials.values() for row in trial]
        summary[method] = {
            "seeds": len(trials),
            "final_success": _spread(finals),
            "mean_expert_cost_per_episode": float(np.mean([row["expert_cost"] for row in method_rows])),
            "mean_attempts_per_episode": float(np.mean([row["attempts"] for row in method_rows])),
            "cost_to_60_percent": {"median": float(np.median(costs)) if costs else None, "seeds_reached": len(costs)},
        }
    return summary
