"""Gradient steps per second and batch-1 inference time of the high-level learners, side by side.

Each learner of ``--learners`` (named learners of :data:`~antmaze_hirl.experiments.config.LEARNERS`, default the
protocol-2 CNN and the planning learner) is built for a body's experiment maps and timed on the same
synthetic batch (random walls at 30%, a goal cell, the agent at the grid's centre), interleaved round by
round so that a shared machine's load falls on each alike: ``fit`` on minibatches of 64 (gradient steps per
second) and one forward of one observation (milliseconds, the high level's cost per subgoal). The figure that
compares them is the ratio to the first learner. With ``--maps``, the planning learners are also timed on the
fixed maps' grids (the same weights, more rounds: zero-shot cost). One torch thread, as a trial runs.

Usage: python benchmarks/learner_speed.py [--body ant] [--learners next_cell_cnn,next_cell_plan]
           [--steps 50] [--forwards 200] [--rounds 3] [--maps large,giant] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import platform
import shlex
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch as th

from antmaze_hirl.dagger.features import EncodedBatch
from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy, LearnerSettings
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.profiles import body_spec
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.envs.suites import fixed_map
from antmaze_hirl.experiments.config import body_settings, learner_settings

RESULTS = Path(__file__).resolve().parents[1] / "results" / "learner_speed"
BODY_DIMS = {"ant": 27, "point": 2}


def synthetic_batch(grid_size: int, vector_dim: int, count: int, rng: np.random.Generator) -> EncodedBatch:
    grids = np.zeros((count, 2, grid_size, grid_size), np.float32)
    grids[:, 0] = rng.random((count, grid_size, grid_size)) < 0.3
    centre = grid_size // 2
    grids[:, 0, centre, centre] = 0.0
    goal = rng.integers(grid_size, size=(count, 2))
    grids[np.arange(count), 1, goal[:, 0], goal[:, 1]] = 1.0
    vectors = rng.normal(size=(count, vector_dim)).astype(np.float32)
    return EncodedBatch(grids, vectors)


def learner(body: str, name: str, geometry: MazeGeometry, maze_size: int) -> HighLevelPolicy:
    settings = LearnerSettings(**learner_settings(name, maze_size))
    policy = HighLevelPolicy(
        geometry, pixels_per_cell=8, body_dim=BODY_DIMS[body], rng=np.random.default_rng(0), settings=settings
    )
    return policy


def time_learner(policy: HighLevelPolicy, steps: int, forwards: int, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    vector_dim = STATE_LAYOUT.state_dim(policy.body_dim)
    batch = synthetic_batch(policy.encoder.grid_size, vector_dim, 512, rng)
    targets = rng.integers(-1, 2, size=(512, 2)).astype(np.float32)
    start = time.perf_counter()
    policy.fit(batch, targets, steps)
    fit_seconds = time.perf_counter() - start
    one = EncodedBatch(batch.grids[:1], batch.vectors[:1])
    policy.offsets(one)  # warm-up
    start = time.perf_counter()
    for _ in range(forwards):
        policy.offsets(one)
    forward_seconds = (time.perf_counter() - start) / forwards
    return {"gradient_steps_per_s": steps / fit_seconds, "batch1_forward_ms": 1000 * forward_seconds}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", choices=("ant", "point"), default="ant")
    parser.add_argument("--learners", default="next_cell_cnn,next_cell_plan")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--forwards", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--maps", default="large,giant")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    th.set_num_threads(1)
    maze_size = body_settings(args.body, held_out_layouts=True)["maze_size"]
    scale = body_spec(args.body).scale
    side = maze_size + 2
    arms: dict[str, HighLevelPolicy] = {}
    for name in args.learners.split(","):
        arms[name] = learner(args.body, name, MazeGeometry(side, side, scale), maze_size)
        if not arms[name].runs_on_any_map:
            continue
        for map_name in filter(None, args.maps.split(",")):
            rows, cols = np.asarray(fixed_map(SUITE_SPECS[map_name])).shape
            arms[f"{name}@{map_name}"] = arms[name].on_map(MazeGeometry(rows, cols, scale))
    samples: dict[str, list[dict[str, float]]] = {arm: [] for arm in arms}
    for round_index in range(args.rounds):
        for arm, policy in arms.items():
            samples[arm].append(time_learner(policy, args.steps, args.forwards, seed=round_index))
    first = next(iter(arms))
    rows = {}
    for arm, runs in samples.items():
        row = {key: statistics.median(run[key] for run in runs) for key in runs[0]}
        row["grid_size"] = arms[arm].encoder.grid_size
        row["planning_rounds"] = arms[arm].settings.planning_iterations
        rows[arm] = row
    for arm, row in rows.items():
        row["gradient_steps_ratio_to_" + first] = row["gradient_steps_per_s"] / rows[first]["gradient_steps_per_s"]
        row["forward_ratio_to_" + first] = row["batch1_forward_ms"] / rows[first]["batch1_forward_ms"]
        print(
            f"{arm:<28} grid {row['grid_size']:>2}  rounds {row['planning_rounds']:>2}  "
            f"{row['gradient_steps_per_s']:7.1f} grad steps/s ({row['gradient_steps_ratio_to_' + first]:.2f}x)  "
            f"{row['batch1_forward_ms']:6.2f} ms/forward ({row['forward_ratio_to_' + first]:.2f}x)"
        )
    result = {
        "command": shlex.join(["python", "benchmarks/learner_speed.py", *(argv if argv is not None else sys.argv[1:])]),
        "body": args.body,
        "machine": {"processor": platform.processor() or platform.machine(), "python": platform.python_version()},
        "torch_threads": 1,
        "rows": rows,
    }
    out = args.out or RESULTS / f"learner_speed_{args.body}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {out}")
    return result


if __name__ == "__main__":
    main()
