"""Leaderboard rows for reward alone: SB3 PPO or SAC on the point's high level, scored on ``point5``.

The high-level env is the held-out protocol's training env (random 5x5 point mazes of the ``train`` part
only, the shipped point low level walking to each subgoal, sparse reward 1 at the goal), wrapped in
``TimeLimit`` at ``point5``'s ``max_episode_steps``. The model is SB3's ``MultiInputPolicy`` with
default hyperparameters apart from what is printed in the report (``training``): ``--steps`` high-level
steps (subgoals), then it is saved and scored exactly as ``antmaze-hirl benchmark point5 --policy
model.zip`` would (:func:`~antmaze_hirl.experiments.benchmark.score_policy`).

Usage: python scripts/benchmark_sb3_high.py [--algo ppo|sac] [--steps 3000] [--seed 0]
Writes results/leaderboard/point5_<algo>_<steps>.json and the model under --out.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import torch
from gymnasium.wrappers import TimeLimit
from stable_baselines3 import PPO, SAC

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments.benchmark import score_policy
from antmaze_hirl.sb3_ext.shipped import make_maze_env

RESULTS = Path(__file__).resolve().parents[1] / "results" / "leaderboard"
SETTINGS = {
    # Small rollouts and batches: a few thousand steps must still give several updates.
    "ppo": (PPO, {"n_steps": 256, "batch_size": 64, "n_epochs": 4}),
    "sac": (SAC, {"buffer_size": 20_000, "learning_starts": 200, "batch_size": 64}),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--algo", choices=sorted(SETTINGS), default="ppo")
    parser.add_argument("--steps", type=int, default=3000, help="high-level training steps (subgoals)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("runs/benchmark_sb3_high"), help="folder for the model")
    args = parser.parse_args()
    if args.steps < 1:
        parser.error(f"--steps must be >= 1, got {args.steps}")
    torch.set_num_threads(1)
    env = TimeLimit(
        make_maze_env("point", split="train"),  # the shipped low level
        SUITE_SPECS["point5"].max_episode_steps,
    )
    algorithm, settings = SETTINGS[args.algo]
    model = algorithm("MultiInputPolicy", env, seed=args.seed, device="cpu", **settings)
    started = time.perf_counter()
    model.learn(total_timesteps=args.steps)
    training_seconds = time.perf_counter() - started
    path = args.out / f"point5_{args.algo}_{args.steps}.zip"
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(path)
    env.close()
    report = score_policy("point5", str(path))
    report["policy"] = f"SB3 {args.algo.upper()} on the high level, {args.steps} high-level steps, seed {args.seed}"
    report["training"] = {
        "algorithm": args.algo,
        "settings": settings,
        "high_level_steps": args.steps,
        "training_split": "train",
        "training_seconds": round(training_seconds, 1),
        "command": shlex.join(["python", "scripts/benchmark_sb3_high.py", *sys.argv[1:]]),
    }
    out = RESULTS / f"point5_{args.algo}_{args.steps}.json"
    atomic_write_json(out, report)
    low, high = report["wilson_95"]
    print(f"{report['policy']}: {report['successes']}/{report['episodes']} [{low:.1%}, {high:.1%}] -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
