"""Prints one section of the leaderboard pages (suites, summary, results, figure, ...) from the committed results.

The summary (``docs/leaderboard.md``) is the leaderboard itself: one row per suite, entry and budget, the seeds
of a trained entry pooled with a cluster bootstrap over seeds and tasks (every seed plays the same tasks).
Every row of the results table (``docs/results/leaderboard-rows.md``) is one ``antmaze-hirl benchmark --json`` report in
``results/leaderboard/`` (its figures, budget, wall time and file), or a "not run yet" row from
:data:`NOT_RUN` with the command that would fill it. The figure section links the labels-against-steps
figures and the points section lists their points (``antmaze_lab.labels_vs_steps`` draws the PNGs from the
same reports).
Nothing is typed in by hand. Each section is a generated block of the page
(``<!-- generated: python -m antmaze_lab.leaderboard --section results -->``), so after adding a report run
``python scripts/generate_docs.py``; ``tests/test_generated_docs.py`` runs its ``--check``.

Usage: python -m antmaze_lab.leaderboard --section suites|leaderboard|summary|results|spread|paired|figure|points
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from statsmodels.stats.multitest import multipletests

from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments.benchmark import load_report
from antmaze_hirl.experiments.submission import SubmissionError, check_submission
from antmaze_hirl.experiments.uncertainty import cluster_bootstrap
from antmaze_lab.claims import sign_test
from antmaze_lab.labels_vs_steps import SUITES as FIGURE_SUITES
from antmaze_lab.labels_vs_steps import figure_path, figure_points, points_table
from antmaze_lab.tables import lab_parser

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "leaderboard"
PAGE = ROOT / "docs" / "leaderboard.md"
ROWS_PAGE = ROOT / "docs" / "results" / "leaderboard-rows.md"
"""The page of every row, one per results file, with the seeds side by side and the figure's points."""

GOAL = 0.95
"""The success the oracle hierarchy should reach on every suite (the verdict beside each oracle row)."""

NOT_RUN: list[tuple[str, str, str]] = [
    (
        "point5",
        "DAgger (plain), generic learner, seeds 2 and up",
        "`python scripts/benchmark_dagger.py --seed 2` (and 3, ...): seeds 0 and 1 ran (the spread table below "
        "sets them side by side; two seeds are too few to read a spread from)",
    ),
    (
        "point5",
        "DAgger (plain), protocol learner, seeds 6 and up",
        "`python scripts/benchmark_dagger.py --learner protocol --seed 6`: seeds 0-5 ran (the spread table below)",
    ),
    (
        "point5",
        "`gated` (protocol 2's fastest learner per label), seed 4 at 1,000 labels, seeds 6 and up",
        "`python scripts/benchmark_dagger.py --learner protocol --method gated --seed 4`: seed 4 ran to 300 labels, "
        "seeds 0-3 and 5 to 1,000 labels; `gated` asks few labels per episode (2.1 on the point in protocol 2), "
        "so 1,000 labels took seeds 0-3 562, 559, 537 and 450 episodes (38, 40, 44 and 33 min; seed 5 535 "
        "episodes, 97 min beside another job)",
    ),
    (
        "point5",
        "SB3 PPO seeds 4 and up; SAC seeds 1 and up",
        "`python scripts/rl_baselines.py --algo sac --seed 1 --steps 200000 --max-minutes 100 --resume "
        "--score-checkpoints --out /work/rl_runs`: PPO reached 200,704 steps on seeds 0-3 (37-42 min each on "
        "seeds 0-2, 86 min on seed 3 beside a heavier job), SAC 200,000 on seed 0 only (4.1 hours of training "
        "in four resumed runs)",
    ),
    (
        "ant4",
        "DAgger (plain), protocol learner, seeds 6 and up; the generic (heading) learner on the ant",
        "`python scripts/benchmark_dagger.py --body ant --learner protocol --seed 6` (or `--learner generic`): "
        "seeds 0-5 ran",
    ),
    (
        "ant4",
        "`gated` on seeds 6 and up; the other active methods",
        "`python scripts/benchmark_dagger.py --body ant --learner protocol --method gated --seed 6`: seeds 0-5 "
        "ran (27, 26, 25, 32, 52 and 70 min of training to 1,000 labels, the last two beside another job)",
    ),
    (
        "ant4",
        "SB3 PPO beyond 24,576 high-level steps, SAC beyond 18,592, flat SAC+HER beyond 126,848 body steps; "
        "seeds 1 and up",
        "`python scripts/rl_baselines.py --body ant --algo ppo --steps 200000 --max-minutes 100 --resume "
        "--score-checkpoints` (or `--algo sac`, `--algo flat-sac-her --steps 1000000`): PPO trained at about 9 "
        "subgoals a second on 8 mazes beside one other job (the point's PPO: about 85, seeds 0-2), SAC at about 3 "
        "beside two, so 200k steps is 6 hours or more of resumed runs; each run's checkpoints lived in "
        "`/work/rl_runs` on the machine that ran it",
    ),
    (
        "ant suites",
        "any learner on `u`, `medium`, `large`, `giant`",
        "not run: `benchmark_dagger.py` trains only on a random family's `train` part (`ant4`'s); the fixed "
        "maps need their own training protocol",
    ),
    (
        "point5",
        "flat SAC+HER (no hierarchy) beyond 133,679 body steps; seeds 1 and up",
        "`python scripts/rl_baselines.py --algo flat-sac-her --seed 1 --steps 1000000 --max-minutes 100 --resume "
        "--score-checkpoints`: seed 0 reached 133,679 body steps in its 100 minutes",
    ),
]
"""Baselines not measured yet: (suite, what, the command that would fill the row)."""


