"""Entry points of the benchmark suite ids (``antmaze_hirl/PointMaze-5x5-v0``, ``antmaze_hirl/AntMaze-large-v0``, ...).

Like [make_maze_env][antmaze_hirl.sb3_ext.shipped.make_maze_env], they plug in the body's shipped low-level
policy when no ``low_level`` is given, so ``gym.make(suite_id)`` plays the suite with the hierarchy every
baseline used, and ``gym.make_vec(suite_id, num_envs=N)`` plays ``N`` of its episodes in lockstep.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from gymnasium.vector import VectorEnv

from antmaze_hirl.envs.suite_specs import check_suite_name
from antmaze_hirl.envs.suites import SuiteMazeEnv
from antmaze_hirl.envs.vector import check_num_envs
from antmaze_hirl.sb3_ext.shipped import ShippedPolicyController, lockstep_env, unit_actions


def make_suite_env(
    suite: str,
    *,
    low_level: Any = None,
    render_mode: str | None = None,
    render_view: str = "schematic",
    normalize_actions: bool = False,
) -> SuiteMazeEnv | gym.Env:
    """The env of benchmark suite ``suite``, with the shipped low level of its body unless ``low_level`` is given.

    ``render_mode`` and ``render_view`` are :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv`'s;
    ``normalize_actions`` takes subgoals in ``[-1, 1]``
    ([unit_actions][antmaze_hirl.sb3_ext.shipped.unit_actions]).

    Raises:
        ValueError: On an unknown suite, render mode or view.
    """
    spec = check_suite_name(suite)
    controller = ShippedPolicyController(spec.body) if low_level is None else low_level
    env = SuiteMazeEnv(suite, low_level=controller, render_mode=render_mode, render_view=render_view)
    return unit_actions(env) if normalize_actions else env


def make_suite_vector_env(
    num_envs: int,
    suite: str,
    *,
    low_level: Any = None,
    render_mode: str | None = None,
    render_view: str = "schematic",
    autoreset_mode: str = "NextStep",
    max_episode_steps: int | None = None,
    normalize_actions: bool = False,
) -> VectorEnv:
    """``vector_entry_point`` of the suite ids: ``num_envs`` episodes of suite ``suite``, low levels in lockstep.

    ``gym.make_vec(suite_id, num_envs=N)`` calls it with the id's ``max_episode_steps`` (its step limit in
    subgoals), which the vector env applies as ``gym.make``'s ``TimeLimit`` does. Every sub-env shares one
    controller, batched over the sub-envs still walking
    ([HighLevelVectorEnv][antmaze_hirl.envs.vector.HighLevelVectorEnv]). ``reset(seed=s)`` seeds sub-env
    ``i`` with ``s + i``, so sub-env 0 plays the task ``gym.make(suite_id).reset(seed=s)`` plays.

    Args:
        num_envs: Number of sub-envs, >= 1.
        suite: A suite name (the id's registered keyword).
        low_level: As :func:`make_suite_env`; one object shared by every sub-env.
        render_mode: As :func:`make_suite_env`.
        render_view: As :func:`make_suite_env`.
        autoreset_mode: Gymnasium autoreset mode: ``"NextStep"`` (default), ``"SameStep"`` or ``"Disabled"``.
        max_episode_steps: High-level steps before truncation (``None``: none).
        normalize_actions: As :func:`make_suite_env`.

    Raises:
        ValueError: If ``num_envs`` is not an integer >= 1 (before anything loads), or as :func:`make_suite_env`.
    """
    num_envs = check_num_envs(num_envs)
    first = make_suite_env(suite, low_level=low_level, render_mode=render_mode, render_view=render_view)
    shared = first.controller  # one controller for all, so that it is batched once
    others = [
        SuiteMazeEnv(suite, low_level=shared, render_mode=render_mode, render_view=render_view)
        for _ in range(num_envs - 1)
    ]
    return lockstep_env([first, *others], autoreset_mode, max_episode_steps, normalize_actions)
