"""Wall time of one protocol-2 trial with and without the outcome-neutral speed-ups, side by side.

The speed-ups, which make protocol 2's 10-seed rerun affordable:

* the simulator pool (:mod:`antmaze_hirl.envs.simulator_pool`): an env coming back to a maze reuses its
  compiled MuJoCo simulator, so the 100 evaluation mazes compile once per process instead of once per
  evaluation;
* Adam's ``foreach`` update in :class:`~antmaze_hirl.dagger.high_level_policy.HighLevelPolicy`.

``baseline`` turns both off (pool capacity 0, ``foreach=False``); ``fast`` is the code as it is. Both arms
run the same reduced trial (fewer episodes and evaluation mazes, the same per-episode work) in their own
process, at the same time, so that a shared machine's load falls on both alike, and the figure is their
ratio. The script also checks that both arms give the same rows and per-maze outcomes, bit for bit.

Usage: python benchmarks/trial_speed.py [--body point] [--method dagger] [--episodes 10] [--eval-every 5]
           [--mazes 40] [--repeats 1] [--out results/trial_speed/trial_speed_point.json]
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parents[1] / "results" / "trial_speed"
ARMS = ("baseline", "fast")


def run_arm(arm: str, body: str, method: str, episodes: int, eval_every: int, mazes: int) -> dict:
    """One trial in this process; returns its wall time and a digest of its outcomes."""
    import hashlib

    import torch

    from antmaze_hirl.envs.simulator_pool import shared_pool
    from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
    from antmaze_hirl.experiments.outcomes import EVALUATION_COLUMNS
    from antmaze_hirl.experiments.results_folder import rows_to_csv
    from antmaze_hirl.experiments.runner import run_trial_with_evaluations

    torch.set_num_threads(1)
    if arm == "baseline":
        shared_pool().capacity = 0
        adam = torch.optim.Adam

        def single_tensor_adam(*args, **kwargs):
            return adam(*args, **{**kwargs, "foreach": False})

        torch.optim.Adam = single_tensor_adam  # type: ignore[misc]
    config = ExperimentConfig(
        body=body,
        episodes=episodes,
        eval_every=eval_every,
        final_eval_episodes=mazes,
        held_out_layouts=True,
        protocol=2,
        evaluation_envs=25,
        **body_settings(body, held_out_layouts=True),
    )
    start = time.perf_counter()
    rows, evaluations = run_trial_with_evaluations(method, 0, config)
    wall_s = time.perf_counter() - start
    digest = hashlib.sha256((rows_to_csv(rows) + rows_to_csv(evaluations, EVALUATION_COLUMNS)).encode()).hexdigest()
    successes = [row["eval_success"] for row in rows if row["eval_success"] == row["eval_success"]]
    pool = shared_pool()
    return {
        "arm": arm,
        "wall_s": round(wall_s, 2),
        "outcomes_sha256": digest,
        "labels": int(rows[-1]["cumulative_expert_cost"]),
        "eval_success": successes,
        "pool_hits": pool.hits,
        "pool_misses": pool.misses,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", default="point", choices=("point", "ant"))
    parser.add_argument("--method", default="dagger")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--eval-every", type=int, default=5)
    parser.add_argument("--mazes", type=int, default=40, help="evaluation mazes (protocol 2's set has 100)")
    parser.add_argument("--repeats", type=int, default=1, help="pairs of arms, run one pair at a time")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--arm", choices=ARMS, help=argparse.SUPPRESS)  # the child process's job
    args = parser.parse_args()
    settings = (args.body, args.method, args.episodes, args.eval_every, args.mazes)
    if args.arm is not None:
        print(json.dumps(run_arm(args.arm, *settings)))
        return
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    pairs = []
    for _ in range(args.repeats):
        children = {
            arm: subprocess.Popen(
                [sys.executable, __file__, *sys.argv[1:], "--arm", arm], stdout=subprocess.PIPE, env=env
            )
            for arm in ARMS
        }
        pair = {
            arm: json.loads(child.communicate()[0].decode().strip().splitlines()[-1]) for arm, child in children.items()
        }
        pair["ratio_baseline_over_fast"] = round(pair["baseline"]["wall_s"] / pair["fast"]["wall_s"], 3)
        pair["same_outcomes"] = pair["baseline"]["outcomes_sha256"] == pair["fast"]["outcomes_sha256"]
        print(json.dumps(pair))
        pairs.append(pair)
    result = {
        "command": shlex.join(["python", "benchmarks/trial_speed.py", *sys.argv[1:]]),
        "machine": f"{os.cpu_count()} cores, shared with other work (both arms at once, one torch thread each)",
        "settings": dict(zip(("body", "method", "episodes", "eval_every", "mazes"), settings, strict=True)),
        "pairs": pairs,
        "ratios": [pair["ratio_baseline_over_fast"] for pair in pairs],
        "same_outcomes": all(pair["same_outcomes"] for pair in pairs),
    }
    out = args.out if args.out is not None else RESULTS / f"trial_speed_{args.body}.json"
    from antmaze_hirl.atomic_io import atomic_write_json

    atomic_write_json(out, result)
    print("ratios (baseline / fast):", result["ratios"], "same outcomes:", result["same_outcomes"])


if __name__ == "__main__":
    main()
