"""Benchmark suites: fixed, versioned evaluation tasks, how they were drawn, and the env that plays them.

Every suite (:data:`~antmaze_hirl.envs.suite_specs.SUITE_SPECS`) is a list of tasks stored in
``benchmark_suites.json`` beside this module. A task is a wall grid, a start cell, a goal cell and a
low-level step limit. An episode of a task starts the body in the start cell and puts the goal in the
goal cell, each at the cell's centre plus uniform noise of +-0.25 cell (the experiments' episodes; for the
ant +-1 m, OGBench's noise), drawn from the reset seed: the task is fixed, its episodes vary with the seed
(without the noise every episode of a task would be the same, the env being deterministic).

How the tasks were drawn (:func:`draw_suite_tasks`, rerun by ``scripts/make_suites.py``):

* random families (``point5``, ``ant4``): mazes of the family the experiments use (``maze_size`` free
  cells per side, 30% walls, goal >= 3 grid steps from a start corner) drawn by rejection from the
  ``eval`` part of :mod:`~antmaze_hirl.envs.layout_splits`, which is closed under the square's 8
  symmetries: no suite maze is, up to rotation or mirror, a wall grid of any family's ``train`` or
  ``selection`` part. Tasks that are symmetric images of an earlier task are skipped, so the 100 tasks
  are 100 distinct tasks to a learner trained on all 8 images. The ``i``-th suite of :data:`SUITE_SPECS`
  draws from ``np.random.default_rng(SEEDS.suites + i)`` (the seed table,
  :data:`~antmaze_hirl.envs.profiles.SEEDS`). Low-level step limit: the family's, 500.
* fixed maps (``u``, ``medium``, ``large``, ``giant``): 5 tasks per map, as OGBench. ``medium``,
  ``large`` and ``giant`` (:data:`GIANT_MAP`) carry OGBench's own ``navigate`` tasks (its ``task1`` to
  ``task5`` are ``task_id`` 0 to 4; gymnasium-robotics' medium and large maps are OGBench's grids). ``u``
  has no OGBench tasks; its 5 are in :data:`FIXED_MAP_TASKS`. Held out there means: no random family the
  package trains on (3x3, 4x4, 5x5 free cells, 30% walls) ever draws the map's wall grid up to symmetry
  (the other maps' shapes differ from every family's; ``u`` has the 3x3 family's shape but 2 interior
  walls where that family places 3; both checked in the tests), whatever part the partition's hash gives
  the grid, and the start/goal pairs are fixed. A learner trained on the map itself is on OGBench's
  footing (same maze, fixed evaluation start/goal pairs), not on held-out mazes: a row says which.
  Low-level step limit: ``max(500, ceil(40 * shortest cell path in metres))``
  (:func:`~antmaze_hirl.envs.profiles.path_scaled_step_limit`, the lab's in-maze rule, a 0.5 m/s
  average).
"""

from __future__ import annotations

import functools
import hashlib
import json
from dataclasses import dataclass
from importlib import resources
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.utils.ezpickle import EzPickle

from antmaze_hirl.envs.bodies import body_spec
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.high_level import DEFAULT_MIN_GOAL_CELLS, HighLevelMazeEnv
from antmaze_hirl.envs.layout_splits import sample_layout_in_split
from antmaze_hirl.envs.layouts import (
    MazeLayout,
    MazeMap,
    canonical_task,
    generate_layout,
    resolve_maze_map,
    shortest_path,
    validate_maze_map,
    wall_grid_string,
)
from antmaze_hirl.envs.profiles import SEEDS, path_scaled_step_limit
from antmaze_hirl.envs.suite_specs import SUITE_SPECS, SuiteSpec, check_suite_name

SUITES_FILE = "benchmark_suites.json"
FORMAT = "antmaze_hirl.benchmark_suites/1"
WALL_FRACTION = 0.3
"""The random families' share of interior walls (:class:`HighLevelMazeEnv`'s default)."""