def suites_table() -> str:
    """One row per suite: id, tasks, protocol episodes, step limits, checksum."""
    lines = [
        "| suite | id | tasks | protocol episodes (K per task) | low-level step limit | "
        "`max_episode_steps` (subgoals) | task-list SHA-256 |",
        "|---|---|---|---|---|---|---|",
    ]
    for spec in SUITE_SPECS.values():
        source = f"random {spec.maze_size}x{spec.maze_size}, eval part" if spec.source == "random" else spec.source
        limit = "500" if spec.source == "random" else f"scaled to the path, up to {spec.max_low_level_steps}"
        lines.append(
            f"| `{spec.name}` | `{spec.env_id}` | {spec.n_tasks} ({source}) | "
            f"{spec.n_tasks * spec.episodes_per_task} ({spec.episodes_per_task}) | {limit} | "
            f"{spec.max_episode_steps} | `{spec.checksum[:16]}` |"
        )
    return "\n".join(lines)


def _percent(value: float) -> str:
    return f"{100 * value:.1f}%"


def goal_verdict(report: dict) -> str:
    """The oracle's goal (>= 95% success) on this row: met, met by the rate only, or missed; blank for others."""
    if report["policy"] != "oracle":
        return ""
    if report["success_rate"] < GOAL:
        return "**missed**"
    return "met" if report["wilson_95"][0] >= GOAL else "met by the rate; interval reaches below 95%"


def training_budget(report: dict) -> int:
    """A row's training budget for sorting: its expert labels, or its training steps (0 when untrained)."""
    training = report.get("training", {})
    return int(training.get("labels", training.get("steps_reached", training.get("high_level_steps", 0))))


