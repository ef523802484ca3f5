"""Leaderboard rows for DAgger, plain or active: a learner trained on a body's training part, scored at label counts.

The learner trains with the experiment's own trainer (:func:`antmaze_hirl.experiments.runner.make_trainer`,
the strategy of ``--method``: ``dagger`` by default, or any of the experiment's active methods), under the
body's held-out-layouts settings (:func:`~antmaze_hirl.experiments.config.body_settings`),
on mazes of the body family's ``train`` part only (the held-out protocol's training env, with the body's
shipped low level), the scripted oracle as the expert. When its label count first reaches each of
``--labels`` (checked after every episode, so the count recorded is the first one at or past the target),
the learner is saved and scored by :func:`~antmaze_hirl.experiments.benchmark.score_policy` on the body's
suite (:data:`SUITES`: ``point5`` or ``ant4``, the held-out family the training part comes from), as
``antmaze-hirl benchmark SUITE --policy learner.zip --num-envs N`` would. The untrained learner (0 labels)
is scored first: a curve starts at its measured score, not at 0.

Learners (:data:`LEARNERS`):

- ``generic`` (default): a learner that must learn (it solves few mazes untrained), the heading head without the
  wall-blocking planner (``head="heading", planning_iterations=0, block_walls=False``); the committed point rows.
- ``protocol``: protocol 2's learner (:data:`~antmaze_hirl.experiments.config.PROTOCOL_LEARNER`, the CNN
  next-cell head), as ``scripts/paper_experiment.py`` trains it.
- ``default``: the body's protocol-1 default (the point's next-cell planner, a strong prior that solves most
  mazes untrained; the ant's next-cell CNN).

Usage: python scripts/benchmark_dagger.py [--body point|ant] [--learner generic|protocol|default]
    [--method dagger|noise|...] [--labels 100,300,1000] [--seed 0] [--num-envs 8] [--max-episodes 1000]
Writes results/leaderboard/<suite>_<method>_<learner>_s<seed>_<labels>.json (:func:`report_name`) and the
learners under --out.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.strategies import METHODS
from antmaze_hirl.experiments.benchmark import DEFAULT_NUM_ENVS, score_policy
from antmaze_hirl.experiments.config import PROTOCOL_LEARNER, ExperimentConfig, body_settings, learner_settings
from antmaze_hirl.experiments.runner import make_env, make_trainer
from antmaze_hirl.experts import PathOracle

RESULTS = Path(__file__).resolve().parents[1] / "results" / "leaderboard"

SUITES = {"point": "point5", "ant": "ant4"}
"""The suite each body's learner is scored on: the held-out family whose ``train`` part it trains on."""

LEARNERS = ("generic", "protocol", "default")
"""The learners ``--learner`` names (module docstring); :func:`learner_setup` gives their settings."""

GENERIC_SETTINGS: dict[str, Any] = {"head": "heading", "planning_iterations": 0, "block_walls": False}
"""The ``generic`` learner's :class:`~antmaze_hirl.dagger.HighLevelPolicy` settings: no planner, so it must learn."""


def report_name(body: str, learner: str, seed: int, labels: int, method: str = "dagger") -> str:
    """The report's file name, distinct per body (its suite), method, learner, seed and label target.

    Raises:
        ValueError: Naming an unknown body, learner or method.
    """
    if body not in SUITES:
        raise ValueError(f"unknown body {body!r}; choose from {sorted(SUITES)}")
    if learner not in LEARNERS:
        raise ValueError(f"unknown learner {learner!r}; choose from {list(LEARNERS)}")
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose from {list(METHODS)}")
    return f"{SUITES[body]}_{method.replace('+', '_')}_{learner}_s{seed}_{labels}.json"


def policy_name(method: str, learner: str, seed: int, labels: int) -> str:
    """The report's ``policy``, as the leaderboard prints it: plain DAgger or the active method by name."""
    trained_by = "DAgger (plain)" if method == "dagger" else f"DAgger with `{method}` (active)"
    return f"{trained_by}, {learner} learner, seed {seed}, {labels} labels"


def learner_setup(body: str, learner: str) -> tuple[ExperimentConfig, dict[str, Any]]:
    """The experiment settings a ``learner`` on ``body`` trains under, and the learner settings it records.

    Every learner trains under the body's held-out-layouts settings; ``protocol`` sets the config's learner
    to :data:`PROTOCOL_LEARNER` (so :func:`make_trainer` builds it as protocol 2 does), ``generic`` passes
    :data:`GENERIC_SETTINGS` over the body's default, and ``default`` passes nothing.

    Returns:
        ``(config, settings)``: the config for :func:`make_trainer` and the settings passed over its learner
        (empty for ``protocol`` and ``default``).

    Raises:
        ValueError: Naming an unknown body or learner.
    """
    report_name(body, learner, 0, 0)  # validates both
    settings = body_settings(body, held_out_layouts=True)
    config = ExperimentConfig(
        body=body,
        held_out_layouts=True,
        protocol=1,  # learner None is the body's default learner in protocol 1 (protocol 2 would give its own)
        learner=PROTOCOL_LEARNER if learner == "protocol" else None,
        **settings,
    )
    return config, dict(GENERIC_SETTINGS) if learner == "generic" else {}


