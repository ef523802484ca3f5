"""One protocol-2 ant paper trial, serial evaluation against lockstep evaluation, side by side in one run.

Plays the trial ``paper_experiment.py --body ant`` runs (protocol 2: random 4x4 held-out layouts, plain
DAgger, the scripted oracle as expert, the shipped low level; the untrained learner evaluated first, then
every ``eval_every`` = 10 episodes and after the last, always on the same 100 held-out mazes) twice from the
same seed: with ``evaluation_envs=1`` (the serial path, one maze after another, as results committed before
lockstep were made) and with ``evaluation_envs=25`` (protocol 2's default: the 100 mazes in four lockstep
chunks of 25). Both train the same learner (the evaluations touch neither the trainer's random stream nor its
env), so their training time should match and their evaluation time is the difference.

A whole trial is 100 training episodes and 11 evaluations of 100 mazes; ``--episodes 10`` (the default here,
to fit a shared 2-core machine) plays its first tenth: 10 episodes and 2 evaluations (the untrained learner
and after 10 episodes). ``scaled_full_trial_s`` estimates the whole trial from it: training time x 100 /
episodes plus evaluation time x 11 / evaluations. The estimate leans high for the evaluations: an untrained
learner's episodes run their full 500 steps, a trained learner's end sooner at the goal. Run
``--episodes 100`` for the trial itself.

Times are wall-clock (``*_s``) and this process's CPU time (``cpu_*_s``). The trial runs on one thread, so
on a shared machine the CPU time is the closer stand-in for a trial alone on its cores (the trial-speed goal:
<= 3 min alone on 2 cores). Also reported: per-maze agreement of the two paths' evaluations (same success out
of all maze plays), since batched float rounding can change an ant episode; the load average before and
after (read the ratios first, the absolute times with the load).

    python benchmarks/paper_trial_speed.py                   # 10 episodes, both paths (about 30 min, shared)
    python benchmarks/paper_trial_speed.py --episodes 100    # one whole trial, both paths
    python benchmarks/paper_trial_speed.py --profile --episodes 10 --mazes 50 --out /tmp/profile.json

``--profile`` plays the lockstep path only, under cProfile, and reports where its process time went
(:data:`PROFILE_PARTS`: the evaluations, the learner's gradient steps, MuJoCo's physics, the low level's
network), each with its share of the whole; cProfile's own cost inflates Python-heavy parts, so read the
shares, not the seconds.
"""

from __future__ import annotations

import argparse
import cProfile
import functools
import json
import os
import platform
import pstats
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.experiments import ExperimentConfig, runner
from antmaze_hirl.experiments.config import (
    CURRENT_PROTOCOL,
    PROTOCOL_EVALUATION_ENVS,
    body_settings,
    evaluation_schedule,
)

RESULTS = Path(__file__).resolve().parents[1] / "results" / "paper_trial_speed" / "paper_trial_speed.json"
FULL_TRIAL_EPISODES = 100
LOCKSTEP_ENVS = PROTOCOL_EVALUATION_ENVS
"""Protocol 2's ``evaluation_envs``."""


def trial_config(episodes: int, evaluation_envs: int, mazes: int = 100) -> ExperimentConfig:
    """The ant's protocol-2 trial settings, as ``paper_experiment.py --body ant`` makes them (``mazes`` a set)."""
    settings = body_settings("ant", held_out_layouts=True)
    return ExperimentConfig(
        body="ant",
        episodes=episodes,
        final_eval_episodes=mazes,
        held_out_layouts=True,
        protocol=CURRENT_PROTOCOL,
        evaluation_envs=evaluation_envs,
        **settings,
    )


