"""The report's own figures: questionnaire bars and per-participant values per method.

Figures come from :mod:`antmaze_hirl.plotting` (a ``Figure`` on an Agg canvas), so nothing here touches
pyplot's global state or the backend, and each PNG is written atomically.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from antmaze_hirl.plotting import new_figure, save_figure


def save_likert(
    items: Sequence[tuple[str, Mapping[str, Mapping[str, Any]]]],
    methods: Sequence[str],
    names: Mapping[str, str],
    path: str | Path,
) -> Path:
    """One bar chart per questionnaire item: mean rating per method with standard-error bars.

    Args:
        items: ``(title, {method: {"mean": ..., "se": ...}})`` per item (``None`` where unknown).
        methods: The methods, in bar order.
        names: What to call each method on the axis.
        path: The PNG to write.

    Returns:
        ``path``.
    """
    columns = 3
    rows = max(1, -(-len(items) // columns))
    fig = new_figure(figsize=(4.5 * columns, 3.4 * rows))
    x = np.arange(len(methods))
    for i, (title, summary) in enumerate(items):
        ax = fig.add_subplot(rows, columns, i + 1)
        means = [summary[m]["mean"] for m in methods]
        errors = [summary[m]["se"] for m in methods]
        ax.bar(x, [np.nan if v is None else v for v in means], yerr=[0 if e is None else e for e in errors], capsize=4)
        ax.set_xticks(x, [names[m] for m in methods], rotation=20, fontsize=8)
        ax.set_ylim(0, 5.5)
        ax.set_title(title)
        ax.set_ylabel("rating (1-5), mean ± SE")
        ax.grid(axis="y", alpha=0.3)
    return save_figure(fig, path)


def save_per_participant(
    panels: Sequence[tuple[str, pd.DataFrame]], methods: Sequence[str], names: Mapping[str, str], path: str | Path
) -> Path:
    """Each participant's value per method as a dot, with the median over participants as a line.

    Args:
        panels: ``(y-axis label, frame)`` per subplot; frame columns ``participant``, ``method``, ``value``.
        methods: The methods, in axis order.
        names: What to call each method on the axis.
        path: The PNG to write.

    Returns:
        ``path``.
    """
    fig = new_figure(figsize=(5 * len(panels), 3.8))
    for i, (ylabel, frame) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), i + 1)
        for x, method in enumerate(methods):
            values = frame.loc[frame["method"] == method, "value"].dropna().to_numpy()
            if values.size == 0:
                continue
            # Spread the dots sideways so participants with equal values stay countable.
            offsets = np.linspace(-0.15, 0.15, values.size) if values.size > 1 else np.zeros(1)
            ax.plot(x + offsets, values, "o", alpha=0.7, color="C0")
            ax.plot([x - 0.25, x + 0.25], [np.median(values)] * 2, color="C1", linewidth=2)
        ax.set_xticks(np.arange(len(methods)), [names[m] for m in methods], rotation=20, fontsize=8)
        ax.set_xlim(-0.6, len(methods) - 0.4)
        ax.set_ylabel(ylabel)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("dots: participants; lines: median over participants", fontsize=9)
    return save_figure(fig, path)
