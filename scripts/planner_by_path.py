"""Success by shortest path length (cells) of saved high-level learners, on the same mazes, side by side.

Each learner (a saved DAgger learner zip, or ``untrained:VARIANT`` for a fresh learner of a named variant,
seed 0) plays the same ``--mazes`` mazes of the body's held-out-layouts family part ``--split`` (default the
``selection`` part, which a choice between learners may read), learner-only (beta = 0, no expert), with the
shipped low level; each maze's outcome is recorded with its shortest cell path (grid steps, 4-connected) from
start to goal. ``antmaze_lab.planning_tables by-path FILE`` prints the table.

Usage: python scripts/planner_by_path.py --body ant --learner cnn=PATH --learner plan=PATH
           [--learner untrained_plan=untrained:next_cell_plan] [--split selection] [--mazes 50]
           [--evaluation-envs 25] --out FILE
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.evaluation import evaluation_outcomes
from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy
from antmaze_hirl.envs.layouts import shortest_path
from antmaze_hirl.experiments.config import SELECTION_SEED, ExperimentConfig, body_settings, learner_settings
from antmaze_hirl.experiments.runner import make_env
from antmaze_hirl.sb3_ext.loading import policy_fingerprint
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy

FIRST_SEEDS = {"selection": SELECTION_SEED}


def load(spec: str, env: Any, config: ExperimentConfig) -> HighLevelPolicy:
    if spec.startswith("untrained:"):
        variant = spec.removeprefix("untrained:")
        reach = {"subgoal_reach_m": config.subgoal_reach_m} if config.subgoal_reach_m else {}
        settings = learner_settings(variant, config.maze_size)
        return HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **reach, **settings)
    return HighLevelPolicy.load(spec)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", choices=("ant", "point"), required=True)
    parser.add_argument("--learner", action="append", required=True, help="NAME=PATH or NAME=untrained:VARIANT")
    parser.add_argument("--split", default="selection", choices=("selection", "eval"))
    parser.add_argument("--mazes", type=int, default=50)
    parser.add_argument("--evaluation-envs", type=int, default=25)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    config = ExperimentConfig(
        body=args.body, held_out_layouts=True, protocol=2, **body_settings(args.body, held_out_layouts=True)
    )
    first_seed = FIRST_SEEDS.get(args.split, 1_000_000)
    rows: dict[str, Any] = {}
    for entry in args.learner:
        name, _, spec = entry.partition("=")
        if not name or not spec:
            parser.error(f"--learner takes NAME=PATH or NAME=untrained:VARIANT, got {entry!r}")
        start = time.perf_counter()
        env = make_env(config, split=args.split)
        policy = load(spec, env, config)
        played = evaluation_outcomes(policy, env, episodes=args.mazes, seed=first_seed, num_envs=args.evaluation_envs)
        env.close()
        outcomes = [
            {
                "path_cells": len(shortest_path(layout.walls, layout.start_cell, layout.goal_cell)) - 1,
                "success": bool(info["is_success"]),
            }
            for layout, info in played
        ]
        rows[name] = {"learner": spec, "settings": policy.config(), "outcomes": outcomes}
        rows[name]["seconds"] = round(time.perf_counter() - start, 1)
        print(f"{name}: {sum(o['success'] for o in outcomes)}/{len(outcomes)} ({rows[name]['seconds']} s)", flush=True)
    result = {
        "command": shlex.join(["python", "scripts/planner_by_path.py", *(argv if argv is not None else sys.argv[1:])]),
        "body": args.body,
        "split": args.split,
        "first_seed": first_seed,
        "mazes": args.mazes,
        "evaluation_envs": args.evaluation_envs,
        "low_level": policy_fingerprint(load_shipped_policy(args.body)),
        "learners": rows,
    }
    atomic_write_json(args.out, result)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
