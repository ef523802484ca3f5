"""Env throughput, side by side in one seeded run.

1. Low-level steps/s of ``antmaze_hirl/AntReach-v0`` (U-maze layout) vs raw gymnasium-robotics
   ``AntMaze_UMaze-v5``, both with random actions, in alternating blocks (goal: ratio >= 0.95).
2. High-level episodes/s of ``antmaze_hirl/PointMaze-v0`` driven by the scripted oracle with the
   scripted low-level controller, and its success rate on 200 random mazes (goal: >= 99%).

Usage: python benchmarks/env_throughput.py [--steps 4000] [--blocks 5] [--mazes 200]
Writes results/env_throughput/env_throughput.json.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import gymnasium as gym
import gymnasium_robotics
import numpy as np

import antmaze_hirl
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.rollout import play_episode

RESULTS = Path(__file__).resolve().parents[1] / "results" / "env_throughput" / "env_throughput.json"


def steps_per_second(env: gym.Env, steps: int, seed: int) -> float:
    env.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1, 1, size=(steps, *env.action_space.shape))
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def low_level_ratio(steps: int, blocks: int) -> dict[str, float]:
    gym.register_envs(gymnasium_robotics)
    ours = gym.make("antmaze_hirl/AntReach-v0", maze_map="u").unwrapped
    raw = gym.make("AntMaze_UMaze-v5").unwrapped
    ours_sps, raw_sps = [], []
    for block in range(blocks):  # alternate so drifts in machine load hit both sides alike
        ours_sps.append(steps_per_second(ours, steps, seed=block))
        raw_sps.append(steps_per_second(raw, steps, seed=block))
    ours_median, raw_median = statistics.median(ours_sps), statistics.median(raw_sps)
    return {
        "ours_steps_per_s": round(ours_median, 1),
        "raw_AntMaze_UMaze_v5_steps_per_s": round(raw_median, 1),
        "ratio": round(ours_median / raw_median, 3),
    }


def high_level_oracle(mazes: int) -> dict[str, float]:
    env = gym.make("antmaze_hirl/PointMaze-v0", low_level=PointGoToController())
    oracle = PathOracle.for_env(env)
    successes, subgoals, steps = 0, [], []
    start = time.perf_counter()
    for seed in range(mazes):
        info = play_episode(env, oracle.label, seed=seed).info
        successes += int(info["is_success"])
        subgoals.append(info["attempts"])
        steps.append(info["total_low_level_steps"])
    elapsed = time.perf_counter() - start
    return {
        "mazes": mazes,
        "success_rate": successes / mazes,
        "episodes_per_s": round(mazes / elapsed, 2),
        "mean_subgoals": round(float(np.mean(subgoals)), 2),
        "mean_low_level_steps": round(float(np.mean(steps)), 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=4000, help="env steps per block and side")
    parser.add_argument("--blocks", type=int, default=5)
    parser.add_argument("--mazes", type=int, default=200)
    args = parser.parse_args()
    result = {
        "version": antmaze_hirl.__version__,
        "low_level": low_level_ratio(args.steps, args.blocks),
        "high_level_point_oracle": high_level_oracle(args.mazes),
        "goals": {"low_level_ratio": ">= 0.95", "oracle_success_rate": ">= 0.99"},
    }
    for section in ("low_level", "high_level_point_oracle"):
        for key, value in result[section].items():
            print(f"{section}.{key}: {value}")
    atomic_write_json(RESULTS, result)
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
