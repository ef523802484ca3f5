"""What the next-cell head learns from the ant's oracle labels: each label's class, by the old and the new rule.

The next-cell head classifies a label by the cell its subgoal lies in (``HighLevelPolicy.cell_steps``). The
ant's oracle gives 2 m subgoals in 4 m cells, so from near a cell's centre most land in the agent's own
cell. The old rule read that as "stay"; the new one carries a label at the reach (at least
``AT_REACH`` of it) one cell side along its direction first. This script samples oracle-labelled states
on freshly generated 4x4 ant mazes (the size of the held-out-layouts family; no learner is trained or
scored here, so no split applies), no simulation: the agent uniformly within ``--spread`` metres of a
free cell's centre (in that cell), the goal in another cell, off its centre by up to ``position_noise_cells``
(0.25 cells, the high-level env's default), and counts per rule:

* ``stay``: the class is the agent's own cell;
* ``matches_grid_path``: the class is the next cell of the grid's shortest path (the rest are mostly the
  oracle's line-of-sight shortcuts, or "back to your cell's centre" before a corner);
* ``goal_within_reach_moved``: the label is the goal itself and the class is not the goal's cell;
* ``own_centre_moved``: the label is the agent's own cell centre and the class is not "stay".

Usage: python scripts/next_cell_labels.py [--mazes 300] [--states 20] [--seed 0]
Writes results/next_cell_labels/next_cell_labels.json.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.high_level_policy import AT_REACH, HighLevelPolicy, LearnerSettings
from antmaze_hirl.envs.bodies import body_spec
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import generate_layout, shortest_path
from antmaze_hirl.experiments.config import BODY_DEFAULTS, HELD_OUT_MAZE_SIZE
from antmaze_hirl.experts.oracle import plan_subgoal

RESULTS = Path(__file__).resolve().parents[1] / "results" / "next_cell_labels"


def sample_labels(mazes: int, states: int, spread: float, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Oracle labels of ant states: agent xy, subgoal, the grid path's next step (dx, dy) and what the label is."""
    size, reach = HELD_OUT_MAZE_SIZE["ant"], BODY_DEFAULTS["ant"]["subgoal_reach_m"]
    geometry = MazeGeometry(size + 2, size + 2, body_spec("ant").scale)
    agents, subgoals, path_steps, is_goal, is_own_centre = [], [], [], [], []
    for _ in range(mazes):
        layout = generate_layout(rng, n_rows=size, n_cols=size, min_goal_cells=3)
        goal_xy = geometry.cell_to_xy(layout.goal_cell) + rng.uniform(-0.25, 0.25, size=2) * geometry.scale
        free = np.argwhere(~layout.walls)
        for _ in range(states):
            cell = tuple(int(v) for v in free[rng.integers(len(free))])
            agent = geometry.cell_to_xy(cell) + rng.uniform(-spread, spread, size=2)
            if cell == layout.goal_cell or geometry.xy_to_cell(agent) != cell:
                continue
            label = plan_subgoal(
                layout.walls, geometry, agent, goal_xy, subgoal_reach_m=reach, clearance_m=0.2 * geometry.scale
            )
            row, col = np.subtract(shortest_path(layout.walls, cell, layout.goal_cell)[1], cell)
            agents.append(agent), subgoals.append(label), path_steps.append((col, -row))
            is_goal.append(np.allclose(label, goal_xy))
            is_own_centre.append(np.allclose(label, geometry.cell_to_xy(cell)))
    return {
        "geometry": geometry,
        "reach": reach,
        "agents": np.array(agents),
        "subgoals": np.array(subgoals),
        "path_steps": np.array(path_steps),
        "is_goal": np.array(is_goal),
        "is_own_centre": np.array(is_own_centre),
    }


def class_figures(steps: np.ndarray, label_cells: np.ndarray, labels: dict[str, np.ndarray]) -> dict[str, float]:
    """The shares of the module docstring for one rule's ``(dx, dy)`` classes (``label_cells``: the old rule's)."""
    stay = np.all(steps == 0, axis=1)
    goal_moved = labels["is_goal"] & np.any(steps != label_cells, axis=1)
    return {
        "stay": round(float(stay.mean()), 4),
        "matches_grid_path": round(float(np.all(steps == labels["path_steps"], axis=1).mean()), 4),
        "goal_within_reach_moved": round(float(goal_moved.mean()), 4),
        "own_centre_moved": round(float((labels["is_own_centre"] & ~stay).mean()), 4),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mazes", type=int, default=300)
    parser.add_argument("--states", type=int, default=20, help="states drawn per maze (some are skipped)")
    parser.add_argument("--spread", type=float, default=1.5, help="metres from a free cell's centre, each axis")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS / "next_cell_labels.json")
    args = parser.parse_args()
    labels = sample_labels(args.mazes, args.states, args.spread, np.random.default_rng(args.seed))
    geometry, reach = labels["geometry"], labels["reach"]
    steps = {}
    for rule, subgoal_reach_m in (("old", geometry.scale), ("new", reach)):
        # At a whole cell's reach cell_steps reads the cell each label lies in (the old rule); at 2 m it carries.
        policy = HighLevelPolicy(
            geometry,
            pixels_per_cell=8,
            body_dim=0,
            rng=np.random.default_rng(0),
            settings=LearnerSettings(subgoal_reach_m=subgoal_reach_m, head="next_cell"),
        )
        steps[rule] = policy.cell_steps(labels["agents"], labels["subgoals"])
    rules = {rule: class_figures(classes, steps["old"], labels) for rule, classes in steps.items()}
    result = {
        "command": shlex.join(["python", "scripts/next_cell_labels.py", *sys.argv[1:]]),
        "maze_size": HELD_OUT_MAZE_SIZE["ant"],
        "reach_m": reach,
        "cell_m": geometry.scale,
        "at_reach": AT_REACH,
        "states": len(labels["agents"]),
        "labels_that_are_the_goal": round(float(labels["is_goal"].mean()), 4),
        "labels_that_are_the_own_cell_centre": round(float(labels["is_own_centre"].mean()), 4),
        "rules": {"old: the cell the label lies in": rules["old"], "new: carried one cell at the reach": rules["new"]},
    }
    for rule, figures in rules.items():
        print(f"{rule} rule: {figures}")
    print(
        f"{result['states']} states; goal labels {result['labels_that_are_the_goal']}, "
        f"own-centre labels {result['labels_that_are_the_own_cell_centre']}"
    )
    atomic_write_json(args.out, result)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
