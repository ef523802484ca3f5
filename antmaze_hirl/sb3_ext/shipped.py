"""The low-level policies shipped in ``antmaze_hirl/policies/``, and the maze ids' factory that plugs them in.

This sits above :mod:`antmaze_hirl.envs`, so the env layer never imports the training stack: the
high-level env takes any controller, and only ``gym.make`` of a maze id without ``low_level`` loads the
shipped policy (torch and Stable-Baselines3 with it).
"""

from __future__ import annotations

import functools
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import VectorEnv
from gymnasium.wrappers import RescaleAction
from gymnasium.wrappers.vector import RescaleAction as VectorRescaleAction

from antmaze_hirl.envs.controllers import PredictController
from antmaze_hirl.envs.high_level import HighLevelMazeEnv
from antmaze_hirl.envs.layout_splits import LayoutSplit
from antmaze_hirl.envs.layouts import MazeMap
from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.envs.simulator import Body, body_spec
from antmaze_hirl.envs.split_env import SplitMazeEnv
from antmaze_hirl.envs.vector import HighLevelVectorEnv, check_num_envs

if TYPE_CHECKING:
    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm


def shipped_policy_path(body: str) -> Path:
    """Path of the policy shipped for ``body`` (``antmaze_hirl/policies/<body>_td3.zip``).

    Raises:
        ValueError: If ``body`` is not a known body.
    """
    body_spec(body)
    return Path(str(resources.files("antmaze_hirl").joinpath("policies", f"{body}_td3.zip")))


@functools.cache
def load_shipped_policy(body: str) -> OffPolicyAlgorithm:
    """The shipped policy for ``body``, loaded once per process and shared (acting only reads it)."""
    # Imported here, not at the top: a maze made with its own controller then never loads torch.
    from antmaze_hirl.sb3_ext.loading import load_low_level

    return load_low_level(body)


class ShippedPolicyController(PredictController):
    """The shipped policy of ``body`` as a controller; it pickles as its body name, not as the weights.

    Args:
        body: ``"ant"`` or ``"point"``.
    """

    def __init__(self, body: str) -> None:
        super().__init__(load_shipped_policy(body))
        self.body = body

    def __reduce__(self) -> tuple[type[ShippedPolicyController], tuple[str]]:
        # An unpickled env reloads the (cached) shipped policy instead of carrying a copy of its weights.
        return type(self), (self.body,)


UNIT_LOW = np.float32(-1.0)
UNIT_HIGH = np.float32(1.0)


def unit_actions(env: gym.Env) -> gym.Env:
    """``env`` with its subgoal action space rescaled to ``[-1, 1]`` (Gymnasium's ``RescaleAction``).

    ``-1`` and ``1`` are the maze's edges along each axis, so SB3's ``check_env`` finds the symmetric,
    normalised ``Box`` it recommends. ``env.unwrapped`` still takes metres (and the oracle still labels in
    metres). The bounds are float32, as the space's, so Gymnasium warns of no precision loss.
    """
    return RescaleAction(env, UNIT_LOW, UNIT_HIGH)


def unit_vector_actions(env: VectorEnv) -> VectorEnv:
    """The vector form of :func:`unit_actions` (Gymnasium's vector ``RescaleAction``)."""
    return VectorRescaleAction(env, UNIT_LOW, UNIT_HIGH)