class EvaluationClock:
    """Sums the wall time spent in the runner's evaluations (``runner.play_mazes``) while installed."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.cpu_seconds = 0.0
        self.calls = 0

    def __enter__(self) -> EvaluationClock:
        self._original = runner.play_mazes

        @functools.wraps(self._original)
        def timed(*args: Any, **kwargs: Any) -> Any:
            start, cpu_start = time.perf_counter(), time.process_time()
            try:
                return self._original(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
                self.cpu_seconds += time.process_time() - cpu_start
                self.calls += 1

        runner.play_mazes = timed  # the runner calls it by this module-level name
        return self

    def __exit__(self, *exc: object) -> None:
        runner.play_mazes = self._original


def timed_trial(
    episodes: int, evaluation_envs: int, seed: int, mazes: int = 100
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """One DAgger trial with ``evaluation_envs``: its timings and final success, and its per-maze outcomes."""
    config = trial_config(episodes, evaluation_envs, mazes)
    full_evaluations = len(evaluation_schedule(trial_config(FULL_TRIAL_EPISODES, evaluation_envs, mazes)))
    load_before = os.getloadavg()
    start, cpu_start = time.perf_counter(), time.process_time()
    with EvaluationClock() as clock:
        rows, outcomes = runner.run_trial_with_evaluations("dagger", seed, config)
    total, cpu_total = time.perf_counter() - start, time.process_time() - cpu_start

    def scaled(training: float, evaluation: float) -> float:
        return training * FULL_TRIAL_EPISODES / episodes + evaluation * full_evaluations / clock.calls

    final = [row for row in outcomes if row["episode"] == episodes]
    figures = {
        "evaluation_envs": evaluation_envs,
        "episodes": episodes,
        "evaluations": clock.calls,
        "evaluations_in_a_full_trial": full_evaluations,
        "maze_plays": len(outcomes),
        "total_s": round(total, 1),
        "training_s": round(total - clock.seconds, 1),
        "evaluation_s": round(clock.seconds, 1),
        "scaled_full_trial_s": round(scaled(total - clock.seconds, clock.seconds), 1),
        "cpu_total_s": round(cpu_total, 1),
        "cpu_evaluation_s": round(clock.cpu_seconds, 1),
        "cpu_scaled_full_trial_s": round(scaled(cpu_total - clock.cpu_seconds, clock.cpu_seconds), 1),
        "final_successes": sum(row["success"] for row in final),
        "final_mazes": len(final),
        "labels": int(rows[-1]["cumulative_expert_cost"]),
        "load_average_1min": [round(load_before[0], 2), round(os.getloadavg()[0], 2)],
    }
    return figures, outcomes


PROFILE_PARTS: dict[str, tuple[str, str]] = {
    "evaluations": ("antmaze_hirl/experiments/outcomes.py", "play_mazes"),
    "learner_gradient_steps": ("antmaze_hirl/dagger/high_level_policy.py", "fit"),
    "physics_mj_step": ("~", "<built-in method mujoco._functions.mj_step>"),
    "low_level_network": ("antmaze_hirl/envs/controllers.py", "_act_directly"),
}
"""Parts of a trial by the function that does them, ``(file suffix, function name)`` as cProfile names it:
cumulative time, or own time for a built-in (file ``~``). Evaluations and the learner's updates are disjoint;
the physics and the low level's network run in both evaluations and training episodes."""


def profile_parts(stats: pstats.Stats) -> dict[str, float]:
    """Seconds of each part of :data:`PROFILE_PARTS` in a profile (0 where its function never ran)."""
    found = dict.fromkeys(PROFILE_PARTS, 0.0)
    for (filename, _, name), (_, _, own, cumulative, _) in stats.stats.items():
        for part, (suffix, function) in PROFILE_PARTS.items():
            if name == function and filename.endswith(suffix):
                found[part] += own if filename == "~" else cumulative
    return found


