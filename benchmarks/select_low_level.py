"""Picks the policy to ship from the snapshots of one or more ``train-low`` runs, without peeking at the test sets.

TD3's success rate swings by +-10 points between evaluations of one run, so the last step is rarely the best.
Every ``<run>/snapshots/step_<n>.zip`` (written at each evaluation) is scored on *selection* sets that the
reported figures never use:

* ``eval_low``: free-space reaching as ``antmaze-hirl eval-low`` measures it, but on subgoal seeds
  ``--seed`` .. ``--seed + episodes - 1`` (default from 100,000), disjoint from the reported ones
  (seeds 0-199: the README and ``benchmarks/low_level.py``) and from train-low's held-out curve (10,000-);
* ``ceiling``: the scripted oracle driving the snapshot through ``--mazes`` random mazes of the ant protocol
  (3x3, 2 m subgoals) drawn from maze seed 2,000,000 (the experiment's held-out mazes start at 1,000,000).
  With ``--held-out-layouts``, the held-out-layouts protocol's ant mazes instead (4x4, 2 m subgoals), drawn
  from maze seed 2,000,000 in the ``selection`` part of the layout partition: no wall grid of the reported
  ``eval`` part (``in_maze.py``'s ``ant4``, the paper experiment's final evaluation) nor of the ``train`` part
  (``ReachEnv(maze_split="train")``), and seeds apart from the paper experiment's periodic evaluation
  (3,000,000-).

The pick is the snapshot with the best mean of the two (what the high level needs and what the issue's
target measures). Scores are cached in the JSON, so a rerun while training goes on scores only new snapshots.

A policy trained under action smoothing (``ReachEnv(action_smoothing=...)``, e.g.
``benchmarks/configs/ant_maze_smoothed.yml``) is scored with ``--action-smoothing`` at its weight: both
figures then run with the same smoothing (the saved zip does not record it).

Usage: python benchmarks/select_low_level.py runs/ant_chain [runs/ant_finetune ...] [policy.zip ...] [--min-step N]
           [--held-out-layouts] [--action-smoothing A]
Writes benchmarks/results/low_level_selection.json (``low_level_selection_held_out.json`` with
``--held-out-layouts``), with the command that made it.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

import torch
from paper_experiment import RESULTS, oracle_success

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experiments import ExperimentConfig
from antmaze_hirl.experiments.config import body_settings
from antmaze_hirl.experiments.runner import low_level_identity
from antmaze_hirl.sb3_ext.evaluation import evaluate_reach, snapshot_step
from antmaze_hirl.sb3_ext.loading import load_low_level

SELECTION_MAZE_SEED = 2_000_000
# Subgoal seeds the selection may not use: eval-low's reported set and train-low's held-out curve.
RESERVED_SUBGOAL_SEEDS = (range(0, 1_000), range(10_000, 20_000))


def score(
    path: Path,
    body: str,
    *,
    seed: int,
    episodes: int,
    mazes: int,
    held_out_layouts: bool = False,
    action_smoothing: float = 0.0,
) -> dict:
    """A snapshot's selection figures: eval-low, the oracle's success through it, and their mean."""
    reach = ReachEnv(body, action_smoothing=action_smoothing)
    eval_low = evaluate_reach(load_low_level(body, path), reach, episodes=episodes, seed=seed)
    config = ExperimentConfig(
        body=body, held_out_layouts=held_out_layouts, **body_settings(body, held_out_layouts=held_out_layouts)
    )
    ceiling = oracle_success(
        config,
        path,
        seed=SELECTION_MAZE_SEED,
        episodes=mazes,
        split="selection" if held_out_layouts else None,  # the split counts only with held-out layouts
        action_smoothing=action_smoothing,
    )
    return {
        "low_level_id": ceiling["low_level_id"],
        "eval_low": eval_low["success_rate"],
        "eval_low_mean_steps": eval_low["mean_steps"],
        "ceiling": ceiling["success_rate"],
        "score": (eval_low["success_rate"] + ceiling["success_rate"]) / 2,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="train-low run folders or policy .zip files")
    parser.add_argument("--body", choices=["point", "ant"], default="ant")
    parser.add_argument("--seed", type=int, default=100_000, help="first subgoal seed of the selection eval-low")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--mazes", type=int, default=50)
    parser.add_argument("--min-step", type=int, default=0, help="skip snapshots before this step")
    parser.add_argument(
        "--held-out-layouts",
        action="store_true",
        help="ceiling on the held-out-layouts protocol's mazes, from the selection part of the layout partition",
    )
    parser.add_argument(
        "--action-smoothing",
        type=float,
        default=0.0,
        help="smooth the policies' actions with this weight in [0, 1) in both figures (for policies trained so)",
    )
    parser.add_argument("--out", type=Path, default=None, help="default: see Usage")
    args = parser.parse_args()
    if args.out is None:
        args.out = RESULTS / (
            "low_level_selection_held_out.json" if args.held_out_layouts else "low_level_selection.json"
        )
    if not 0.0 <= args.action_smoothing < 1.0:
        parser.error(f"--action-smoothing must lie in [0, 1), got {args.action_smoothing}")
    chosen = range(args.seed, args.seed + args.episodes)
    for reserved in RESERVED_SUBGOAL_SEEDS:
        if chosen.start < reserved.stop and reserved.start < chosen.stop:
            parser.error(f"subgoal seeds {chosen} overlap {reserved}, which reported figures use: pick another --seed")
    missing = [str(run) for run in args.runs if run.suffix != ".zip" and not (run / "snapshots").is_dir()]
    if missing:
        parser.error(f"no snapshots/ folder in {missing}")
    torch.set_num_threads(1)
    command = shlex.join(["python", "benchmarks/select_low_level.py", *sys.argv[1:]])
    settings = {"body": args.body, "seed": args.seed, "episodes": args.episodes, "mazes": args.mazes}
    # Only when set, so that the cache of a run without them stays valid.
    if args.held_out_layouts:
        settings["held_out_layouts"] = True
    if args.action_smoothing:
        settings["action_smoothing"] = args.action_smoothing
    cached = json.loads(args.out.read_text()) if args.out.exists() else {}
    scores = cached.get("scores", {}) if cached.get("settings") == settings else {}
    steps = {p: snapshot_step(p) for run in args.runs for p in (run / "snapshots").glob("step_*.zip")}
    snapshots = [run for run in args.runs if run.suffix == ".zip"] + sorted(
        (p for p, step in steps.items() if step is not None and step >= args.min_step),
        key=lambda p: (str(p.parent), steps[p]),
    )
    if not snapshots:
        parser.error(f"no snapshots at or after step {args.min_step} in {[str(r) for r in args.runs]}")
    for path in snapshots:
        known = scores.get(str(path), {}).get("low_level_id")
        if known != low_level_identity(args.body, load_low_level(args.body, path)):  # new, or a rerun's file
            scores[str(path)] = score(
                path,
                args.body,
                seed=args.seed,
                episodes=args.episodes,
                mazes=args.mazes,
                held_out_layouts=args.held_out_layouts,
                action_smoothing=args.action_smoothing,
            )
            atomic_write_json(args.out, {"command": command, "settings": settings, "scores": scores})  # if stopped
        print(f"{path}: {scores[str(path)]}")
    best = max((str(p) for p in snapshots), key=lambda p: scores[p]["score"])
    atomic_write_json(args.out, {"command": command, "settings": settings, "scores": scores, "best": best})
    print("best:", best, scores[best])


if __name__ == "__main__":
    main()
