"""Maze layouts: validation of user maps, the standard maps and a seeded random generator.

A layout is a boolean wall grid (``True`` = wall) with a border of walls, as used by
gymnasium-robotics' ``maze_map`` (``1`` wall, ``0`` free, ``"g"``/``"r"``/``"c"`` free cells that
mark goal/reset locations). Cells are ``(row, col)`` pairs; row 0 is the top of the map.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gymnasium_robotics.envs.maze import maps

Cell = tuple[int, int]
MazeMap = Sequence[Sequence[int | str]]

STANDARD_MAPS: dict[str, list[list[int | str]]] = {
    "u": maps.U_MAZE,
    "open": maps.OPEN,
    "medium": maps.MEDIUM_MAZE,
    "large": maps.LARGE_MAZE,
}
"""Named gymnasium-robotics maps usable wherever a ``maze_map`` is accepted."""

_FREE_SYMBOLS = {0, "0", maps.GOAL, maps.RESET, maps.COMBINED}
_WALL_SYMBOLS = {1, "1"}
_NEIGHBOUR_STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))


@dataclass(frozen=True)
class MazeLayout:
    """A validated maze with its start and goal cells.

    Attributes:
        walls: Boolean grid, ``True`` where a cell is a wall; the border is all walls.
        start_cell: Free cell the agent starts in.
        goal_cell: Free cell holding the final goal, reachable from ``start_cell``.

    """

    walls: np.ndarray
    start_cell: Cell
    goal_cell: Cell

    def __post_init__(self) -> None:
        walls = np.asarray(self.walls, dtype=bool)
        walls.setflags(write=False)
        object.__setattr__(self, "walls", walls)
        check_reachable(walls, self.start_cell, self.goal_cell, what="goal")

    def to_maze_map(self) -> list[list[int]]:
        """The layout as a gymnasium-robotics ``maze_map`` of ``1`` (wall) and ``0`` (free)."""
        return walls_to_maze_map(self.walls)

    def canonical(self) -> str:
        """The layout as one string: see :func:`canonical_layout`."""
        return canonical_layout(self)


def wall_grid_string(walls: np.ndarray) -> str:
    """The wall grid alone as one string: rows of ``1`` (wall) and ``0`` (free) joined by ``/``.

    For example ``11111/10001/10101/10001/11111``. Two layouts with the same string differ only in
    their start and goal cells.
    """
    return "/".join("".join("1" if cell else "0" for cell in row) for row in np.asarray(walls, dtype=bool))


def canonical_layout(layout: MazeLayout) -> str:
    """The layout as one string: :func:`wall_grid_string` with ``S`` at the start cell and ``G`` at the goal cell.

    For example ``11111/1S001/10101/100G1/11111``: row 0 (the top border) first, ``1`` wall, ``0``
    free. This is the form of the ``layout`` columns of an experiment's ``episodes.csv`` and
    ``eval_layouts.csv``. A layout whose start is its goal (no generator draws one) shows ``G`` there.
    """
    rows = [list(row) for row in wall_grid_string(layout.walls).split("/")]
    for (r, c), mark in ((layout.start_cell, "S"), (layout.goal_cell, "G")):
        rows[r][c] = mark
    return "/".join("".join(row) for row in rows)


SQUARE_SYMMETRIES: tuple[tuple[int, bool], ...] = tuple((k, flip) for flip in (False, True) for k in range(4))
"""The eight symmetries of the square as ``(k, flip)``: mirror the columns first if ``flip``, then rotate by
``k`` quarter turns counter-clockwise (``np.rot90``), on grids drawn with row 0 at the top. The learner's
augmentation (``antmaze_hirl.dagger.features``) draws from the same group; ``tests/test_layout_splits.py``
checks that against its code."""


def transform_wall_grid(grid: np.ndarray, k: int, flip: bool) -> np.ndarray:
    """The image of a ``(..., rows, cols)`` grid under the symmetry ``(k, flip)`` of :data:`SQUARE_SYMMETRIES`."""
    out = np.flip(grid, axis=-1) if flip else np.asarray(grid)
    return np.ascontiguousarray(np.rot90(out, k=k, axes=(-2, -1)))


def transform_cell(cell: Cell, shape: tuple[int, int], k: int, flip: bool) -> Cell:
    """Where ``cell`` of a ``shape`` grid lands under the symmetry ``(k, flip)`` (as :func:`transform_wall_grid`)."""
    marker = np.zeros(shape, dtype=bool)
    marker[cell] = True
    row, col = np.argwhere(transform_wall_grid(marker, k, flip))[0]
    return int(row), int(col)


def transform_layout(layout: MazeLayout, k: int, flip: bool) -> MazeLayout:
    """The layout's image under the symmetry ``(k, flip)``: walls, start and goal moved together."""
    shape = layout.walls.shape
    return MazeLayout(
        transform_wall_grid(layout.walls, k, flip),
        transform_cell(layout.start_cell, shape, k, flip),
        transform_cell(layout.goal_cell, shape, k, flip),
    )


