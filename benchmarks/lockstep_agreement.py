"""Serial against lockstep evaluation on the same held-out mazes: identical outcomes out of N, and the speedup.

For each body (shipped low level) and each high level (the scripted oracle, and a learner trained by DAgger
for ``--train-episodes`` episodes), ``evaluate_high_level``'s serial path (``num_envs=1``, the one committed
results were made with) and its lockstep path (``num_envs=--num-envs``) play the same ``--mazes`` seeds from
``HELD_OUT_SEED``. Reported per pair: mazes whose success outcome agrees, mazes whose whole episode agrees
(success, attempts and low-level steps), both success rates and both wall times. Batched matrix products may
round the low level's (and the learner's) last bits differently from a batch of one, and MuJoCo amplifies
such differences, so a disagreement is a float effect, not another maze.

    python benchmarks/lockstep_agreement.py             # 100 mazes, both bodies (about 15 min on 2 loaded cores)
    python benchmarks/lockstep_agreement.py --mazes 20 --bodies point
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import antmaze_hirl  # noqa: F401  (registers the ids)
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED, evaluation_episodes
from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.experiments.config import body_settings
from antmaze_hirl.experts.oracle import PathOracle

RESULTS = Path(__file__).resolve().parents[1] / "results" / "lockstep_agreement" / "lockstep_agreement.json"


def trained_learner(env: gym.Env, oracle: PathOracle, episodes: int, seed: int) -> HighLevelPolicy:
    """A learner trained by DAgger (the trainer's defaults) for ``episodes`` episodes on ``env``'s training seeds."""
    rng = np.random.default_rng(seed)
    policy = HighLevelPolicy.for_env(env, rng=rng)
    DAggerTrainer(env=env, expert=oracle, learner=policy, rng=rng).train(episodes)
    return policy


def compare(policy: Any, env: gym.Env, *, mazes: int, num_envs: int) -> dict[str, Any]:
    """Serial and lockstep evaluation of ``policy`` on the same ``mazes`` seeds."""
    start = time.perf_counter()
    serial = evaluation_episodes(policy, env, episodes=mazes, seed=HELD_OUT_SEED)
    serial_s = time.perf_counter() - start
    start = time.perf_counter()
    lockstep = evaluation_episodes(policy, env, episodes=mazes, seed=HELD_OUT_SEED, num_envs=num_envs)
    lockstep_s = time.perf_counter() - start

    def episode(info: dict[str, Any]) -> tuple[bool, int, int]:
        return bool(info["is_success"]), int(info["attempts"]), int(info["total_low_level_steps"])

    pairs = list(zip(map(episode, serial), map(episode, lockstep), strict=True))
    return {
        "mazes": mazes,
        "same_success": sum(a[0] == b[0] for a, b in pairs),
        "same_episode": sum(a == b for a, b in pairs),
        "serial_successes": sum(a[0] for a, _ in pairs),
        "lockstep_successes": sum(b[0] for _, b in pairs),
        "serial_s": round(serial_s, 1),
        "lockstep_s": round(lockstep_s, 1),
        "speedup": round(serial_s / lockstep_s, 2),
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mazes", type=int, default=100, help="held-out mazes per comparison")
    parser.add_argument("--num-envs", type=int, default=25, help="mazes at once in lockstep")
    parser.add_argument("--bodies", nargs="+", default=["ant", "point"], choices=["ant", "point"])
    parser.add_argument("--train-episodes", type=int, default=20, help="DAgger episodes of the trained learner")
    parser.add_argument("--seed", type=int, default=0, help="seed of the learner's training")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.mazes < 1 or args.num_envs < 1:
        parser.error(f"--mazes and --num-envs must be >= 1, got {args.mazes} and {args.num_envs}")
    rows = []
    for body in args.bodies:
        settings = body_settings(body)
        env = gym.make(maze_env_id(body), maze_size=settings["maze_size"])
        oracle = PathOracle.for_env(env, subgoal_reach_m=settings["subgoal_reach_m"])
        learner = trained_learner(env, oracle, args.train_episodes, args.seed)
        for name, policy in (("oracle", oracle), (f"learner ({args.train_episodes} DAgger episodes)", learner)):
            row = {"body": body, "maze_size": settings["maze_size"], "high_level": name}
            row.update(compare(policy, env, mazes=args.mazes, num_envs=args.num_envs))
            rows.append(row)
            print(json.dumps(row), flush=True)
        env.close()
    report = {
        "benchmark": "lockstep_agreement",
        "command": "python benchmarks/lockstep_agreement.py " + " ".join(argv),
        "num_envs": args.num_envs,
        "machine": f"{platform.machine()} ({os.cpu_count()} CPUs), shared with other work while measured",
        "rows": rows,
    }
    print(f"wrote {atomic_write_json(args.out, report)}")
    return report


if __name__ == "__main__":
    main()