FIXED_MAP_TASKS: dict[str, list[tuple[tuple[int, int], tuple[int, int]]]] = {
    # Corner to corner around the U, both ways, and three shorter ones; every goal >= 3 grid steps away.
    "u": [((3, 1), (1, 1)), ((1, 1), (3, 1)), ((3, 3), (1, 1)), ((1, 3), (3, 1)), ((3, 2), (1, 2))],
    # OGBench's antmaze-{medium,large}-navigate tasks 1-5, (row, col) of the same maps.
    "medium": [((1, 1), (6, 6)), ((6, 1), (1, 6)), ((5, 3), (4, 2)), ((6, 5), (6, 1)), ((2, 6), (1, 1))],
    "large": [((1, 1), (7, 10)), ((5, 4), (7, 1)), ((7, 4), (1, 10)), ((3, 8), (5, 4)), ((1, 1), (5, 4))],
}
"""The fixed maps' (start cell, goal cell) pairs, in ``task_id`` order."""
FIXED_MAP_TASKS["giant"] = [
    ((1, 1), (10, 14)),
    ((1, 14), (10, 1)),
    ((8, 14), (1, 1)),
    ((8, 3), (5, 12)),
    ((5, 9), (3, 8)),
]

GIANT_MAP: list[list[int]] = [
    [1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1],
    [1, 0, 1, 0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1],
    [1, 0, 1, 0, 1, 1, 0, 1, 0, 1, 0, 0, 1, 1, 0, 1],
    [1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1],
    [1, 0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 0, 1, 0, 1],
    [1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1],
    [1, 1, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 1, 1],
    [1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1],
    [1, 0, 1, 0, 1, 0, 1, 1, 1, 1, 1, 1, 0, 1, 0, 1],
    [1, 0, 1, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1],
    [1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1],
    [1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1],
]
"""OGBench's ``giant`` maze (``antmaze-giant-navigate``), 10x14 free cells; its tasks are OGBench's 5."""


@dataclass(frozen=True)
class SuiteTask:
    """One evaluation task.

    Attributes:
        layout: Walls, start cell and goal cell.
        max_low_level_steps: The episode's low-level step budget.
    """

    layout: MazeLayout
    max_low_level_steps: int

    def to_json(self) -> dict[str, Any]:
        """The task as stored in the suites file."""
        return {
            "walls": wall_grid_string(self.layout.walls),
            "start_cell": list(self.layout.start_cell),
            "goal_cell": list(self.layout.goal_cell),
            "max_low_level_steps": self.max_low_level_steps,
        }

    @classmethod
    def from_json(cls, entry: dict[str, Any]) -> SuiteTask:
        """A task from its stored form."""
        walls = np.array([[char == "1" for char in row] for row in entry["walls"].split("/")])
        layout = MazeLayout(walls, tuple(entry["start_cell"]), tuple(entry["goal_cell"]))
        return cls(layout, int(entry["max_low_level_steps"]))


def path_step_limit(walls: np.ndarray, start_cell: tuple[int, int], goal_cell: tuple[int, int], scale: float) -> int:
    """The step limit of a shortest 4-connected cell path of ``L`` metres (:func:`path_scaled_step_limit`).

    ``L`` counts cell centre to cell centre (grid steps times ``scale``), so the detours around walls count.
    """
    return path_scaled_step_limit((len(shortest_path(walls, start_cell, goal_cell)) - 1) * scale)


def scaled_step_limit(layout: MazeLayout, scale: float) -> int:
    """:func:`path_step_limit` from ``layout``'s start cell to its goal cell."""
    return path_step_limit(layout.walls, layout.start_cell, layout.goal_cell, scale)


def fixed_map(spec: SuiteSpec) -> MazeMap:
    """The maze map of a fixed-map suite: :data:`GIANT_MAP` or a gymnasium-robotics map."""
    return GIANT_MAP if spec.source == "giant" else resolve_maze_map(spec.source)