def canonical_wall_grid(walls: np.ndarray) -> str:
    """The wall grid's form up to symmetry: the smallest :func:`wall_grid_string` of its eight images.

    A grid and its rotations and mirrors have the same canonical form, and two grids with the same form
    are images of each other. The layout partition (``layout_splits``) hashes this.
    """
    return min(wall_grid_string(transform_wall_grid(walls, k, flip)) for k, flip in SQUARE_SYMMETRIES)


def canonical_task(layout: MazeLayout) -> str:
    """The task (walls, start and goal) up to symmetry: the smallest :func:`canonical_layout` of its eight images.

    Unlike :func:`canonical_layout` (the layout as drawn, which ``episodes.csv`` records), two tasks that
    are rotations or mirrors of each other share this form: what the learner, trained on all eight
    images, cannot tell apart.
    """
    return min(canonical_layout(transform_layout(layout, k, flip)) for k, flip in SQUARE_SYMMETRIES)


def walls_to_maze_map(walls: np.ndarray) -> list[list[int]]:
    """Converts a boolean wall grid to a gymnasium-robotics ``maze_map`` list of lists."""
    return [[int(cell) for cell in row] for row in np.asarray(walls, dtype=bool)]


def resolve_maze_map(maze_map: str | MazeMap) -> MazeMap:
    """Returns the map itself, or the standard map of that name (``"u"``, ``"open"``, ...).

    Raises:
        ValueError: If ``maze_map`` is a string that names no standard map.

    """
    if isinstance(maze_map, str):
        key = maze_map.lower()
        if key not in STANDARD_MAPS:
            raise ValueError(f"unknown maze name {maze_map!r}; choose one of {sorted(STANDARD_MAPS)}")
        return STANDARD_MAPS[key]
    return maze_map


def validate_maze_map(maze_map: str | MazeMap) -> np.ndarray:
    """Checks a ``maze_map`` and returns its boolean wall grid.

    Args:
        maze_map: List of rows (``1`` wall, ``0``/``"g"``/``"r"``/``"c"`` free) or a standard map name.

    Returns:
        A ``(rows, cols)`` boolean array, ``True`` at walls.

    Raises:
        ValueError: Naming the problem and the cell: a ragged or empty map, an unknown symbol,
            a gap in the border wall, no free cell, or a marked goal/reset cell unreachable from
            another marked cell.

    """
    rows = resolve_maze_map(maze_map)
    if isinstance(rows, np.ndarray):
        rows = rows.tolist()
    if len(rows) < 3:
        raise ValueError(f"maze_map needs at least 3 rows (border, free, border), got {len(rows)}")
    n_cols = len(rows[0])
    if n_cols < 3:
        raise ValueError(f"maze_map needs at least 3 columns, row 0 has {n_cols}")
    walls = np.zeros((len(rows), n_cols), dtype=bool)
    marked: list[Cell] = []
    for r, row in enumerate(rows):
        if len(row) != n_cols:
            raise ValueError(f"maze_map is not rectangular: row {r} has {len(row)} cells, row 0 has {n_cols}")
        for c, symbol in enumerate(row):
            if _is_symbol(symbol, _WALL_SYMBOLS):
                walls[r, c] = True
            elif not _is_symbol(symbol, _FREE_SYMBOLS):
                raise ValueError(
                    f"maze_map has unknown symbol {symbol!r} at cell ({r}, {c}); use 1, 0, 'g', 'r' or 'c'"
                )
            elif symbol in (maps.GOAL, maps.RESET, maps.COMBINED):
                marked.append((r, c))
    border = np.ones_like(walls)
    border[1:-1, 1:-1] = False
    gaps = np.argwhere(border & ~walls)
    if len(gaps):
        r, c = gaps[0]
        raise ValueError(f"maze_map border must be all walls (1), but cell ({r}, {c}) is free")
    if walls.all():
        raise ValueError("maze_map has no free cell")
    for cell in marked[1:]:
        check_reachable(walls, marked[0], cell, what="marked")
    return walls


