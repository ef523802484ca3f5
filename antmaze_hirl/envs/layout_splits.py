"""A fixed partition of maze layouts into training, evaluation and selection parts, by wall grid up to symmetry.

A layout's part is decided by its wall grid alone, start and goal ignored, and by that grid *up to the
eight symmetries of the square*: ``int(sha256(canonical_wall_grid(walls)).hexdigest(), 16) % 10`` is 0 or
1 for ``"eval"`` (20%), 2 for ``"selection"`` (10%), 3 to 9 for ``"train"`` (70%), where
:func:`~antmaze_hirl.envs.layouts.canonical_wall_grid` is the smallest string of the grid's eight
rotations and mirrors. The learner trains on all eight images of every sample (its augmentation,
``antmaze_hirl.dagger.features``), so a rotated or mirrored copy of a training grid is a training grid
to it: hashing the canonical form puts a grid and all its images in one part, and no evaluation or
selection task (walls, start, goal) is a symmetric image of a training task. Hashing the walls rather
than the whole layout means an evaluation maze never shares its walls with a training maze, not merely
its start and goal. The partition is a pure function of the grid, the same on every machine and run.

The first partition (protocol 1, :func:`wall_grid_split_v1`) hashed the raw grid: a 4x4 evaluation grid
then almost always had a rotated copy in the training part. Every results folder made with
``held_out_layouts`` before this change (``results/paper_experiment/{point,ant}``,
``select_low_level/low_level_selection_held_out*.json``, ``paper_experiment/oracle_success_ant_4.json``,
``maze_families/maze_families.json``) used it.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from typing import Literal, get_args

import numpy as np

from antmaze_hirl.envs.layouts import MazeLayout, canonical_wall_grid, wall_grid_string

LayoutSplit = Literal["train", "eval", "selection"]
SPLITS: tuple[LayoutSplit, ...] = get_args(LayoutSplit)
_BUCKETS: dict[int, LayoutSplit] = {0: "eval", 1: "eval", 2: "selection", **dict.fromkeys(range(3, 10), "train")}

DEFAULT_MAX_TRIES = 1000
"""Draws :func:`sample_layout_in_split` makes before giving up: the eval part (20%) misses 1000 in a row
with probability 0.8**1000, so a failure means the family has no grid in that part, not bad luck."""


def check_split(split: str) -> LayoutSplit:
    """Returns ``split`` if it names a part.

    Raises:
        ValueError: Naming the value and the parts, otherwise.
    """
    if split not in SPLITS:
        raise ValueError(f"unknown layout split {split!r}; choose one of {list(SPLITS)}")
    return split  # type: ignore[return-value]


def wall_grid_split(walls: np.ndarray) -> LayoutSplit:
    """The part a wall grid belongs to: that of its canonical form up to symmetry (see the module docstring).

    Every rotation and mirror of ``walls`` gets the same part.
    """
    return _bucket(canonical_wall_grid(walls))


def wall_grid_split_v1(walls: np.ndarray) -> LayoutSplit:
    """The part of protocol 1, the raw grid's hash, kept to audit the results folders made with it.

    Not closed under symmetry: a grid and its rotation often fall in different parts. Nothing draws
    mazes with it any more.
    """
    return _bucket(wall_grid_string(walls))


def _bucket(grid_string: str) -> LayoutSplit:
    return _BUCKETS[int(hashlib.sha256(grid_string.encode()).hexdigest(), 16) % 10]


def layout_split(layout: MazeLayout) -> LayoutSplit:
    """The part ``layout`` belongs to: that of its wall grid."""
    return wall_grid_split(layout.walls)


def sample_layout_in_split(
    sample: Callable[[np.random.Generator], MazeLayout],
    rng: np.random.Generator,
    split: LayoutSplit,
    *,
    max_tries: int = DEFAULT_MAX_TRIES,
) -> MazeLayout:
    """Draws layouts with ``sample(rng)`` until one falls in ``split`` (rejection sampling).

    The result follows the family's own distribution restricted to the part, and the same ``rng``
    state gives the same layout.

    Args:
        sample: The family's sampler, e.g. a high-level env's ``sample_layout``.
        rng: Source of the draws.
        split: ``"train"``, ``"eval"`` or ``"selection"``.
        max_tries: Draws before giving up.

    Raises:
        ValueError: On an unknown split or ``max_tries < 1``, or when no draw fell in ``split``
            (naming how many distinct wall grids were seen: the family has too few for the partition).
    """
    check_split(split)
    if max_tries < 1:
        raise ValueError(f"max_tries must be >= 1, got {max_tries}")
    seen: set[str] = set()
    for _ in range(max_tries):
        layout = sample(rng)
        if layout_split(layout) == split:
            return layout
        seen.add(canonical_wall_grid(layout.walls))
    raise ValueError(
        f"no layout in split {split!r} in {max_tries} draws ({len(seen)} distinct wall grids up to symmetry "
        "seen, all in other parts): this maze family has too few wall grids to hold out; use a larger maze_size"
    )
