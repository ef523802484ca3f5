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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from antmaze_hirl.envs.controllers import as_batch_controller, inference_threads
from antmaze_hirl.envs.high_level import HighLevelMazeEnv, SubgoalWalk
from antmaze_hirl.envs.layouts import MazeLayout
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.envs.vector import check_episodes_and_num_envs, check_num_envs, copies_of, walk_in_lockstep
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
    num_envs = check_episodes_and_num_envs(episodes, num_envs)
    if num_envs == 1:
        played, maze = [], maze_env(env)
        for episode in range(episodes):
            info = play_episode(env, policy, seed=seed + episode).info
            played.append((maze.layout, info))  # drawn at this episode's reset
        return played
    return _lockstep_episodes(policy, env, episodes=episodes, seed=seed, num_envs=min(num_envs, episodes))


def time_limit(env: Any) -> int | None:
    """The subgoal limit ``env`` plays under: its ``TimeLimit`` wrapper's, else its unwrapped env's spec's.

    Read from the wrappers themselves, not from ``env.spec``: a wrapper's ``spec`` deep-copies the env's
    kwargs, a low level among them, and warns where that cannot be copied (a model holding a lock); the
    unwrapped env's spec alone misses a ``gym.make(..., max_episode_steps=N)`` override.
    """
    layer = env
    while isinstance(layer, gym.Wrapper):
        if isinstance(layer, gym.wrappers.TimeLimit):
            return int(layer._max_episode_steps)
        layer = layer.env
    return getattr(getattr(getattr(env, "unwrapped", env), "spec", None), "max_episode_steps", None)


def _lockstep_episodes(
    policy: Any, env: Any, *, episodes: int, seed: int, num_envs: int
) -> list[tuple[MazeLayout, dict[str, Any]]]:
    # The serial path plays the env as given, TimeLimit included; lockstep copies are unwrapped, so the limit
    # is applied here in the same way.
    max_subgoals = time_limit(env)
    played = play_on_copies(policy, env, range(seed, seed + episodes), num_envs=num_envs, max_subgoals=max_subgoals)
    return [(episode.layout, episode.info) for episode in played]


@dataclass(frozen=True)
class LockstepEpisode:
    """One episode played by :func:`play_in_lockstep`.

    Attributes:
        seed: The seed its maze was reset with (``None`` if its reset gave none).
        layout: The maze as its reset drew it.
        info: The env's last ``info`` (``is_success``, ``attempts``, ``total_low_level_steps``, ...).
        truncated: Whether it was truncated: out of its low-level step budget, or of ``max_subgoals``.
    """

    seed: int | None
    layout: MazeLayout
    info: dict[str, Any]
    truncated: bool


Reset = int | dict[str, Any]
"""One episode's reset: a seed, or the keywords of ``reset`` (``seed``, ``options``)."""


def play_on_copies(
    policy: Any, env: Any, resets: Sequence[Reset], *, num_envs: int, **kwargs: Any
) -> list[LockstepEpisode]:
    """:func:`play_in_lockstep` on up to ``num_envs`` lockstep copies of ``env``, made once and kept.

    The copies (:func:`~antmaze_hirl.envs.vector.copies_of`) are cached per ``env`` and ``num_envs``, so a
    periodic evaluation compiles its simulators once; :func:`release_copies` closes them.

    Args:
        policy: As :func:`evaluate_high_level`'s.
        env: The unwrapped high-level env whose copies play.
        resets: As :func:`play_in_lockstep`'s.
        num_envs: Sub-envs; at most ``len(resets)`` are made.
        **kwargs: :func:`play_in_lockstep`'s keywords.

    Raises:
        ValueError: If ``num_envs`` is below 1 or ``resets`` is empty.
    """
    num_envs = check_num_envs(num_envs)
    if not resets:
        raise ValueError("lockstep play needs at least one reset, got none")
    num_envs = min(num_envs, len(resets))
    copies = _COPIES.setdefault(env, {})
    if num_envs not in copies:
        copies[num_envs] = copies_of(env, num_envs)
    return play_in_lockstep(policy, copies[num_envs], resets, **kwargs)


