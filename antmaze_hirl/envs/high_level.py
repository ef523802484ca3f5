"""High-level subgoal-selection env: the action is an xy subgoal that a low-level controller walks to."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils.ezpickle import EzPickle

from antmaze_hirl.envs._constructor_args import record_constructor_arguments
from antmaze_hirl.envs.birdseye import BirdseyeRenderer
from antmaze_hirl.envs.controllers import as_controller, reset_controller
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import MazeLayout, MazeMap, generate_layout, layout_from_map
from antmaze_hirl.envs.profiles import DEFAULT_MAX_STEPS, maze_env_id
from antmaze_hirl.envs.reach import ReachEnv, as_finite_vector, as_free_point
from antmaze_hirl.envs.rendering import RENDER_MODES, EpisodeFrames, check_render_settings
from antmaze_hirl.envs.simulator import Body, body_spec
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.envs.task import Task

STATE_AGENT_XY = STATE_LAYOUT.agent_slice  # older names of STATE_LAYOUT's slices, kept for existing imports
STATE_GOAL_XY = STATE_LAYOUT.goal_slice
DEFAULT_MIN_GOAL_CELLS = 3


class AgentPath:
    """The body's xy after every low-level step of one high-level step, ``(steps + 1, 2)`` metres.

    An array in all but type: ``np.asarray(path)``, ``path.shape``, ``len(path)``, indexing and iteration
    work as on the array it holds (:attr:`xy`). It is no ``np.ndarray`` so that Gymnasium's vector envs,
    which stack an ndarray info into one array of the first sub-env's shape, keep these paths of different
    lengths in an object array instead (``infos["agent_path"][i]``).

    Args:
        xy: The positions, ``(steps + 1, 2)``.
    """

    __slots__ = ("xy",)

    def __init__(self, xy: np.ndarray) -> None:
        self.xy = xy

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        """The positions as an array (a copy when ``copy`` or another ``dtype`` asks for one)."""
        if dtype is not None and np.dtype(dtype) != self.xy.dtype:
            return self.xy.astype(dtype)
        return self.xy.copy() if copy else self.xy

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of :attr:`xy`."""
        return self.xy.shape

    def __len__(self) -> int:
        return len(self.xy)

    def __getitem__(self, index: Any) -> Any:
        return self.xy[index]

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter(self.xy)

    def __eq__(self, other: object) -> bool:
        """Whether ``other`` is an :class:`AgentPath` with the same positions, exactly."""
        return isinstance(other, AgentPath) and bool(np.array_equal(self.xy, other.xy))

    __hash__ = None  # type: ignore[assignment]  # equal by value, and mutable like an array

    def __repr__(self) -> str:
        return f"AgentPath({self.xy!r})"


@dataclass
class SubgoalWalk:
    """One high-level step in progress: the low level walking to one subgoal (see :meth:`HighLevelMazeEnv.step`).

    Attributes:
        subgoal: The subgoal as executed (clipped, pushed out), metres.
        clipped: Whether the subgoal was clipped to the maze.
        extended: Whether it was pushed out to ``min_subgoal_distance_m``.
        low_obs: The low level's current goal observation.
        path: Body xy at the start and after every low-level step so far.
        success: Whether the final goal is reached.
        subgoal_reached: Whether the subgoal is reached.
        fell: Whether the ant flipped (a terminal flip).
        done: Whether the walk is over (then :meth:`HighLevelMazeEnv.end_subgoal`).
    """

    subgoal: np.ndarray
    clipped: bool
    extended: bool
    low_obs: dict[str, np.ndarray]
    path: list[np.ndarray]
    success: bool = False
    subgoal_reached: bool = False
    fell: bool = False
    done: bool = False


