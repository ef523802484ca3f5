"""Low-level goal-reaching env: walk the body to an xy subgoal within H steps (what SB3 + HER trains)."""

from __future__ import annotations

import functools
import numbers
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.utils.ezpickle import EzPickle
from gymnasium_robotics.core import GoalEnv

from antmaze_hirl.envs._constructor_args import record_constructor_arguments
from antmaze_hirl.envs.birdseye import BirdseyeRenderer
from antmaze_hirl.envs.controllers import ActionSmoother
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layout_splits import LayoutSplit, check_split, sample_layout_in_split
from antmaze_hirl.envs.layouts import MazeMap, generate_layout, validate_maze_map
from antmaze_hirl.envs.simulator import Body, body_spec
from antmaze_hirl.envs.simulator_pool import acquire_simulator, release_simulator

REWARD_TYPES = ("sparse", "dense")


def as_finite_vector(value: Any, size: int, name: str) -> np.ndarray:
    """``value`` as a float64 vector of ``size`` finite entries.

    Raises:
        ValueError: Naming ``name`` and the value if the shape is wrong or an entry is NaN/inf.

    """
    vector = np.asarray(value, dtype=np.float64)
    if vector.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), got shape {vector.shape}: {value!r}")
    if not np.isfinite(vector).all():  # the method skips np.all's dispatch: called on every low-level step
        raise ValueError(f"{name} must be finite, got {vector.tolist()}")
    return vector


def as_free_point(value: Any, geometry: MazeGeometry, walls: np.ndarray, name: str) -> np.ndarray:
    """``value`` as a finite xy that lies in a free cell of ``walls``.

    Raises:
        ValueError: Naming ``name`` and the value if it is malformed, NaN/inf, or not in a free cell.
    """
    point = as_finite_vector(value, 2, name)
    if not geometry.is_free(walls, point):
        raise ValueError(f"{name} {point.tolist()} is not in a free cell of the maze")
    return point


RESET_OPTIONS = ("start_xy", "subgoal_xy")
"""The keys of :class:`ReachEnv`'s reset ``options``. Any other is refused, since ignoring one (a misspelling, or
``"goal_xy"``, the final goal of :class:`HighLevelMazeEnv`) would draw a random start or subgoal instead."""


def _check_options(options: dict[str, Any]) -> None:
    """Raises ``ValueError`` naming the first key of ``options`` not in :data:`RESET_OPTIONS`, and its value."""
    for key in options:
        if key not in RESET_OPTIONS:
            raise ValueError(
                f"ReachEnv's reset options are {list(RESET_OPTIONS)}: got options[{key!r}]={options[key]!r}"
            )


INFO_PENALTIES = ("flip_penalty", "tilt_penalty")
""":class:`ReachEnv` arguments whose reward terms read the step infos: HER's relabelling must keep the infos."""


def info_values(info: Any, key: str, shape: tuple[int, ...], default: float) -> np.ndarray:
    """``info[key]`` as floats of ``shape``, ``default`` where missing.

    ``info`` is one step's dict or a sequence of dicts (HER's batch).

    Raises:
        ValueError: If ``info`` is neither, or holds another number of dicts than ``shape`` needs.
    """
    if isinstance(info, dict):
        return np.full(shape, float(info.get(key, default)))
    if not isinstance(info, list | tuple | np.ndarray) or not all(isinstance(item, dict) for item in info):
        raise ValueError(f"info must be a dict or a sequence of dicts, got {type(info).__name__}: {info!r:.80}")
    values = np.array([float(item.get(key, default)) for item in info])
    if values.size != int(np.prod(shape)):
        raise ValueError(f"info holds {values.size} dicts for {int(np.prod(shape))} rewards of shape {shape}")
    return values.reshape(shape)


def flipped_flags(info: Any, shape: tuple[int, ...]) -> np.ndarray:
    """``info["flipped"]`` as floats (1.0 flipped, 0.0 not or missing) of ``shape``, as :func:`info_values`."""
    return (info_values(info, "flipped", shape, 0.0) != 0).astype(np.float64)


