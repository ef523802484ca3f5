"""Learner-only evaluation (beta = 0, no expert) on a fixed set of held-out random mazes."""

from __future__ import annotations

from typing import Any

import numpy as np

from antmaze_hirl.rollout import play_episode

HELD_OUT_SEED = 1_000_000
"""Episode ``i`` of an evaluation resets with seed ``HELD_OUT_SEED + i``, a seed range no training run uses.

Held out by seed only: a family with few wall grids repeats training mazes at these seeds (the ant's 3x3
mazes have about 48 grids). Mazes held out by construction come from an env restricted to the evaluation
part of :mod:`antmaze_hirl.envs.layout_splits` (:class:`~antmaze_hirl.envs.split_env.SplitMazeEnv`).
"""


def evaluate_high_level(policy: Any, env: Any, *, episodes: int, seed: int = HELD_OUT_SEED) -> dict[str, float]:
    """Runs ``policy`` alone (no expert) for ``episodes`` episodes from the env's corner starts.

    Args:
        policy: Callable or object with ``predict(observation)`` returning a subgoal (or SB3's
            ``(subgoal, state)`` tuple, as :class:`~antmaze_hirl.dagger.agent.HierarchicalAgent` does).
        env: High-level env; subgoals are clipped to its action space.
        episodes: Number of held-out mazes.
        seed: Seed of the first maze; the same seed gives the same mazes.

    Returns:
        ``{"success_rate", "mean_attempts", "mean_low_level_steps", "episodes"}``.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    played = [play_episode(env, policy, seed=seed + episode).info for episode in range(episodes)]
    return {
        "success_rate": float(np.mean([info["is_success"] for info in played])),
        "mean_attempts": float(np.mean([info["attempts"] for info in played])),
        "mean_low_level_steps": float(np.mean([info["total_low_level_steps"] for info in played])),
        "episodes": episodes,
    }
