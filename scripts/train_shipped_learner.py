"""Trains the planning learner shipped for a body: DAgger with the oracle on the family's ``train`` part.

Plain DAgger (protocol-2 settings: the trainer of ``antmaze-hirl experiment``, 200 gradient steps an episode)
trains the ``next_cell_plan`` learner on the body's held-out-layouts family (the point's 5x5, the ant's 4x4,
``train`` part only) until its labels reach ``--labels``, then saves it to ``antmaze_hirl/learners/<body>_plan.zip``
with a record beside it (``<body>_plan.json``: the command, seed, episodes, labels, seconds, the low level's
fingerprint and the learner file's SHA-256). No evaluation maze is seen: score it afterwards with
``antmaze-hirl benchmark SUITE --policy planner``.

Usage: python scripts/train_shipped_learner.py --body ant [--labels 300] [--seed 0] [--out-dir DIR]
           [--learner next_cell_gate|next_cell_switch|next_cell_switch_flat|next_cell_switch_cell|
           next_cell_switch_seen]
"""

from __future__ import annotations

import argparse
import hashlib
import shlex
import sys
import time
from pathlib import Path

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.shipped import shipped_learner_path
from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env, make_trainer
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.sb3_ext.loading import policy_fingerprint
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy

LEARNER = "next_cell_plan"
"""The shipped learner; ``--learner`` trains another planning learner the same way (not shipped: give --out-dir)."""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", choices=("ant", "point"), required=True)
    parser.add_argument("--labels", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out-dir", type=Path, default=None, help="default: the package's learners/ folder")
    parser.add_argument(
        "--learner",
        choices=(
            "next_cell_plan",
            "next_cell_gate",
            "next_cell_switch",
            "next_cell_switch_flat",
            "next_cell_switch_cell",
            "next_cell_switch_seen",
        ),
        default=LEARNER,
        help="(default: %(default)s)",
    )
    args = parser.parse_args(argv)
    if args.labels < 1:
        parser.error(f"--labels must be >= 1, got {args.labels}")
    if args.learner != LEARNER and args.out_dir is None:
        parser.error(f"--learner {args.learner} is not the shipped learner: give --out-dir")
    torch.set_num_threads(1)
    config = ExperimentConfig(
        body=args.body,
        held_out_layouts=True,
        protocol=2,
        learner=args.learner,
        **body_settings(args.body, held_out_layouts=True),
    )
    start = time.perf_counter()
    env = make_env(config, split="train")
    trainer = make_trainer(
        "dagger", args.seed, config, env, PathOracle.for_env(env, subgoal_reach_m=config.subgoal_reach_m)
    )
    episodes = 0
    while trainer.total_expert_cost < args.labels:
        trainer.run_episode()
        episodes += 1
        print(f"episode {episodes}: {trainer.total_expert_cost} labels", flush=True)
    env.close()
    path = shipped_learner_path(args.body)
    if args.learner != LEARNER:  # never the shipped learner's name, so no --out-dir can overwrite it
        path = path.with_name(f"{args.body}_{args.learner.removeprefix('next_cell_')}.zip")
    if args.out_dir is not None:
        path = args.out_dir / path.name
    trainer.learner.save(path)
    record = {
        "command": shlex.join(
            ["python", "scripts/train_shipped_learner.py", *(argv if argv is not None else sys.argv[1:])]
        ),
        "learner": args.learner,
        "body": args.body,
        "seed": args.seed,
        "family": f"{config.maze_size}x{config.maze_size}, train part",
        "episodes": episodes,
        "labels": trainer.total_expert_cost,
        "gradient_steps": trainer.learner.gradient_steps,
        "seconds": round(time.perf_counter() - start, 1),
        "low_level": policy_fingerprint(load_shipped_policy(args.body)),
        "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
    }
    outcomes = getattr(trainer.learner, "outcomes", ())
    if len(outcomes):  # the moves its episodes tried, made or blocked (experience_blocking_weight only)
        blocked = outcomes.arrays()[2]
        record["move_outcomes"] = {"recorded": len(blocked), "blocked": int(blocked.sum())}
    atomic_write_json(path.with_suffix(".json"), record)
    print(f"wrote {path} ({record['labels']} labels, {episodes} episodes, {record['seconds']} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
