"""In-maze success: the scripted oracle driving a low-level policy through held-out mazes (what the high level gets).

For each low level (default the shipped ant; ``--low-level ZIP`` for candidates, repeatable, run side by side on
the same mazes) and each maze family:

* ``ant3``: the ant experiment's family (random 3x3 layouts, 500-step limit), the mazes of
  ``paper_experiment.py --body ant --oracle-only``;
* ``ant4``: the held-out-layouts protocol's ant family (random 4x4 layouts from the ``eval`` part of the layout
  partition, 500-step limit), the mazes of ``paper_experiment.py --body ant --oracle-only --held-out-layouts``;
* ``u``, ``medium``, ``large``: gymnasium-robotics' standard maps, random start corner and goal (at least 3 grid
  steps apart), with the step limit scaled to the episode's shortest path (:func:`step_limit`).

``select4`` and ``select6`` (:data:`SELECTION_FAMILIES`) are for ``antmaze_lab.select_low_level`` only:
``--families`` takes the reported ones above.

The oracle's subgoals are at most 2 m away (the ant experiment's ``subgoal_reach_m``). Episode ``i`` of every
family resets with seed ``HELD_OUT_SEED + i`` (1,000,000 + i, as every held-out figure): for ``ant3`` these are the
mazes of ``paper_experiment/oracle_success_ant_3.json``. Note the 3x3 family has few distinct wall grids
(``results/maze_families/maze_families.json``), so a
training run that sees random 3x3 layouts (``ReachEnv(maze_probability=...)``) has seen these grids; only the
seeds are held out.

Each episode ends in exactly one outcome: ``success``, ``flip`` (the ant turned over: the env ends the episode),
``frozen`` (truncated, and over its last :data:`FROZEN_SUBGOALS` subgoals the body never got
:data:`FROZEN_RADIUS` m from where it stood when the first of them was set) or ``timeout`` (any other truncation).
Success rates carry a 95% Wilson interval; ``flips_per_subgoal`` is flips over subgoals set.

Inference-time candidates against flips, measured without retraining: ``--action-smoothing 0,0.3,0.5`` adds a row
per weight, each low level's actions smoothed exponentially (:class:`~antmaze_hirl.envs.SmoothedController`);
``--subgoal-reach-m D`` (``--subgoal-distance`` before 0.2.0) changes the oracle's farthest subgoal for every row.
``--jobs N`` plays chunks of ``--chunk-episodes`` episodes in N processes; every episode resets with its own seed,
so the figures do not depend on N (``seconds`` then sums the workers' time).

``--num-envs N`` (default :data:`LOCKSTEP_ENVS`) plays up to N mazes of a chunk at once in lockstep: the
oracle labels every maze that needs a subgoal, the low level acts in one batch for every maze still walking.
The same mazes and seeds; a batched forward pass may round the last bits differently, which MuJoCo can turn
into another outcome now and then (``antmaze_lab.lockstep_paths`` counts how often). ``--num-envs 1`` plays
them one after another, the path every ``in_maze/in_maze*.json`` committed before lockstep was made with: use it to
replay one exactly.

Usage: python -m antmaze_lab.in_maze [--episodes 100] [--families ant3,ant4,u,medium,large] [--low-level cand.zip ...]
           [--action-smoothing 0[,A...]] [--subgoal-reach-m 2.0] [--jobs 1] [--chunk-episodes 25] [--num-envs 25]
Writes results/in_maze/in_maze.json (or ``--out``), with the command that made it, and prints a table. Files
written before it moved into the lab record ``python scripts/in_maze.py`` (earlier ``benchmarks/in_maze.py``):
the same options replay them here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED
from antmaze_hirl.experiments.config import BODY_DEFAULTS
from antmaze_lab.commands import recorded_command
from antmaze_lab.in_maze_protocol import (
    FAMILIES,
    FROZEN_RADIUS,
    FROZEN_SUBGOALS,
    LOCKSTEP_ENVS,
    MIN_STEPS,
    STEPS_PER_METRE,
    parse_families,
    parse_smoothing,
    row_names,
    run,
    worker_low_level,
)
from antmaze_lab.tables import lab_parser, refuse_below_one

RESULTS = Path(__file__).resolve().parents[1] / "results" / "in_maze"


def table(results: dict[str, Any]) -> str:
    """A plain-text table: one row per low level and family."""
    lines = [f"{'low level':<40} {'family':<7} {'success [95% CI]':<22} flips frozen timeouts flips/subgoal"]
    for name, figures in results.items():
        for family, row in figures["families"].items():
            low, high = row["success_ci95"]
            ci = f"{row['success_rate']:.0%} [{low:.0%}, {high:.0%}]"
            lines.append(
                f"{name[-40:]:<40} {family:<7} {ci:<22} {row['flips']:>5} {row['frozen']:>6} "
                f"{row['timeouts']:>8} {row['flips_per_subgoal']:>13.4f}"
            )
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``scripts/results_index.py --check`` parses recorded options with it)."""
    parser = lab_parser("antmaze_lab.in_maze", __doc__)
    parser.add_argument("--episodes", type=int, default=100, help="held-out mazes (episodes) per family")
    parser.add_argument("--families", default=",".join(FAMILIES), help=f"comma-separated subset of {FAMILIES}")
    parser.add_argument(
        "--low-level",
        type=Path,
        action="append",
        default=None,
        help="candidate policy .zip or low-level name, such as ensemble (repeatable); the shipped policy always runs "
        "first (default: none)",
    )
    parser.add_argument("--seed", type=int, default=HELD_OUT_SEED, help="maze seed of episode 0")
    parser.add_argument(
        "--action-smoothing",
        default="0",
        help="comma-separated weights A of the previous action (a_t = A a_t-1 + (1 - A) raw_t), each a row; 0: none",
    )
    parser.add_argument(
        "--subgoal-reach-m",
        type=float,
        default=None,
        help=f"the oracle's farthest subgoal, metres (default {BODY_DEFAULTS['ant']['subgoal_reach_m']}: "
        "the ant experiment's)",
    )
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (chunks of --chunk-episodes episodes)")
    parser.add_argument("--chunk-episodes", type=int, default=25, help="episodes per worker task with --jobs > 1")
    parser.add_argument(
        "--num-envs",
        type=int,
        default=LOCKSTEP_ENVS,
        help=f"mazes played at once in lockstep (default {LOCKSTEP_ENVS}); 1: one after another, for exact "
        "replays of results committed before lockstep",
    )
    parser.add_argument("--out", type=Path, default=RESULTS / "in_maze.json")
    return parser