def _is_symbol(symbol: object, allowed: set[int | str]) -> bool:
    # bool is an int subclass and numpy scalars hash like Python ints; accept neither silently.
    if isinstance(symbol, bool | float):
        return False
    try:
        return symbol in allowed
    except TypeError:  # unhashable symbols such as lists
        return False


def bfs_distances(walls: np.ndarray, source: Cell) -> np.ndarray:
    """Grid shortest-path lengths (4-connected) from ``source``; ``-1`` where unreachable."""
    n_rows, n_cols = walls.shape
    r, c = (int(value) for value in source)
    if not (0 <= r < n_rows and 0 <= c < n_cols):
        raise IndexError(f"source cell {(r, c)} is outside the {n_rows}x{n_cols} grid")
    # On Python lists, not the arrays: a maze draw runs this once per wall it tries, and an array's element
    # reads and writes cost about ten times a list's.
    blocked = np.asarray(walls, dtype=bool).tolist()
    distances = [[-1] * n_cols for _ in range(n_rows)]
    distances[r][c] = 0
    queue = deque([(r, c)])
    while queue:
        r, c = queue.popleft()
        step = distances[r][c] + 1
        for dr, dc in _NEIGHBOUR_STEPS:
            nr, nc = r + dr, c + dc
            if 0 <= nr < n_rows and 0 <= nc < n_cols and not blocked[nr][nc] and distances[nr][nc] < 0:
                distances[nr][nc] = step
                queue.append((nr, nc))
    return np.array(distances, dtype=np.int64).reshape(n_rows, n_cols)


def shortest_path(walls: np.ndarray, start: Cell, goal: Cell) -> list[Cell]:
    """Cells of a shortest 4-connected path from ``start`` to ``goal``, both included.

    Raises:
        ValueError: If ``goal`` cannot be reached from ``start``.

    """
    check_reachable(walls, start, goal, what="goal")
    distances = bfs_distances(walls, goal)
    path = [tuple(start)]
    while path[-1] != tuple(goal):
        r, c = path[-1]
        path.append(
            min(
                ((r + dr, c + dc) for dr, dc in _NEIGHBOUR_STEPS if _in_free_grid(walls, (r + dr, c + dc))),
                key=lambda cell: distances[cell] if distances[cell] >= 0 else np.inf,
            )
        )
    return [(int(r), int(c)) for r, c in path]


def _in_free_grid(walls: np.ndarray, cell: Cell) -> bool:
    r, c = cell
    return 0 <= r < walls.shape[0] and 0 <= c < walls.shape[1] and not walls[r, c]


def check_reachable(walls: np.ndarray, start: Cell, target: Cell, *, what: str) -> None:
    """Raises ``ValueError`` naming the cell if ``start`` or ``target`` is a wall, outside, or unconnected."""
    for name, cell in (("start", start), (what, target)):
        if len(cell) != 2 or not _in_free_grid(walls, (int(cell[0]), int(cell[1]))):
            raise ValueError(f"{name} cell {tuple(cell)} is outside the maze or a wall")
    if bfs_distances(walls, (int(start[0]), int(start[1])))[int(target[0]), int(target[1])] < 0:
        raise ValueError(f"{what} cell {tuple(target)} is not reachable from start cell {tuple(start)}")


def corner_cells(walls: np.ndarray) -> list[Cell]:
    """For each interior corner of the maze, the free cell nearest to it (Manhattan distance).

    These are the start cells of the paper's task ("from a start corner to a random goal").
    Duplicates are removed, order is top-left, top-right, bottom-left, bottom-right.
    """
    free = np.argwhere(~walls)
    n_rows, n_cols = walls.shape
    corners = [(1, 1), (1, n_cols - 2), (n_rows - 2, 1), (n_rows - 2, n_cols - 2)]
    found: list[Cell] = []
    for corner in corners:
        nearest = free[np.argmin(np.abs(free - np.asarray(corner)).sum(axis=1))]
        cell = (int(nearest[0]), int(nearest[1]))
        if cell not in found:
            found.append(cell)
    return found


