"""Acting speed of an action ensemble: batched heads against sequential ones, same heads, same run.

An action ensemble (:class:`~antmaze_hirl.sb3_ext.ensemble.EnsemblePolicy`; by default the shipped ant, stage 6,
seven heads) is rebuilt in both layouts with ``build_ensemble([policy], batched_heads=...)``, the same weights:
heads computed one after another (:class:`~antmaze_hirl.sb3_ext.ensemble.MeanOfHeads`, the layout of stage 5)
and all heads in one batched product per layer (:class:`~antmaze_hirl.sb3_ext.ensemble.BatchedMeanOfHeads`).
It times them alternating in rounds, so that a slow spell of a shared machine hits both:

* ``predict``: one deterministic ``model.predict`` on one observation, as the high-level env calls it once
  per low-level step;
* ``env_step``: one step of the ant ``ReachEnv``, for scale (a low-level step costs one of each).

Observations come from seeded random-action rollouts of the env. It prints the medians and the ratios
(sequential over batched ``predict``, and over a whole low-level step ``predict + env_step``) and checks that
both layouts give the same action up to float rounding. Goal: batched ``predict`` at least 1.5x faster.

Usage: python benchmarks/ensemble_speed.py [--policy ENSEMBLE.zip] [--rounds 7] [--calls 300] [--seed 0] [--out FILE]
Writes results/ensemble_speed/ensemble_speed.json by default.
"""

from __future__ import annotations

import argparse
import json
import platform
import shlex
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch as th

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.ensemble import build_ensemble
from antmaze_hirl.sb3_ext.loading import policy_fingerprint
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

RESULTS = Path(__file__).resolve().parents[1] / "results" / "ensemble_speed" / "ensemble_speed.json"
GOAL = 1.5


def microseconds(call: Callable[[], object], calls: int) -> float:
    """Mean wall time of ``call`` over ``calls`` calls, in microseconds."""
    start = time.perf_counter()
    for _ in range(calls):
        call()
    return (time.perf_counter() - start) / calls * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--policy", type=Path, default=None, help="an ensemble zip (default: the shipped ant)")
    parser.add_argument("--rounds", type=int, default=7, help="alternating timing rounds")
    parser.add_argument("--calls", type=int, default=300, help="calls per timing")
    parser.add_argument("--seed", type=int, default=0, help="seed of the env and its random actions")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    th.set_num_threads(1)  # as the experiment workers run
    path = args.policy if args.policy is not None else shipped_policy_path("ant")
    models = {
        "sequential": build_ensemble([path], "ant", batched_heads=False),
        "batched": build_ensemble([path], "ant", batched_heads=True),
    }
    env = ReachEnv("ant")
    obs, _ = env.reset(seed=args.seed)
    rng = np.random.default_rng(args.seed)
    observations = []
    for _ in range(args.calls):
        observations.append(obs)
        obs, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, size=env.action_space.shape))
        if terminated or truncated:
            obs, _ = env.reset()
    gap = max(
        float(
            np.abs(
                models["sequential"].predict(o, deterministic=True)[0]
                - models["batched"].predict(o, deterministic=True)[0]
            ).max()
        )
        for o in observations
    )
    cycle = iter(observations * (args.rounds * 2 + 2))
    times: dict[str, list[float]] = {"sequential": [], "batched": [], "env_step": []}
    action = np.zeros(env.action_space.shape)
    for _ in range(args.rounds):
        for name, model in models.items():
            times[name].append(
                microseconds(lambda model=model: model.predict(next(cycle), deterministic=True), args.calls)
            )
        times["env_step"].append(microseconds(lambda: env.step(action), args.calls))
    env.close()
    medians = {name: statistics.median(values) for name, values in times.items()}
    step = {name: medians[name] + medians["env_step"] for name in models}
    result = {
        "policy": str(path.name) if args.policy is None else str(path),
        "fingerprints": {name: policy_fingerprint(model) for name, model in models.items()},
        "heads": models["batched"].policy.n_members,
        "median_microseconds": {name: round(value, 1) for name, value in medians.items()},
        "microseconds": {name: [round(value, 1) for value in values] for name, values in times.items()},
        "predict_speedup": round(medians["sequential"] / medians["batched"], 3),
        "low_level_step_speedup": round(step["sequential"] / step["batched"], 3),
        "max_action_gap": gap,
        "goal_predict_speedup_at_least": GOAL,
        "settings": {key: str(value) if isinstance(value, Path) else value for key, value in vars(args).items()},
        "machine": {"platform": platform.platform(), "processor": platform.processor(), "torch": th.__version__},
        "command": shlex.join(["python", "benchmarks/ensemble_speed.py", *sys.argv[1:]]),
    }
    print(json.dumps(result, indent=1))
    atomic_write_json(args.out, result)


if __name__ == "__main__":
    main()
