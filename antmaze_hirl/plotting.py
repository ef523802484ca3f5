"""Every picture of the package: mazes and paths, learning curves, the experiment's panels.

Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas, never through pyplot: importing
this module leaves the backend a notebook user chose alone, touches no global figure state, and works
headless. Each PNG is written atomically, so a reader never sees half a file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from antmaze_hirl.atomic_io import atomic_write_with
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.rollout import HighLevelEpisode

__all__ = [
    "draw_band",
    "new_figure",
    "plot_episode",
    "plot_learning_curves",
    "plot_panels",
    "plot_played_episode",
    "save_figure",
    "success_points",
]


def new_figure(**kwargs: Any) -> Figure:
    """A :class:`~matplotlib.figure.Figure` on its own Agg canvas (``kwargs`` go to ``Figure``)."""
    figure = Figure(**kwargs)
    FigureCanvasAgg(figure)  # attaches itself: savefig renders with Agg whatever pyplot's backend is
    return figure


def save_figure(figure: Figure, out_file: str | Path, *, dpi: int = 110) -> Path:
    """Lays ``figure`` out tightly and writes it atomically (folders are created).

    Returns:
        The path of the written file.
    """
    figure.tight_layout()
    # The temp file keeps the suffix, so matplotlib picks the format from the name.
    return atomic_write_with(out_file, lambda tmp: figure.savefig(tmp, dpi=dpi))


def plot_episode(
    walls: np.ndarray,
    geometry: MazeGeometry,
    path: np.ndarray,
    subgoals: Sequence[np.ndarray],
    goal_xy: np.ndarray,
    out_file: str | Path,
    *,
    title: str = "",
) -> Path:
    """Saves a bird's-eye PNG: walls, the body's path, numbered subgoals, start and goal.

    Returns:
        The path of the written file.
    """
    low, high = geometry.low, geometry.high
    fig = new_figure(figsize=(6, 6 * geometry.n_rows / geometry.n_cols))
    ax = fig.add_subplot()
    ax.imshow(walls, cmap="Greys", vmin=0, vmax=1.6, extent=(low[0], high[0], low[1], high[1]), origin="upper")
    ax.plot(path[:, 0], path[:, 1], color="tab:blue", linewidth=1.5, label="path")
    if len(subgoals):
        points = np.asarray(subgoals)
        ax.scatter(points[:, 0], points[:, 1], marker="x", color="tab:orange", zorder=3, label="subgoals")
        for index, point in enumerate(points, start=1):
            ax.annotate(str(index), point, textcoords="offset points", xytext=(3, 3), fontsize=7, color="tab:orange")
    ax.scatter(*path[0], marker="o", s=80, color="tab:green", zorder=4, label="start")
    ax.scatter(*goal_xy, marker="*", s=200, color="tab:red", zorder=4, label="goal")
    # Half of the border wall is enough to see it: the full cell (4 m on the ant) framed a 12 m maze in 20 m.
    margin_m = geometry.scale / 2
    ax.set_xlim(low[0] + margin_m, high[0] - margin_m)
    ax.set_ylim(low[1] + margin_m, high[1] - margin_m)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    return save_figure(fig, out_file, dpi=120)


def plot_played_episode(env: Any, episode: HighLevelEpisode, out_file: str | Path, *, title: str = "") -> Path:
    """:func:`plot_episode` for an episode just played in ``env`` (its current layout and goal)."""
    inner = env.unwrapped
    return plot_episode(
        inner.layout.walls, inner.geometry, episode.path, episode.subgoals, inner.goal_xy, out_file, title=title
    )


def plot_learning_curves(
    curves: Mapping[str, tuple[Sequence[int], Sequence[float]]], out_file: str | Path, *, title: str = ""
) -> Path:
    """Saves a PNG of held-out success rate against environment steps, one line per labelled run.

    Args:
        curves: ``label -> (timesteps, success_rate)``.
        out_file: PNG path (folders are created).
        title: Figure title.

    Returns:
        The path of the written file.
    """
    fig = new_figure(figsize=(7, 4))
    ax = fig.add_subplot()
    for label, (timesteps, success_rate) in curves.items():
        ax.plot(timesteps, success_rate, marker="o", markersize=3, label=label)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("held-out success rate")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    return save_figure(fig, out_file, dpi=120)


def _per_seed(rows: Sequence[Mapping[str, Any]], method: str, key: str, evaluated_only: bool) -> np.ndarray:
    """``(seeds, points)`` array of ``key`` for one method (evaluation rows only, if asked)."""
    trials: dict[float, list[float]] = {}
    for row in rows:
        if row["method"] == method and (not evaluated_only or not math.isnan(row["eval_success"])):
            trials.setdefault(row["seed"], []).append(float(row[key]))
    length = min((len(values) for values in trials.values()), default=0)
    return np.array([values[:length] for values in trials.values()])


def draw_band(ax: Axes, x: np.ndarray, values: np.ndarray, label: str) -> Line2D:
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


def success_points(
    rows: Sequence[Mapping[str, Any]], method: str, untrained: Mapping[int, float] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The success curves' points of one method: ``(episodes, labels, success)``.

    ``episodes`` and ``labels`` are the medians over seeds at each evaluation, ``success`` is
    ``(seeds, points)``. With protocol 2's per-seed untrained success (``untrained``: ``{seed: rate}``,
    the evaluation at episode 0) every curve starts at ``(0 episodes / 0 labels, untrained success)``;
    without it (protocol 1) the curves start at the first evaluation after training.
    """
    success = _per_seed(rows, method, "eval_success", evaluated_only=True)
    if success.size == 0:
        return np.zeros(0), np.zeros(0), success
    episodes = np.median(_per_seed(rows, method, "episode", evaluated_only=True), axis=0) + 1
    labels = np.median(_per_seed(rows, method, "cumulative_expert_cost", evaluated_only=True), axis=0)
    if untrained:
        seeds = list(dict.fromkeys(row["seed"] for row in rows if row["method"] == method))  # _per_seed's order
        start = np.array([[float(untrained[int(seed)])] for seed in seeds])
        success = np.hstack([start, success])
        episodes, labels = np.concatenate([[0.0], episodes]), np.concatenate([[0.0], labels])
    return episodes, labels, success


def plot_panels(
    rows: Sequence[Mapping[str, Any]],
    methods: Sequence[str],
    out_file: str | Path,
    *,
    title: str = "",
    untrained: Mapping[str, Mapping[int, float]] | None = None,
) -> Path:
    """Saves the paper's three panels as one PNG: success vs episode, success vs expert cost, attempts vs episode.

    Each panel draws the median over seeds with a min-max band (:func:`draw_band`). With protocol 2's
    untrained success (``untrained``: ``{method: {seed: rate}}``) the success curves start there, at 0
    episodes and 0 labels (:func:`success_points`).

    Returns:
        The path of the written file.
    """
    fig = new_figure(figsize=(15, 4))
    axes = fig.subplots(1, 3)
    for method in methods:
        episodes, cost, success = success_points(rows, method, (untrained or {}).get(method))
        if success.size == 0:
            continue
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
    return save_figure(fig, out_file)