class HighLevelMazeEnv(gym.Env, EzPickle):
    """Reach a random goal in a maze by choosing xy subgoals for a low-level controller.

    Each episode draws a layout (a random connected maze, or the fixed ``maze_map``), starts the body
    in a corner and puts the goal in a free cell at least ``min_goal_cells`` grid steps away. Each
    :meth:`step` takes a subgoal and runs the low-level controller on the inner :class:`ReachEnv` for
    up to ``horizon`` steps, stopping early once the subgoal or the goal is reached. The episode ends
    when the goal is reached (``terminated``, reward 1), when the ant has flipped onto its back
    (``terminated``, reward 0: it cannot get up again) or after ``max_steps`` low-level steps
    (``truncated``, reward 0).

    Observation ``Dict``:
        * ``image``: ``uint8 (3, rows*ppc, cols*ppc)`` bird's-eye view, channels walls/agent/goal,
        * ``state``: ``float32`` vector ``[agent_x, agent_y, goal_x, goal_y, *body_observation]``.

    Action: subgoal xy in metres, ``Box`` over the maze inside its border walls.

    ``info``: ``low_level_steps`` (this step), ``total_low_level_steps``, ``subgoal_reached``, ``flipped``,
    ``attempts`` (subgoals so far, the paper's measure), ``is_success``, ``subgoal`` (as executed),
    ``subgoal_clipped``, ``subgoal_extended``, ``subgoal_in_wall`` and ``agent_path`` (xy after every low-level step).

    Args:
        body: ``"point"`` (the default, as in :class:`ReachEnv`: the cheaper body) or ``"ant"``.
        maze_map: ``None`` for a new random layout every episode, else a fixed map (rows or a
            standard name ``"u"``, ``"open"``, ``"medium"``, ``"large"``) with random start corner and goal.
        maze_size: Free cells of random layouts, ``n`` or ``(rows, cols)``.
        wall_fraction: Share of interior cells that random layouts turn into walls.
        min_goal_cells: Least grid steps on the shortest path from the start cell to the goal cell.
        low_level: SB3 model or callable ``goal observation -> action`` (required). ``gym.make`` of
            ``antmaze_hirl/AntMaze-v0`` or ``antmaze_hirl/PointMaze-v0`` without it plugs in the policy
            shipped for the body (:func:`antmaze_hirl.sb3_ext.shipped.make_maze_env`).
        horizon: Low-level steps per subgoal, H. Default per body (ant 100, point 50).
        max_steps: Low-level step budget per episode.
        success_radius_m: How near the final goal counts as reached, metres. Default per body (ant 0.45,
            point 0.2). The low level's, for subgoals, is ``reach_kwargs["success_radius_m"]`` (same default).
        position_noise_cells: Start and goal offsets, cells: uniform in ``±position_noise_cells``.
        pixels_per_cell: Image resolution.
        clip_subgoals: Clip out-of-bounds subgoals (flagged in ``info``) instead of raising.
        min_subgoal_distance_m: Subgoals nearer the body than this, metres, are pushed out to it along
            the same heading, then clipped to the maze bounds (flagged in ``info``; near a border the
            clip can leave them nearer, which :class:`~antmaze_hirl.dagger.DAggerTrainer` catches).
            A subgoal inside the low level's success radius is "reached" in one step, so a learner (or a
            beta-blend of opposite proposals) that keeps proposing one would burn an expert label per
            low-level step. Default twice the low level's ``success_radius_m`` (ant 0.9 m, point
            0.4 m); 0 turns it off.
        terminate_on_flip: Ant only: end the episode as a failure once the ant has flipped.
        reach_kwargs: Extra :class:`ReachEnv` arguments (``success_radius_m`` for subgoals, ...).
        render_mode: ``"rgb_array"`` for a picture of now, ``"rgb_array_list"`` for one frame at the reset and one
            after every low-level step (``render()`` returns those since its last call), e.g. for a video of the walk.
        render_view: What the pictures show (:mod:`antmaze_hirl.envs.rendering`): ``"schematic"`` (the default,
            the bird's-eye picture), ``"trail"`` (it, plus the path so far and the current subgoal) or ``"mujoco"``
            (a MuJoCo camera over the maze, offscreen: needs ``MUJOCO_GL=egl`` or ``osmesa`` on a headless machine).

    Raises:
        ValueError: If ``low_level`` is missing, a number is out of range, or the render mode or view is
            unknown.
        RenderUnavailable: For ``render_view="mujoco"`` without ``MUJOCO_GL`` or a display.

    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": list(RENDER_MODES), "render_fps": 4}

    def __init__(
        self,
        body: Body = "point",
        maze_map: str | MazeMap | None = None,
        *,
        maze_size: int | tuple[int, int] = 5,
        wall_fraction: float = 0.3,
        min_goal_cells: int = DEFAULT_MIN_GOAL_CELLS,
        low_level: Any = None,
        horizon: int | None = None,
        max_steps: int = DEFAULT_MAX_STEPS,
        success_radius_m: float | None = None,
        position_noise_cells: float = 0.25,
        pixels_per_cell: int = 8,
        clip_subgoals: bool = False,
        min_subgoal_distance_m: float | None = None,
        terminate_on_flip: bool = True,
        reach_kwargs: dict[str, Any] | None = None,
        render_mode: str | None = None,
        render_view: str = "schematic",
    ) -> None:
        record_constructor_arguments(self, locals(), HighLevelMazeEnv)  # first: locals() holds only the parameters
        if low_level is None:
            raise ValueError(
                f"HighLevelMazeEnv needs a low-level controller: pass low_level=<SB3 model or callable obs -> "
                f"action>, or make it with gym.make('{maze_env_id(str(body))}') to use the "
                f"shipped policy"
            )
        spec = body_spec(body)
        if max_steps < 1:
            raise ValueError(f"max_steps must be >= 1, got {max_steps}")
        if not 0 <= position_noise_cells < 0.5:
            raise ValueError(f"position_noise_cells must lie in [0, 0.5) cells, got {position_noise_cells}")
        check_render_settings(render_mode, render_view)
        self.body = body
        self.render_mode = render_mode
        self.max_steps = int(max_steps)
        self.success_radius_m = float(success_radius_m if success_radius_m is not None else spec.success_radius_m)
        self.position_noise_cells = float(position_noise_cells)
        self.clip_subgoals = clip_subgoals
        self.min_goal_cells = int(min_goal_cells)
        self.wall_fraction = float(wall_fraction)
        n_rows, n_cols = (maze_size, maze_size) if isinstance(maze_size, int) else maze_size
        self.maze_size = (int(n_rows), int(n_cols))
        self._fixed_map = None if maze_map is None else maze_map
        first_layout = self.sample_layout(np.random.default_rng(0))
        self.controller = as_controller(low_level)
        reach_kwargs = {"terminate_on_flip": terminate_on_flip, **(reach_kwargs or {})}
        self.reach = ReachEnv(body, first_layout.to_maze_map(), horizon=horizon, **reach_kwargs)
        self.layout = first_layout
        self.geometry: MazeGeometry = self.reach.sim.geometry
        self.min_subgoal_distance_m = float(
            min_subgoal_distance_m if min_subgoal_distance_m is not None else 2 * self.reach.success_radius_m
        )
        if not 0 <= self.min_subgoal_distance_m < self.geometry.scale:
            raise ValueError(
                f"min_subgoal_distance_m must lie in [0, {self.geometry.scale}) metres (one cell), "
                f"got {self.min_subgoal_distance_m}"
            )
        self.renderer = BirdseyeRenderer(self.geometry, pixels_per_cell)
        self.frames = EpisodeFrames(render_mode, render_view, self.renderer)
        scale = self.geometry.scale
        self.action_space = spaces.Box(
            (self.geometry.low + scale).astype(np.float32),
            (self.geometry.high - scale).astype(np.float32),
            dtype=np.float32,
        )
        state_dim = STATE_LAYOUT.state_dim(self.reach.sim.observation_dim)
        self.observation_space = spaces.Dict(
            {
                "image": spaces.Box(0, 255, shape=self.renderer.shape, dtype=np.uint8),
                "state": spaces.Box(-np.inf, np.inf, shape=(state_dim,), dtype=np.float32),
            }
        )
        self.goal_xy = np.zeros(2)
        self.attempts = 0
        self.total_low_level_steps = 0

    @property
    def agent_xy(self) -> np.ndarray:
        """Current body xy, metres."""
        return self.reach.agent_xy

    @property
    def pixels_per_cell(self) -> int:
        """Image pixels per maze cell side (the ``pixels_per_cell`` argument)."""
        return self.renderer.pixels_per_cell

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """Starts an episode.

        Args:
            seed: Seeds ``self.np_random``, the only source of randomness.
            options: Optional ``"layout"`` (a :class:`MazeLayout` of this env's map shape),
                ``"start_xy"`` and ``"goal_xy"`` (exact positions, metres, in free cells).

        Raises:
            ValueError: If a given layout has another shape or a position is NaN or in a wall.

        """
        super().reset(seed=seed)
        options = options or {}
        task = self.sample_task(
            self.np_random,
            layout=options.get("layout"),
            start_xy=options.get("start_xy"),
            goal_xy=options.get("goal_xy"),
        )
        self.reach.set_walls(task.layout.walls)
        self.layout = task.layout
        self.goal_xy = task.goal_xy
        self.reach.reset(
            seed=int(self.np_random.integers(2**31)), options={"start_xy": task.start_xy, "subgoal_xy": self.goal_xy}
        )
        self.attempts = 0
        self.total_low_level_steps = 0
        # A stateful controller (action smoothing, say) starts every episode afresh, so that episode
        # figures do not depend on the order episodes ran in.
        reset_controller(self.controller)
        self.frames.start_episode(self)
        return self._get_obs(), {"is_success": self._goal_reached(), "attempts": 0, "total_low_level_steps": 0}

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        """Runs the low-level controller towards subgoal ``action`` for up to ``horizon`` steps.

        Raises:
            ValueError: If the subgoal is NaN/inf or, unless ``clip_subgoals``, outside the maze.

        """
        walk = self.begin_subgoal(action)
        while not walk.done:
            self.advance_subgoal(walk, self.controller(walk.low_obs))
        return self.end_subgoal(walk)

    def begin_subgoal(self, action: np.ndarray) -> SubgoalWalk:
        """The first part of :meth:`step`: checks and sets subgoal ``action``, and starts its walk.

        :meth:`step` is ``begin_subgoal`` (:meth:`check_subgoal`, then :meth:`start_walk`), then
        :meth:`advance_subgoal` with the controller's action until the walk is done, then
        :meth:`end_subgoal`; a vector env runs the same parts for many mazes, with one batched controller
        call per low-level step.

        Raises:
            ValueError: If the subgoal is NaN/inf or, unless ``clip_subgoals``, outside the maze.
        """
        return self.start_walk(*self.check_subgoal(action))

    def check_subgoal(self, action: np.ndarray) -> tuple[np.ndarray, bool]:
        """Subgoal ``action`` clipped to the maze, and whether it was clipped; changes nothing.

        Raises:
            ValueError: If the subgoal is NaN/inf or, unless ``clip_subgoals``, outside the maze.
        """
        subgoal = as_finite_vector(action, 2, "subgoal")
        low, high = self.action_space.low, self.action_space.high
        clipped = bool(np.any(subgoal < low) or np.any(subgoal > high))
        if clipped and not self.clip_subgoals:
            raise ValueError(
                f"subgoal {subgoal.tolist()} is outside the maze bounds x in [{low[0]}, {high[0]}], "
                f"y in [{low[1]}, {high[1]}]; pass clip_subgoals=True to clip instead"
            )
        return np.clip(subgoal, low, high), clipped

    def start_walk(self, subgoal: np.ndarray, clipped: bool) -> SubgoalWalk:
        """Sets a subgoal that :meth:`check_subgoal` returned (pushed out if too near) and starts its walk."""
        subgoal, extended = self._push_out(subgoal)
        low_obs = self.reach.set_subgoal(subgoal)
        self.attempts += 1
        walk = SubgoalWalk(subgoal, clipped, extended, low_obs, [self.reach.agent_xy])
        walk.done = self.total_low_level_steps >= self.max_steps
        return walk

    def advance_subgoal(self, walk: SubgoalWalk, low_action: np.ndarray) -> None:
        """One low-level step of ``walk`` with ``low_action``; sets ``walk.done`` when the walk is over."""
        low_obs, _, fell, horizon_over, low_info = self.reach.step(low_action)
        self.total_low_level_steps += 1
        walk.path.append(low_obs["achieved_goal"])
        walk.low_obs = low_obs
        walk.success = self._goal_reached()
        walk.subgoal_reached = low_info["is_success"]
        walk.fell = fell
        walk.done = bool(
            walk.success or walk.subgoal_reached or fell or horizon_over or self.total_low_level_steps >= self.max_steps
        )
        self.frames.after_low_level_step(self, walk.subgoal)

    def end_subgoal(self, walk: SubgoalWalk) -> tuple[dict, float, bool, bool, dict]:
        """The last part of :meth:`step`: its ``(observation, reward, terminated, truncated, info)``."""
        success = walk.success
        info = {
            "low_level_steps": len(walk.path) - 1,
            "total_low_level_steps": self.total_low_level_steps,
            "subgoal_reached": bool(walk.subgoal_reached),
            "flipped": bool(walk.fell),
            "attempts": self.attempts,
            "is_success": success,
            "subgoal": walk.subgoal,
            "subgoal_clipped": walk.clipped,
            "subgoal_extended": walk.extended,
            "subgoal_in_wall": not self.geometry.is_free(self.layout.walls, walk.subgoal),
            "agent_path": AgentPath(np.asarray(walk.path)),
        }
        truncated = not success and self.total_low_level_steps >= self.max_steps
        return self._get_obs(), float(success), success or walk.fell, truncated, info

    def is_no_op_subgoal(self, subgoal: np.ndarray) -> bool:
        """Whether ``subgoal`` lies within :attr:`min_subgoal_distance_m` of the body's exact position.

        The low level would "reach" such a subgoal without moving: :meth:`step` pushes it out, and the
        DAgger trainer replaces a mix that is still one after clipping by the expert's subgoal.
        """
        return bool(np.linalg.norm(subgoal - self.agent_xy) < self.min_subgoal_distance_m)

    def _push_out(self, subgoal: np.ndarray) -> tuple[np.ndarray, bool]:
        offset = subgoal - self.agent_xy
        distance = float(np.linalg.norm(offset))
        if not self.is_no_op_subgoal(subgoal) or distance == 0.0:
            return subgoal, False
        pushed = self.agent_xy + offset * (self.min_subgoal_distance_m / distance)
        return np.clip(pushed, self.action_space.low, self.action_space.high), True

    def render(self) -> np.ndarray | list[np.ndarray] | None:
        """The ``render_view`` picture now (``"rgb_array"``), or the frames since the last call (``rgb_array_list``)."""
        return self.frames.render(self)

    def close(self) -> None:
        """Releases the simulator (and the MuJoCo view's renderer, if one was made)."""
        self.frames.close()
        self.reach.close()

    def sample_layout(self, rng: np.random.Generator) -> MazeLayout:
        """Draws an episode's layout the way :meth:`reset` does (a random maze, or the fixed map), from ``rng``."""
        if self._fixed_map is None:
            n_rows, n_cols = self.maze_size
            return generate_layout(
                rng,
                n_rows=n_rows,
                n_cols=n_cols,
                wall_fraction=self.wall_fraction,
                min_goal_cells=self.min_goal_cells,
            )
        return layout_from_map(self._fixed_map, rng, min_goal_cells=self.min_goal_cells)

    def sample_task(
        self,
        rng: np.random.Generator,
        *,
        layout: MazeLayout | None = None,
        start_xy: np.ndarray | None = None,
        goal_xy: np.ndarray | None = None,
        draw_start: bool = True,
    ) -> Task:
        """Draws an episode's task from ``rng`` the way :meth:`reset` does, keeping the parts given.

        Draws, in this order and only where not given: the layout (:meth:`sample_layout`), the start
        (its start cell, when ``draw_start``) and the goal (its goal cell), each cell's position with
        :meth:`noisy_cell_centre`. :meth:`reset` calls it with its ``options``; the DAgger trainer with
        ``draw_start=False``, since its query strategy picks the start once it knows layout and goal.

        Raises:
            ValueError: If ``layout`` is not a :class:`MazeLayout` or ``goal_xy`` is NaN or in a wall.
        """
        layout = layout or self.sample_layout(rng)
        if not isinstance(layout, MazeLayout):
            raise ValueError(f"layout (reset's options['layout']) must be a MazeLayout, got {type(layout).__name__}")
        if start_xy is None and draw_start:
            start_xy = self.noisy_cell_centre(layout.start_cell, rng)
        if goal_xy is None:
            goal_xy = self.noisy_cell_centre(layout.goal_cell, rng)
        else:
            goal_xy = as_free_point(goal_xy, self.geometry, layout.walls, "goal_xy")
        return Task(layout, goal_xy, start_xy)

    def noisy_cell_centre(self, cell: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        """The centre of ``cell`` plus uniform noise in ``±position_noise_cells`` (cells) from ``rng``.

        This is how :meth:`sample_task` places starts and goals.
        """
        noise = rng.uniform(-self.position_noise_cells, self.position_noise_cells, size=2)
        return self.geometry.cell_to_xy(cell) + noise * self.geometry.scale

    def _goal_reached(self) -> bool:
        return bool(np.linalg.norm(self.reach.agent_xy - self.goal_xy) <= self.success_radius_m)

    def _get_obs(self) -> dict[str, np.ndarray]:
        agent_xy = self.reach.agent_xy
        state = STATE_LAYOUT.compose(agent_xy, self.goal_xy, self.reach.body_observation)
        return {"image": self.renderer.observation(self.layout.walls, agent_xy, self.goal_xy), "state": state}
