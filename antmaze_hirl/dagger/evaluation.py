"""Learner-only evaluation (beta = 0, no expert) on a fixed set of held-out random mazes.

Serial (``num_envs=1``, the default) plays one maze after another on the given env, exactly as committed
results were made. Lockstep (``num_envs=N``) plays ``N`` mazes at once on copies of the env
(:func:`~antmaze_hirl.envs.vector.copies_of`): the policy predicts in one batch for every maze that needs a
subgoal, and the low level acts in one batch for every maze still walking. The mazes and seeds are the same;
batched matrix products may round the last bits differently, which a MuJoCo rollout can amplify into another
outcome now and then (``docs/guides/vector-envs.md`` has the measured rate).
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from antmaze_hirl.envs.controllers import as_batch_controller, inference_threads
from antmaze_hirl.envs.high_level import HighLevelMazeEnv, SubgoalWalk
from antmaze_hirl.envs.layouts import MazeLayout
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.vector import check_num_envs, copies_of, walk_in_lockstep
from antmaze_hirl.rollout import play_episode

HELD_OUT_SEED = SEEDS.held_out
"""Episode ``i`` of an evaluation resets with seed ``HELD_OUT_SEED + i``, a seed range no training run uses.

Held out by seed only: a family with few wall grids repeats training mazes at these seeds (the ant's 3x3
mazes have about 48 grids). Mazes held out by construction come from an env restricted to the evaluation
part of :mod:`antmaze_hirl.envs.layout_splits` (:class:`~antmaze_hirl.envs.split_env.SplitMazeEnv`).
"""

# Lockstep copies of an evaluation env, made once per env and size (an experiment evaluates on one env
# eleven times); they go when the env does.
_COPIES: weakref.WeakKeyDictionary[Any, dict[int, list[HighLevelMazeEnv]]] = weakref.WeakKeyDictionary()


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
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    num_envs = check_num_envs(num_envs)
    if num_envs == 1:
        played = []
        for episode in range(episodes):
            info = play_episode(env, policy, seed=seed + episode).info
            played.append((env.unwrapped.layout, info))  # drawn at this episode's reset
        return played
    return _lockstep_episodes(policy, env, episodes=episodes, seed=seed, num_envs=min(num_envs, episodes))


def _lockstep_episodes(
    policy: Any, env: Any, *, episodes: int, seed: int, num_envs: int
) -> list[tuple[MazeLayout, dict[str, Any]]]:
    copies = _COPIES.setdefault(env, {})
    if num_envs not in copies:
        copies[num_envs] = copies_of(env, num_envs)
    envs = copies[num_envs]
    low_level = as_batch_controller(envs[0].controller, num_envs)
    space = envs[0].action_space
    results: list[tuple[MazeLayout, dict[str, Any]] | None] = [None] * episodes
    playing: dict[int, int] = {}  # sub-env -> episode it plays
    observations: dict[int, dict[str, np.ndarray]] = {}
    queued = iter(range(episodes))

    def start_next(index: int) -> None:
        episode = next(queued, None)
        if episode is None:
            return
        observations[index], _ = envs[index].reset(seed=seed + episode)
        low_level.reset(index)
        playing[index] = episode

    for index in range(num_envs):
        start_next(index)
    while playing:
        indices = sorted(playing)
        subgoals = _predict_batch(policy, [observations[index] for index in indices])
        walks: dict[int, SubgoalWalk] = {
            index: envs[index].begin_subgoal(np.clip(subgoal, space.low, space.high))
            for index, subgoal in zip(indices, subgoals, strict=True)
        }
        walk_in_lockstep(envs, walks, low_level)
        for index in indices:
            observations[index], _, terminated, truncated, info = envs[index].end_subgoal(walks[index])
            if terminated or truncated:
                results[playing.pop(index)] = (envs[index].layout, info)
                start_next(index)
    return [played for played in results if played is not None]


def _predict_batch(policy: Any, observations: list[dict[str, np.ndarray]]) -> list[np.ndarray]:
    # One batch for every maze that needs a subgoal, where the policy can take one; else one call each.
    owner = policy if hasattr(policy, "predict_batch") else getattr(policy, "high_level", None)
    batch = getattr(owner, "predict_batch", None)
    if callable(batch):
        with inference_threads(len(observations)):
            return list(np.asarray(batch(observations)))
    act = policy.predict if hasattr(policy, "predict") else policy
    subgoals = []
    for observation in observations:
        subgoal = act(observation)
        subgoals.append(subgoal[0] if isinstance(subgoal, tuple) else subgoal)
    return subgoals
