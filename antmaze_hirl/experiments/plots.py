"""The paper's three panels: success vs episode, success vs expert cost, attempts vs episode."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def _per_seed(rows: Sequence[dict[str, Any]], method: str, key: str, evaluated_only: bool) -> np.ndarray:
    """``(seeds, points)`` array of ``key`` for one method (evaluation rows only, if asked)."""
    trials: dict[float, list[float]] = {}
    for row in rows:
        if row["method"] == method and (not evaluated_only or not math.isnan(row["eval_success"])):
            trials.setdefault(row["seed"], []).append(float(row[key]))
    length = min((len(values) for values in trials.values()), default=0)
    return np.array([values[:length] for values in trials.values()])


def draw_band(ax: Any, x: np.ndarray, values: np.ndarray, label: str) -> Any:
    """Draws the median over seeds (rows of ``values``) against ``x``, with a min-max band.

    A curve of one point gets a marker and a min-max error bar: a one-point line and band draw nothing.

    Returns:
        The median's ``Line2D``.
    """
    single = len(x) == 1
    line = ax.plot(x, np.median(values, axis=0), label=label, marker="o" if single else None)[0]
    if single:
        median = np.median(values, axis=0)
        spread = [median - values.min(axis=0), values.max(axis=0) - median]
        ax.errorbar(x, median, yerr=spread, color=line.get_color(), capsize=3, linestyle="none")
    else:
        ax.fill_between(x, values.min(axis=0), values.max(axis=0), color=line.get_color(), alpha=0.2)
    return line


def plot_panels(
    rows: Sequence[dict[str, Any]], methods: Sequence[str], out_file: str | Path, *, title: str = ""
) -> Path:
    """Saves the three panels (median over seeds, min-max band) as one PNG.

    Returns:
        The path of the written file.
    """
    out_file = Path(out_file)
    out_file.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for method in methods:
        success = _per_seed(rows, method, "eval_success", evaluated_only=True)
        if success.size == 0:
            continue
        episodes = np.median(_per_seed(rows, method, "episode", evaluated_only=True), axis=0) + 1
        cost = np.median(_per_seed(rows, method, "cumulative_expert_cost", evaluated_only=True), axis=0)
        draw_band(axes[0], episodes, success, method)
        draw_band(axes[1], cost, success, method)
        attempts = _per_seed(rows, method, "attempts", evaluated_only=False)
        draw_band(axes[2], np.arange(1, attempts.shape[1] + 1), attempts, method)
    labels = [
        ("episode", "learner-only success rate"),
        ("cumulative expert cost (labels)", "learner-only success rate"),
        ("episode", "attempts (subgoals per episode)"),
    ]
    for ax, (xlabel, ylabel) in zip(axes, labels, strict=True):
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-0.02, 1.02)
    axes[1].set_ylim(-0.02, 1.02)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out_file, dpi=110)
    plt.close(fig)
    return out_file