def make_maze_env(
    body: Body = "point",
    maze_map: str | MazeMap | None = None,
    *,
    low_level: Any = None,
    split: LayoutSplit | None = None,
    normalize_actions: bool = False,
    **kwargs: Any,
) -> HighLevelMazeEnv | RescaleAction:
    """Entry point of ``antmaze_hirl/AntMaze-v0`` and ``antmaze_hirl/PointMaze-v0``: the one factory of maze envs.

    Args:
        body: ``"point"`` or ``"ant"``.
        maze_map: ``None`` for random layouts, else a fixed map (see
            :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv`).
        low_level: SB3 model or callable ``goal observation -> action``. Default: the policy shipped for
            ``body`` (:func:`load_shipped_policy`).
        split: ``None`` to draw layouts from the whole family, else the part of the layout partition to
            draw from (``"train"``, ``"selection"``, ``"eval"``: a
            :class:`~antmaze_hirl.envs.split_env.SplitMazeEnv`), e.g. ``gym.make(id, split="eval")``.
        normalize_actions: Opt-in: subgoals in ``[-1, 1]`` (the maze's edges) instead of metres, for RL
            libraries that expect a normalised action space (:func:`unit_actions`); e.g.
            ``gym.make(id, normalize_actions=True)``.
        **kwargs: More :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv` keywords.

    Raises:
        ValueError: If ``low_level`` is left out and no policy ships for ``body``, or ``split`` is unknown.
    """
    if low_level is None:
        if not shipped_policy_path(body).exists():
            name = maze_env_id(body)
            raise ValueError(
                f"{name} needs a low-level controller: pass low_level=<SB3 model or callable obs -> action>, "
                f"e.g. gym.make('{name}', low_level=model)"
            )
        low_level = ShippedPolicyController(body)
    env = _maze_env(body, maze_map, low_level, split, kwargs)
    return unit_actions(env) if normalize_actions else env


def _maze_env(
    body: Body, maze_map: str | MazeMap | None, low_level: Any, split: LayoutSplit | None, kwargs: dict[str, Any]
) -> HighLevelMazeEnv:
    # One place that picks the class, so the single and the vector factory draw their layouts alike.
    if split is None:
        return HighLevelMazeEnv(body, maze_map, low_level=low_level, **kwargs)
    return SplitMazeEnv(body, maze_map, split=split, low_level=low_level, **kwargs)


def make_maze_vector_env(
    num_envs: int,
    body: Body = "point",
    maze_map: str | MazeMap | None = None,
    *,
    low_level: Any = None,
    split: LayoutSplit | None = None,
    autoreset_mode: str = "NextStep",
    max_episode_steps: int | None = None,
    normalize_actions: bool = False,
    **kwargs: Any,
) -> VectorEnv:
    """``vector_entry_point`` of the maze ids: ``num_envs`` mazes, their low levels in lockstep.

    ``gym.make_vec("antmaze_hirl/AntMaze-v0", num_envs=N, **kwargs)`` calls it. Every sub-env shares one
    controller (the shipped policy by default), batched over the sub-envs still walking
    (:class:`~antmaze_hirl.envs.vector.HighLevelVectorEnv`).

    Args:
        num_envs: Number of mazes, >= 1.
        body: ``"point"`` or ``"ant"``.
        maze_map: As :func:`make_maze_env`.
        low_level: As :func:`make_maze_env`; one object shared by every sub-env.
        split: As :func:`make_maze_env`.
        autoreset_mode: Gymnasium autoreset mode: ``"NextStep"`` (default), ``"SameStep"`` or ``"Disabled"``.
        max_episode_steps: As :class:`~antmaze_hirl.envs.vector.HighLevelVectorEnv` (``None``: no limit).
        normalize_actions: As :func:`make_maze_env` (:func:`unit_vector_actions`).
        **kwargs: More :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv` keywords.

    Raises:
        ValueError: If ``num_envs`` is not an integer >= 1 (before anything loads), or as :func:`make_maze_env`.
    """
    num_envs = check_num_envs(num_envs)
    first = make_maze_env(body, maze_map, low_level=low_level, split=split, **kwargs)
    shared = first.controller  # one controller for all, so that it is batched once

    def another() -> HighLevelMazeEnv:
        return _maze_env(body, maze_map, shared, split, kwargs)

    envs = [first, *(another() for _ in range(num_envs - 1))]
    return lockstep_env(envs, autoreset_mode, max_episode_steps, normalize_actions)


def lockstep_env(
    envs: list[HighLevelMazeEnv], autoreset_mode: str, max_episode_steps: int | None, normalize_actions: bool
) -> VectorEnv:
    """The lockstep vector env over ``envs`` (one shared controller), its actions in ``[-1, 1]`` if asked.

    The one tail of every id's ``vector_entry_point`` (the maze ids' and the suites').
    """
    venv = HighLevelVectorEnv(envs, autoreset_mode=autoreset_mode, max_episode_steps=max_episode_steps)
    return unit_vector_actions(venv) if normalize_actions else venv
