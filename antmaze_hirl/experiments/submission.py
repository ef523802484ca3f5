"""Checking a leaderboard submission: ``antmaze-hirl submit REPORT.json``.

A submission is one ``antmaze-hirl benchmark --json`` report of a trained high-level policy. Before it becomes
a row of the leaderboard (``docs/leaderboard.md``), :func:`check_submission` checks what the row's figures
rest on: the report's format, that it was scored on the suite's current task list (its checksum), that it
played the protocol's episodes (every task, ``K`` episodes each) and that its counts agree with its episodes.
It then fills the row's budget and seed from the report (``report["submission"]``, written by
``antmaze-hirl benchmark --budget ... --training-seed ...``; for the repository's own training scripts, their
``training`` block), so that the row names what it is: the policy, what it was trained with, and which seed.
Reports of one policy and budget with other seeds are pooled into one entry, as the baselines' seeds are.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path
from typing import Any

from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments.benchmark import RESULTS_FORMAT
from antmaze_hirl.experiments.benchmark_policies import POLICY_KEYWORDS


class SubmissionError(ValueError):
    """A report that cannot be a leaderboard row; the message names the file, the field and its value."""


def _budget_from_training(training: dict[str, Any]) -> str | None:
    # The repository's own scripts record what they trained on (labels for DAgger, steps for the RL baselines).
    if "labels" in training:
        return f"{int(training['labels']):,} labels"
    if "steps_reached" in training:
        return f"{int(training['steps_reached']):,} {training.get('step_kind', 'steps')}"
    return None


def check_submission(
    report: dict[str, Any], *, name: str = "the report", budget: str | None = None, seed: int | None = None
) -> dict[str, Any]:
    """The report with its ``submission`` block filled, once it passes every check.

    Args:
        report: A report as ``antmaze-hirl benchmark --json`` writes it.
        name: How errors name the report (its file).
        budget: The training budget, e.g. ``"200k high-level steps"`` (default: the report's
            ``submission["budget"]``, else its ``training`` block's labels or steps).
        seed: The training seed (default: the report's ``submission["seed"]``, else ``training["seed"]``).

    Returns:
        A copy of ``report`` with ``report["submission"] = {"budget": str, "seed": int}``.

    Raises:
        SubmissionError: On another format, an unknown suite, a checksum or env id that is not the suite's,
            fewer episodes than the protocol's, counts that disagree with the episodes, a reference policy's
            name, or no budget or seed; one line naming the field and value.
    """
    if not isinstance(report, dict) or report.get("format") != RESULTS_FORMAT:
        found = report.get("format") if isinstance(report, dict) else type(report).__name__
        raise SubmissionError(f"{name}: format {found!r} is not a benchmark report ({RESULTS_FORMAT!r})")
    suite = report.get("suite")
    if suite not in SUITE_SPECS:
        raise SubmissionError(f"{name}: suite {suite!r} is not a suite (one of {', '.join(SUITE_SPECS)})")
    spec = SUITE_SPECS[suite]
    if report.get("suite_checksum") != spec.checksum:
        raise SubmissionError(
            f"{name}: suite checksum {str(report.get('suite_checksum'))[:16]!r} is not suite {suite!r}'s "
            f"({spec.checksum[:16]}...): it was scored on another task list; score it again with this version"
        )
    if report.get("env_id") != spec.env_id:
        raise SubmissionError(f"{name}: env_id {report.get('env_id')!r} is not suite {suite!r}'s ({spec.env_id})")
    _check_episodes(report, name, spec.n_tasks, spec.episodes_per_task)
    policy = str(report.get("policy", "")).strip()
    if not policy or policy in POLICY_KEYWORDS:
        raise SubmissionError(
            f"{name}: policy {policy!r} is no entry's name: score with --policy-name 'what it is' (oracle and "
            "random are the suites' reference rows)"
        )
    given = report.get("submission", {})
    training = report.get("training", {})
    budget = budget or given.get("budget") or _budget_from_training(training)
    if not budget:
        raise SubmissionError(f"{name}: no training budget: pass --budget, e.g. --budget '200k high-level steps'")
    seed = seed if seed is not None else given.get("seed", training.get("seed"))
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise SubmissionError(f"{name}: training seed {seed!r} is not an integer: pass --training-seed N")
    return {**report, "submission": {"budget": str(budget), "seed": seed}}


def _check_episodes(report: dict[str, Any], name: str, n_tasks: int, episodes_per_task: int) -> None:
    outcomes = report.get("episode_outcomes")
    if not isinstance(outcomes, list) or not outcomes:
        raise SubmissionError(f"{name}: no episode_outcomes: write the report with antmaze-hirl benchmark --json")
    protocol = n_tasks * episodes_per_task
    per_task = Counter(outcome.get("task_id") for outcome in outcomes)
    short = sorted(task for task in range(n_tasks) if per_task.get(task, 0) < episodes_per_task)
    if len(outcomes) < protocol or short:
        raise SubmissionError(
            f"{name}: {len(outcomes)} episodes, the protocol plays {protocol} ({episodes_per_task} on each of "
            f"{n_tasks} tasks; short: tasks {short[:5]}): score with the default --episodes-per-task and no --tasks"
        )
    successes = sum(bool(outcome.get("success")) for outcome in outcomes)
    if report.get("episodes") != len(outcomes) or report.get("successes") != successes:
        raise SubmissionError(
            f"{name}: episodes {report.get('episodes')!r} and successes {report.get('successes')!r} disagree with "
            f"its {len(outcomes)} episode_outcomes ({successes} successes)"
        )


def load_submission(path: str | Path, *, budget: str | None = None, seed: int | None = None) -> dict[str, Any]:
    """:func:`check_submission` of the JSON file at ``path``.

    Raises:
        SubmissionError: If the file is no JSON, or as :func:`check_submission`.
        FileNotFoundError: If there is no file at ``path``.
    """
    path = Path(path)
    try:
        report = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise SubmissionError(f"{path}: not JSON ({error.msg}, line {error.lineno})") from None
    return check_submission(report, name=str(path), budget=budget, seed=seed)


HELP = "check a benchmark report for the leaderboard and fill its budget and seed"
DESCRIPTION = (
    "Check a benchmark report for the leaderboard: its format, the suite's checksum, the protocol's "
    "episodes and its counts; fill the row's budget and training seed from the report (or the options "
    "below), print the row and, with --out, write the checked report (CONTRIBUTING.md)."
)
EXAMPLE = "antmaze-hirl submit runs/point5_mine.json --out results/leaderboard/point5_mine_s0.json"
"""The subcommand's help line, description and example; ``antmaze_hirl.cli`` makes its parser from them."""


def add_submit_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds ``submit``'s arguments and handler to its parser (light: no envs, no torch)."""
    parser.add_argument("report", type=Path, help="the report written by antmaze-hirl benchmark --json (required)")
    parser.add_argument(
        "--budget", default=None, help="the training budget, e.g. '200k high-level steps' (default: the report's)"
    )
    parser.add_argument(
        "--training-seed", type=int, default=None, help="the training run's seed (default: the report's)"
    )
    parser.add_argument(
        "--out", type=Path, default=None, help="write the checked report here, atomically (default: print only)"
    )
    parser.set_defaults(handler=run_submit_command)


def run_submit_command(args: argparse.Namespace) -> int:
    """Handler of ``antmaze-hirl submit``: checks, prints the row, writes ``--out``."""
    report = load_submission(args.report, budget=args.budget, seed=args.training_seed)
    row = report["submission"]
    print(
        f"ok: {report['suite']} | {report['policy']} | {row['budget']} | seed {row['seed']} | "
        f"{report['successes']} of {report['episodes']} episodes"
    )
    if args.out is not None:
        from antmaze_hirl.atomic_io import atomic_write_json

        atomic_write_json(args.out, report)
        print(f"wrote {args.out}")
    return 0
