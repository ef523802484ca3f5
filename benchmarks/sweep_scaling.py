"""Wall time of one small experiment grid on the serial backend against Ray with 2 workers, in one run.

The grid: the point body, ``--methods`` x ``--seeds`` trials of ``--episodes`` episodes (small mazes and
evaluations), run once with ``backend="serial"`` and once with ``backend="ray"`` (2 workers of one CPU
each, a local Ray instance) into fresh folders; both give the same ``episodes.csv`` (checked here).

Ray's start-up is measured apart: ``ray.init()`` of a local 2-CPU instance plus its first trivial task
(a worker process started and answering). The Ray grid then runs on that instance, so
``ray_grid_seconds`` leaves the start-up out (but includes its workers importing the package, torch and
MuJoCo), and ``ray_end_to_end_seconds`` is the two together, what ``--backend ray`` costs a user.

The figures depend on the machine's load, which is recorded (``os.getloadavg`` before and after).

Usage: python benchmarks/sweep_scaling.py [--seeds 2] [--episodes 6] [--methods dagger,reward]
Writes results/sweep_scaling/sweep_scaling.json.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import ray
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.experiments import ExperimentConfig, run_experiment
from antmaze_hirl.experiments.provenance import code_provenance

RESULTS = Path(__file__).resolve().parents[1] / "results" / "sweep_scaling" / "sweep_scaling.json"
WORKERS = 2


def _nothing() -> None:
    """The first trivial task."""


def ray_startup_seconds() -> float:
    """Seconds of ``ray.init()`` (local, ``WORKERS`` CPUs) and its first trivial task; leaves Ray running."""
    start = time.perf_counter()
    ray.init(num_cpus=WORKERS, include_dashboard=False, logging_level="WARNING")
    ray.get(ray.remote(num_cpus=1)(_nothing).remote())
    return time.perf_counter() - start


def timed_grid(methods: list[str], seeds: int, config: ExperimentConfig, out: Path, **backend) -> tuple[float, float]:
    """Wall time of the grid, and the sum of its trials' own wall times (``summary.json``'s ``trial_seconds``)."""
    start = time.perf_counter()
    summary = run_experiment(methods, seeds, config, out, progress_bar=False, cpus_per_trial=1, **backend)
    return time.perf_counter() - start, sum(summary["trial_seconds"].values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--methods", default="dagger,reward")
    args = parser.parse_args()
    torch.set_num_threads(1)
    methods = args.methods.split(",")
    config = ExperimentConfig(
        body="point",
        episodes=args.episodes,
        eval_every=3,
        eval_episodes=2,
        final_eval_episodes=3,
        maze_size=3,
        gradient_steps=20,
        held_out_layouts=False,  # protocol 1's tiny 3x3 grid, as the committed timings ran
        protocol=1,
        evaluation_envs=1,
    )
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as folder:
        serial, serial_trials = timed_grid(methods, args.seeds, config, Path(folder) / "serial", backend="serial")
        startup = ray_startup_seconds()
        try:
            grid, ray_trials = timed_grid(
                methods, args.seeds, config, Path(folder) / "ray", backend="ray", jobs=WORKERS
            )
        finally:
            ray.shutdown()
        same = (Path(folder) / "serial" / "episodes.csv").read_bytes() == (
            Path(folder) / "ray" / "episodes.csv"
        ).read_bytes()
    provenance = code_provenance()
    result = {
        "grid": {"body": "point", "methods": methods, "seeds": args.seeds, "trials": len(methods) * args.seeds},
        "config": asdict(config),
        "ray_workers": WORKERS,
        "cpus_per_trial": 1,
        "serial_seconds": round(serial, 1),
        "ray_startup_seconds": round(startup, 1),
        "ray_grid_seconds": round(grid, 1),
        "ray_end_to_end_seconds": round(startup + grid, 1),
        # Trials' own wall times, summed: on a machine already busy, two at once each take longer.
        "serial_trial_seconds_sum": round(serial_trials, 1),
        "ray_trial_seconds_sum": round(ray_trials, 1),
        "speedup_serial_over_ray_grid": round(serial / grid, 2),
        "speedup_serial_over_ray_end_to_end": round(serial / (startup + grid), 2),
        "episodes_csv_identical": same,
        "machine": {
            "cpu_count": os.cpu_count(),
            "cpu_model": provenance["cpu_model"],
            "load_average_1_5_15_before": [round(load, 2) for load in load_before],
            "load_average_1_5_15_after": [round(load, 2) for load in os.getloadavg()],
        },
        "packages": {**provenance["packages"], "ray": ray.__version__},
        "git_commit": provenance["git_commit"],
    }
    atomic_write_json(RESULTS, result)
    print(result)


if __name__ == "__main__":
    main()