class ReachEnv(GoalEnv, EzPickle):
    """Goal-conditioned locomotion in a maze: reach a subgoal sampled near the body.

    Each episode places the body in a random free cell of ``maze_map`` (or where ``options`` say) and
    samples a subgoal uniformly (by area) in the ring ``min_sample_radius_m..sample_radius_m`` around it, in
    free space and in line of sight (a straight walk can reach it). The episode is truncated after ``horizon`` steps.

    Observation ``Dict``:
        * ``observation``: body state without its xy (ant: 27 values, 105 with contact forces;
          point: its 2 velocities),
        * ``achieved_goal``: body xy (metres),
        * ``desired_goal``: subgoal xy (metres).

    Action: the body's own ``Box(-1, 1)`` (ant: 8 joint torques, point: 2 forces), multiplied by
    ``action_scale`` before it reaches the actuators.

    Reward: ``sparse`` gives 1.0 within ``success_radius_m`` of the subgoal, else 0.0 (the
    gymnasium-robotics convention); ``dense`` gives ``exp(-distance)``. ``info["is_success"]`` says
    whether the body is within ``success_radius_m`` now.

    Args:
        body: ``"point"`` (PointMaze ball in 1 m cells; the default, as in :class:`HighLevelMazeEnv`:
            the cheaper body) or ``"ant"`` (Gymnasium Ant-v5 in 4 m cells). The registered ids name
            their body explicitly.
        maze_map: Layout, a list of rows or a standard map name. Default ``"open"`` (3x5 free cells).
        horizon: Steps per episode, H. Default per body: ant 100, point 50.
        sample_radius_m: Largest subgoal distance, metres (not the oracle's reach). Default: one maze cell
            (ant 4 m, point 1 m).
        min_sample_radius_m: Smallest subgoal distance, metres. Default: ``success_radius_m``.
        success_radius_m: How near the subgoal counts as reached, metres. Default per body: ant 0.45, point 0.2.
        reward_type: ``"sparse"`` or ``"dense"``.
        action_scale: Multiplier in ``(0, 1]`` on actions. Default per body: ant 0.5, point 1. The
            paper's rllab Ant used a (-30, 30) control range with gear 1; Gymnasium's Ant-v5, used here,
            has (-1, 1) with gear 150, so scale 1 is 150 N m peak torque and smaller scales mimic weaker
            motors (at 0.5 the ant flips far less often).
        terminate_on_flip: Ant only: end the episode when the torso faces down or drops below 0.2 m.
        chain_probability: Chance that a ``reset()`` without seed or options keeps the body as it is
            (moving, wherever the last episode left it) and only draws a new subgoal. The high level
            switches subgoals while the body is in motion; training from rest only never shows that.
            Never after a flip. Default 0: every episode starts from rest.
        include_contact_forces: Ant only: keep contact forces in ``observation``.
        render_mode: ``"rgb_array"`` renders the bird's-eye view (no OpenGL needed).
        maze_probability: Chance that a from-rest ``reset()`` without ``start_xy``/``subgoal_xy`` options
            rebuilds the walls from a random layout (:func:`~antmaze_hirl.envs.layouts.generate_layout`)
            instead of ``maze_map``: the high level walks the body between walls, the open map never
            shows any. Subgoals stay in line of sight, so they hug walls and corners. Default 0: always
            ``maze_map``.
        maze_sizes: Free cells per side of those random layouts, one drawn uniformly per layout
            (the ant experiment's mazes are 3x3). Each at least 2.
        maze_wall_fraction: Share of interior cells that random layouts turn into walls, in ``[0, 1)``
            (default 0.3, as :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv`).
        maze_split: Draw random layouts only from this part of the fixed layout partition
            (:mod:`~antmaze_hirl.envs.layout_splits`, by wall grid): ``"train"`` keeps every wall grid of
            the held-out evaluation and selection mazes out of training, by construction. Default
            ``None``: any layout (the 3x3 family's 48 wall grids then overlap its evaluation mazes).
        flip_penalty: Ant only: subtracted from the reward of every step on which the body is flipped
            (``info["flipped"]``), so a flip costs more than a timeout. With ``terminate_on_flip`` that
            is the terminal step only. HER relabelling needs the infos kept (SB3's
            ``copy_info_dict=True``) to see it. Default 0.
        action_smoothing: Weight ``alpha`` in ``[0, 1)`` of the previous applied action: the body gets
            ``alpha * previous + (1 - alpha) * action`` (:class:`~antmaze_hirl.envs.controllers.ActionSmoother`),
            restarting at every from-rest reset and carried through chained ones. Part of the dynamics, so a
            policy trained with it learns under it; the previous action is not in the observation. Default 0.
        tilt_penalty: Ant only: subtracted from every step's reward, times how far the torso's
            uprightness (``info["uprightness"]``, the world z of its up axis: 1 upright, 0 on its side)
            is below ``upright_threshold``. A dense warning before a flip, which ``flip_penalty`` marks
            only at the terminal step: in mazes the ant's uprightness falls some steps before it flips
            (docs/results/ant-in-mazes.md, "What comes before a flip"). HER relabelling needs the
            infos kept (SB3's ``copy_info_dict=True``). Default 0.
        upright_threshold: Uprightness in ``(-1, 1]`` below which ``tilt_penalty`` applies. Default 0.8
            (a tilt of about 37 degrees): rarely crossed by an ant that does not flip, and crossed some steps
            before a flip (docs/results/ant-in-mazes.md, "What comes before a flip").

    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        body: Body = "point",
        maze_map: str | MazeMap = "open",
        *,
        horizon: int | None = None,
        sample_radius_m: float | None = None,
        min_sample_radius_m: float | None = None,
        success_radius_m: float | None = None,
        reward_type: str = "sparse",
        action_scale: float | None = None,
        terminate_on_flip: bool = False,
        chain_probability: float = 0.0,
        include_contact_forces: bool = False,
        render_mode: str | None = None,
        maze_probability: float = 0.0,
        maze_sizes: tuple[int, ...] | list[int] = (3,),
        maze_wall_fraction: float = 0.3,
        maze_split: LayoutSplit | None = None,
        flip_penalty: float = 0.0,
        action_smoothing: float = 0.0,
        tilt_penalty: float = 0.0,
        upright_threshold: float = 0.8,
    ) -> None:
        record_constructor_arguments(self, locals(), ReachEnv)  # first: locals() holds only the parameters
        spec = body_spec(body)
        self.body = body
        self.horizon = int(horizon if horizon is not None else spec.default_horizon)
        self.sample_radius_m = float(sample_radius_m if sample_radius_m is not None else spec.scale)
        self.success_radius_m = float(success_radius_m if success_radius_m is not None else spec.success_radius_m)
        self.min_sample_radius_m = float(
            min_sample_radius_m if min_sample_radius_m is not None else self.success_radius_m
        )
        if self.horizon < 1:
            raise ValueError(f"horizon must be >= 1, got {horizon}")
        if self.min_sample_radius_m < 0:
            raise ValueError(f"min_sample_radius_m must be >= 0 metres, got {self.min_sample_radius_m}")
        if not self.min_sample_radius_m < self.sample_radius_m:
            raise ValueError(
                f"sample_radius_m {self.sample_radius_m} m leaves no room for subgoals: it must exceed "
                f"min_sample_radius_m {self.min_sample_radius_m} m (default: success_radius_m)"
            )
        if self.success_radius_m <= 0:
            raise ValueError(f"success_radius_m must be > 0, got {success_radius_m}")
        if reward_type not in REWARD_TYPES:
            raise ValueError(f"reward_type must be one of {REWARD_TYPES}, got {reward_type!r}")
        if action_scale is not None and not 0 < action_scale <= 1:
            raise ValueError(f"action_scale must lie in (0, 1], got {action_scale}")
        if not 0 <= chain_probability <= 1:
            raise ValueError(f"chain_probability must lie in [0, 1], got {chain_probability}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if not 0 <= maze_probability <= 1:
            raise ValueError(f"maze_probability must lie in [0, 1], got {maze_probability}")
        sizes = tuple(maze_sizes)
        if not sizes or not all(isinstance(n, numbers.Integral) and not isinstance(n, bool) and n >= 2 for n in sizes):
            raise ValueError(f"maze_sizes must be a non-empty list of integers >= 2, got {maze_sizes!r}")
        if not 0 <= maze_wall_fraction < 1:
            raise ValueError(f"maze_wall_fraction must lie in [0, 1), got {maze_wall_fraction}")
        if flip_penalty < 0:
            raise ValueError(f"flip_penalty must be >= 0, got {flip_penalty}")
        if not tilt_penalty >= 0:
            raise ValueError(f"tilt_penalty must be >= 0, got {tilt_penalty}")
        if not -1 < upright_threshold <= 1:
            raise ValueError(f"upright_threshold must lie in (-1, 1], got {upright_threshold}")
        self.maze_probability = float(maze_probability)
        self.maze_sizes = tuple(int(n) for n in sizes)
        self.maze_wall_fraction = float(maze_wall_fraction)
        self.maze_split = check_split(maze_split) if maze_split is not None else None
        self.flip_penalty = float(flip_penalty)
        self.tilt_penalty = float(tilt_penalty)
        self.upright_threshold = float(upright_threshold)
        self._smoother = ActionSmoother(action_smoothing)
        self.reward_type = reward_type
        self.action_scale = float(action_scale if action_scale is not None else spec.default_action_scale)
        self.terminate_on_flip = terminate_on_flip and body == "ant"
        self.chain_probability = float(chain_probability)
        self.render_mode = render_mode
        self._include_contact_forces = include_contact_forces
        self._base_walls = validate_maze_map(maze_map)
        self.sim = acquire_simulator(body, self._base_walls, include_contact_forces=include_contact_forces)
        self.action_space = spaces.Box(-1.0, 1.0, shape=self.sim.action_space.shape, dtype=np.float32)
        xy_space = spaces.Box(-np.inf, np.inf, shape=(2,), dtype=np.float64)
        self.observation_space = spaces.Dict(
            {
                "observation": spaces.Box(-np.inf, np.inf, shape=(self.sim.observation_dim,), dtype=np.float64),
                "achieved_goal": xy_space,
                "desired_goal": xy_space,
            }
        )
        self._renderer = BirdseyeRenderer(self.sim.geometry)
        self._body_obs = np.zeros(self.sim.observation_dim)
        self._xy = np.zeros(2)
        self._subgoal_xy = np.zeros(2)
        self._steps = 0
        self._started = False

    @property
    def action_smoothing(self) -> float:
        """Weight of the previous applied action (``action_smoothing`` of the constructor)."""
        return self._smoother.alpha

    @property
    def walls(self) -> np.ndarray:
        """Boolean wall grid of the current layout."""
        return self.sim.walls

    @property
    def agent_xy(self) -> np.ndarray:
        """Current body xy, metres."""
        return self._xy.copy()

    @property
    def body_observation(self) -> np.ndarray:
        """Current body state without xy."""
        return self._body_obs.copy()

    @property
    def subgoal_xy(self) -> np.ndarray:
        """Current subgoal xy, metres."""
        return self._subgoal_xy.copy()

    def set_walls(self, walls: np.ndarray) -> None:
        """Swaps in another layout (a simulator of the new walls from the pool, else a rebuild of the MuJoCo model)."""
        walls = np.asarray(walls, dtype=bool)
        if walls.shape != self.sim.walls.shape:
            raise ValueError(f"new layout has shape {walls.shape}, this env's spaces are for {self.sim.walls.shape}")
        self._load_walls(walls)

    def _load_walls(self, walls: np.ndarray) -> None:
        # Any shape: the spaces hold xy and body state only. The random layouts of maze_probability
        # differ in size from maze_map; a rebuild costs about as much as a few ant steps, far less than
        # a gradient update (docs/lab-notes.md), so every from-rest episode may draw a new one.
        if walls.shape != self.sim.walls.shape or not np.array_equal(walls, self.sim.walls):
            # The pool keeps the simulator of the maze this env leaves, so coming back to it skips the compile.
            release_simulator(self.sim)
            self.sim = acquire_simulator(self.body, walls, include_contact_forces=self._include_contact_forces)
            self._renderer = BirdseyeRenderer(self.sim.geometry)
            self._started = False  # the new simulator holds no body to chain from

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """Starts an episode: a new start and subgoal, or, when it chains, only a new subgoal.

        Args:
            seed: Seeds ``self.np_random`` (the only source of randomness).
            options: Optional ``"start_xy"`` (exact body xy; default a random free cell centre with
                ±0.25 cell of noise) and ``"subgoal_xy"`` (exact subgoal xy; default sampled near the body).

        Raises:
            ValueError: If a given start or subgoal is NaN, or outside the maze's free space, or ``options``
                holds a key not in :data:`RESET_OPTIONS`.

        """
        _check_options(options or {})
        super().reset(seed=seed)
        if self._chains(seed, options):
            return self.set_subgoal(self.sample_subgoal()), {"is_success": self._is_success()}
        self._smoother.reset()  # from rest: no previous torque to carry (a chained reset keeps it)
        options = options or {}
        if all(options.get(key) is None for key in RESET_OPTIONS):
            self._draw_walls()  # only a free draw may move it to another maze: given positions are in this one
        self._started = True  # after the walls: a rebuild clears it
        geometry = self.sim.geometry
        if options.get("start_xy") is not None:
            start = as_free_point(options["start_xy"], geometry, self.walls, "start_xy")
        else:
            free = np.argwhere(~self.walls)
            cell = free[self.np_random.integers(len(free))]
            start = geometry.cell_to_xy(cell) + self.np_random.uniform(-0.25, 0.25, size=2) * geometry.scale
        self._body_obs, self._xy = self.sim.reset(start, seed=int(self.np_random.integers(2**31)))
        subgoal = options.get("subgoal_xy")
        given = None if subgoal is None else as_free_point(subgoal, geometry, self.walls, "subgoal_xy")
        self.set_subgoal(self.sample_subgoal() if given is None else given)
        return self._get_obs(), {"is_success": self._is_success()}

    def _chains(self, seed: int | None, options: dict[str, Any] | None) -> bool:
        if seed is not None or options or not self._started or self.sim.is_flipped:
            return False
        # Draw only when chaining is on, so chain_probability=0 keeps the random stream unchanged.
        return self.chain_probability > 0 and bool(self.np_random.random() < self.chain_probability)

    def _draw_walls(self) -> None:
        # Draw only when mazes are on, so maze_probability=0 keeps the random stream (and figures) unchanged.
        if self.maze_probability == 0:
            return
        if self.np_random.random() < self.maze_probability:
            size = self.maze_sizes[self.np_random.integers(len(self.maze_sizes))]
            sample = functools.partial(
                generate_layout, n_rows=size, n_cols=size, wall_fraction=self.maze_wall_fraction, min_goal_cells=0
            )
            split = self.maze_split
            layout = sample(self.np_random) if split is None else sample_layout_in_split(sample, self.np_random, split)
            self._load_walls(np.asarray(layout.walls))
        else:
            self._load_walls(self._base_walls)

    def set_subgoal(self, subgoal_xy: np.ndarray) -> dict[str, np.ndarray]:
        """Gives the body a new subgoal and restarts the step count (one new sub-episode of H steps).

        Returns:
            The observation with the new ``desired_goal``.

        """
        self._subgoal_xy = as_finite_vector(subgoal_xy, 2, "subgoal_xy")
        self._steps = 0
        self.sim.show_target(self._subgoal_xy)
        return self._get_obs()

    def sample_subgoal(self) -> np.ndarray:
        """A subgoal in free space and line of sight, ``min_sample_radius_m..sample_radius_m`` from the body.

        Falls back to the body's own cell centre if 1000 draws find none (a body squeezed into a corner).
        """
        geometry = self.sim.geometry
        for _ in range(1000):
            radius = np.sqrt(self.np_random.uniform(self.min_sample_radius_m**2, self.sample_radius_m**2))
            angle = self.np_random.uniform(0, 2 * np.pi)
            subgoal = self._xy + radius * np.array([np.cos(angle), np.sin(angle)])
            if geometry.segment_is_free(self.walls, self._xy, subgoal):
                return subgoal
        return geometry.cell_to_xy(geometry.xy_to_cell(self._xy))

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        """Applies ``action`` for one step (``dt`` = 0.05 s ant, 0.01 s point).

        Raises:
            ValueError: If ``action`` has the wrong shape or holds NaN/inf.

        """
        action = self._smoother(np.clip(as_finite_vector(action, self.action_space.shape[0], "action"), -1.0, 1.0))
        self._body_obs, self._xy = self.sim.step(action * self.action_scale)
        self._steps += 1
        obs = self._get_obs()
        flipped, uprightness = self.sim.posture()  # read once: both went through the torso quaternion twice a step
        info = {"is_success": self._is_success(), "flipped": flipped, "uprightness": uprightness}
        reward = float(self.compute_reward(self._xy, self._subgoal_xy, info))
        terminated = self.terminate_on_flip and flipped
        truncated = self._steps >= self.horizon
        return obs, reward, terminated, truncated, info

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any) -> np.ndarray:
        """Reward for (batches of) achieved and desired goals; vectorised over leading axes for HER.

        ``info`` is one step's dict or, from HER, a sequence of them; with ``flip_penalty`` their
        ``"flipped"`` entries (missing = not flipped) cost ``flip_penalty`` each; with ``tilt_penalty``
        their ``"uprightness"`` (missing = upright) costs ``tilt_penalty`` per unit below ``upright_threshold``.
        """
        distance = np.linalg.norm(np.asarray(achieved_goal) - np.asarray(desired_goal), axis=-1)
        if self.reward_type == "dense":
            reward = np.exp(-distance)
        else:
            reward = (distance <= self.success_radius_m).astype(np.float64)
        if self.flip_penalty > 0:
            reward = reward - self.flip_penalty * flipped_flags(info, np.shape(distance))
        if self.tilt_penalty > 0:
            uprightness = info_values(info, "uprightness", np.shape(distance), 1.0)
            reward = reward - self.tilt_penalty * np.maximum(0.0, self.upright_threshold - uprightness)
        return reward

    def render(self) -> np.ndarray | None:
        """Bird's-eye RGB image (rows, cols, 3) of walls, body and subgoal when ``render_mode="rgb_array"``."""
        if self.render_mode != "rgb_array":
            return None
        return self._renderer.rgb(self.walls, self._xy, self._subgoal_xy)

    def close(self) -> None:
        """Releases the simulator (closes it: a closed env's simulator never goes back to the pool)."""
        self.sim.close()

    def _is_success(self) -> bool:
        return bool(np.linalg.norm(self._xy - self._subgoal_xy) <= self.success_radius_m)

    def _get_obs(self) -> dict[str, np.ndarray]:
        return {
            "observation": self._body_obs.copy(),
            "achieved_goal": self._xy.copy(),
            "desired_goal": self._subgoal_xy.copy(),
        }