def sample_start_and_goal(
    walls: np.ndarray, rng: np.random.Generator, *, min_goal_cells: int = 0
) -> tuple[Cell, Cell] | None:
    """Draws a start corner and a goal at least ``min_goal_cells`` path steps away.

    Returns:
        ``(start_cell, goal_cell)`` or ``None`` if no corner has a far enough reachable cell.

    """
    corners = corner_cells(walls)
    for start_index in rng.permutation(len(corners)):
        start = corners[start_index]
        distances = bfs_distances(walls, start)
        candidates = np.argwhere(distances >= max(min_goal_cells, 1))
        if len(candidates):
            goal = candidates[rng.integers(len(candidates))]
            return start, (int(goal[0]), int(goal[1]))
    return None


def layout_from_map(maze_map: str | MazeMap, rng: np.random.Generator, *, min_goal_cells: int = 0) -> MazeLayout:
    """A layout on a fixed (user or standard) map with a random start corner and goal.

    Raises:
        ValueError: If the map is invalid or no goal is ``min_goal_cells`` steps from a corner.

    """
    walls = validate_maze_map(maze_map)
    drawn = sample_start_and_goal(walls, rng, min_goal_cells=min_goal_cells)
    if drawn is None:
        raise ValueError(f"no free cell is min_goal_cells={min_goal_cells} steps from a start corner")
    return MazeLayout(walls, *drawn)


def generate_layout(
    rng: np.random.Generator,
    *,
    n_rows: int = 5,
    n_cols: int = 5,
    wall_fraction: float = 0.3,
    min_goal_cells: int = 4,
    max_tries: int = 100,
) -> MazeLayout:
    """Generates a random connected maze with a start corner and a far goal.

    Interior cells are turned into walls in random order, each kept only if all free cells stay
    connected, until ``wall_fraction`` of the interior is wall (or no further wall fits).

    Args:
        rng: Source of all randomness (same generator state, same layout).
        n_rows: Free-space rows (the map adds a border wall on each side).
        n_cols: Free-space columns.
        wall_fraction: Target share of interior cells that are walls, in ``[0, 1)``.
        min_goal_cells: Least number of grid steps on the shortest path from start to goal.
        max_tries: Layouts drawn before giving up on ``min_goal_cells``.

    Raises:
        ValueError: On sizes below 1, a ``wall_fraction`` outside ``[0, 1)``, or when no draw has a
            goal ``min_goal_cells`` steps away.

    """
    if n_rows < 1 or n_cols < 1:
        raise ValueError(f"maze size must be at least 1x1 free cells, got {n_rows}x{n_cols}")
    if not 0.0 <= wall_fraction < 1.0:
        raise ValueError(f"wall_fraction must lie in [0, 1), got {wall_fraction}")
    target_walls = round(wall_fraction * n_rows * n_cols)
    for _ in range(max_tries):
        walls = np.ones((n_rows + 2, n_cols + 2), dtype=bool)
        walls[1:-1, 1:-1] = False
        corners = corner_cells(walls)
        anchor = corners[rng.integers(len(corners))]
        interior = [(r + 1, c + 1) for r in range(n_rows) for c in range(n_cols) if (r + 1, c + 1) != anchor]
        placed = 0
        for index in rng.permutation(len(interior)):
            if placed >= target_walls:
                break
            cell = interior[index]
            walls[cell] = True
            if _free_cells_connected(walls, anchor):
                placed += 1
            else:
                walls[cell] = False
        drawn = sample_start_and_goal(walls, rng, min_goal_cells=min_goal_cells)
        if drawn is not None:
            return MazeLayout(walls, *drawn)
    raise ValueError(
        f"no {n_rows}x{n_cols} layout with wall_fraction={wall_fraction} had a goal "
        f"min_goal_cells={min_goal_cells} steps from a corner in {max_tries} tries"
    )


def _free_cells_connected(walls: np.ndarray, anchor: Cell) -> bool:
    return int((bfs_distances(walls, anchor) >= 0).sum()) == int((~walls).sum())