def profiled_trial(episodes: int, evaluation_envs: int, seed: int, mazes: int) -> dict[str, Any]:
    """One lockstep trial under cProfile: its process time and each part's seconds and share of it."""
    profile = cProfile.Profile(time.process_time)  # CPU seconds: on a shared machine wall time counts the others'
    profile.enable()
    figures, _ = timed_trial(episodes, evaluation_envs, seed, mazes)
    profile.disable()
    stats = pstats.Stats(profile)
    total = max(stats.total_tt, 1e-9)
    parts = profile_parts(stats)
    parts["training_episodes_besides_gradient_steps"] = total - parts["evaluations"] - parts["learner_gradient_steps"]
    return {
        **figures,
        "profiled_s": round(total, 1),
        "parts_s": {part: round(seconds, 1) for part, seconds in parts.items()},
        "parts_share": {part: round(seconds / total, 3) for part, seconds in parts.items()},
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=10, help="training episodes of the trial (a whole one: 100)")
    parser.add_argument("--seed", type=int, default=0, help="the trial's seed")
    parser.add_argument("--num-envs", type=int, default=LOCKSTEP_ENVS, help="mazes at once on the lockstep path")
    parser.add_argument("--mazes", type=int, default=100, help="held-out mazes per evaluation (the protocol: 100)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument(
        "--profile", action="store_true", help="profile the lockstep path alone (default: time both paths)"
    )
    args = parser.parse_args(argv)
    if min(args.episodes, args.mazes) < 1 or args.num_envs < 2:
        parser.error(
            f"--episodes and --mazes must be >= 1 and --num-envs >= 2, got {args.episodes}, {args.mazes}, "
            f"{args.num_envs}"
        )
    torch.set_num_threads(1)  # paper_experiment.py's --cpus-per-trial 1
    if args.profile:
        if args.out == RESULTS:
            parser.error("--profile writes a profile, not the committed timings: give --out")
        found = profiled_trial(args.episodes, args.num_envs, args.seed, args.mazes)
        report = {
            "benchmark": "paper_trial_speed --profile",
            "command": shlex.join(["python", "benchmarks/paper_trial_speed.py", *argv]),
            "profile": found,
        }
        print(json.dumps(found["parts_share"]), flush=True)
        print(f"wrote {atomic_write_json(args.out, report)}")
        return report
    rows, played = [], []
    for evaluation_envs in (1, args.num_envs):
        figures, outcomes = timed_trial(args.episodes, evaluation_envs, args.seed, args.mazes)
        rows.append(figures)
        played.append(outcomes)
        print(figures, flush=True)
    serial, lockstep = rows
    pairs = list(zip(*played, strict=True))
    report = {
        "benchmark": "paper_trial_speed",
        "command": shlex.join(["python", "benchmarks/paper_trial_speed.py", *argv]),
        "trial": f"protocol {CURRENT_PROTOCOL}, ant, dagger, seed {args.seed}, {args.episodes} of "
        f"{FULL_TRIAL_EPISODES} training episodes, {args.mazes} held-out mazes per evaluation",
        "machine": f"{platform.machine()} ({os.cpu_count()} CPUs), shared with other work while measured",
        "rows": rows,
        "speedup_total": round(serial["total_s"] / lockstep["total_s"], 2),
        "speedup_evaluation": round(serial["evaluation_s"] / lockstep["evaluation_s"], 2),
        "cpu_speedup_total": round(serial["cpu_total_s"] / lockstep["cpu_total_s"], 2),
        "cpu_speedup_evaluation": round(serial["cpu_evaluation_s"] / lockstep["cpu_evaluation_s"], 2),
        "same_training": [row["labels"] for row in rows].count(serial["labels"]) == 2,
        "maze_plays_same_success": sum(a["success"] == b["success"] for a, b in pairs),
        "maze_plays": len(pairs),
        # The paper question's goal: an ant trial in <= 5 CPU-minutes (an earlier goal was 3).
        "goal_full_trial_s": 300,
    }
    print(
        f"serial {serial['total_s']} s (evaluation {serial['evaluation_s']} s), lockstep {lockstep['total_s']} s "
        f"(evaluation {lockstep['evaluation_s']} s): {report['speedup_total']}x overall, "
        f"{report['speedup_evaluation']}x on evaluation; scaled to a whole trial {serial['scaled_full_trial_s']} s "
        f"against {lockstep['scaled_full_trial_s']} s (process CPU time: {serial['cpu_scaled_full_trial_s']} s "
        f"against {lockstep['cpu_scaled_full_trial_s']} s); {report['maze_plays_same_success']} of {len(pairs)} "
        "maze plays with the same success",
        flush=True,
    )
    print(f"wrote {atomic_write_json(args.out, report)}")
    return report


if __name__ == "__main__":
    main()
