"""Learner-ablation trial files (``scripts/learner_ablation.py``), read per maze for the learner-selection check.

The preregistration's ``learner.beats`` rule (``docs/preregistration.md``, section 2) pairs two learners' seeds
maze by maze on the selection mazes, so it needs each trial's learner-only outcome **on every selection maze**,
not only the rate. A trial file carries them in ``selection_success["mazes"]``: one record per maze, in the
order of its reset seeds, as :func:`antmaze_hirl.experiments.outcomes.play_mazes` returns them::

    "selection_success": {"rate": 0.92, "successes": 46, "episodes": 50, "first_seed": 3000000, ...,
                          "mazes": [{"maze_seed": 3000000, "layout": "111111/1S0001/...",
                                     "task_class": "...", "success": true, ...}, ...]}

``maze_seed`` and ``success`` are required; the maze's task up to symmetry is ``task_class``, or is computed
from ``layout`` where only that is recorded (a record with both is checked: they must agree).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.envs.layouts import canonical_task
from antmaze_lab.folders import layout_from_string

PER_MAZE_FIELD = "mazes"
"""The key of ``selection_success`` that holds the per-maze records."""


@dataclass(frozen=True)
class SelectionTrial:
    """One trial's learner-only outcomes on the selection mazes.

    Attributes:
        path: The trial file.
        body: ``point`` or ``ant``.
        variant: The learner (``next_cell_cnn``, ``next_cell_plan``, ...).
        seed: The trial's seed.
        episodes: Training episodes before the evaluation.
        maze_seeds: Each selection maze's reset seed, ascending.
        task_classes: Each maze's task up to the square's 8 symmetries, in the same order.
        success: ``(mazes,)`` learner-only success, in the same order.
        evaluation_envs: Mazes played at once in lockstep (``None`` where the file does not say).
    """

    path: Path
    body: str
    variant: str
    seed: int
    episodes: int
    maze_seeds: tuple[int, ...]
    task_classes: tuple[str, ...]
    success: np.ndarray
    evaluation_envs: int | None


def _task_class(path: Path, record: dict) -> str:
    recorded, layout = record.get("task_class"), record.get("layout")
    if layout is None:
        if recorded is None:
            raise ValueError(f"{path}: selection maze {record['maze_seed']} records neither task_class nor layout")
        return str(recorded)
    computed = canonical_task(layout_from_string(layout))
    if recorded is not None and recorded != computed:
        raise ValueError(f"{path}: selection maze {record['maze_seed']}'s task_class is not its layout's task")
    return computed


def _load(path: Path) -> dict[str, Any]:
    try:
        trial = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{path} is not a readable JSON file: {error}") from None
    if not isinstance(trial, dict) or not {"variant", "seed", "episodes", "selection_success"} <= set(trial):
        raise ValueError(f"{path} is not a learner-ablation trial (variant, seed, episodes, selection_success)")
    return trial


def _body(trial: dict[str, Any]) -> str:
    # Trials recorded before the ant joined the ablation name no body: they are the point's (the runner's rule).
    return str(trial.get("body", "point"))


def trial_identity(path: Path) -> tuple[str, str, int, int]:
    """A trial file's ``(body, variant, seed, episodes)``, whether or not it records per-maze outcomes.

    Raises:
        ValueError: One line naming the file if it is not JSON or not a learner-ablation trial.
    """
    trial = _load(path)
    return _body(trial), str(trial["variant"]), int(trial["seed"]), int(trial["episodes"])


def read_selection_trial(path: Path) -> SelectionTrial:
    """One trial file, with its per-maze selection outcomes.

    Raises:
        ValueError: One line naming the file: not JSON, not a learner-ablation trial, no per-maze outcomes
            (``selection_success["mazes"]``, see the module docstring), a record without ``maze_seed`` or
            ``success``, a maze listed twice, or per-maze outcomes that disagree with the recorded count.
    """
    path = Path(path)
    trial = _load(path)
    figures = trial["selection_success"]
    records = figures.get(PER_MAZE_FIELD)
    if not records:
        raise ValueError(
            f"{path}: selection_success has no per-maze outcomes ({PER_MAZE_FIELD!r}: one {{maze_seed, layout, "
            "task_class, success} per selection maze, as antmaze_hirl.experiments.outcomes.play_mazes returns them)"
        )
    if any("maze_seed" not in r or "success" not in r for r in records):
        raise ValueError(f"{path}: a selection maze record lacks maze_seed or success")
    records = sorted(records, key=lambda r: int(r["maze_seed"]))
    seeds = tuple(int(r["maze_seed"]) for r in records)
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"{path}: a selection maze is listed twice")
    success = np.array([bool(r["success"]) for r in records])
    if "successes" in figures and int(figures["successes"]) != int(success.sum()):
        raise ValueError(f"{path}: {int(success.sum())} per-maze successes, but successes = {figures['successes']}")
    return SelectionTrial(
        path=path,
        body=_body(trial),
        variant=str(trial["variant"]),
        seed=int(trial["seed"]),
        episodes=int(trial["episodes"]),
        maze_seeds=seeds,
        task_classes=tuple(_task_class(path, r) for r in records),
        success=success,
        evaluation_envs=trial.get("evaluation_envs"),
    )


def trial_files(paths: Iterable[Path]) -> list[Path]:
    """Every ``*.json`` of the folders given, and the files given, in sorted order.

    Raises:
        ValueError: For a path that is neither a folder nor a file, or a folder without ``*.json``.
    """
    found: list[Path] = []
    for path in map(Path, paths):
        if path.is_dir():
            inside = sorted(path.glob("*.json"))
            if not inside:
                raise ValueError(f"no trial files (*.json) in {path}")
            found += inside
        elif path.is_file():
            found.append(path)
        else:
            raise ValueError(f"no trial file or folder at {path}")
    return sorted(set(found))
