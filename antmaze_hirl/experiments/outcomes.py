"""Per-maze outcomes of learner-only evaluations (protocol 2's ``evaluations.csv``).

Every evaluation of a protocol-2 trial writes one row per maze: which trial and when (training episodes
and expert labels so far), which maze (its seed, the layout as drawn, and its task up to the square's
symmetries, :func:`~antmaze_hirl.envs.layouts.canonical_task`), and what happened (success, attempts,
low-level steps). Any reader can then slice by maze, and the pooled figures resample mazes and seeds as
the clusters they are (:func:`~antmaze_hirl.experiments.uncertainty.cluster_bootstrap`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from antmaze_hirl.dagger.evaluation import evaluation_outcomes
from antmaze_hirl.envs.layouts import canonical_layout, canonical_task

EVALUATION_COLUMNS = (
    "method",
    "seed",
    "episode",
    "labels",
    "maze_seed",
    "layout",
    "task_class",
    "success",
    "attempts",
    "low_level_steps",
)
"""Columns of ``evaluations.csv``: ``episode`` counts the training episodes before the evaluation (0: the
untrained learner), ``labels`` the expert labels spent by then."""

EVALUATION_TEXT_COLUMNS = ("method", "layout", "task_class")


def play_mazes(policy: Any, env: Any, *, episodes: int, seed: int, num_envs: int = 1) -> list[dict[str, Any]]:
    """The learner alone on mazes ``seed .. seed + episodes - 1``: one outcome per maze.

    Each maze is the one an episode reset with its seed plays (as
    :func:`~antmaze_hirl.dagger.evaluation.evaluate_high_level` plays them), ``num_envs`` at once in
    lockstep (:attr:`~antmaze_hirl.experiments.config.ExperimentConfig.evaluation_envs`).

    Returns:
        ``{"maze_seed", "layout", "task_class", "success", "attempts", "low_level_steps"}`` per maze.

    Raises:
        ValueError: If ``episodes < 1``.
    """
    played = evaluation_outcomes(policy, env, episodes=episodes, seed=seed, num_envs=num_envs)
    outcomes = []
    for maze_seed, (layout, info) in enumerate(played, start=seed):
        outcomes.append(
            {
                "maze_seed": maze_seed,
                "layout": canonical_layout(layout),
                "task_class": canonical_task(layout),
                "success": bool(info["is_success"]),
                "attempts": int(info["attempts"]),
                "low_level_steps": int(info["total_low_level_steps"]),
            }
        )
    return outcomes


def summarise_mazes(outcomes: list[dict[str, Any]]) -> dict[str, float]:
    """An evaluation's row fields from its per-maze outcomes: ``eval_success``, ``eval_attempts``, ``eval_mazes``."""
    return {
        "eval_success": float(np.mean([o["success"] for o in outcomes])),
        "eval_attempts": float(np.mean([o["attempts"] for o in outcomes])),
        "eval_mazes": len(outcomes),
    }
