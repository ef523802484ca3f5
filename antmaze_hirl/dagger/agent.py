"""A hierarchical agent: a high-level subgoal policy over a low-level reach policy."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy
from antmaze_hirl.envs.controllers import as_controller
from antmaze_hirl.envs.profiles import maze_env_id


class HierarchicalAgent:
    """Composes a :class:`HighLevelPolicy` with a low-level controller.

    Args:
        high_level: Chooses subgoals from high-level observations.
        low_level: SB3 model or callable that walks to a subgoal.
    """

    def __init__(self, high_level: HighLevelPolicy, low_level: Any) -> None:
        self.high_level = high_level
        self.low_level = as_controller(low_level)

    @classmethod
    def load(
        cls, high_level_path: str | Path, body: str, low_level_path: str | Path | None = None
    ) -> HierarchicalAgent:
        """A saved high-level policy over a saved (default: shipped) low-level policy for ``body``."""
        from antmaze_hirl.sb3_ext.loading import load_low_level

        return cls(HighLevelPolicy.load(high_level_path), load_low_level(body, low_level_path))

    def make_env(self, body: str, **kwargs: Any) -> gym.Env:
        """The full maze env for ``body`` with this agent's low level plugged in."""
        return gym.make(maze_env_id(body), low_level=self.low_level, **kwargs)

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, None]:
        """SB3-style ``predict``: the subgoal for a high-level observation (the policy is deterministic)."""
        return self.high_level.predict(observation), None
