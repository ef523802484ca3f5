"""The points of the leaderboard's figure: success on ``point5`` against expert labels and environment steps.

Read from committed ``antmaze-hirl benchmark --json`` reports (nothing typed in) by ``scripts/labels_vs_steps.py``,
which draws the figure, and ``scripts/leaderboard.py``, which lists the points under it on ``docs/leaderboard.md``:
the DAgger rows at their labels (``training.labels``; 0 is the untrained learner), the RL rows at their training
steps (``training.steps_reached``, or ``training.high_level_steps`` for the older PPO row). The random policy and
the oracle are reference lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from antmaze_hirl.experiments.benchmark import load_report

SUITE = "point5"
"""The suite the figure plots."""
FIGURE = Path("docs") / "images" / "point5_labels_vs_steps.png"
"""The figure's file, relative to the repository root."""


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


def figure_points(reports: Path) -> tuple[list[Point], dict[str, float]]:
    """The points of the figure, and the reference lines (``{"random": rate, "oracle": rate}``) of ``point5``.

    Args:
        reports: The folder of committed ``antmaze-hirl benchmark --json`` reports; each ``point5_*.json`` of
            100 episodes or more is a point or a line, the others are left out.
    """
    points, lines = [], {}
    for path in sorted(reports.glob(f"{SUITE}_*.json")):
        report = load_report(path)
        if report["suite"] != SUITE or report["episodes"] < 100:
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
    """The plotted points as a Markdown table (the leaderboard page prints it under the figure)."""
    lines = ["| series | x | success [95% Wilson] | file |", "|---|---|---|---|"]
    for point in points:
        rate = point.successes / point.episodes
        lines.append(
            f"| {point.series} | {point.x:,} {point.x_kind} | {point.successes}/{point.episodes} = {100 * rate:.1f}% "
            f"[{100 * point.low:.1f}%, {100 * point.high:.1f}%] | `{point.file}` |"
        )
    return "\n".join(lines)
