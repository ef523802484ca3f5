"""The bodies (ant, point) and their fixed facts: plain data, importable without MuJoCo (the CLI's choices)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Body = Literal["ant", "point"]


@dataclass(frozen=True)
class BodySpec:
    """Fixed facts about a body in gymnasium-robotics' mazes.

    Attributes:
        scale: Maze cell side in metres (``maze_size_scaling``, fixed by gymnasium-robotics).
        distance_threshold: Default reach radius in metres for subgoals and the final goal.
        default_horizon: Default low-level steps per subgoal (H).
        dt: Simulated seconds per env step.
        default_action_scale: Default multiplier on policy actions before the actuators.

    """

    scale: float
    distance_threshold: float
    default_horizon: int
    dt: float
    default_action_scale: float = 1.0


BODY_SPECS: dict[str, BodySpec] = {
    # 0.45 m is gymnasium-robotics' own success radius; H=100 (5 s) leaves a walking ant time for one cell.
    # Half of Ant-v5's gear-150 torque: at full torque TD3 learns to hop, and 30 of 32 failures of the
    # full-torque policy were flips (see README, "Low-level policies").
    "ant": BodySpec(scale=4.0, distance_threshold=0.45, default_horizon=100, dt=0.05, default_action_scale=0.5),
    # The point mass lives in 1 m cells, so the radius shrinks with it; it crosses a cell in ~20 steps.
    "point": BodySpec(scale=1.0, distance_threshold=0.2, default_horizon=50, dt=0.01),
}


def body_spec(body: str) -> BodySpec:
    """Returns the spec of ``body``.

    Raises:
        ValueError: If ``body`` is not ``"ant"`` or ``"point"``.

    """
    if body not in BODY_SPECS:
        raise ValueError(f"unknown body {body!r}; choose one of {sorted(BODY_SPECS)}")
    return BODY_SPECS[body]
