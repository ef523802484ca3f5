"""``antmaze-hirl benchmark``: its options, its handler and the plain-text table it prints.

The scoring itself is :func:`antmaze_hirl.experiments.benchmark.score_policy`; the policies it takes by name
or file are :mod:`antmaze_hirl.experiments.benchmark_policies`'.
"""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path
from typing import Any

from antmaze_hirl.cli_validation import LOW_LEVEL_VALUE, SB3_ZIP_WARNING
from antmaze_hirl.envs.suite_specs import SUITE_SPECS, check_suite_name
from antmaze_hirl.experiments.benchmark import DEFAULT_NUM_ENVS, save_report, score_policy
from antmaze_hirl.experiments.benchmark_policies import check_oracle_settings


def report_table(report: dict[str, Any], *, per_task: bool) -> str:
    """A plain-text table of a report: the suite line, then one line per task if ``per_task``."""

    def line(name: str, row: dict[str, Any]) -> str:
        low, high = row["wilson_95"]
        return (
            f"{name:<10} {row['successes']:>4}/{row['episodes']:<4} {row['success_rate']:>6.1%} "
            f"[{low:.1%}, {high:.1%}]  attempts {row['mean_attempts']:6.1f}  low-level steps "
            f"{row['mean_low_level_steps']:7.1f}"
        )

    lines = [f"{report['suite']} ({report['env_id']}), policy {report['policy']}, {report['seconds']} s"]
    lines.append(line("suite", report))
    if "task_bootstrap_95" in report:
        low, high = report["task_bootstrap_95"]
        lines.append(f"{'':<10} bootstrap over tasks 95%: [{low:.1%}, {high:.1%}]")
    if per_task:
        lines += [line(f"task {row['task_id']}", row) for row in report["tasks"]]
    return "\n".join(lines)


HELP = "score a high-level policy on a benchmark suite"
DESCRIPTION = (
    "Score a high-level policy on a benchmark suite: success with its 95% Wilson interval, attempts and "
    f"low-level steps, per suite and per task. Suites: {', '.join(SUITE_SPECS)} (docs/leaderboard.md)."
)
EXAMPLE = "antmaze-hirl benchmark point5 --policy oracle --json runs/point5_oracle.json"
"""The subcommand's help line, description and example; ``antmaze_hirl.cli`` makes its parser from them."""