def main() -> None:
    """The command line: play every low level and family, write the file, print the table."""
    parser = build_parser()
    args = parser.parse_args()
    try:
        families = parse_families(args.families)
        smoothing = parse_smoothing(args.action_smoothing)
        row_names([None, *(args.low_level or [])], tuple(smoothing))
    except ValueError as error:
        parser.error(str(error))
    refuse_below_one(parser, args, ("episodes", "jobs", "chunk_episodes", "num_envs"))
    if args.subgoal_reach_m is not None and not args.subgoal_reach_m > 0:
        parser.error(f"--subgoal-reach-m must be > 0 metres, got {args.subgoal_reach_m}")
    torch.set_num_threads(1)
    for value in args.low_level or []:
        try:  # loaded here once (a name, its body, its zip checked) rather than failing in a worker
            worker_low_level(value)
        except (ValueError, FileNotFoundError) as error:
            parser.error(str(error))
    subgoal_reach_m = args.subgoal_reach_m or BODY_DEFAULTS["ant"]["subgoal_reach_m"]
    results = run(
        [None, *(args.low_level or [])],
        families,
        episodes=args.episodes,
        seed=args.seed,
        smoothing=tuple(smoothing),
        subgoal_reach_m=subgoal_reach_m,
        jobs=args.jobs,
        chunk_episodes=args.chunk_episodes,
        num_envs=args.num_envs,
    )
    atomic_write_json(
        args.out,
        {
            "command": recorded_command("antmaze_lab.in_maze", sys.argv[1:]),
            "subgoal_reach_m": subgoal_reach_m,
            "num_envs": args.num_envs,
            "step_limit": (
                f"ant3, ant4: 500; standard maps: max({MIN_STEPS}, ceil({STEPS_PER_METRE} * shortest cell path m))"
            ),
            "frozen": f"truncated, and within {FROZEN_RADIUS} m over the last {FROZEN_SUBGOALS} subgoals",
            "results": results,
        },
    )
    print(table(results))


if __name__ == "__main__":
    main()
