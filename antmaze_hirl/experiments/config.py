"""The settings of the paper's experiment: plain data, importable without torch (the CLI's defaults)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict

from antmaze_hirl.envs.bodies import body_spec

DEFAULT_METHODS = ("dagger", "noise", "multi_policy", "reward")
"""Every query strategy of :data:`antmaze_hirl.dagger.strategies.STRATEGIES`, the paper's four methods."""


class BodyDefaults(TypedDict):
    """What a body can do in the maze (see :data:`BODY_DEFAULTS`).

    Attributes:
        maze_size: Free cells per side of the random layouts.
        expert_max_distance: The oracle's farthest subgoal, metres; ``None``: one cell.
    """

    maze_size: int
    expert_max_distance: float | None


BODY_DEFAULTS: dict[str, BodyDefaults] = {
    # The point walks one-cell (1 m) oracle subgoals through 5x5 mazes.
    "point": {"maze_size": 5, "expert_max_distance": None},
    # At half torque the shipped ant walks ~0.7-1 m/s, so 500 steps (25 s) cover about 20 m: too short for
    # most 5x5 paths, and 4 m subgoals often run past H = 100 steps (README, the ant experiment).
    "ant": {"maze_size": 3, "expert_max_distance": 2.0},
}
"""Maze size and oracle subgoal distance each body can do: the ant experiment's settings and the demo's."""


@dataclass(frozen=True)
class ExperimentConfig:
    """Settings shared by every (method, seed) trial.

    Attributes:
        body: ``"point"`` or ``"ant"`` (the ant uses its shipped low-level policy).
        episodes: Training episodes per trial.
        eval_every: M: learner-only evaluation every M episodes.
        eval_episodes: Held-out mazes per intermediate evaluation.
        final_eval_episodes: Held-out mazes at the end.
        maze_size: Free cells per side of the random layouts.
        gradient_steps: N per update.
        episodes_per_update: K.
        decay: d in ``beta <- beta / d``.
        mixing: ``"blend"`` or ``"switch"``.
        expert_max_distance: The oracle's farthest subgoal, metres. ``None``: one cell. The ant's
            shipped low level reaches 2 m subgoals far more reliably than 4 m ones (README).
    """

    body: str = "point"
    episodes: int = 100
    eval_every: int = 10
    eval_episodes: int = 20
    final_eval_episodes: int = 100
    maze_size: int = 5
    gradient_steps: int = 200
    episodes_per_update: int = 1
    decay: float = 2.0
    mixing: str = "blend"
    expert_max_distance: float | None = None

    def __post_init__(self) -> None:
        body_spec(self.body)
        for name in (
            "episodes",
            "eval_every",
            "eval_episodes",
            "final_eval_episodes",
            "maze_size",
            "episodes_per_update",
        ):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.expert_max_distance is not None and not self.expert_max_distance > 0:
            raise ValueError(f"expert_max_distance must be > 0 metres, got {self.expert_max_distance}")
        if self.mixing not in ("blend", "switch"):
            raise ValueError(f"mixing must be 'blend' or 'switch', got {self.mixing!r}")
