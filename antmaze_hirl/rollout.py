"""One high-level episode played to its end, with what a picture or a measure needs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

OUTCOMES: tuple[str, ...] = ("success", "flip", "frozen", "timeout", "ended")
"""Every way a high-level episode can end, one spelling each: the goal reached, the ant on its back, the body
stuck in place until the step limit (``frozen``, which only the in-maze protocol tells apart from a
``timeout``, :func:`antmaze_hirl.experiments.in_maze.outcome`), the step limit, or any other end."""


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


def play_episode(env: Any, policy: Any, *, seed: int | None = None) -> HighLevelEpisode:
    """Resets ``env`` with ``seed`` and lets ``policy`` choose subgoals (clipped to the maze) until the end.

    Args:
        env: A high-level maze env.
        policy: Callable ``observation -> subgoal``, or an object with ``predict`` returning a subgoal or
            SB3's ``(subgoal, state)`` tuple.
        seed: Seed of the reset.
    """
    act = policy.predict if hasattr(policy, "predict") else policy
    space = env.unwrapped.action_space
    obs, _ = env.reset(seed=seed)
    paths, subgoals, done, truncated, info = [], [], False, False, {}
    while not done:
        action = act(obs)
        if isinstance(action, tuple):
            action = action[0]
        obs, _, terminated, truncated, info = env.step(np.clip(action, space.low, space.high))
        paths.append(info["agent_path"])
        subgoals.append(info["subgoal"])
        done = terminated or truncated
    return HighLevelEpisode(np.concatenate(paths), np.asarray(subgoals), info, truncated=bool(truncated))
