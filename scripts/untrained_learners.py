"""A learner that must learn, as protocol 2 asks: each candidate learner's success before its first label.

The curve of a method starts at its untrained learner's success. A learner that solves the held-out
mazes untrained (the point's planning next-cell head, which reads the next cell out of value iteration
that rules out wall moves) measures no learning: its label-efficiency figures measure recovery from
training damage. This runs each candidate of ``scripts/learner_ablation.py``'s :data:`LEARNERS`,
freshly initialised (``--seeds`` initialisations), on the ``"selection"`` part's mazes (what a choice
may read; from ``SELECTION_SEED``) and on protocol 2's evaluation set (the ``"eval"`` part, from
``HELD_OUT_SEED``), and prints and writes each success with its 95% Wilson interval. The protocol's
rule: the default learner scores <= 20% untrained on the selection mazes.

Usage: python scripts/untrained_learners.py [--body point|ant] [--variants a,b] [--seeds 0,1,2]
           [--mazes 50] [--out FILE]
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger import HighLevelPolicy, evaluate_high_level
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED
from antmaze_hirl.experiments.config import LEARNERS, SELECTION_SEED, ExperimentConfig, body_settings, learner_settings
from antmaze_hirl.experiments.runner import make_env
from antmaze_hirl.experiments.uncertainty import rate_with_interval

RESULTS = Path(__file__).resolve().parents[1] / "results" / "untrained_learners"
UNTRAINED_LIMIT = 0.2
"""The most untrained success a main-protocol learner may have on the selection mazes."""


def untrained_success(config: ExperimentConfig, variant: str, seed: int, split: str, first: int, mazes: int) -> dict:
    """One fresh learner of ``variant`` (initialised from ``seed``) on ``mazes`` mazes of ``split``."""
    env = make_env(config, split=split)
    reach = {} if config.subgoal_reach_m is None else {"subgoal_reach_m": config.subgoal_reach_m}
    policy = HighLevelPolicy.for_env(
        env, rng=np.random.default_rng(seed), **{**reach, **learner_settings(variant, config.maze_size)}
    )
    start = time.perf_counter()
    result = evaluate_high_level(policy, env, episodes=mazes, seed=first)
    env.close()
    return {
        "success_rate": result["success_rate"],
        "wilson_95": rate_with_interval(result["success_rate"], mazes)["wilson_95"],
        "mazes": mazes,
        "seconds": round(time.perf_counter() - start, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--body", choices=["point", "ant"], default="point")
    parser.add_argument("--variants", default=",".join(LEARNERS))
    parser.add_argument("--seeds", default="0,1,2", help="learner initialisations")
    parser.add_argument("--mazes", type=int, default=50, help="mazes per part")
    parser.add_argument("--out", type=Path, default=None, help="default: results/untrained_learners_BODY.json")
    args = parser.parse_args()
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = sorted(set(variants) - set(LEARNERS))
    if unknown:
        parser.error(f"unknown variants {unknown}; choose from {sorted(LEARNERS)}")
    seeds = [int(s) for s in args.seeds.split(",")]
    torch.set_num_threads(1)
    config = ExperimentConfig(
        body=args.body, held_out_layouts=True, protocol=2, **body_settings(args.body, held_out_layouts=True)
    )
    rows = []
    for variant in variants:
        for seed in seeds:
            for split, first in (("selection", SELECTION_SEED), ("eval", HELD_OUT_SEED)):
                row = {"variant": variant, "seed": seed, "split": split}
                row.update(untrained_success(config, variant, seed, split, first, args.mazes))
                rows.append(row)
                print(row, flush=True)
    verdict = {}
    for variant in variants:
        selection = [r["success_rate"] for r in rows if r["variant"] == variant and r["split"] == "selection"]
        verdict[variant] = {
            "selection_untrained_max": max(selection),
            "eval_untrained": [r["success_rate"] for r in rows if r["variant"] == variant and r["split"] == "eval"],
            "meets_limit": max(selection) <= UNTRAINED_LIMIT,
        }
    result = {
        "command": shlex.join(["python", "scripts/untrained_learners.py", *sys.argv[1:]]),
        "body": args.body,
        "maze_size": config.maze_size,
        "untrained_limit": UNTRAINED_LIMIT,
        "rows": rows,
        "by_variant": verdict,
    }
    out = args.out if args.out is not None else RESULTS / f"untrained_learners_{args.body}.json"
    atomic_write_json(out, result)
    print("by variant:", verdict)
    print("wrote", out)


if __name__ == "__main__":
    main()
