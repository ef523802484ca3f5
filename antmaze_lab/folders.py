"""A paper-experiment results folder's per-maze evaluations, as protocol 3's readings need them.

Reads the committed files only (``evaluations.csv.gz``, ``episodes.csv``, ``eval_layouts.csv``,
``summary.json``): every method's learner-only outcome on every evaluation maze at every evaluation, the
oracle's success on the same mazes, and what the symmetry re-check and the path-length tables need.
"""

from __future__ import annotations

import csv
import gzip
import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from antmaze_hirl.envs.layout_splits import wall_grid_split
from antmaze_hirl.envs.layouts import MazeLayout, bfs_distances, canonical_task, canonical_wall_grid


def layout_from_string(text: str) -> MazeLayout:
    """The layout of a ``layout`` column (``111111/1S0001/...``: ``1`` wall, ``0`` free, ``S`` start, ``G`` goal).

    Raises:
        ValueError: One line naming the text if it is not such a layout (ragged, another symbol, no ``S`` or
            ``G``, or a goal the start cannot reach).
    """
    rows = text.split("/")
    if len({len(row) for row in rows}) != 1 or set(text) - set("10SG/"):
        raise ValueError(f"not a layout string: {text!r}")
    cells = {
        mark: [(r, c) for r, row in enumerate(rows) for c, char in enumerate(row) if char == mark] for mark in "SG"
    }
    if len(cells["S"]) != 1 or len(cells["G"]) != 1:
        raise ValueError(f"a layout string needs one S and one G: {text!r}")
    walls = np.array([[char == "1" for char in row] for row in rows])
    return MazeLayout(walls, cells["S"][0], cells["G"][0])


def path_length_cells(layout: MazeLayout) -> int:
    """The shortest 4-connected path from the layout's start to its goal, in cells."""
    return int(bfs_distances(layout.walls, layout.goal_cell)[layout.start_cell])


@dataclass(frozen=True)
class MethodEvaluations:
    """One method's evaluations in one folder, seeds in ascending order.

    Attributes:
        seeds: The seeds, ascending.
        episodes: ``(evaluations,)`` training episodes before each evaluation (0: the untrained learner).
        labels: ``(seeds, evaluations)`` the expert's labels recorded before each evaluation.
        outcomes: ``(seeds, evaluations, mazes)`` learner-only success, mazes in :attr:`BodyEvaluations.mazes`'
            order.
    """

    seeds: tuple[int, ...]
    episodes: np.ndarray
    labels: np.ndarray
    outcomes: np.ndarray


@dataclass(frozen=True)
class BodyEvaluations:
    """A folder's evaluations: every method on one shared set of mazes.

    Attributes:
        folder: Where they were read.
        body: ``config.body`` of its summary.
        mazes: The evaluation mazes' layout strings, by ascending maze seed.
        task_classes: Each maze's task up to the square's 8 symmetries (:func:`canonical_task`).
        oracle_success: The oracle's success rate on the same mazes (``summary.json``'s ``oracle_success``).
        methods: ``{method: MethodEvaluations}``.
    """

    folder: Path
    body: str
    mazes: tuple[str, ...]
    task_classes: tuple[str, ...]
    oracle_success: float
    methods: dict[str, MethodEvaluations]

    @property
    def path_lengths(self) -> np.ndarray:
        """``(mazes,)`` each evaluation maze's shortest path from start to goal, in cells."""
        return np.array([path_length_cells(layout_from_string(maze)) for maze in self.mazes])


