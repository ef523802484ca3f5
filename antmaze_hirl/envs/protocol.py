"""What the layers above read from a high-level maze env, and the one way they reach it through wrappers.

A trainer, a query strategy, the oracle or an evaluation loop is handed a high-level env as the user made
it: ``gym.make("antmaze_hirl/PointMaze-v0")`` (wrapped in Gymnasium's checkers), a
:class:`~antmaze_hirl.envs.split_env.SplitMazeEnv` or a benchmark suite's env. Besides ``reset`` and
``step`` (which go through the wrappers) they read the episode's maze, draw tasks and check subgoals on
the env under the wrappers: :class:`MazeEnvProtocol` lists exactly that, and :func:`maze_env` is the one
place that unwraps, so a caller holds a typed object instead of ``env.unwrapped.x`` chains.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np
from gymnasium import spaces

from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import MazeLayout
from antmaze_hirl.envs.task import Task


@runtime_checkable
class MazeEnvProtocol(Protocol):
    """The high-level maze env as the DAgger trainer, its strategies and learners, and the oracle read it.

    :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv` and its subclasses (the split and suite envs)
    provide it. ``isinstance(env, MazeEnvProtocol)`` checks that every member exists, not their types.

    Attributes:
        body: ``"point"`` or ``"ant"``.
        layout: The current episode's maze (drawn at reset).
        goal_xy: The current episode's goal, metres.
        geometry: Where the maze's cells lie, metres.
        min_goal_cells: Least grid steps from an episode's start cell to its goal cell.
        pixels_per_cell: Resolution of the bird's-eye image observation (what the oracle decodes walls from).
        action_space: Subgoal xy ``Box``, metres: the maze inside its border walls.
        observation_space: ``Dict`` of ``image`` and ``state``.
    """

    body: str
    layout: MazeLayout
    goal_xy: np.ndarray
    geometry: MazeGeometry
    min_goal_cells: int
    action_space: spaces.Box
    observation_space: spaces.Dict

    @property
    def pixels_per_cell(self) -> int:
        """Image pixels per maze cell."""
        ...

    def sample_task(
        self,
        rng: np.random.Generator,
        *,
        layout: MazeLayout | None = None,
        start_xy: np.ndarray | None = None,
        goal_xy: np.ndarray | None = None,
        draw_start: bool = True,
    ) -> Task:
        """Draws an episode's task from ``rng`` as ``reset`` does; ``reset(options=task.reset_options())`` plays it."""
        ...

    def is_no_op_subgoal(self, subgoal: np.ndarray) -> bool:
        """Whether the low level would "reach" ``subgoal`` without moving (too near the body)."""
        ...


MAZE_ENV_MEMBERS: tuple[str, ...] = (
    "action_space",
    "body",
    "geometry",
    "goal_xy",
    "is_no_op_subgoal",
    "layout",
    "min_goal_cells",
    "observation_space",
    "pixels_per_cell",
    "sample_task",
)
"""The members of :class:`MazeEnvProtocol`, which :func:`maze_env`'s error lists where they are missing."""


def maze_env(env: Any) -> MazeEnvProtocol:
    """The high-level maze env under ``env``'s Gymnasium wrappers (``env`` itself when it has none).

    Raises:
        TypeError: If what lies under the wrappers lacks a member of :class:`MazeEnvProtocol` (names its
            type and the members missing).
    """
    inner = getattr(env, "unwrapped", env)
    if isinstance(inner, MazeEnvProtocol):
        return inner
    missing = [name for name in MAZE_ENV_MEMBERS if not hasattr(inner, name)]
    raise TypeError(
        f"expected a high-level maze env (antmaze_hirl/...Maze-v0, possibly wrapped), got {type(inner).__name__} "
        f"without {', '.join(missing)}"
    )
