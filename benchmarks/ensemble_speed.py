"""Acting speed of an action ensemble: batched heads against sequential ones, and against one network, same run.

An action ensemble (:class:`~antmaze_hirl.sb3_ext.ensemble.EnsemblePolicy`; by default the shipped ant, stage 6,
seven heads) is rebuilt in both layouts with ``build_ensemble([policy], batched_heads=...)``, the same weights:
heads computed one after another (:class:`~antmaze_hirl.sb3_ext.ensemble.MeanOfHeads`, the layout of stage 5)
and all heads in one batched product per layer (:class:`~antmaze_hirl.sb3_ext.ensemble.BatchedMeanOfHeads`).
Beside them, a single actor network of a member's size (the ensemble's head 0 as a plain TD3 actor,
:func:`~antmaze_hirl.sb3_ext.distill.make_student`: the size of a distilled student), and the numpy forward pass
(:class:`~antmaze_hirl.sb3_ext.numpy_actor.NumpyActor`) of the single actor and of the batched ensemble.
It times them alternating in rounds, so that a slow spell of a shared machine hits every row:

* ``sequential``, ``batched``, ``single``: one deterministic SB3 ``model.predict`` on one observation;
* ``batched_controller``, ``single_controller``: the same models through
  :class:`~antmaze_hirl.envs.controllers.PredictController`, the path the high-level env calls once per
  low-level step (SB3's predict steps without its per-call overhead);
* ``batched_numpy``, ``single_numpy``: the numpy forward pass on one observation;
* ``env_step``: one step of the ant ``ReachEnv``, for scale (a low-level step costs one of each).

Observations come from seeded random-action rollouts of the env. It prints the medians and the ratios
(sequential over batched ``predict``; the batched ensemble's ``predict`` over every other row, and over a whole
low-level step ``predict + env_step``) and checks that the layouts give the same action up to float rounding
(the numpy rows against their torch models too). Goals: batched ``predict`` at least 1.5x faster than sequential;
a single network's low-level action at least 5x faster than the ensemble's ``predict``.

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
from typing import Any

import numpy as np
import torch as th

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.controllers import PredictController
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.distill import make_student
from antmaze_hirl.sb3_ext.ensemble import build_ensemble
from antmaze_hirl.sb3_ext.loading import policy_fingerprint
from antmaze_hirl.sb3_ext.numpy_actor import NumpyActor
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

RESULTS = Path(__file__).resolve().parents[1] / "results" / "ensemble_speed" / "ensemble_speed.json"
GOAL = 1.5
SINGLE_GOAL = 5.0
"""One network's batch-1 action at least this many times faster than the ensemble's ``predict``."""


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
        "single": make_student(path, "ant", init_head=0),
    }
    actors: dict[str, Callable[[dict], np.ndarray]] = {
        "batched_controller": PredictController(models["batched"]),
        "single_controller": PredictController(models["single"]),
        "batched_numpy": NumpyActor.from_model(models["batched"]),
        "single_numpy": NumpyActor.from_model(models["single"]),
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

    def gap(first: Callable[[dict], np.ndarray], second: Callable[[dict], np.ndarray]) -> float:
        return max(float(np.abs(np.asarray(first(o)) - np.asarray(second(o))).max()) for o in observations)

    def predict(model: Any) -> Callable[[dict], np.ndarray]:
        return lambda o: model.predict(o, deterministic=True)[0]

    gaps = {
        "sequential_vs_batched": gap(predict(models["sequential"]), predict(models["batched"])),
        "batched_numpy_vs_torch": gap(actors["batched_numpy"], predict(models["batched"])),
        "single_numpy_vs_torch": gap(actors["single_numpy"], predict(models["single"])),
    }
    cycle = iter(observations * (args.rounds * (len(models) + len(actors)) + 2))
    rows = {**{name: predict(model) for name, model in models.items()}, **actors}
    times: dict[str, list[float]] = {name: [] for name in [*rows, "env_step"]}
    action = np.zeros(env.action_space.shape)
    for _ in range(args.rounds):
        for name, act in rows.items():
            times[name].append(microseconds(lambda act=act: act(next(cycle)), args.calls))
        times["env_step"].append(microseconds(lambda: env.step(action), args.calls))
    env.close()
    medians = {name: statistics.median(values) for name, values in times.items()}
    reference = medians["batched"]
    step = {name: medians[name] + medians["env_step"] for name in rows}
    result = {
        "policy": str(path.name) if args.policy is None else str(path),
        "fingerprints": {name: policy_fingerprint(model) for name, model in models.items()},
        "heads": models["batched"].policy.n_members,
        "median_microseconds": {name: round(value, 1) for name, value in medians.items()},
        "microseconds": {name: [round(value, 1) for value in values] for name, values in times.items()},
        "predict_speedup": round(medians["sequential"] / medians["batched"], 3),
        "low_level_step_speedup": round(step["sequential"] / step["batched"], 3),
        "speedup_over_batched_predict": {name: round(reference / medians[name], 3) for name in rows},
        "low_level_step_speedup_over_batched_predict": {
            name: round(step["batched"] / value, 3) for name, value in step.items()
        },
        "max_action_gap": gaps["sequential_vs_batched"],
        "max_action_gaps": gaps,
        "goal_predict_speedup_at_least": GOAL,
        "goal_single_speedup_over_batched_predict_at_least": SINGLE_GOAL,
        "single_goal_met_by": sorted(
            name for name in rows if name.startswith("single") and reference / medians[name] >= SINGLE_GOAL
        ),
        "settings": {key: str(value) if isinstance(value, Path) else value for key, value in vars(args).items()},
        "machine": {"platform": platform.platform(), "processor": platform.processor(), "torch": th.__version__},
        "command": shlex.join(["python", "benchmarks/ensemble_speed.py", *sys.argv[1:]]),
    }
    print(json.dumps(result, indent=1))
    atomic_write_json(args.out, result)


if __name__ == "__main__":
    main()
