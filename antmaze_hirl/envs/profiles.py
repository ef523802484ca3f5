"""One home for the package's fixed facts: body profiles, the seed table and the maze families (plain data).

Every other module reads these values from here instead of restating them: the bodies' physics and defaults
(:data:`BODY_SPECS`, re-exported by :mod:`antmaze_hirl.envs.bodies`), what each body does in the maze
experiment (:data:`BODY_PROFILES`, read by :mod:`antmaze_hirl.experiments.config` and the high-level learner's
defaults), the registered id strings (:func:`maze_env_id`, :func:`reach_env_id`), the seed ranges that keep
evaluation sets apart (:data:`SEEDS`), and the maze families with their step limits (:data:`MAZE_FAMILIES`,
:data:`SUITE_FAMILIES`).

The lowest layer: it imports only the standard library, so the CLI, registration and ``--help`` read it for free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

Body = Literal["ant", "point"]


@dataclass(frozen=True)
class BodySpec:
    """Fixed facts about a body in gymnasium-robotics' mazes.

    Attributes:
        scale: Maze cell side in metres (``maze_size_scaling``, fixed by gymnasium-robotics).
        success_radius_m: Default success radius, metres: how near a subgoal (``ReachEnv``) or the final goal
            (``HighLevelMazeEnv``) counts as reached.
        default_horizon: Default low-level steps per subgoal (H).
        dt: Simulated seconds per env step.
        default_action_scale: Default multiplier on policy actions before the actuators.

    """

    scale: float
    success_radius_m: float
    default_horizon: int
    dt: float
    default_action_scale: float = 1.0


BODY_SPECS: dict[str, BodySpec] = {
    # 0.45 m is gymnasium-robotics' own success radius; H=100 (5 s) leaves a walking ant time for one cell.
    # Half of Ant-v5's gear-150 torque: at full torque TD3 learns to hop, and the hopping ant flips
    # (docs/lab-notes.md has the full-torque runs).
    "ant": BodySpec(scale=4.0, success_radius_m=0.45, default_horizon=100, dt=0.05, default_action_scale=0.5),
    # The point mass lives in 1 m cells, so the radius shrinks with it; it crosses a cell in ~20 steps.
    "point": BodySpec(scale=1.0, success_radius_m=0.2, default_horizon=50, dt=0.01),
}
"""Each body's physics and low-level defaults."""


def body_spec(body: str) -> BodySpec:
    """Returns the spec of ``body``.

    Raises:
        ValueError: If ``body`` is not ``"ant"`` or ``"point"``.

    """
    if body not in BODY_SPECS:
        raise ValueError(f"unknown body {body!r}; choose one of {sorted(BODY_SPECS)}")
    return BODY_SPECS[body]


def maze_env_id(body: str, variant: str | None = None, *, version: int = 0) -> str:
    """The registered high-level maze id of ``body``: ``antmaze_hirl/AntMaze-v0`` or ``antmaze_hirl/PointMaze-v0``.

    Args:
        body: ``"ant"`` or ``"point"``.
        variant: A benchmark suite's maze (``"5x5"``, ``"large"``): ``antmaze_hirl/AntMaze-large-v0``.
        version: The id's ``-vN``.
    """
    name = f"{body.capitalize()}Maze" if variant is None else f"{body.capitalize()}Maze-{variant}"
    return f"antmaze_hirl/{name}-v{version}"


def reach_env_id(body: str) -> str:
    """The registered low-level reach id of ``body``: ``antmaze_hirl/AntReach-v0`` or ``antmaze_hirl/PointReach-v0``."""
    return f"antmaze_hirl/{body.capitalize()}Reach-v0"


@dataclass(frozen=True)
class BodyProfile:
    """What a body does in the maze experiment, beside its physics (:attr:`spec`).

    Attributes:
        body: ``"ant"`` or ``"point"``.
        spec: The body's physics and low-level defaults (:data:`BODY_SPECS`): cell size, success radius
            (``success_radius_m``), H (``default_horizon``), ``dt``, action scale.
        maze_size: Free cells per side of the experiment's random layouts.
        held_out_maze_size: Free cells per side under the held-out-layouts protocol (a family with many
            wall grids, so that whole layouts can be held out).
        subgoal_reach_m: The oracle's farthest subgoal, metres; ``None``: one cell.
        learner_head: The high-level learner's head by default.
        learner_plans: Whether the default learner adds value iteration (``rows + cols + 2`` rounds) that
            rules out moves the walls block.
    """

    body: str
    spec: BodySpec
    maze_size: int
    held_out_maze_size: int
    subgoal_reach_m: float | None
    learner_head: str
    learner_plans: bool

    @property
    def maze_env_id(self) -> str:
        """The body's registered high-level maze id."""
        return maze_env_id(self.body)

    @property
    def reach_env_id(self) -> str:
        """The body's registered low-level reach id."""
        return reach_env_id(self.body)


BODY_PROFILES: dict[str, BodyProfile] = {
    # The point walks one-cell (1 m) oracle subgoals through 5x5 mazes. Its learner reads the next cell out
    # of value iteration that rules out wall moves (results/learner_ablation/learner_ablation.json).
    "point": BodyProfile(
        "point",
        BODY_SPECS["point"],
        maze_size=5,
        held_out_maze_size=5,
        subgoal_reach_m=None,
        learner_head="next_cell",
        learner_plans=True,
    ),
    # At half torque the shipped ant walks ~0.7-1 m/s, so 500 steps (25 s) cover about 20 m: too short for
    # most 5x5 paths, and 4 m subgoals often run past H = 100 steps (docs/lab-notes.md, stage 1). Holding
    # layouts out needs its 4x4 family (1,968 wall grids; the 3x3 family has 48). Its learner is the CNN's
    # next-cell head: its 2 m labels cut corners the cell grid calls walls
    # (results/learner_ablation/learner_ablation_ant.json).
    "ant": BodyProfile(
        "ant",
        BODY_SPECS["ant"],
        maze_size=3,
        held_out_maze_size=4,
        subgoal_reach_m=2.0,
        learner_head="next_cell",
        learner_plans=False,
    ),
}
"""Every body's profile, by name."""


