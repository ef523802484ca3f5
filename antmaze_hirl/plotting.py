"""Matplotlib pictures of mazes and paths (Agg backend: works headless)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.rollout import HighLevelEpisode


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
    out_file = Path(out_file)
    out_file.parent.mkdir(parents=True, exist_ok=True)
    low, high = geometry.low, geometry.high
    fig, ax = plt.subplots(figsize=(6, 6 * geometry.n_rows / geometry.n_cols))
    ax.imshow(walls, cmap="Greys", vmin=0, vmax=1.6, extent=(low[0], high[0], low[1], high[1]), origin="upper")
    ax.plot(path[:, 0], path[:, 1], color="tab:blue", linewidth=1.5, label="path")
    if len(subgoals):
        points = np.asarray(subgoals)
        ax.scatter(points[:, 0], points[:, 1], marker="x", color="tab:orange", zorder=3, label="subgoals")
        for index, point in enumerate(points, start=1):
            ax.annotate(str(index), point, textcoords="offset points", xytext=(3, 3), fontsize=7, color="tab:orange")
    ax.scatter(*path[0], marker="o", s=80, color="tab:green", zorder=4, label="start")
    ax.scatter(*goal_xy, marker="*", s=200, color="tab:red", zorder=4, label="goal")
    ax.set_xlim(low[0], high[0])
    ax.set_ylim(low[1], high[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    fig.tight_layout()
    fig.savefig(out_file, dpi=120)
    plt.close(fig)
    return out_file


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
    out_file = Path(out_file)
    out_file.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, (timesteps, success_rate) in curves.items():
        ax.plot(timesteps, success_rate, marker="o", markersize=3, label=label)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("held-out success rate")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(out_file, dpi=120)
    plt.close(fig)
    return out_file


def plot_played_episode(env: Any, episode: HighLevelEpisode, out_file: str | Path, *, title: str = "") -> Path:
    """:func:`plot_episode` for an episode just played in ``env`` (its current layout and goal)."""
    inner = env.unwrapped
    return plot_episode(
        inner.layout.walls, inner.geometry, episode.path, episode.subgoals, inner.goal_xy, out_file, title=title
    )