def draw_suite_tasks(name: str) -> list[SuiteTask]:
    """Draws suite ``name``'s tasks as described in the module docstring (deterministic).

    Raises:
        ValueError: For an unknown suite.
    """
    spec = check_suite_name(name)
    scale = body_spec(spec.body).scale
    if spec.source != "random":
        walls = validate_maze_map(fixed_map(spec))
        layouts = [MazeLayout(walls, start, goal) for start, goal in FIXED_MAP_TASKS[spec.source]]
        return [SuiteTask(layout, scaled_step_limit(layout, scale)) for layout in layouts]
    # Suite i draws from its own seed (the seed table's range, apart from every evaluation set's).
    rng = np.random.default_rng(SEEDS.suites + list(SUITE_SPECS).index(name))
    family = functools.partial(
        generate_layout,
        n_rows=spec.maze_size,
        n_cols=spec.maze_size,
        wall_fraction=WALL_FRACTION,
        min_goal_cells=DEFAULT_MIN_GOAL_CELLS,
    )
    tasks: list[SuiteTask] = []
    seen: set[str] = set()
    while len(tasks) < spec.n_tasks:
        layout = sample_layout_in_split(family, rng, "eval")
        key = canonical_task(layout)
        if key not in seen:
            seen.add(key)
            tasks.append(SuiteTask(layout, spec.max_low_level_steps))
    return tasks


