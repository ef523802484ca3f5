"""The points of the leaderboard's figures: success on a family suite against expert labels and environment steps.

One figure per suite of :data:`SUITES` (``point5`` and ``ant4``, the suites both DAgger and the RL baselines
are scored on). Read from committed ``antmaze-hirl benchmark --json`` reports (nothing typed in) by
``scripts/labels_vs_steps.py``, which draws the figures, and ``antmaze_lab.leaderboard``, which lists the points:
the DAgger rows at their labels (``training.labels``; 0 is the untrained learner), the RL rows at their training
steps (``training.steps_reached``, or ``training.high_level_steps`` for the older PPO row). The random policy and
the oracle are reference lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from antmaze_hirl.experiments.benchmark import load_report

SUITES = ("point5", "ant4")
"""The suites with a figure: the held-out families both DAgger and the RL baselines train for."""


def figure_path(suite: str) -> Path:
    """The figure of ``suite``, relative to the repository root.

    Raises:
        ValueError: For a suite without a figure (not in :data:`SUITES`).
    """
    if suite not in SUITES:
        raise ValueError(f"suite {suite!r} has no labels-against-steps figure; choose from {list(SUITES)}")
    return Path("docs") / "images" / f"{suite}_labels_vs_steps.png"


@dataclass(frozen=True)
class Point:
    """One plotted report.

    Attributes:
        series: The legend entry.
        x: Labels or training steps.
        x_kind: ``"labels"``, ``"high-level steps"`` or ``"body steps"``.
        successes: Successful episodes.
        episodes: Episodes scored.
        low: Wilson interval's lower end.
        high: Its upper end.
        file: The report's file name.
    """

    series: str
    x: int
    x_kind: str
    successes: int
    episodes: int
    low: float
    high: float
    file: str


def figure_points(reports: Path, suite: str = "point5") -> tuple[list[Point], dict[str, float]]:
    """The points of ``suite``'s figure, and its reference lines (``{"random": rate, "oracle": rate}``).

    Args:
        reports: The folder of committed ``antmaze-hirl benchmark --json`` reports; each ``<suite>_*.json`` of
            100 episodes or more is a point or a line, the others are left out.
        suite: A suite of :data:`SUITES`.

    Raises:
        ValueError: For a suite without a figure.
    """
    figure_path(suite)  # validates the suite
    points, lines = [], {}
    for path in sorted(reports.glob(f"{suite}_*.json")):
        report = load_report(path)
        if report["suite"] != suite or report["episodes"] < 100:
            continue
        if report["policy"] in ("oracle", "random"):
            lines[report["policy"]] = report["success_rate"]
            continue
        training = report.get("training", {})
        if "labels" in training:
            seed = report["policy"].split("seed ")[1].split(",")[0]
            # One series per learner and seed: the learners differ in prior, so their curves are not pooled.
            learner = training.get("learner", "generic")
            # An active method's curve is its own series (reports from before --method are plain DAgger's).
            method = training.get("method", "dagger")
            trainer = "DAgger (plain)" if method == "dagger" else f"DAgger with `{method}`"
            series, x, kind = f"{trainer}, {learner} learner, seed {seed}", training["labels"], "labels"
        elif "algorithm" in training:
            x = training.get("steps_reached", training.get("high_level_steps"))
            seed = training.get("seed", 0)  # one series per seed, as for DAgger: a run's curve is one draw
            if training["algorithm"] == "flat-sac-her":
                series, kind = f"flat SAC+HER, no hierarchy, seed {seed}", "body steps"
            else:
                mazes = training.get("num_envs", 1)  # the older PPO row trained on one maze at a time
                algorithm = training["algorithm"].upper()
                series = f"SB3 {algorithm} on the high level, {mazes} maze{'s' * (mazes > 1)}, seed {seed}"
                kind = "high-level steps"
        else:
            continue
        low, high = report["wilson_95"]
        points.append(Point(series, int(x), kind, report["successes"], report["episodes"], low, high, path.name))
    points.sort(key=lambda point: (point.x_kind != "labels", point.series, point.x))
    return points, lines


def points_table(points: list[Point]) -> str:
    """The plotted points as a Markdown table (``docs/results/leaderboard-rows.md`` prints one per suite)."""
    lines = ["| series | x | success [95% Wilson] | file |", "|---|---|---|---|"]
    for point in points:
        rate = point.successes / point.episodes
        lines.append(
            f"| {point.series} | {point.x:,} {point.x_kind} | {point.successes}/{point.episodes} = {100 * rate:.1f}% "
            f"[{100 * point.low:.1f}%, {100 * point.high:.1f}%] | `{point.file}` |"
        )
    return "\n".join(lines)
