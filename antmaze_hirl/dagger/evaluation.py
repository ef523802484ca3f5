"""Learner-only evaluation (beta = 0, no expert) on a fixed set of held-out random mazes."""

from __future__ import annotations

from typing import Any

import numpy as np

HELD_OUT_SEED = 1_000_000
"""Episode ``i`` of an evaluation resets with seed ``HELD_OUT_SEED + i``: mazes no training run draws."""


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
    act = policy.predict if hasattr(policy, "predict") else policy
    space = env.unwrapped.action_space
    successes, attempts, steps = 0, [], []
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode)
        done, info = False, {}
        while not done:
            action = act(obs)
            if isinstance(action, tuple):  # SB3-style predict: (action, state)
                action = action[0]
            obs, _, terminated, truncated, info = env.step(np.clip(action, space.low, space.high))
            done = terminated or truncated
        successes += int(info["is_success"])
        attempts.append(info["attempts"])
        steps.append(info["total_low_level_steps"])
    return {
        "success_rate": successes / episodes,
        "mean_attempts": float(np.mean(attempts)),
        "mean_low_level_steps": float(np.mean(steps)),
        "episodes": episodes,
    }
