"""Leaderboard rows for plain DAgger on ``point5``: one learner trained on the training part, scored at label counts.

The learner trains with the experiment's own trainer (:func:`antmaze_hirl.experiments.runner.make_trainer`,
method ``dagger``, the point's settings) on mazes of the point family's ``train`` part only (the held-out
protocol's training env), with the scripted oracle as the expert. When its label count first reaches each of
``--labels`` (checked after every episode, so the count recorded is the first one at or past the target),
the learner is saved and scored by :func:`~antmaze_hirl.experiments.benchmark.score_policy` on the suite, as
``antmaze-hirl benchmark point5 --policy learner.zip`` would. The untrained learner (0 labels) is scored
first: a curve starts at its measured score, not at 0.

``--learner generic`` (default) is issue 32's learner that must learn: the heading head without the
wall-blocking planner (``head="heading", planning_iterations=0, block_walls=False``). ``--learner default``
is the point's default next-cell planner (a strong prior: it solves most mazes untrained).

Usage: python scripts/benchmark_dagger.py [--labels 100,300,1000] [--seed 0] [--learner generic|default]
Writes results/leaderboard/point5_dagger_<learner>_s<seed>_<labels>.json and the learners under --out.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.experiments.benchmark import score_policy
from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env, make_trainer
from antmaze_hirl.experts import PathOracle

RESULTS = Path(__file__).resolve().parents[1] / "results" / "leaderboard"
LEARNERS = {
    "generic": {"head": "heading", "planning_iterations": 0, "block_walls": False},
    "default": {},
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--labels", default="100,300,1000", help="comma-separated label counts to score at")
    parser.add_argument("--seed", type=int, default=0, help="the learner's and the trainer's seed")
    parser.add_argument("--learner", choices=sorted(LEARNERS), default="generic")
    parser.add_argument("--out", type=Path, default=Path("runs/benchmark_dagger"), help="folder for the learners")
    args = parser.parse_args()
    try:
        targets = sorted(int(entry) for entry in args.labels.split(","))
    except ValueError:
        parser.error(f"--labels must be comma-separated integers, got {args.labels!r}")
    if not targets or targets[0] < 1:
        parser.error(f"--labels must be >= 1, got {args.labels!r}")
    torch.set_num_threads(1)
    config = ExperimentConfig(body="point", held_out_layouts=True, **body_settings("point", held_out_layouts=True))
    env = make_env(config, split="train")
    expert = PathOracle.for_env(env, subgoal_reach_m=config.expert_max_distance)
    trainer = make_trainer("dagger", args.seed, config, env, expert, policy_settings=LEARNERS[args.learner])
    command = shlex.join(["python", "scripts/benchmark_dagger.py", *sys.argv[1:]])
    training_seconds = 0.0
    for target in [0, *targets]:
        started = time.perf_counter()
        while trainer.total_expert_cost < target:
            trainer.run_episode()
        training_seconds += time.perf_counter() - started
        labels = trainer.total_expert_cost
        path = trainer.learner.save(args.out / f"{args.learner}_s{args.seed}_{target}.zip")
        report = score_policy("point5", str(path))
        report["policy"] = f"DAgger (plain), {args.learner} learner, seed {args.seed}, {labels} labels"
        report["training"] = {
            "method": "dagger",
            "learner": args.learner,
            "learner_settings": LEARNERS[args.learner],
            "labels": labels,
            "episodes": trainer.episodes_done,
            "training_split": "train",
            "training_seconds": round(training_seconds, 1),
            "command": command,
        }
        out = RESULTS / f"point5_dagger_{args.learner}_s{args.seed}_{target}.json"
        atomic_write_json(out, report)
        low, high = report["wilson_95"]
        print(
            f"{labels} labels ({trainer.episodes_done} episodes, {training_seconds:.0f} s): "
            f"{report['successes']}/{report['episodes']} [{low:.1%}, {high:.1%}] -> {out}",
            flush=True,
        )
    env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
