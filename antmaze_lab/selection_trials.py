"""Learner-ablation trial files (``scripts/learner_ablation.py``), read per maze for the learner-selection check.

The preregistration's ``learner.beats`` rule (``docs/preregistration.md``, section 2) pairs two learners' seeds
maze by maze on the selection mazes, so it needs each trial's learner-only outcome **on every selection maze**,
not only the rate. A trial file carries them in ``selection_success["outcomes"]``: 1 or 0 per maze, in the order
of the mazes' reset seeds from ``first_seed``::

    "selection_success": {"rate": 0.92, "successes": 46, "episodes": 50, "first_seed": 3000000, ...,
                          "outcomes": [1, 0, 1, ...]}

The files do not record the mazes themselves: maze ``i`` is the one the selection part draws at a reset with seed
``first_seed + i`` (the evaluation reset with that seed before the learner acted), so
:func:`selection_task_classes` draws them again to group them into tasks up to symmetry.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.envs.layouts import canonical_task
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env

PER_MAZE_FIELD = "outcomes"
"""The key of ``selection_success`` that holds the per-maze outcomes."""


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
        success: ``(mazes,)`` learner-only success, in the same order.
        evaluation_envs: Mazes played at once in lockstep (``None`` where the file does not say).
        split: The layout partition's part the mazes came from (``selection_success["split"]``).
    """

    path: Path
    body: str
    variant: str
    seed: int
    episodes: int
    maze_seeds: tuple[int, ...]
    success: np.ndarray
    evaluation_envs: int | None
    split: str = "selection"


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
            (``selection_success["outcomes"]``, see the module docstring), outcomes other than 0 and 1, or
            outcomes that disagree with the recorded count of mazes or of successes.
    """
    path = Path(path)
    trial = _load(path)
    figures = trial["selection_success"]
    outcomes = figures.get(PER_MAZE_FIELD)
    if not outcomes or "first_seed" not in figures:
        raise ValueError(
            f"{path}: selection_success has no per-maze outcomes ({PER_MAZE_FIELD!r}: 1 or 0 per selection maze, "
            "in seed order from first_seed, as scripts/learner_ablation.py writes them since 6df364a)"
        )
    if any(value not in (0, 1) for value in outcomes):
        raise ValueError(f"{path}: selection_success.{PER_MAZE_FIELD} holds values other than 0 and 1")
    success = np.array(outcomes, dtype=bool)
    for key, count in (("episodes", len(success)), ("successes", int(success.sum()))):
        if key in figures and int(figures[key]) != count:
            raise ValueError(f"{path}: {count} per-maze {key}, but selection_success.{key} = {figures[key]}")
    first = int(figures["first_seed"])
    return SelectionTrial(
        path=path,
        body=_body(trial),
        variant=str(trial["variant"]),
        seed=int(trial["seed"]),
        episodes=int(trial["episodes"]),
        maze_seeds=tuple(range(first, first + len(success))),
        success=success,
        evaluation_envs=trial.get("evaluation_envs"),
        split=str(figures.get("split", "selection")),
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


@functools.lru_cache(maxsize=8)
def selection_task_classes(body: str, maze_seeds: tuple[int, ...]) -> tuple[str, ...]:
    """Each selection maze's task up to the square's 8 symmetries, drawn again from its reset seed.

    The learner-ablation trials' env (held-out layouts, the body's maze size, the ``selection`` part), reset with
    each seed as the evaluation reset it; the maze is drawn at the reset, before any policy acts, so no low level
    is loaded.
    """
    config = ExperimentConfig(body=body, held_out_layouts=True, **body_settings(body, held_out_layouts=True))
    env = make_env(config, lambda *_: None, split="selection")
    try:
        classes = []
        for seed in maze_seeds:
            env.reset(seed=seed)
            classes.append(canonical_task(maze_env(env).layout))
    finally:
        env.close()
    return tuple(classes)