def _rows(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        raise ValueError(f"no {path.name} in {path.parent}")
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", newline="") as handle:
        return list(csv.DictReader(handle))


def read_body(folder: Path) -> BodyEvaluations:
    """The per-maze evaluations of a results folder with ``evaluations.csv.gz`` and ``summary.json``.

    Raises:
        ValueError: One line naming the file: a missing file, a maze whose recorded ``task_class`` is not its
            task up to symmetry, methods or seeds evaluated on different mazes or at different episodes, or a
            missing (method, seed, episode, maze) outcome.
    """
    folder = Path(folder)
    summary = json.loads((folder / "summary.json").read_text()) if (folder / "summary.json").is_file() else None
    if summary is None:
        raise ValueError(f"no summary.json in {folder}")
    rows = _rows(folder / "evaluations.csv.gz")
    mazes = {int(row["maze_seed"]): row["layout"] for row in rows}
    classes = {int(row["maze_seed"]): row["task_class"] for row in rows}
    order = sorted(mazes)
    for maze_seed in order:
        if canonical_task(layout_from_string(mazes[maze_seed])) != classes[maze_seed]:
            raise ValueError(
                f"{folder / 'evaluations.csv.gz'}: maze {maze_seed}'s task_class is not its task up to symmetry"
            )
    column = {maze_seed: index for index, maze_seed in enumerate(order)}
    grouped: dict[str, list[dict[str, str]]] = {}
    for row in rows:
        grouped.setdefault(row["method"], []).append(row)
    methods = {name: _method(folder, name, found, column) for name, found in sorted(grouped.items())}
    episodes = {tuple(m.episodes.tolist()) for m in methods.values()}
    if len(episodes) != 1:
        raise ValueError(f"{folder / 'evaluations.csv.gz'}: methods evaluated at different episodes {sorted(episodes)}")
    return BodyEvaluations(
        folder=folder,
        body=summary["config"]["body"],
        mazes=tuple(mazes[s] for s in order),
        task_classes=tuple(classes[s] for s in order),
        oracle_success=float(summary["oracle_success"]["success_rate"]),
        methods=methods,
    )


def _method(folder: Path, name: str, rows: list[dict[str, str]], column: dict[int, int]) -> MethodEvaluations:
    seeds = sorted({int(row["seed"]) for row in rows})
    episodes = sorted({int(row["episode"]) for row in rows})
    seed_index, episode_index = {s: i for i, s in enumerate(seeds)}, {e: i for i, e in enumerate(episodes)}
    outcomes = np.full((len(seeds), len(episodes), len(column)), -1, dtype=np.int8)
    labels = np.full((len(seeds), len(episodes)), -1.0)
    for row in rows:
        i, j = seed_index[int(row["seed"])], episode_index[int(row["episode"])]
        outcomes[i, j, column[int(row["maze_seed"])]] = row["success"] == "True"
        labels[i, j] = float(row["labels"])
    if (outcomes < 0).any():
        i, j, k = np.argwhere(outcomes < 0)[0]
        raise ValueError(
            f"{folder / 'evaluations.csv.gz'}: no outcome of {name} seed {seeds[i]} at episode {episodes[j]} "
            f"on maze column {k}"
        )
    return MethodEvaluations(tuple(seeds), np.array(episodes), labels, outcomes.astype(bool))


def training_layouts(folder: Path) -> set[str]:
    """Every maze a trial of the folder trained on (``episodes.csv``'s ``layout`` column)."""
    return {row["layout"] for row in _rows(Path(folder) / "episodes.csv")}


def evaluation_layouts(folder: Path) -> set[str]:
    """Every maze the folder evaluated on: ``eval_layouts.csv`` and ``evaluations.csv.gz``'s layouts."""
    folder = Path(folder)
    listed = {row["layout"] for row in _rows(folder / "eval_layouts.csv")}
    return listed | {row["layout"] for row in _rows(folder / "evaluations.csv.gz")}


def _classes(layouts: Iterable[str]) -> tuple[set[str], set[str]]:
    parsed = [layout_from_string(text) for text in layouts]
    return {canonical_wall_grid(layout.walls) for layout in parsed}, {canonical_task(layout) for layout in parsed}


def symmetry_check(folder: Path) -> dict[str, object]:
    """Training and evaluation of a folder disjoint under the square's 8 symmetries, re-checked on its files.

    Returns:
        ``{"training_mazes", "evaluation_mazes", "evaluation_tasks_up_to_symmetry",
        "evaluation_wall_grids_up_to_symmetry", "shared_wall_grids", "shared_tasks",
        "training_grids_outside_train", "evaluation_grids_outside_eval", "disjoint"}``: counts, and
        ``disjoint`` true when no wall grid (and so no task) up to symmetry is shared and every grid lies in its
        part of the layout partition.
    """
    train, evaluation = training_layouts(folder), evaluation_layouts(folder)
    train_grids, train_tasks = _classes(train)
    eval_grids, eval_tasks = _classes(evaluation)
    walls = {text: layout_from_string(text).walls for text in train | evaluation}
    outside_train = sum(wall_grid_split(walls[text]) != "train" for text in train)
    outside_eval = sum(wall_grid_split(walls[text]) != "eval" for text in evaluation)
    shared_grids, shared_tasks = len(train_grids & eval_grids), len(train_tasks & eval_tasks)
    return {
        "training_mazes": len(train),
        "evaluation_mazes": len(evaluation),
        "evaluation_tasks_up_to_symmetry": len(eval_tasks),
        "evaluation_wall_grids_up_to_symmetry": len(eval_grids),
        "shared_wall_grids": shared_grids,
        "shared_tasks": shared_tasks,
        "training_grids_outside_train": int(outside_train),
        "evaluation_grids_outside_eval": int(outside_eval),
        "disjoint": shared_grids == 0 and shared_tasks == 0 and outside_train == 0 and outside_eval == 0,
    }