def body_profile(body: str) -> BodyProfile:
    """Returns the profile of ``body``.

    Raises:
        ValueError: For an unknown body.
    """
    if body not in BODY_PROFILES:
        raise ValueError(f"unknown body {body!r}; choose from {sorted(BODY_PROFILES)}")
    return BODY_PROFILES[body]


@dataclass(frozen=True)
class SeedTable:
    """The first seed of each disjoint seed range. Episode ``i`` of a set resets with ``first + i``.

    Attributes:
        held_out: Held-out mazes: the experiment's final evaluation (``evaluate_high_level``'s default) and
            the lab's in-maze runs (``python -m antmaze_lab.in_maze``).
        low_level_selection_mazes: The mazes the lab's ``select_low_level`` picked the shipped ant on.
        selection: The periodic evaluations' mazes under ``held_out_layouts`` (the ``"selection"`` part).
        low_level_curve: Subgoal seeds of ``train-low``'s held-out success curve (:class:`SuccessRateCallback`).
        low_level_selection_subgoals: First subgoal seed of the lab's ``select_low_level``'s ``eval-low``.
        low_level_report_subgoals: First subgoal seed of ``eval-low``'s reported set (its ``--seed`` default).
        suites: The benchmark suites' draws: suite ``i`` (in ``SUITE_SPECS`` order) draws its tasks from
            ``np.random.default_rng(suites + i)`` (``scripts/make_suites.py``).
    """

    held_out: int = 1_000_000
    low_level_selection_mazes: int = 2_000_000
    selection: int = 3_000_000
    low_level_curve: int = 10_000
    low_level_selection_subgoals: int = 100_000
    low_level_report_subgoals: int = 0
    suites: int = 4_000_000


SEEDS = SeedTable()
"""The seed table."""


@dataclass(frozen=True)
class MazeFamily:
    """A family of high-level mazes the benchmarks play, with its low-level step limit.

    Attributes:
        body: The body that walks it.
        source: ``"random"`` (random layouts of :attr:`maze_size`) or a standard map's name.
        maze_size: Free cells per side of a random family; ``None`` for a standard map.
        split: The part of the layout partition it draws from (``None``: the whole family).
        step_limit: Low-level steps per episode; ``None``: scaled to each episode's shortest path,
            ``max(MIN_STEPS, ceil(STEPS_PER_METRE * metres))``.
    """

    body: Body
    source: str
    maze_size: int | None
    split: str | None
    step_limit: int | None


DEFAULT_MAX_STEPS = 500
"""The high-level env's default low-level step budget per episode (25 s of ant, 5 s of point)."""
STEPS_PER_METRE = 40
"""Step budget per metre of shortest cell path: a 0.5 m/s average, half the ~1 m/s of a straight walk."""
MIN_STEPS = DEFAULT_MAX_STEPS
"""No path-scaled episode gets fewer steps than the high-level env's default budget."""


def path_scaled_step_limit(path_m: float) -> int:
    """A path-scaled family's step limit for a shortest cell path of ``path_m`` metres.

    ``max(MIN_STEPS, ceil(STEPS_PER_METRE * path_m))``.
    """
    return max(MIN_STEPS, math.ceil(STEPS_PER_METRE * path_m))


MAZE_FAMILIES: dict[str, MazeFamily] = {
    # The ant experiment's family (paper_experiment.py --body ant --oracle-only).
    "ant3": MazeFamily("ant", "random", BODY_PROFILES["ant"].maze_size, None, DEFAULT_MAX_STEPS),
    # The held-out-layouts protocol's ant family, its "eval" part.
    "ant4": MazeFamily("ant", "random", BODY_PROFILES["ant"].held_out_maze_size, "eval", DEFAULT_MAX_STEPS),
    # gymnasium-robotics' standard maps, random start corner and goal.
    "u": MazeFamily("ant", "u", None, None, None),
    "medium": MazeFamily("ant", "medium", None, None, None),
    "large": MazeFamily("ant", "large", None, None, None),
    # For picking a low level only, never reported: the "selection" part, 4x4 (ant4's size) and 6x6
    # (medium's 8x8 grid, scaled like the standard maps).
    "select4": MazeFamily("ant", "random", 4, "selection", DEFAULT_MAX_STEPS),
    "select6": MazeFamily("ant", "random", 6, "selection", None),
}
"""The maze families of the lab's ``in_maze`` and ``select_low_level`` runs (``antmaze_lab/``), by name."""

SUITE_FAMILIES: dict[str, MazeFamily] = {
    # The point's experiment family, its "eval" part (the ant's is ant4).
    "point5": MazeFamily("point", "random", BODY_PROFILES["point"].held_out_maze_size, "eval", DEFAULT_MAX_STEPS),
    **{name: MAZE_FAMILIES[name] for name in ("ant4", "u", "medium", "large")},
    # OGBench's giant map (antmaze_hirl.envs.suites.GIANT_MAP).
    "giant": MazeFamily("ant", "giant", None, None, None),
    # The same four maps and tasks walked by the point mass: planning measured without the ant's falls.
    **{
        f"point-{source}": MazeFamily("point", source, None, None, None) for source in ("u", "medium", "large", "giant")
    },
}
"""The family each benchmark suite draws its tasks from, by suite name (``SUITE_SPECS``, same order)."""
