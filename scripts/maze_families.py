"""Distinct wall grids of candidate maze families: how many mazes a family can hold out.

Draws ``--draws`` layouts (default 20,000) from each family's own sampler (the high-level env's
``sample_layout`` at the experiment's settings: wall fraction 0.3, goal at least 3 steps from a
start corner) and counts distinct wall grids and distinct layouts (walls, start and goal), overall
and per part of the layout partition (:mod:`antmaze_hirl.envs.layout_splits`). A family needs
>= 1,000 distinct wall grids to hold the ant's evaluation mazes out by layout, not by seed only.

Usage: python scripts/maze_families.py [--draws 20000] [--seed 0]
Writes results/maze_families/maze_families.json.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import gymnasium as gym
import numpy as np

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.layout_splits import SPLITS, wall_grid_split
from antmaze_hirl.envs.layouts import wall_grid_string
from antmaze_hirl.envs.profiles import maze_env_id

FAMILIES = {"ant_3x3": ("ant", 3), "ant_4x4": ("ant", 4), "ant_5x5": ("ant", 5), "point_5x5": ("point", 5)}
RESULTS = Path(__file__).resolve().parents[1] / "results" / "maze_families"


def family_figures(body: str, maze_size: int, draws: int, seed: int) -> dict:
    # Only the layout sampler is used: a do-nothing controller spares loading the shipped policy.
    action_dim = {"ant": 8, "point": 2}[body]
    env = gym.make(maze_env_id(body), maze_size=maze_size, low_level=lambda obs: np.zeros(action_dim))
    rng = np.random.default_rng(seed)
    layouts = [env.unwrapped.sample_layout(rng) for _ in range(draws)]
    env.close()
    grids = Counter(wall_grid_string(layout.walls) for layout in layouts)
    walls_of = {wall_grid_string(layout.walls): layout.walls for layout in layouts}
    parts = Counter(wall_grid_split(layout.walls) for layout in layouts)
    grid_parts = Counter(wall_grid_split(walls) for walls in walls_of.values())
    return {
        "body": body,
        "maze_size": maze_size,
        "draws": draws,
        "distinct_wall_grids": len(grids),
        "distinct_layouts": len({layout.canonical() for layout in layouts}),
        "most_common_grid_share": grids.most_common(1)[0][1] / draws,
        "distinct_wall_grids_per_split": {split: grid_parts[split] for split in SPLITS},
        "draw_share_per_split": {split: parts[split] / draws for split in SPLITS},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--draws", type=int, default=20_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    figures = {name: family_figures(body, size, args.draws, args.seed) for name, (body, size) in FAMILIES.items()}
    for name, family in figures.items():
        print(
            f"{name}: {family['distinct_wall_grids']} distinct wall grids, {family['distinct_layouts']} distinct "
            f"layouts in {family['draws']} draws; grids per split {family['distinct_wall_grids_per_split']}"
        )
    atomic_write_json(RESULTS / "maze_families.json", {"draws": args.draws, "seed": args.seed, "families": figures})


if __name__ == "__main__":
    main()
