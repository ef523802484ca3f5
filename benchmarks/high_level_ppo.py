"""SB3 PPO on the high level of PointMaze-v0: high-level steps/s, one env against the lockstep vector env, in one run.

* ``single``: ``gym.make("antmaze_hirl/PointMaze-v0")`` in SB3's ``DummyVecEnv`` (one maze);
* ``lockstep``: ``make_sb3_vec_env("antmaze_hirl/PointMaze-v0", N)`` (``N`` mazes, one batched low-level
  forward per low-level step).

Both learn ``--steps`` high-level steps (rollouts of ``--n-steps`` per env, one epoch), seeded, with the
shipped point low level and ``clip_subgoals=True`` (PPO's Gaussian actions leave the maze).

    python benchmarks/high_level_ppo.py                 # N = 8, 256 high-level steps each
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv

import antmaze_hirl  # noqa: F401  (registers the ids)
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.sb3_ext.vec_env import make_sb3_vec_env

RESULTS = Path(__file__).resolve().parents[1] / "results" / "high_level_ppo" / "high_level_ppo.json"
ENV_ID = "antmaze_hirl/PointMaze-v0"


def steps_per_s(venv: Any, steps: int, n_steps: int, seed: int) -> float:
    """High-level steps/s of PPO learning ``steps`` steps on ``venv`` (policy updates included)."""
    model = PPO("MultiInputPolicy", venv, n_steps=n_steps, batch_size=64, n_epochs=1, seed=seed)
    start = time.perf_counter()
    model.learn(steps)
    rate = model.num_timesteps / (time.perf_counter() - start)
    venv.close()
    return rate


def main(argv: list[str] | None = None) -> dict[str, Any]:
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--num-envs", type=int, default=8)
    parser.add_argument("--steps", type=int, default=256, help="high-level steps each side learns")
    parser.add_argument("--n-steps", type=int, default=16, help="PPO rollout length per env")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.num_envs < 1 or args.steps < 1 or args.n_steps < 2:
        parser.error(f"--num-envs and --steps must be >= 1 and --n-steps >= 2, got {args}")
    settings = {"clip_subgoals": True}
    single = steps_per_s(DummyVecEnv([lambda: gym.make(ENV_ID, **settings)]), args.steps, args.n_steps, args.seed)
    print(f"single: {single:.1f} high-level steps/s", flush=True)
    lockstep = steps_per_s(make_sb3_vec_env(ENV_ID, args.num_envs, **settings), args.steps, args.n_steps, args.seed)
    print(f"lockstep N={args.num_envs}: {lockstep:.1f} high-level steps/s ({lockstep / single:.2f}x)", flush=True)
    report = {
        "benchmark": "high_level_ppo",
        "command": "python benchmarks/high_level_ppo.py " + " ".join(argv),
        "env_id": ENV_ID,
        "num_envs": args.num_envs,
        "steps": args.steps,
        "single_steps_per_s": round(single, 2),
        "lockstep_steps_per_s": round(lockstep, 2),
        "ratio": round(lockstep / single, 2),
        "machine": f"{platform.machine()} ({os.cpu_count()} CPUs), shared with other work while measured",
    }
    print(f"wrote {atomic_write_json(args.out, report)}")
    return report


if __name__ == "__main__":
    main()
