"""Registers the ``antmaze_hirl/...`` ids with Gymnasium (done when ``antmaze_hirl`` is imported).

This module sits above every layer its entry points name: the reach ids are plain
:class:`~antmaze_hirl.envs.reach.ReachEnv`, the maze ids go through
:func:`antmaze_hirl.sb3_ext.shipped.make_maze_env`, which plugs in the shipped low-level policy when no
``low_level`` is given. The entry points are strings, so registering imports neither the envs nor torch.
"""

from __future__ import annotations

import gymnasium as gym

from antmaze_hirl.envs.profiles import maze_env_id, reach_env_id
from antmaze_hirl.envs.suite_specs import SUITE_ENTRY_POINT, SUITE_SPECS, SUITE_VECTOR_ENTRY_POINT

VECTOR_ENTRY_POINTS: dict[str, str] = {
    **{reach_env_id(body): "antmaze_hirl.envs.vector:make_reach_vector_env" for body in ("ant", "point")},
    **{maze_env_id(body): "antmaze_hirl.sb3_ext.shipped:make_maze_vector_env" for body in ("ant", "point")},
}
"""Each base id's native vector env (``gym.make_vec(id, N)``, ``vectorization_mode="vector_entry_point"``); the
suite ids' is :data:`~antmaze_hirl.envs.suite_specs.SUITE_VECTOR_ENTRY_POINT`."""

ENV_IDS: dict[str, tuple[str, dict[str, str]]] = {
    **{reach_env_id(body): ("antmaze_hirl.envs.reach:ReachEnv", {"body": body}) for body in ("ant", "point")},
    **{maze_env_id(body): ("antmaze_hirl.sb3_ext.shipped:make_maze_env", {"body": body}) for body in ("ant", "point")},
}
"""The four base ids (reach and maze, per body): entry point and default keyword arguments. The benchmark
suites' ids (:data:`~antmaze_hirl.envs.suite_specs.SUITE_SPECS`) are registered too, by :func:`register_envs`."""


def register_envs() -> None:
    """Registers every id in :data:`ENV_IDS` that is not registered yet (safe to call twice)."""
    for env_id, (entry_point, kwargs) in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id, entry_point=entry_point, vector_entry_point=VECTOR_ENTRY_POINTS[env_id], kwargs=kwargs
            )
    # The benchmark suites (antmaze_hirl.envs.suite_specs): one id per suite, its step limit in subgoals.
    for spec in SUITE_SPECS.values():
        if spec.env_id not in gym.registry:
            kwargs = {"suite": spec.name}
            gym.register(
                spec.env_id,
                SUITE_ENTRY_POINT,
                vector_entry_point=SUITE_VECTOR_ENTRY_POINT,
                max_episode_steps=spec.max_episode_steps,
                kwargs=kwargs,
            )
