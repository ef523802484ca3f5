"""An episode's task in a high-level maze env: the layout, where the body starts and where the goal is."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from antmaze_hirl.envs.layouts import MazeLayout


@dataclass(frozen=True)
class Task:
    """What :meth:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv.sample_task` draws for an episode.

    Attributes:
        layout: The episode's maze.
        goal_xy: The goal, metres.
        start_xy: The body's start, metres; ``None`` leaves it to the env's reset (the layout's start
            cell, drawn from the env's own RNG), e.g. while a query strategy is still to choose it.
    """

    layout: MazeLayout
    goal_xy: np.ndarray
    start_xy: np.ndarray | None = None

    def reset_options(self) -> dict[str, Any]:
        """The ``options`` of ``env.reset`` that start this task (``start_xy`` only when set)."""
        options: dict[str, Any] = {"layout": self.layout, "goal_xy": self.goal_xy}
        if self.start_xy is not None:
            options["start_xy"] = self.start_xy
        return options