def results_table() -> str:
    """One row per committed report (suite order, then policy), then the rows not run yet."""
    reports = [(path, load_report(path)) for path in sorted(RESULTS.glob("*.json"))]
    order = list(SUITE_SPECS)
    named = ("oracle", "random")
    reports.sort(
        key=lambda item: (
            order.index(item[1]["suite"]),
            item[1]["policy"] not in named,
            item[1]["policy"].split(",")[0],
            item[1].get("training", {}).get("learner", ""),  # one learner's rows together, then the next's
            training_budget(item[1]),
            -item[1]["episodes"],
        )
    )
    lines = [
        "| suite | policy | budget | success [95% Wilson] | oracle goal (>= 95%) | mean subgoals | "
        "mean low-level steps | flips | wall time | file (in `results/leaderboard/`) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for path, report in reports:
        spec = SUITE_SPECS[report["suite"]]
        low, high = report["wilson_95"]
        tasks = spec.n_tasks if report["task_ids"] == "all" else len(report["task_ids"])
        budget = f"{tasks} tasks x {report['episodes_per_task']} = {report['episodes']} episodes"
        if report["episodes"] < spec.n_tasks * spec.episodes_per_task:
            budget += " (below the protocol's)"
        success = f"{report['successes']}/{report['episodes']} = {_percent(report['success_rate'])} "
        success += f"[{_percent(low)}, {_percent(high)}]"
        wall = f"{report['seconds']:.0f} s"
        if "training" in report:
            wall = f"{wall} scoring + {report['training']['training_seconds']:.0f} s training"
        lines.append(
            f"| `{report['suite']}` | {report['policy']} | {budget} | {success} | {goal_verdict(report)} | "
            f"{report['mean_attempts']:.1f} | {report['mean_low_level_steps']:.0f} | {report['flips']} | {wall} | "
            f"`{path.name}` |"
        )
    for suite, what, command in NOT_RUN:
        lines.append(f"| `{suite}` | {what} | not run yet | not run yet | | | | | | {command} |")
    return "\n".join(lines)


DAGGER_ROW = re.compile(
    r"(?P<suite>[a-z0-9]+)_(?P<method>[a-z_]+?)_(?P<learner>generic|protocol|default)_s(?P<seed>\d+)_(?P<target>\d+)\.json"
)
"""A DAgger row's file name (``scripts/benchmark_dagger.py``): suite, method, learner, seed and label target."""
TRAINED_ROWS = ("*_*_generic_s*_*.json", "*_*_protocol_s*_*.json", "*_*_default_s*_*.json")
"""The file patterns of rows trained by ``scripts/benchmark_dagger.py``, plain DAgger or an active method."""


def dagger_groups() -> dict[tuple[str, str, str, int], dict[int, dict]]:
    """The DAgger rows by (suite, method, learner, label target), each a dict of its reports by seed.

    Raises:
        SystemExit: If a plain-DAgger file's name does not parse (a misnamed row would silently drop out).
    """
    groups: dict[tuple[str, str, str, int], dict[int, dict]] = {}
    # Every plain-DAgger file must parse (a misnamed one is an error); active methods are found by their learner.
    paths = sorted(
        {path for pattern in TRAINED_ROWS for path in RESULTS.glob(pattern)} | set(RESULTS.glob("*_dagger_*"))
    )
    for path in paths:
        match = DAGGER_ROW.fullmatch(path.name)
        if match is None:
            raise SystemExit(f"error: {path}: a DAgger row's name must be SUITE_METHOD_LEARNER_sSEED_TARGET.json")
        key = (match["suite"], match["method"], match["learner"], int(match["target"]))
        groups.setdefault(key, {})[int(match["seed"])] = load_report(path)
    return groups


def spread_table() -> str:
    """DAgger's rows across seeds: per suite, method, learner and label target, each seed's successes, mean, range.

    One seed's row is one draw of the training run; this table shows how far seeds disagree at each budget.
    The label count of a row is the first evaluation at or past its target, so it varies a little by seed.
    """
    groups = dagger_groups()
    order = list(SUITE_SPECS)
    lines = [
        "| suite | method | learner | label target | seeds | labels per seed | successes per seed (of 100) | mean | "
        "range |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    # Plain DAgger first in each suite, then the active methods by name.
    ranked = sorted(groups.items(), key=lambda kv: (order.index(kv[0][0]), kv[0][1] != "dagger", kv[0][1:]))
    for (suite, method, learner, target), by_seed in ranked:
        seeds = sorted(by_seed)
        rates = [100 * by_seed[seed]["success_rate"] for seed in seeds]
        labels = [str(by_seed[seed].get("training", {}).get("labels", 0)) for seed in seeds]
        lines.append(
            f"| `{suite}` | `{method}` | {learner} | {target} | {', '.join(map(str, seeds))} | {', '.join(labels)} | "
            f"{', '.join(f'{rate:.0f}' for rate in rates)} | {sum(rates) / len(rates):.1f} | "
            f"{min(rates):.0f}-{max(rates):.0f} |"
        )
    return "\n".join(lines)


RL_ROW = re.compile(
    r"(?P<suite>[a-z0-9]+)_(?P<algorithm>ppo|sac|flat_sac_her)_rl_s(?P<seed>\d+)(?P<untrained>_untrained)?\.json"
)
"""An RL baseline's final or untrained row (``scripts/rl_baselines.py``); its checkpoints (``_at_N``) are the curve."""
CHECKPOINT_ROW = re.compile(r".+_rl_s\d+_at_\d+\.json")
"""A checkpoint of an RL run: a point of its curve (the figure's), not a leaderboard entry."""
LEGACY_ROWS = ("point5_ppo_2048.json",)
"""Rows kept as points of a curve only: the single-maze PPO row of ``scripts/benchmark_sb3_high.py``."""
MIN_POOLED_SEEDS = 3
"""Fewest seeds pooled with a bootstrap over seeds: resampling two rows gives only three distinct mixes, and
understates the spread between seeds, so two seeds carry the envelope of their Wilson intervals instead."""
RL_NAMES = {
    "ppo": "SB3 PPO on the high level",
    "sac": "SB3 SAC on the high level",
    "flat_sac_her": "flat SAC+HER, no hierarchy",
}
"""The summary's name of each RL baseline, in the order it lists them."""


def rl_groups() -> dict[tuple[str, str, int], dict[int, dict]]:
    """The RL baselines' final and untrained rows by (suite, algorithm, steps reached), each a dict of reports by seed.

    Seeds that reached different steps (a run stopped by its wall-time cap) are different budgets, so they
    are different entries; an untrained row has 0 steps.
    """
    groups: dict[tuple[str, str, int], dict[int, dict]] = {}
    for path in sorted(RESULTS.glob("*_rl_s*.json")):
        match = RL_ROW.fullmatch(path.name)
        if match is not None:
            report = load_report(path)
            steps = 0 if match["untrained"] else report["training"]["steps_reached"]
            groups.setdefault((match["suite"], match["algorithm"], steps), {})[int(match["seed"])] = report
    return groups


def outcome_table(reports: list[dict]) -> np.ndarray:
    """The ``(seeds, tasks)`` success rates of reports that played the same tasks (one row per report).

    Raises:
        SystemExit: If the reports did not play the same tasks (they could not be pooled).
    """
    rows, tasks = [], None
    for report in reports:
        by_task: dict[int, list[bool]] = {}
        for episode in report["episode_outcomes"]:
            by_task.setdefault(episode["task_id"], []).append(bool(episode["success"]))
        if tasks is None:
            tasks = sorted(by_task)
        elif sorted(by_task) != tasks:
            raise SystemExit(f"error: {report['policy']}: its tasks differ from its group's, so it cannot be pooled")
        rows.append([np.mean(by_task[task]) for task in tasks])
    return np.array(rows)


def _minutes(seconds: list[float]) -> str:
    if max(seconds) < 60:
        return f"{max(seconds):.0f} s" if len(seconds) == 1 else f"{min(seconds):.0f}-{max(seconds):.0f} s"
    low, high = round(min(seconds) / 60), round(max(seconds) / 60)
    low_text = f"{min(seconds) / 60:.1f}" if min(seconds) < 60 else str(low)
    return f"{low_text} min" if low == high else f"{low_text}-{high} min"


@dataclass(frozen=True)
class Entry:
    """One leaderboard entry: a suite's policy at one budget, its seeds pooled, with its figures."""

    suite: str
    name: str
    budget: str
    seeds: str
    per_seed: str
    episodes: int
    rate: float
    low: float
    high: float
    interval: str
    training_time: str


def pooled_entry(suite: str, name: str, budget: str, by_seed: dict[int, dict]) -> Entry:
    """The entry of ``by_seed``'s reports: the seeds, each seed's successes, the pooled rate and its interval.

    One seed's row carries its own 95% Wilson interval (it says nothing of another training seed). Seeds
    pooled together played the same tasks, so their outcomes are not independent draws: from
    :data:`MIN_POOLED_SEEDS` seeds the interval is :func:`cluster_bootstrap`'s over seeds and tasks; two seeds
    give the envelope of their Wilson intervals.
    """
    seeds = sorted(by_seed)
    reports = [by_seed[seed] for seed in seeds]
    per_seed = ", ".join(f"{report['successes']}" for report in reports)
    episodes = reports[0]["episodes"]
    spec = SUITE_SPECS[suite]
    if episodes < spec.n_tasks * spec.episodes_per_task:  # a quick check, not the protocol: said in the budget
        budget += (
            " (below the protocol's)"
            if budget.endswith(" episodes")
            else f"; {episodes} episodes, below the protocol's"
        )
    table = outcome_table(reports) if len(reports) > 1 else None  # the same tasks, or an error
    if 1 < len(reports) < MIN_POOLED_SEEDS:
        rate = float(table.mean())
        low, high = min(report["wilson_95"][0] for report in reports), max(report["wilson_95"][1] for report in reports)
        kind = f"envelope of its {len(reports)} seeds' Wilson intervals (too few seeds for a bootstrap)"
    elif len(reports) == 1:
        low, high = reports[0]["wilson_95"]
        rate, kind = reports[0]["success_rate"], "Wilson"
        if "task_bootstrap_95" in reports[0]:  # K episodes per task share its maze: Wilson alone is too narrow
            task_low, task_high = reports[0]["task_bootstrap_95"]
            kind += f"; over its {len(reports[0]['tasks'])} tasks [{_percent(task_low)}, {_percent(task_high)}]"
    else:
        pooled = cluster_bootstrap(table)
        (low, high), rate = pooled["cluster_bootstrap_95"], pooled["rate"]
        kind = f"cluster bootstrap, {len(seeds)} seeds x {pooled['mazes']} tasks"
    training = [report["training"]["training_seconds"] for report in reports if "training" in report]
    time = _minutes(training) if training and max(training) > 0 else ""
    trained = "training" in reports[0] or "submission" in reports[0]
    seed_text = ", ".join(map(str, seeds)) if trained else ""
    return Entry(suite, name, budget, seed_text, per_seed, episodes, rate, low, high, kind, time)


def summary_row(suite: str, entry: str, budget: str, by_seed: dict[int, dict]) -> str:
    """One row of the full summary (the rows page): :func:`pooled_entry` with every figure and the training time."""
    row = pooled_entry(suite, entry, budget, by_seed)
    return (
        f"| `{suite}` | {row.name} | {row.budget} | {row.seeds} | {row.per_seed} (of {row.episodes}) | "
        f"{_percent(row.rate)} [{_percent(row.low)}, {_percent(row.high)}] | {row.interval} | {row.training_time} |"
    )


def _reference_entries(suite: str, reports: list[dict]) -> list[tuple[str, str, str, dict[int, dict]]]:
    """The oracle's and the random policy's entries of one suite: each its report with the most episodes."""
    rows = []
    for policy in ("oracle", "random"):
        candidates = [report for report in reports if report["policy"] == policy]
        if candidates:
            report = max(candidates, key=lambda report: report["episodes"])
            budget = f"{report['episodes']} episodes"
            verdict = goal_verdict(report)
            entry = f"oracle (goal >= 95%: {verdict})" if verdict else policy
            rows.append((suite, entry, budget, {0: report}))
    return rows


def _label_budget(target: int, by_seed: dict[int, dict]) -> str:
    if target == 0:
        return "untrained (0 labels)"
    labels = sorted(report["training"]["labels"] for report in by_seed.values())
    spread = f"{labels[0]:,}" if labels[0] == labels[-1] else f"{labels[0]:,}-{labels[-1]:,}"
    return f"{target:,} labels ({spread})"


def _step_budget(by_seed: dict[int, dict], steps: int) -> str:
    if steps == 0:
        return "untrained (0 steps)"
    training = next(iter(by_seed.values()))["training"]
    return f"{steps:,} {'body steps' if training['algorithm'] == 'flat-sac-her' else 'high-level steps'}"


def _other_rows(suite: str, reports: dict[str, dict], placed: set[str]) -> list[tuple[str, str, dict[int, dict]]]:
    """Each submitted entry of ``suite``, its seeds side by side.

    The reports no other entry pools, checked (``antmaze-hirl submit``) and pooled by policy and budget.

    Raises:
        SystemExit: If a submitted report fails the check, naming its file and what is wrong.
    """
    entries: dict[tuple[str, str], dict[int, dict]] = {}
    for name, report in sorted(reports.items()):
        if report["suite"] != suite or name in placed or name in LEGACY_ROWS or CHECKPOINT_ROW.fullmatch(name):
            continue
        if report["policy"] in ("oracle", "random"):
            continue  # the suite's reference rows: the one with the most episodes is placed
        try:
            checked = check_submission(report, name=name)
        except SubmissionError as error:
            raise SystemExit(f"error: {error}") from None
        row = checked["submission"]
        entries.setdefault((checked["policy"], row["budget"]), {})[row["seed"]] = checked
    return [(policy, budget, by_seed) for (policy, budget), by_seed in entries.items()]


def summary_entries() -> list[tuple[str, str, str, dict[int, dict]]]:
    """Every leaderboard entry as (suite, name, budget, reports by seed).

    Per suite: the oracle, the random policy, DAgger's entries by label target, the RL baselines, then the
    submitted entries.

    A trained entry pools its seeds' final rows (one per seed) at one budget; the rows it pools are in the
    results table. Checkpoints of an RL run (``_at_N``) are points of its curve, not entries, and an active
    method's untrained rows are plain DAgger's untrained learner again, so only plain DAgger's is listed.
    """
    entries = []
    reports = {path.name: load_report(path) for path in sorted(RESULTS.glob("*.json"))}
    dagger, rl = dagger_groups(), rl_groups()
    placed = {name for name in reports if DAGGER_ROW.fullmatch(name) or RL_ROW.fullmatch(name)}
    for suite in SUITE_SPECS:
        entries += _reference_entries(suite, [report for report in reports.values() if report["suite"] == suite])
        ranked = sorted((key for key in dagger if key[0] == suite), key=lambda key: (key[1] != "dagger", key[1:]))
        for key in ranked:
            _, method, learner, target = key
            if method != "dagger" and target == 0:
                continue
            trained_by = "DAgger (plain)" if method == "dagger" else f"DAgger with `{method}` (active)"
            entries.append((suite, f"{trained_by}, {learner} learner", _label_budget(target, dagger[key]), dagger[key]))
        for algorithm, name in RL_NAMES.items():
            for key in sorted(key for key in rl if key[:2] == (suite, algorithm)):
                entries.append((suite, name, _step_budget(rl[key], key[2]), rl[key]))
        entries += [(suite, *entry) for entry in _other_rows(suite, reports, placed)]
    return entries


def summary_table() -> str:
    """Every entry of :func:`summary_entries` with all its figures: the rows page's full summary."""
    lines = [
        "| suite | entry | budget | seeds | successes per seed | success [95% interval] | interval | "
        "training time per seed |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [summary_row(*entry) for entry in summary_entries()]
    return "\n".join(lines)


def seed_ranges(seeds: str) -> str:
    """``"0, 1, 2, 3, 5"`` as ``"0-3, 5"``: runs of consecutive seeds as ranges (blank stays blank)."""
    numbers = [int(seed) for seed in seeds.split(", ")] if seeds else []
    runs: list[list[int]] = []
    for number in numbers:
        if runs and number == runs[-1][-1] + 1:
            runs[-1].append(number)
        else:
            runs.append([number])
    return ", ".join(f"{run[0]}-{run[-1]}" if len(run) > 2 else ", ".join(map(str, run)) for run in runs)


def leaderboard_tables() -> str:
    """The leaderboard page's lead: one compact table per suite (entry, budget, seeds, success and interval).

    Each seed's successes, the interval's kind and the training time are in :func:`summary_table`.
    """
    by_suite: dict[str, list[Entry]] = {}
    for entry in summary_entries():
        by_suite.setdefault(entry[0], []).append(pooled_entry(*entry))
    parts = []
    for suite, entries in by_suite.items():
        spec = SUITE_SPECS[suite]
        lines = [
            f"### `{suite}`",
            "",
            f"`{spec.env_id}`: {spec.n_tasks * spec.episodes_per_task} episodes a row, unless its budget says less.",
            "",
            "| entry | budget | seeds | success [95% interval] |",
            "|---|---|---|---|",
        ]
        lines += [
            f"| {e.name} | {e.budget} | {seed_ranges(e.seeds)} | {_percent(e.rate)} [{100 * e.low:.1f}, "
            f"{100 * e.high:.1f}] |"
            for e in entries
        ]
        parts.append("\n".join(lines))
    return "\n\n".join(parts)


def sign_test_p(ahead: int, behind: int) -> float:
    """The two-sided exact sign test's p-value for ``ahead`` against ``behind`` paired outcomes (ties dropped)."""
    _, upper, lower = sign_test(ahead, ahead + behind, 0.05)  # the claims' one-sided tails, doubled
    return min(1.0, 2 * min(upper, lower))


def paired_table() -> str:
    """Each active method against plain DAgger with the same learner, seed by seed, at each label target.

    A seed is the unit: its two rows share the seed's untrained learner and the suite's evaluation tasks, so
    its difference (the method's success rate minus plain DAgger's, in percentage points) is a paired one; each
    row is the first evaluation at or past the target, so the two label counts differ by a few. The sign test
    counts only how many seeds favour the method (ties dropped); with n seeds its smallest two-sided p is
    2 / 2**n, so 4 seeds cannot reach 0.05 whatever they show. The table asks one question per row, so a row
    is read at 5% only after Holm's correction over all its rows (statsmodels' ``multipletests``): with 6 rows
    a clean sweep needs 8 seeds (2 / 2**8 < 0.05 / 6). Untrained rows (target 0) are left out: both methods'
    are the same learner.
    """
    groups = dagger_groups()
    order = list(SUITE_SPECS)
    lines = [
        "| suite | method against plain DAgger | learner | label target | seeds | difference per seed (points) | "
        "ahead / behind / tied | sign test, two-sided p | Holm-adjusted p | reading |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    pairs = sorted(
        (key for key in groups if key[1] != "dagger" and key[3] > 0 and (key[0], "dagger", *key[2:]) in groups),
        key=lambda key: (order.index(key[0]), key[1:]),
    )
    rows = []
    for suite, method, learner, target in pairs:
        ours, plain = groups[(suite, method, learner, target)], groups[(suite, "dagger", learner, target)]
        seeds = sorted(set(ours) & set(plain))
        differences = [round(100 * (ours[seed]["success_rate"] - plain[seed]["success_rate"])) for seed in seeds]
        ahead, behind = sum(d > 0 for d in differences), sum(d < 0 for d in differences)
        rows.append((suite, method, learner, target, seeds, differences, ahead, behind, sign_test_p(ahead, behind)))
    holm = multipletests([row[-1] for row in rows], method="holm")[1] if rows else []
    for (suite, method, learner, target, seeds, differences, ahead, behind, p), adjusted in zip(
        rows, holm, strict=True
    ):
        if adjusted < 0.05:
            reading = f"{'ahead' if ahead > behind else 'behind'} beyond chance (Holm-adjusted p < 0.05)"
        elif ahead == len(seeds) or behind == len(seeds):
            reading = f"{'ahead' if ahead else 'behind'} on every seed: a direction, not shown at 5%"
        else:
            reading = "mixed, not shown at 5%"
        lines.append(
            f"| `{suite}` | `{method}` | {learner} | {target} | {', '.join(map(str, seeds))} | "
            f"{', '.join(f'{d:+d}' for d in differences)} | {ahead} / {behind} / {len(seeds) - ahead - behind} | "
            f"{p:.3g} | {adjusted:.3g} | {reading} |"
        )
    return "\n".join(lines)


def figure_section() -> str:
    """The figures, drawn by ``antmaze_lab.labels_vs_steps`` from the same reports (points: :func:`points_section`)."""
    images = []
    for suite in FIGURE_SUITES:
        image = (ROOT / figure_path(suite)).relative_to(PAGE.parent).as_posix()
        alt = f"{suite}: success against expert labels (DAgger) and against environment steps (RL baselines)"
        images.append(f"![{alt}]({image})")
    return "\n\n".join(images)


def points_section() -> str:
    """The tables of the figures' points, one per suite."""
    tables = []
    for suite in FIGURE_SUITES:
        points, _ = figure_points(RESULTS, suite)
        tables.append(f"**`{suite}`**\n\n{points_table(points)}")
    return "\n\n".join(tables)


SECTIONS: dict[str, Callable[[], str]] = {
    "suites": suites_table,
    "leaderboard": leaderboard_tables,
    "summary": summary_table,
    "results": results_table,
    "spread": spread_table,
    "paired": paired_table,
    "figure": figure_section,
    "points": points_section,
}
"""The pages' generated sections, by the name ``--section`` takes."""
ON_ROWS_PAGE = ("summary", "results", "spread", "points")
"""The sections on :data:`ROWS_PAGE`; the others are on :data:`PAGE`."""


def page_of(section: str) -> Path:
    """The page that holds ``section``'s generated block."""
    return ROWS_PAGE if section in ON_ROWS_PAGE else PAGE


def main(argv: list[str] | None = None) -> int:
    """Prints the section named by ``--section``; returns the exit status."""
    parser = lab_parser("antmaze_lab.leaderboard", __doc__)
    parser.add_argument("--section", required=True, choices=list(SECTIONS), help="the section of the page to print")
    args = parser.parse_args(argv)
    print(SECTIONS[args.section]())
    return 0


if __name__ == "__main__":
    sys.exit(main())
