"""The layout of the high-level observation's ``state`` vector: ``[agent_x, agent_y, goal_x, goal_y, *body]``."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

# Fixed by HighLevelMazeEnv's observation; every consumer reads the vector through STATE_LAYOUT.
_XY_DIM = 2


class HighLevelStateLayout:
    """Where the agent xy, the goal xy and the body observation sit in a high-level ``state``.

    Accessors take one state ``(d,)`` or a batch ``(..., d)`` and return views of the same dtype, so
    reading through them changes no numbers.

    Attributes:
        agent_slice: Where the agent's xy, metres, sits.
        goal_slice: Where the goal's xy, metres, sits.
        body_slice: Where the body observation sits (the rest of the vector).
    """

    agent_slice: ClassVar[slice] = slice(0, _XY_DIM)
    goal_slice: ClassVar[slice] = slice(_XY_DIM, 2 * _XY_DIM)
    body_slice: ClassVar[slice] = slice(2 * _XY_DIM, None)

    @property
    def positions_dim(self) -> int:
        """Length of the leading agent and goal xy part, metres (not the learner's ``planar_feature_dim``)."""
        return 2 * _XY_DIM

    def agent_xy(self, state: np.ndarray) -> np.ndarray:
        """The agent's xy in ``state``."""
        return state[..., self.agent_slice]

    def goal_xy(self, state: np.ndarray) -> np.ndarray:
        """The goal's xy in ``state``."""
        return state[..., self.goal_slice]

    def body_observation(self, state: np.ndarray) -> np.ndarray:
        """The body observation in ``state`` (the point's velocity, the ant's torso and joints)."""
        return state[..., self.body_slice]

    def state_dim(self, body_dim: int) -> int:
        """Length of a state whose body observation has ``body_dim`` values.

        Raises:
            ValueError: If ``body_dim`` is negative.
        """
        if body_dim < 0:
            raise ValueError(f"body_dim must be >= 0, got {body_dim}")
        return self.positions_dim + body_dim

    def body_dim(self, state_dim: int) -> int:
        """Length of the body observation in a state of ``state_dim`` values.

        Raises:
            ValueError: If ``state_dim`` leaves no room for the agent and goal xy.
        """
        if state_dim < self.positions_dim:
            raise ValueError(f"a high-level state has at least {self.positions_dim} values, got {state_dim}")
        return state_dim - self.positions_dim

    def compose(self, agent_xy: np.ndarray, goal_xy: np.ndarray, body: np.ndarray) -> np.ndarray:
        """The ``float32`` state of these parts (as the env builds it)."""
        return np.concatenate([agent_xy, goal_xy, body]).astype(np.float32)


STATE_LAYOUT = HighLevelStateLayout()
"""The one layout of every high-level env's ``state``."""
