"""Playing high-level episodes: the one home of the play loops, serial and lockstep.

:func:`play_episode` plays one episode to its end with what a picture or a measure needs;
:func:`play_in_lockstep` and :func:`play_on_copies` play many at once.

Every player asks the policy for a subgoal through :func:`subgoal_function` (a callable or an object with
``predict``, SB3's ``(subgoal, state)`` tuple unwrapped) and clips it to the env's action space. The serial
player plays the env as given, wrappers (a ``TimeLimit``) included: the committed results were made that way.
The lockstep player steps unwrapped copies whose low levels act in one batched call per low-level step
(:func:`~antmaze_hirl.envs.vector.walk_in_lockstep`, as :class:`~antmaze_hirl.envs.vector.HighLevelVectorEnv`
does) and applies a subgoal limit itself (:func:`time_limit`); an episode plays as the serial player would
play it with the same reset, up to the float rounding of batched matrix products, which MuJoCo can amplify
into another outcome now and then (``docs/guides/vector-envs.md`` has the measured rate).
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
from antmaze_hirl.envs.vector import check_num_envs, copies_of, walk_in_lockstep

OUTCOMES: tuple[str, ...] = ("success", "flip", "frozen", "timeout", "ended")
"""Every way a high-level episode can end, one spelling each: the goal reached, the ant on its back, the body
stuck in place until the step limit (``frozen``, which only the in-maze protocol tells apart from a
``timeout``: the lab's ``antmaze_lab.in_maze_protocol.outcome``), the step limit, or any other end."""


@dataclass(frozen=True)
class HighLevelEpisode:
    """What happened in one high-level episode.

    Attributes:
        path: Body xy after every low-level step, ``(steps + 1, 2)``.
        subgoals: Executed subgoals, ``(attempts, 2)``.
        info: The env's last ``info`` (``is_success``, ``attempts``, ``total_low_level_steps``, ...).
        truncated: Whether the episode ran out of its low-level step budget.
    """

    path: np.ndarray
    subgoals: np.ndarray
    info: dict[str, Any]
    truncated: bool = False

    @property
    def success(self) -> bool:
        """Whether the goal was reached."""
        return bool(self.info["is_success"])

    @property
    def outcome(self) -> str:
        """Why the episode ended: ``"success"``, ``"flip"`` (the ant on its back), ``"timeout"`` or ``"ended"``.

        Spelt as in :data:`OUTCOMES`; ``"ended"`` is any other end (a step limit of a wrapper, say).
        """
        return episode_outcome(self.info, truncated=self.truncated)


def episode_outcome(info: dict[str, Any], *, truncated: bool) -> str:
    """:attr:`HighLevelEpisode.outcome` from an episode's last ``info`` and whether it was truncated."""
    if info["is_success"]:
        return "success"
    if info.get("flipped"):
        return "flip"
    return "timeout" if truncated else "ended"


def subgoal_function(policy: Any) -> Callable[[dict[str, np.ndarray]], np.ndarray]:
    """``policy`` as a function ``observation -> subgoal``: its ``predict`` where it has one, else itself.

    The result of an SB3 model's ``predict``, a ``(subgoal, state)`` tuple, is unwrapped to its subgoal.

    Raises:
        ValueError: If ``policy`` is neither callable nor has a ``predict`` (naming its type).
    """
    act = policy.predict if hasattr(policy, "predict") else policy
    if not callable(act):
        raise ValueError(f"policy must be callable or have predict(observation), got {type(policy).__name__}")

    def subgoal(observation: dict[str, np.ndarray]) -> np.ndarray:
        action = act(observation)
        return action[0] if isinstance(action, tuple) else action

    return subgoal


def play_episode(
    env: Any,
    policy: Any,
    *,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    after_reset: Callable[[], None] | None = None,
) -> HighLevelEpisode:
    """Resets ``env`` (``seed``, ``options``) and lets ``policy`` choose subgoals (clipped to the maze) until the end.

    Args:
        env: A high-level maze env, played as given (its wrappers' limits apply).
        policy: Callable ``observation -> subgoal``, or an object with ``predict`` returning a subgoal or
            SB3's ``(subgoal, state)`` tuple (:func:`subgoal_function`).
        seed: Seed of the reset.
        options: Options of the reset (e.g. a suite's ``{"task_id": k}``); ``None``: none.
        after_reset: Called as ``after_reset()`` after the reset, before the first subgoal (e.g. to set the
            episode's step budget from the layout the reset drew): the serial form of :func:`play_in_lockstep`'s
            hook, which also gets the env index and the seed.

    Raises:
        ValueError: If ``policy`` is neither callable nor has a ``predict``.
    """
    act = subgoal_function(policy)
    space = env.unwrapped.action_space
    obs, _ = env.reset(seed=seed, options=options)
    if after_reset is not None:
        after_reset()
    paths, subgoals, done, truncated, info = [], [], False, False, {}
    while not done:
        obs, _, terminated, truncated, info = env.step(np.clip(act(obs), space.low, space.high))
        paths.append(info["agent_path"])
        subgoals.append(info["subgoal"])
        done = terminated or truncated
    return HighLevelEpisode(np.concatenate(paths), np.asarray(subgoals), info, truncated=bool(truncated))


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

# Lockstep copies of an env, made once per env and size (an experiment evaluates on one env eleven times);
# they go when the env does.
_COPIES: weakref.WeakKeyDictionary[Any, dict[int, list[HighLevelMazeEnv]]] = weakref.WeakKeyDictionary()


def play_on_copies(
    policy: Any, env: Any, resets: Sequence[Reset], *, num_envs: int, **kwargs: Any
) -> list[LockstepEpisode]:
    """:func:`play_in_lockstep` on up to ``num_envs`` lockstep copies of ``env``, made once and kept.

    The copies (:func:`~antmaze_hirl.envs.vector.copies_of`) are cached per ``env`` and ``num_envs``, so a
    periodic evaluation compiles its simulators once; :func:`release_copies` closes them.

    Args:
        policy: As :func:`play_in_lockstep`'s.
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


def release_copies(env: Any) -> None:
    """Closes and forgets the lockstep copies made of ``env`` (their simulators), if any."""
    for envs in _COPIES.pop(env, {}).values():
        for copy in envs:
            copy.close()


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
    sub-env that needs a subgoal (``predict_batch`` where it or its ``high_level`` has one, else
    :func:`subgoal_function` one observation at a time; subgoals are clipped to the action space); the
    sub-envs' shared low-level controller acts in one batch for every sub-env still walking
    (:func:`~antmaze_hirl.envs.vector.walk_in_lockstep`). An episode plays as :func:`play_episode` would play
    it with the same reset, up to the float rounding of batched matrix products.

    Args:
        policy: Callable or object with ``predict(observation)`` returning a subgoal (or SB3's
            ``(subgoal, state)`` tuple); ``predict_batch(observations)`` (of
            :class:`~antmaze_hirl.dagger.HighLevelPolicy`, or an agent's ``high_level``) is used where there is one.
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
        ValueError: If ``envs`` or ``resets`` is empty, the sub-envs do not share one controller, or
            ``policy`` can neither predict in a batch nor one observation at a time.
    """
    envs = list(envs)
    resets = [reset if isinstance(reset, dict) else {"seed": int(reset)} for reset in resets]
    if not envs or not resets:
        raise ValueError(f"lockstep play needs sub-envs and resets, got {len(envs)} sub-envs and {len(resets)} resets")
    if any(env.controller is not envs[0].controller for env in envs):
        raise ValueError("the lockstep sub-envs must share one low-level controller object (it is batched once)")
    predict = _batch_predictor(policy)
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
        subgoals = predict([observations[index] for index in indices])
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


def _batch_predictor(policy: Any) -> Callable[[list[dict[str, np.ndarray]]], list[np.ndarray]]:
    # One batch for every maze that needs a subgoal, where the policy can take one; else one call each.
    owner = policy if hasattr(policy, "predict_batch") else getattr(policy, "high_level", None)
    batch = getattr(owner, "predict_batch", None)
    if callable(batch):

        def predict(observations: list[dict[str, np.ndarray]]) -> list[np.ndarray]:
            with inference_threads(len(observations)):
                return list(np.asarray(batch(observations)))

        return predict
    act = subgoal_function(policy)
    return lambda observations: [act(observation) for observation in observations]
