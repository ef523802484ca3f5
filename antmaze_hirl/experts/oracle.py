"""Scripted oracle expert: plans the shortest grid path and gives the next subgoal along it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from antmaze_hirl.envs.birdseye import BirdseyeRenderer
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import shortest_path
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.envs.state_layout import STATE_LAYOUT


def plan_subgoal(
    walls: np.ndarray,
    geometry: MazeGeometry,
    agent_xy: np.ndarray,
    goal_xy: np.ndarray,
    *,
    subgoal_reach_m: float,
    clearance_m: float,
) -> np.ndarray:
    """The farthest point along the shortest path that a straight walk from the agent reaches.

    Waypoints are the centres of the path's cells, then the goal itself. The subgoal is the last
    waypoint before the first one hidden behind a wall (the segment to it must keep ``clearance_m``
    from walls), pulled back to at most ``subgoal_reach_m`` from the agent.

    Raises:
        ValueError: If the goal cannot be reached from the agent's cell.

    """
    agent_cell = _nearest_free_cell(walls, geometry, agent_xy)
    goal_cell = _nearest_free_cell(walls, geometry, goal_xy)
    cells = shortest_path(walls, agent_cell, goal_cell)
    waypoints = [geometry.cell_to_xy(cell) for cell in cells[1:-1]] + [np.asarray(goal_xy, dtype=float)]
    target = geometry.cell_to_xy(agent_cell)  # own cell centre: always reachable in a straight line
    for waypoint in waypoints:
        if not geometry.segment_is_free(walls, agent_xy, waypoint, clearance_m):
            break
        target = waypoint
    offset = target - agent_xy
    distance = float(np.linalg.norm(offset))
    if distance > subgoal_reach_m:
        target = agent_xy + offset * (subgoal_reach_m / distance)
    return target


@dataclass(frozen=True)
class LabelledStates:
    """Oracle-labelled states: parallel lists of wall grids, agent and goal xy (metres), body states and labels."""

    walls: list[np.ndarray]
    agents: list[np.ndarray]
    goals: list[np.ndarray]
    bodies: list[np.ndarray]
    labels: list[np.ndarray]


def sample_labelled_states(
    env: Any, count: int, *, subgoal_reach_m: float, rng: np.random.Generator, reset_seed: int = 0
) -> LabelledStates:
    """``count`` states of ``env``'s tasks, each labelled by :func:`plan_subgoal`, without simulating.

    Each state draws a task (``sample_task(rng)``: the env's layouts, its split's part where it has one) and
    puts the agent at a random free cell other than the goal's, its centre moved by up to 0.35 cell on each
    axis, at rest (the body observation a reset with ``reset_seed`` leaves), labelled with the oracle's reach
    ``subgoal_reach_m`` and a clearance of 0.2 cell. For a learner's held-out agreement and grid-level checks.
    """
    maze = maze_env(env)
    geometry = maze.geometry
    at_rest = STATE_LAYOUT.body_observation(env.reset(seed=reset_seed)[0]["state"])
    states = LabelledStates([], [], [], [], [])
    while len(states.agents) < count:
        task = maze.sample_task(rng)
        free = np.argwhere(~task.layout.walls)
        cell = tuple(free[rng.integers(len(free))])
        if cell == geometry.xy_to_cell(task.goal_xy):
            continue
        agent = geometry.cell_to_xy(cell) + rng.uniform(-0.35, 0.35, size=2) * geometry.scale
        label = plan_subgoal(
            task.layout.walls,
            geometry,
            agent,
            task.goal_xy,
            subgoal_reach_m=subgoal_reach_m,
            clearance_m=0.2 * geometry.scale,
        )
        states.walls.append(task.layout.walls)
        states.agents.append(agent)
        states.goals.append(task.goal_xy)
        states.bodies.append(at_rest)
        states.labels.append(label)
    return states


def _nearest_free_cell(walls: np.ndarray, geometry: MazeGeometry, xy: np.ndarray) -> tuple[int, int]:
    # A body pressed against a wall can have its centre a hair inside the wall's cell.
    row, col = geometry.xy_to_cell(xy)
    if 0 <= row < walls.shape[0] and 0 <= col < walls.shape[1] and not walls[row, col]:
        return row, col
    free = np.argwhere(~walls)
    centres = np.array([geometry.cell_to_xy(cell) for cell in free])
    nearest = free[np.argmin(np.linalg.norm(centres - xy, axis=1))]
    return int(nearest[0]), int(nearest[1])


class PathOracle:
    """Scripted expert for the high-level env: labels an observation with a subgoal.

    It reads everything from the observation itself (walls from the image's wall channel, agent and
    goal from ``state``), so it labels stored or perturbed observations as well as live ones.

    Args:
        geometry: Map placement of the env it serves.
        pixels_per_cell: The env's image resolution.
        subgoal_reach_m: Farthest subgoal from the agent, metres ("towards the target but not too far").
            Default one cell.
        clearance_m: Distance the straight walk to a subgoal keeps from walls, metres. Default 0.2 cell.
        noise_std_m: Std of Gaussian noise added to each subgoal, metres, to imitate a human's clicks.
        rng: Source of the noise (required when ``noise_std_m > 0``).

    """

    def __init__(
        self,
        geometry: MazeGeometry,
        *,
        pixels_per_cell: int = 8,
        subgoal_reach_m: float | None = None,
        clearance_m: float | None = None,
        noise_std_m: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> None:
        if noise_std_m < 0:
            raise ValueError(f"noise_std_m must be >= 0, got {noise_std_m}")
        if noise_std_m > 0 and rng is None:
            raise ValueError("noise_std_m > 0 needs an explicit rng (np.random.Generator) so labels are reproducible")
        self.geometry = geometry
        self.renderer = BirdseyeRenderer(geometry, pixels_per_cell)
        self.subgoal_reach_m = float(subgoal_reach_m if subgoal_reach_m is not None else geometry.scale)
        if self.subgoal_reach_m <= 0:
            raise ValueError(f"subgoal_reach_m must be > 0, got {subgoal_reach_m}")
        self.clearance_m = float(clearance_m if clearance_m is not None else 0.2 * geometry.scale)
        self.noise_std_m = float(noise_std_m)
        self.rng = rng

    @classmethod
    def for_env(cls, env: Any, **kwargs: Any) -> PathOracle:
        """An oracle matching the geometry and image resolution of a (wrapped) high-level env.

        Raises:
            TypeError: If ``env`` is no high-level maze env (:func:`~antmaze_hirl.envs.protocol.maze_env`).
        """
        maze = maze_env(env)
        return cls(maze.geometry, pixels_per_cell=maze.pixels_per_cell, **kwargs)

    def label(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The expert subgoal ``pi*(s)`` for a high-level observation, metres."""
        state = np.asarray(observation["state"], dtype=np.float64)
        walls = self.renderer.walls_from_image(observation["image"])
        subgoal = plan_subgoal(
            walls,
            self.geometry,
            STATE_LAYOUT.agent_xy(state),
            STATE_LAYOUT.goal_xy(state),
            subgoal_reach_m=self.subgoal_reach_m,
            clearance_m=self.clearance_m,
        )
        if self.noise_std_m > 0:
            subgoal = subgoal + self.rng.normal(0.0, self.noise_std_m, size=2)
        inner_low = self.geometry.low + self.geometry.scale
        return np.clip(subgoal, inner_low, -inner_low)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Same as :meth:`label`, so the oracle also serves as a policy callable."""
        return self.label(observation)