def add_benchmark_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds ``benchmark``'s arguments and handler to its parser (light: the handler imports the envs and SB3)."""
    parser.add_argument("suite", help=f"suite name: one of {', '.join(SUITE_SPECS)} (required)")
    parser.add_argument(
        "--policy",
        required=True,
        help="oracle, random, planner (the planning learner shipped for the suite's body), or the path of an SB3 zip "
        "of a high-level model or a saved DAgger learner; "
        f"{SB3_ZIP_WARNING} (required)",
    )
    parser.add_argument(
        "--episodes-per-task",
        type=int,
        default=None,
        help="episodes per task, K (default: the suite's, 1 on point5/ant4, 20 on the fixed maps)",
    )
    parser.add_argument("--seed", type=int, default=0, help="episode j of task k resets with seed + k*K + j")
    parser.add_argument(
        "--num-envs",
        type=int,
        default=DEFAULT_NUM_ENVS,
        help="mazes played at once in lockstep, one batched low-level forward per step "
        "(1: one after another, as the committed results were made)",
    )
    parser.add_argument("--tasks", default=None, help="comma-separated task ids (default: all)")
    parser.add_argument(
        "--subgoal-reach-m",
        type=float,
        default=None,
        help="--policy oracle only: its farthest subgoal, metres (default: the body's experiment setting, "
        "1 cell for the point and 2 m for the ant)",
    )
    parser.add_argument(
        "--clearance-m",
        type=float,
        default=None,
        help="--policy oracle only: how far its straight walks to a subgoal keep from walls, metres "
        "(default: 0.2 cell, 0.8 m for the ant)",
    )
    parser.add_argument(
        "--json", type=Path, default=None, help="write the report here, atomically (default: print only)"
    )
    parser.add_argument(
        "--policy-name",
        default=None,
        help="the report's policy name, the leaderboard's entry (default: as --policy names it), e.g. "
        "'PPO on the high level'; its budget goes in --budget",
    )
    parser.add_argument(
        "--budget",
        default=None,
        help="for a leaderboard submission: the policy's training budget, e.g. '200k high-level steps', "
        "recorded in the report for antmaze-hirl submit (default: none)",
    )
    parser.add_argument(
        "--training-seed",
        type=int,
        default=None,
        help="for a leaderboard submission: the training run's seed (default: none)",
    )
    parser.add_argument(
        "--low-level",
        default=None,
        help=f"the low level: {LOW_LEVEL_VALUE}; the report records its fingerprint; {SB3_ZIP_WARNING} "
        "(default: the body's shipped low level)",
    )
    parser.add_argument(
        "--per-task", action="store_true", help="print one line per task (always done with 10 tasks or fewer)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(handler=run_benchmark_command)


def _parse_task_ids(text: str | None) -> list[int] | None:
    if text is None:
        return None
    try:
        return [int(entry) for entry in text.split(",")]
    except ValueError:
        raise ValueError(f"--tasks must be comma-separated integers, got {text!r}") from None


def run_benchmark_command(args: argparse.Namespace) -> int:
    """Handler of ``antmaze-hirl benchmark``: scores, prints the table, writes ``--json``."""
    spec = check_suite_name(args.suite)
    # The bounds of --episodes-per-task, --num-envs and the metres are argparse's (cli_validation); this names
    # the flags before torch loads, where score_policy would name its keywords.
    check_oracle_settings(
        None if args.policy == "oracle" else f"--policy {args.policy}",
        {"--subgoal-reach-m": args.subgoal_reach_m, "--clearance-m": args.clearance_m},
    )
    import torch

    torch.set_num_threads(1)  # small-batch forwards: a second thread only contends (shared/README.md)
    low_level = None
    if args.low_level is not None:
        from antmaze_hirl.sb3_ext.loading import load_low_level

        low_level = load_low_level(spec.body, args.low_level)  # a name, or a zip of this body (checked)
    report = score_policy(
        spec.name,
        args.policy,
        episodes_per_task=args.episodes_per_task,
        seed=args.seed,
        task_ids=_parse_task_ids(args.tasks),
        num_envs=args.num_envs,
        progress=not args.no_progress,
        subgoal_reach_m=args.subgoal_reach_m,
        clearance_m=args.clearance_m,
        low_level=low_level,
    )
    command = ["antmaze-hirl", "benchmark", spec.name, "--policy", str(args.policy)]
    command += ["--episodes-per-task", str(report["episodes_per_task"]), "--seed", str(args.seed)]
    command += ["--num-envs", str(args.num_envs)]
    command += [] if args.subgoal_reach_m is None else ["--subgoal-reach-m", f"{args.subgoal_reach_m:g}"]
    command += [] if args.clearance_m is None else ["--clearance-m", f"{args.clearance_m:g}"]
    command += [] if args.policy_name is None else ["--policy-name", args.policy_name]
    command += [] if args.budget is None else ["--budget", args.budget]
    command += [] if args.training_seed is None else ["--training-seed", str(args.training_seed)]
    command += [] if args.low_level is None else ["--low-level", str(args.low_level)]
    report["command"] = shlex.join(command + (["--tasks", args.tasks] if args.tasks else []))
    if args.policy_name is not None:
        report["policy"] = args.policy_name
    if args.low_level is not None:
        report["low_level"] = f"{args.low_level}: {report['low_level']}"
    submission = {"budget": args.budget, "seed": args.training_seed}
    if any(value is not None for value in submission.values()):
        report["submission"] = {key: value for key, value in submission.items() if value is not None}
    print(report_table(report, per_task=args.per_task or len(report["tasks"]) <= 10))
    if args.json is not None:
        save_report(report, args.json)
        print(f"wrote {args.json}")
    return 0
