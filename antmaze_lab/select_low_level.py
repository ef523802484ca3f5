"""Picks the ant policy to ship from the snapshots of one or more ``train-low`` runs, without peeking at the test sets.

TD3's success rate swings between evaluations of one run (``results/low_level/ant_learning_curve*.csv``), so the last
step is rarely the best.
Every ``<run>/snapshots/step_<n>.zip`` (written at each evaluation) is scored, at each action-smoothing weight of
``--action-smoothing``, on *selection* sets that the reported figures never use:

* ``eval_low``: free-space reaching as ``antmaze-hirl eval-low`` measures it, but on subgoal seeds
  ``--seed`` .. ``--seed + episodes - 1`` (default from 100,000), disjoint from the reported ones
  (seeds 0-199: the README and ``antmaze_lab.low_level``) and from train-low's held-out curve (10,000-);
* the scripted oracle (2 m subgoals) driving the snapshot through ``--mazes`` random mazes per family, from maze
  seed 2,000,000 (every reported maze figure starts at 1,000,000, the paper experiment's periodic evaluation at
  3,000,000), played by ``antmaze_lab.in_maze``'s machinery:

  - by default ``ant3``: the ant protocol's 3x3 mazes;
  - with ``--held-out-layouts``, ``select4``: 4x4 layouts (``ant4``'s family, 500 steps) from the ``selection``
    part of the layout partition, which holds no wall grid of the reported ``eval`` part (``antmaze_lab.in_maze``'s
    ``ant4``, the paper experiment's final evaluation) nor of the ``train`` part
    (``ReachEnv(maze_split="train")``);
  - with ``--large-mazes`` as well, ``select6``: 6x6 layouts of the same part (``medium``'s 8x8 grid), the step
    limit scaled to the path as on the standard maps, so that the pick also weighs long walks.

A row's score is the mean of its figures (eval-low and one success rate per family): what the high level needs
and what the in-maze goals measure. The pick is the best row, a (snapshot, smoothing weight) pair; a tie
keeps the row listed first (policy files come before run snapshots, in the order given). Scores are cached per
row in the JSON, so a rerun while training goes on scores only new snapshots.

A policy trained under action smoothing (``ReachEnv(action_smoothing=...)``, e.g.
``scripts/configs/ant_maze_smoothed.yml``) is scored at its weight: every figure of a row runs with the same
smoothing (the saved zip does not record it).

Usage: python -m antmaze_lab.select_low_level runs/ant_chain [runs/ant_finetune ...] [policy.zip ...] [--min-step N]
           [--held-out-layouts [--large-mazes]] [--action-smoothing 0[,A...]] [--jobs N]
Writes results/select_low_level/low_level_selection.json (``low_level_selection_held_out.json`` beside it with
``--held-out-layouts``, ``low_level_selection_held_out_large.json`` with ``--large-mazes`` too), with the command
that made it. Files written before it moved into the lab record ``python scripts/select_low_level.py`` (earlier
``benchmarks/select_low_level.py``): the same options replay them here.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experiments.runner import low_level_identity
from antmaze_hirl.sb3_ext.evaluation import evaluate_reach, snapshot_step
from antmaze_hirl.sb3_ext.loading import load_low_level
from antmaze_lab.commands import recorded_command
from antmaze_lab.in_maze_protocol import map_tasks, parse_smoothing, row_name, row_names
from antmaze_lab.in_maze_protocol import run as play_families
from antmaze_lab.tables import lab_parser, refuse_below_one

RESULTS = Path(__file__).resolve().parents[1] / "results" / "select_low_level"
SELECTION_MAZE_SEED = SEEDS.low_level_selection_mazes
# Subgoal seeds the selection may not use: eval-low's reported set and train-low's held-out curve.
RESERVED_SUBGOAL_SEEDS = (
    range(SEEDS.low_level_report_subgoals, SEEDS.low_level_report_subgoals + 1_000),
    range(SEEDS.low_level_curve, SEEDS.low_level_curve + 10_000),
)


def selection_families(*, held_out_layouts: bool, large_mazes: bool) -> list[str]:
    """The maze families a row is scored on (see the module docstring).

    Raises:
        ValueError: For ``large_mazes`` without ``held_out_layouts`` (the large family is a held-out part).
    """
    if large_mazes and not held_out_layouts:
        raise ValueError("--large-mazes needs --held-out-layouts: its 6x6 mazes come from the selection part")
    if not held_out_layouts:
        return ["ant3"]
    return ["select4", "select6"] if large_mazes else ["select4"]


def eval_low(path: Path, smoothing: float, seed: int, episodes: int) -> dict[str, float]:
    """Free-space reaching of the policy at ``path`` under ``smoothing`` (a worker process's task with ``--jobs``)."""
    torch.set_num_threads(1)
    reach = ReachEnv("ant", action_smoothing=smoothing)
    try:
        result = evaluate_reach(load_low_level("ant", path), reach, episodes=episodes, seed=seed)
    finally:
        reach.close()
    return {"eval_low": result["success_rate"], "eval_low_mean_steps": result["mean_steps"]}


def score_rows(
    paths: list[Path],
    smoothing: float,
    families: list[str],
    *,
    seed: int,
    episodes: int,
    mazes: int,
    jobs: int = 1,
) -> dict[str, dict[str, Any]]:
    """Every row (policy at ``paths``, ``smoothing``): eval-low, the oracle's success per family, their mean.

    Keyed by :func:`in_maze.row_name`. With ``jobs`` > 1, eval-low runs one policy per process and the mazes in
    chunks over processes; the figures do not depend on ``jobs``.
    """
    free = list(map_tasks(eval_low, [(path, smoothing, seed, episodes) for path in paths], jobs))
    mazes_played = play_families(
        list(paths), families, episodes=mazes, seed=SELECTION_MAZE_SEED, smoothing=(smoothing,), jobs=jobs
    )
    rows = {}
    for path, figures in zip(paths, free, strict=True):
        played = mazes_played[row_name(path, smoothing)]
        success = {family: played["families"][family]["success_rate"] for family in families}
        rows[row_name(path, smoothing)] = {
            "path": str(path),
            "action_smoothing": smoothing,
            "low_level_id": played["low_level_id"],
            **figures,
            "success": success,
            "flips_per_subgoal": {family: played["families"][family]["flips_per_subgoal"] for family in families},
            "score": (figures["eval_low"] + sum(success.values())) / (1 + len(success)),
        }
    return rows


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``scripts/results_index.py --check`` parses recorded options with it)."""
    parser = lab_parser("antmaze_lab.select_low_level", __doc__)
    parser.add_argument("runs", nargs="+", type=Path, help="train-low run folders or policy .zip files")
    first_seed = SEEDS.low_level_selection_subgoals
    parser.add_argument("--seed", type=int, default=first_seed, help="first subgoal seed of the selection eval-low")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--mazes", type=int, default=50, help="mazes per family")
    parser.add_argument("--min-step", type=int, default=0, help="skip snapshots before this step")
    parser.add_argument(
        "--held-out-layouts",
        action="store_true",
        help="4x4 mazes from the selection part of the layout partition instead of the 3x3 protocol's",
    )
    parser.add_argument("--large-mazes", action="store_true", help="also 6x6 selection-part mazes (scaled limits)")
    parser.add_argument(
        "--action-smoothing",
        default="0",
        help="comma-separated weights in [0, 1), a row per policy and weight (for policies trained under one)",
    )
    parser.add_argument("--jobs", type=int, default=1, help="worker processes")
    parser.add_argument("--out", type=Path, default=None, help="default: see Usage")
    return parser


def main() -> None:
    """The command line: score every snapshot and policy, write the file, print each row and the best."""
    parser = build_parser()
    args = parser.parse_args()
    if args.out is None:
        suffix = ("_held_out" if args.held_out_layouts else "") + ("_large" if args.large_mazes else "")
        args.out = RESULTS / f"low_level_selection{suffix}.json"
    try:
        smoothing = parse_smoothing(args.action_smoothing)
        families = selection_families(held_out_layouts=args.held_out_layouts, large_mazes=args.large_mazes)
    except ValueError as error:
        parser.error(str(error))
    refuse_below_one(parser, args, ("episodes", "mazes", "jobs"))
    chosen = range(args.seed, args.seed + args.episodes)
    for reserved in RESERVED_SUBGOAL_SEEDS:
        if chosen.start < reserved.stop and reserved.start < chosen.stop:
            parser.error(f"subgoal seeds {chosen} overlap {reserved}, which reported figures use: pick another --seed")
    missing = [str(run) for run in args.runs if not run.is_file() and not (run / "snapshots").is_dir()]
    if missing:
        parser.error(f"neither a policy file nor a run with a snapshots/ folder: {missing}")
    torch.set_num_threads(1)
    command = recorded_command("antmaze_lab.select_low_level", sys.argv[1:])
    settings = {"body": "ant", "seed": args.seed, "episodes": args.episodes, "mazes": args.mazes, "families": families}
    cached = json.loads(args.out.read_text()) if args.out.exists() else {}
    scores = cached.get("scores", {}) if cached.get("settings") == settings else {}
    steps = {p: snapshot_step(p) for run in args.runs if run.is_dir() for p in (run / "snapshots").glob("step_*.zip")}
    snapshots = [run for run in args.runs if run.is_file()] + sorted(
        (p for p, step in steps.items() if step is not None and step >= args.min_step),
        key=lambda p: (str(p.parent), steps[p]),
    )
    if not snapshots:
        parser.error(f"no snapshots at or after step {args.min_step} in {[str(r) for r in args.runs]}")
    try:
        names = row_names(snapshots, tuple(smoothing))
    except ValueError as error:
        parser.error(str(error))
    try:  # every file loaded (its body, its zip checked) before any row is scored
        identities = {path: low_level_identity("ant", load_low_level("ant", path)) for path in snapshots}
    except (ValueError, FileNotFoundError) as error:
        parser.error(str(error))
    for alpha in smoothing:
        # New rows, or rows whose file a rerun of training replaced.
        new = [p for p in snapshots if scores.get(row_name(p, alpha), {}).get("low_level_id") != identities[p]]
        if new:
            scores.update(
                score_rows(
                    new, alpha, families, seed=args.seed, episodes=args.episodes, mazes=args.mazes, jobs=args.jobs
                )
            )
            atomic_write_json(args.out, {"command": command, "settings": settings, "scores": scores})  # if stopped
    for name in names:
        print(f"{name}: {scores[name]}")
    best = max(names, key=lambda name: scores[name]["score"])
    atomic_write_json(args.out, {"command": command, "settings": settings, "scores": scores, "best": best})
    print("best:", best, scores[best])


if __name__ == "__main__":
    main()