def tasks_checksum(tasks: list[SuiteTask]) -> str:
    """SHA-256 of the task list in its stored form (sorted keys, no spaces)."""
    text = json.dumps([task.to_json() for task in tasks], sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def suites_file_text() -> str:
    """The suites file's exact text, drawn afresh (what ``scripts/make_suites.py`` writes)."""
    suites = {}
    for name, spec in SUITE_SPECS.items():
        tasks = draw_suite_tasks(name)
        suites[name] = {
            "env_id": spec.env_id,
            "body": spec.body,
            "source": spec.source,
            "checksum": tasks_checksum(tasks),
            "tasks": [task.to_json() for task in tasks],
        }
    return json.dumps({"format": FORMAT, "version": 0, "suites": suites}, indent=1, sort_keys=True) + "\n"


@functools.cache
def _stored_suites() -> dict[str, Any]:
    text = resources.files("antmaze_hirl.envs").joinpath(SUITES_FILE).read_text()
    data = json.loads(text)
    if data.get("format") != FORMAT:
        raise ValueError(f"{SUITES_FILE} has format {data.get('format')!r}, expected {FORMAT!r}")
    return data["suites"]


@functools.cache
def suite_tasks(name: str) -> tuple[SuiteTask, ...]:
    """Suite ``name``'s stored tasks, checked against the checksum of :data:`SUITE_SPECS`.

    Raises:
        ValueError: For an unknown suite, or a stored list whose checksum or length is not the spec's
            (an edited or damaged file).
    """
    spec = check_suite_name(name)
    stored = _stored_suites().get(name)
    if stored is None:
        raise ValueError(f"{SUITES_FILE} has no suite {name!r}; regenerate it with scripts/make_suites.py")
    tasks = tuple(SuiteTask.from_json(entry) for entry in stored["tasks"])
    checksum = tasks_checksum(list(tasks))
    if checksum != spec.checksum or len(tasks) != spec.n_tasks:
        raise ValueError(
            f"{SUITES_FILE}: suite {name!r} has {len(tasks)} tasks with checksum {checksum[:12]}..., expected "
            f"{spec.n_tasks} with {spec.checksum[:12]}...: the file was edited or damaged"
        )
    return tasks


def check_task_id(task_id: Any, n_tasks: int, suite: str) -> int:
    """Returns ``task_id`` if it is an integer in ``[0, n_tasks)``.

    Raises:
        ValueError: Naming the value and the range, otherwise.
    """
    if isinstance(task_id, bool) or not isinstance(task_id, int | np.integer):
        raise ValueError(
            f"task_id {task_id!r} is not an integer ({type(task_id).__name__}); suite {suite!r} takes an integer "
            f"in [0, {n_tasks - 1}]"
        )
    if not 0 <= task_id < n_tasks:
        raise ValueError(
            f"task_id {task_id!r} is out of range for suite {suite!r}: choose an integer in [0, {n_tasks - 1}]"
        )
    return int(task_id)


class SuiteMazeEnv(HighLevelMazeEnv):
    """A high-level maze env that plays one benchmark suite's fixed tasks.

    ``reset(options={"task_id": k})`` plays task ``k`` (0-based; OGBench's ``taskN`` is ``k = N - 1``). A
    plain ``reset`` draws a task uniformly with ``self.np_random``, so a seeded reset picks the same task
    on every machine. ``info["task_id"]`` names the task played. Start and goal lie in the task's cells,
    placed with :meth:`noisy_cell_centre` from ``np_random``. The observation space is the same for
    every task of a suite (one maze shape per suite). The low-level budget ``max_steps`` is the task's.

    Args:
        suite: A name of :data:`~antmaze_hirl.envs.suite_specs.SUITE_SPECS`.
        low_level: SB3 model or callable ``goal observation -> action`` (required here; the registered ids
            plug in the shipped policy).
        render_mode: As :class:`HighLevelMazeEnv` (``"rgb_array"``, or ``"rgb_array_list"``: every low-level step).
        render_view: As :class:`HighLevelMazeEnv` (``"schematic"``, ``"trail"`` or ``"mujoco"``).

    Raises:
        ValueError: On an unknown suite or a damaged task list.
    """

    metadata: ClassVar[dict[str, Any]] = HighLevelMazeEnv.metadata

    def __init__(
        self, suite: str, *, low_level: Any = None, render_mode: str | None = None, render_view: str = "schematic"
    ) -> None:
        self.suite = check_suite_name(suite)
        self.tasks = suite_tasks(suite)
        shape = self.tasks[0].layout.walls.shape
        super().__init__(
            self.suite.body,
            None if self.suite.source == "random" else fixed_map(self.suite),
            maze_size=(shape[0] - 2, shape[1] - 2),
            low_level=low_level,
            max_steps=self.suite.max_low_level_steps,
            render_mode=render_mode,
            render_view=render_view,
        )
        EzPickle.__init__(self, suite, low_level=low_level, render_mode=render_mode, render_view=render_view)
        self.task_id = 0

    @property
    def n_tasks(self) -> int:
        """Tasks in the suite."""
        return len(self.tasks)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """Starts task ``options["task_id"]``, or one drawn with ``np_random``.

        Raises:
            ValueError: On a ``task_id`` that is not an integer in ``[0, n_tasks)``, or any other option
                (a suite's tasks are fixed).
        """
        options = dict(options or {})
        unknown = sorted(set(options) - {"task_id"})
        if unknown:
            raise ValueError(f"a suite env takes only options['task_id'], got {unknown}")
        gym.Env.reset(self, seed=seed)  # seeds np_random only; the parent's reset below must not reseed it
        if "task_id" in options:
            task_id = check_task_id(options["task_id"], self.n_tasks, self.suite.name)
        else:
            task_id = int(self.np_random.integers(self.n_tasks))
        task = self.tasks[task_id]
        self.task_id = task_id
        self.max_steps = task.max_low_level_steps
        # The parent draws the start and goal positions in the task's cells from np_random (noisy_cell_centre).
        obs, info = super().reset(options={"layout": task.layout})
        return obs, {**info, "task_id": task_id}

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        """As :meth:`HighLevelMazeEnv.step`, with ``info["task_id"]``."""
        obs, reward, terminated, truncated, info = super().step(action)
        info["task_id"] = self.task_id
        return obs, reward, terminated, truncated, info


def suite_geometry(name: str) -> MazeGeometry:
    """The map placement of suite ``name``'s mazes (without building an env)."""
    spec = check_suite_name(name)
    shape = suite_tasks(name)[0].layout.walls.shape
    return MazeGeometry(shape[0], shape[1], body_spec(spec.body).scale)