def parse_labels(text: str) -> list[int]:
    """The label targets of ``--labels``, ascending.

    Raises:
        ValueError: If ``text`` is not comma-separated integers >= 1.
    """
    try:
        targets = sorted(int(entry) for entry in text.split(","))
    except ValueError:
        raise ValueError(f"--labels must be comma-separated integers, got {text!r}") from None
    if targets[0] < 1:
        raise ValueError(f"--labels must be >= 1, got {text!r}")
    return targets


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The checked command line; a bad value exits with argparse's one-line error naming it."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--body", choices=sorted(SUITES), default="point", help="the body; its suite is scored")
    parser.add_argument("--learner", choices=LEARNERS, default="generic")
    parser.add_argument(
        "--method", choices=METHODS, default="dagger", help="the query strategy (plain DAgger or an active one)"
    )
    parser.add_argument("--labels", default="100,300,1000", help="comma-separated label counts to score at")
    parser.add_argument("--seed", type=int, default=0, help="the learner's and the trainer's seed")
    parser.add_argument(
        "--max-episodes",
        type=int,
        default=1000,
        help="stop training here even short of a label target (a method may ask few labels per episode, or none)",
    )
    parser.add_argument("--num-envs", type=int, default=DEFAULT_NUM_ENVS, help="suite mazes scored in lockstep")
    parser.add_argument("--tasks", type=int, default=None, help="score only the first N tasks (a quick check)")
    parser.add_argument("--out", type=Path, default=Path("runs/benchmark_dagger"), help="folder for the learners")
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder for the reports")
    args = parser.parse_args(argv)
    try:
        args.targets = parse_labels(args.labels)
    except ValueError as error:
        parser.error(str(error))
    if args.num_envs < 1:
        parser.error(f"--num-envs must be >= 1, got {args.num_envs}")
    if args.max_episodes < 1:
        parser.error(f"--max-episodes must be >= 1, got {args.max_episodes}")
    if args.tasks is not None and args.tasks < 1:
        parser.error(f"--tasks must be >= 1, got {args.tasks}")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Trains one learner and writes its reports; returns the exit status."""
    args = parse_args(argv)
    torch.set_num_threads(1)
    config, policy_settings = learner_setup(args.body, args.learner)
    suite = SUITES[args.body]
    env = make_env(config, split="train")
    expert = PathOracle.for_env(env, subgoal_reach_m=config.subgoal_reach_m)
    trainer = make_trainer(args.method, args.seed, config, env, expert, policy_settings=policy_settings or None)
    recorded_settings = learner_settings(config.learner, config.maze_size) if config.learner else policy_settings
    task_ids = None if args.tasks is None else list(range(args.tasks))
    command = shlex.join(["python", "scripts/benchmark_dagger.py", *(sys.argv[1:] if argv is None else argv)])
    training_seconds = 0.0
    for target in [0, *args.targets]:
        started = time.perf_counter()
        while trainer.total_expert_cost < target and trainer.episodes_done < args.max_episodes:
            trainer.run_episode()
        training_seconds += time.perf_counter() - started
        labels = trainer.total_expert_cost
        # Short of the target after --max-episodes: scored and recorded as it stands, and the last one scored.
        short = labels < target
        name = report_name(args.body, args.learner, args.seed, target, args.method)
        stem = Path(name).stem
        path = trainer.learner.save(args.out / f"{stem}.zip")
        report = score_policy(suite, str(path), task_ids=task_ids, num_envs=args.num_envs)
        report["policy"] = policy_name(args.method, args.learner, args.seed, labels)
        report["training"] = {
            "method": args.method,
            "body": args.body,
            "learner": args.learner,
            "learner_settings": recorded_settings,
            "subgoal_reach_m": config.subgoal_reach_m,
            "labels": labels,
            "episodes": trainer.episodes_done,
            "label_target": target,
            "stopped_short_at_max_episodes": short,
            "training_split": "train",
            "training_seconds": round(training_seconds, 1),
            "num_envs": args.num_envs,
            "command": command,
        }
        out = args.results / name
        atomic_write_json(out, report)
        low, high = report["wilson_95"]
        print(
            f"{labels} labels ({trainer.episodes_done} episodes, {training_seconds:.0f} s training, "
            f"{report['seconds']:.0f} s scoring): {report['successes']}/{report['episodes']} "
            f"[{low:.1%}, {high:.1%}] -> {out}" + (f" (short of {target}: --max-episodes)" if short else ""),
            flush=True,
        )
        if short:
            break
    env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