def play_in_lockstep(
    policy: Any,
    envs: Sequence[HighLevelMazeEnv],
    resets: Sequence[Reset],
    *,
    max_subgoals: int | None = None,
    after_reset: Callable[[int, int | None], None] | None = None,
    after_subgoal: Callable[[int, int | None, dict[str, Any], bool], None] | None = None,
    on_episode_end: Callable[[], None] | None = None,
) -> list[LockstepEpisode]:
    """Plays one episode per entry of ``resets`` on ``envs``, ``len(envs)`` at once, in the order of ``resets``.

    Each sub-env takes the next reset as soon as its episode ends. ``policy`` predicts in one batch for every
    sub-env that needs a subgoal (``predict_batch`` where it has one; subgoals are clipped to the action space);
    the sub-envs' shared low-level controller acts in one batch for every sub-env still walking
    (:func:`~antmaze_hirl.envs.vector.walk_in_lockstep`). An episode plays as the serial
    :func:`~antmaze_hirl.rollout.play_episode` would play it with the same reset, up to the float rounding
    of batched matrix products.

    Args:
        policy: As :func:`evaluate_high_level`'s.
        envs: Unwrapped high-level envs sharing one low-level controller object (made by
            :func:`~antmaze_hirl.envs.vector.copies_of`, or with the same arguments and controller).
        resets: One episode each: a seed, or the keywords of its ``reset`` (``seed``, ``options``).
        max_subgoals: Truncate an episode after this many subgoals, as ``gym.make``'s ``TimeLimit`` does
            (``None``: only the env's own low-level budget).
        after_reset: Called as ``after_reset(env_index, seed)`` after each reset, before the first subgoal
            (e.g. to change that episode's step budget).
        after_subgoal: Called as ``after_subgoal(env_index, seed, info, done)`` after each high-level step,
            ``done`` on the episode's last.
        on_episode_end: Called after every finished episode (a progress bar's update).

    Raises:
        ValueError: If ``envs`` or ``resets`` is empty, or the sub-envs do not share one controller.
    """
    envs = list(envs)
    resets = [reset if isinstance(reset, dict) else {"seed": int(reset)} for reset in resets]
    if not envs or not resets:
        raise ValueError(f"lockstep play needs sub-envs and resets, got {len(envs)} sub-envs and {len(resets)} resets")
    if any(env.controller is not envs[0].controller for env in envs):
        raise ValueError("the lockstep sub-envs must share one low-level controller object (it is batched once)")
    envs = envs[: len(resets)]
    low_level = as_batch_controller(envs[0].controller, len(envs))
    space = envs[0].action_space
    results: dict[int, LockstepEpisode] = {}
    playing: dict[int, int] = {}  # sub-env -> position in resets of the episode it plays
    subgoals_set: dict[int, int] = {}
    observations: dict[int, dict[str, np.ndarray]] = {}
    queued = iter(range(len(resets)))

    def start_next(index: int) -> None:
        episode = next(queued, None)
        if episode is None:
            return
        observations[index], _ = envs[index].reset(**resets[episode])
        low_level.reset(index)
        playing[index] = episode
        subgoals_set[index] = 0
        if after_reset is not None:
            after_reset(index, resets[episode].get("seed"))

    for index in range(len(envs)):
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
            subgoals_set[index] += 1
            if max_subgoals is not None and subgoals_set[index] >= max_subgoals:
                truncated = True
            done = bool(terminated or truncated)
            seed = resets[playing[index]].get("seed")
            if after_subgoal is not None:
                after_subgoal(index, seed, info, done)
            if done:
                episode = playing.pop(index)
                results[episode] = LockstepEpisode(seed, envs[index].layout, info, bool(truncated))
                if on_episode_end is not None:
                    on_episode_end()
                start_next(index)
    return [results[episode] for episode in range(len(resets))]


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


def release_copies(env: Any) -> None:
    """Closes and forgets the lockstep copies made of ``env`` (their simulators), if any."""
    for envs in _COPIES.pop(env, {}).values():
        for copy in envs:
            copy.close()
