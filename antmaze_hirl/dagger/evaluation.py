"""Learner-only evaluation (beta = 0, no expert) on a fixed set of held-out random mazes.

Serial (``num_envs=1``, the default) plays one maze after another on the given env, exactly as committed
results were made. Lockstep (``num_envs=N``) plays ``N`` mazes at once on copies of the env
(:func:`~antmaze_hirl.envs.vector.copies_of`): the policy predicts in one batch for every maze that needs a
subgoal, and the low level acts in one batch for every maze still walking. The mazes and seeds are the same;
batched matrix products may round the last bits differently, which a MuJoCo rollout can amplify into another
outcome now and then (``docs/guides/vector-envs.md`` has the measured rate). Both players are
:mod:`antmaze_hirl.rollout`'s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from antmaze_hirl.envs.layouts import MazeLayout
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.envs.vector import check_episodes_and_num_envs
from antmaze_hirl.rollout import play_episode, play_on_copies, time_limit

HELD_OUT_SEED = SEEDS.held_out
"""Episode ``i`` of an evaluation resets with seed ``HELD_OUT_SEED + i``, a seed range no training run uses.

Held out by seed only: a family with few wall grids repeats training mazes at these seeds (the ant's 3x3
mazes have about 48 grids). Mazes held out by construction come from an env restricted to the evaluation
part of :mod:`antmaze_hirl.envs.layout_splits` (:class:`~antmaze_hirl.envs.split_env.SplitMazeEnv`).
"""


def evaluate_high_level(
    policy: Any, env: Any, *, episodes: int, seed: int = HELD_OUT_SEED, num_envs: int = 1
) -> dict[str, float]:
    """Runs ``policy`` alone (no expert) for ``episodes`` episodes from the env's corner starts.

    Args:
        policy: Callable or object with ``predict(observation)`` returning a subgoal (or SB3's
            ``(subgoal, state)`` tuple, as :class:`~antmaze_hirl.dagger.agent.HierarchicalAgent` does).
            In lockstep, ``predict_batch(observations)`` (of :class:`~antmaze_hirl.dagger.HighLevelPolicy`,
            or an agent's ``high_level``) is used when there is one.
        env: High-level env; subgoals are clipped to its action space.
        episodes: Number of held-out mazes.
        seed: Seed of the first maze; the same seed gives the same mazes.
        num_envs: ``1`` plays the mazes one after another on ``env`` (exact replays of committed results);
            more plays up to that many at once in lockstep (see the module docstring).

    Returns:
        ``{"success_rate", "mean_attempts", "mean_low_level_steps", "episodes"}``.

    Raises:
        ValueError: If ``episodes`` or ``num_envs`` is below 1.
    """
    played = evaluation_episodes(policy, env, episodes=episodes, seed=seed, num_envs=num_envs)
    return {
        "success_rate": float(np.mean([info["is_success"] for info in played])),
        "mean_attempts": float(np.mean([info["attempts"] for info in played])),
        "mean_low_level_steps": float(np.mean([info["total_low_level_steps"] for info in played])),
        "episodes": episodes,
    }


def evaluation_episodes(
    policy: Any, env: Any, *, episodes: int, seed: int = HELD_OUT_SEED, num_envs: int = 1
) -> list[dict[str, Any]]:
    """Each evaluation episode's last ``info``, in seed order (as :func:`evaluate_high_level` plays them).

    Raises:
        ValueError: If ``episodes`` or ``num_envs`` is below 1.
    """
    return [info for _, info in evaluation_outcomes(policy, env, episodes=episodes, seed=seed, num_envs=num_envs)]


def evaluation_outcomes(
    policy: Any, env: Any, *, episodes: int, seed: int = HELD_OUT_SEED, num_envs: int = 1
) -> list[tuple[MazeLayout, dict[str, Any]]]:
    """Each evaluation episode's maze (as its reset drew it) and last ``info``, in seed order.

    Raises:
        ValueError: If ``episodes`` or ``num_envs`` is below 1.
    """
    num_envs = check_episodes_and_num_envs(episodes, num_envs)
    if num_envs == 1:
        played, maze = [], maze_env(env)
        for episode in range(episodes):
            info = play_episode(env, policy, seed=seed + episode).info
            played.append((maze.layout, info))  # drawn at this episode's reset
        return played
    return _lockstep_episodes(policy, env, episodes=episodes, seed=seed, num_envs=min(num_envs, episodes))


def _lockstep_episodes(
    policy: Any, env: Any, *, episodes: int, seed: int, num_envs: int
) -> list[tuple[MazeLayout, dict[str, Any]]]:
    # The serial path plays the env as given, TimeLimit included; lockstep copies are unwrapped, so the limit
    # is applied here in the same way.
    max_subgoals = time_limit(env)
    played = play_on_copies(policy, env, range(seed, seed + episodes), num_envs=num_envs, max_subgoals=max_subgoals)
    return [(episode.layout, episode.info) for episode in played]
