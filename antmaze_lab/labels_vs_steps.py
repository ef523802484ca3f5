"""The leaderboard's figures: success on ``point5`` and ``ant4`` against expert labels and environment steps.

Every point is one committed ``antmaze-hirl benchmark --json`` report in ``results/leaderboard/``
(nothing typed in): the DAgger rows at their labels (``training.labels``; 0 is the untrained learner), the
RL rows at their training steps (``training.steps_reached``, or ``training.high_level_steps`` for the older
PPO row): high-level steps (subgoals) for PPO and SAC on the high level, body steps for the flat SAC+HER.
Each point carries its 95% Wilson interval over the suite's 100 tasks. The random policy and the oracle are
horizontal lines. The x axis is logarithmic (``symlog``: linear below 1, so the 0-label learners show).

One expert label and one high-level environment step are both one subgoal chosen in one maze state, which
is why they share the axis; a body step is a 50th of a subgoal's walk or less.

The points come from :func:`figure_points`; ``python -m antmaze_lab.leaderboard --section points`` lists them
too.

Usage: python -m antmaze_lab.labels_vs_steps [--suite point5|ant4]   (default both; writes
docs/images/<suite>_labels_vs_steps.png and prints its points)
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.experiments.benchmark import load_report
from antmaze_lab.tables import lab_parser

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "leaderboard"

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


def series_colours(series: list[str], plt: Any) -> dict[str, Any]:
    """A colour per series: each method (the series less ``, seed N``) its own tab10 hue, each seed a shade of it.

    Hues are tab10's ten, one per method in order of first appearance, so no two methods share or neighbour a
    hue (a shared tab20 had paired hues across methods; sequential maps such as Reds and RdPu came out alike).
    A method's seeds run from a darker to a lighter shade of its hue.
    """
    families: dict[str, list[str]] = {}
    for name in dict.fromkeys(series):
        families.setdefault(name.split(", seed ")[0], []).append(name)
    hues = plt.get_cmap("tab10").colors
    colours = {}
    for index, members in enumerate(families.values()):
        hue = np.asarray(hues[index % len(hues)])
        # Negative: mixed with black; positive: mixed with white. Kept within +-0.35 so a shade stays its hue.
        for mix, name in zip(
            np.linspace(-0.35, 0.35, len(members)) if len(members) > 1 else [0.0], members, strict=True
        ):
            target = np.ones(3) if mix > 0 else np.zeros(3)
            colours[name] = tuple(hue + abs(mix) * (target - hue))
    return colours


def draw(points: list[Point], lines: dict[str, float], path: Path, suite: str) -> None:
    """Plots ``suite``'s ``points`` (success with Wilson bars against a symlog x) and reference lines into ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(12, 5.2))
    markers = {"labels": "o", "high-level steps": "s", "body steps": "^"}
    colours = series_colours([point.series for point in points], plt)
    for series in dict.fromkeys(point.series for point in points):
        mine = [point for point in points if point.series == series]
        xs = [point.x for point in mine]
        ys = [point.successes / point.episodes for point in mine]
        # Clipped at 0: the Wilson ends of 0/n and n/n can differ from the rate in the last bit.
        errors = [[max(y - point.low, 0.0) for y, point in zip(ys, mine, strict=True)]]
        errors.append([max(point.high - y, 0.0) for y, point in zip(ys, mine, strict=True)])
        kind = mine[0].x_kind
        # The untrained point (x = 0) sits in symlog's linear part: joined by a dotted line, not the curve's.
        colour = colours[series]
        axes.errorbar(
            xs,
            ys,
            yerr=errors,
            marker=markers[kind],
            capsize=3,
            linestyle="none",
            color=colour,
            label=f"{series} (x: {kind})",
        )
        trained = [(x, y) for x, y in zip(xs, ys, strict=True) if x > 0]
        if trained:
            axes.plot(*zip(*trained, strict=True), color=colour)
        if xs[0] == 0 and trained:
            axes.plot([0, trained[0][0]], [ys[0], trained[0][1]], color=colour, linestyle=":", linewidth=1)
    for name, rate in sorted(lines.items()):
        axes.axhline(rate, linestyle="--" if name == "oracle" else ":", color="grey", linewidth=1)
        axes.annotate(f"{name} {100 * rate:.0f}%", (1, rate), xytext=(2, 3), textcoords="offset points", fontsize=8)
    axes.set_xscale("symlog", linthresh=1)
    axes.set_xlim(0, 3 * max(point.x for point in points))
    axes.set_ylim(-0.02, 1.05)
    axes.set_xlabel("expert labels (imitation) / training environment steps (reward), log scale")
    axes.set_ylabel(f"success on {suite} (100 held-out tasks)")
    axes.set_title(f"{suite}: success against expert labels and against environment steps (95% Wilson)")
    # Beside the axes, not on them: inside, it hid the DAgger curves.
    axes.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    axes.grid(True, which="major", alpha=0.3)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(figure)


def main(argv: list[str] | None = None) -> int:
    """Draws the figure of each suite asked for and prints its points; returns the exit status."""
    parser = lab_parser("antmaze_lab.labels_vs_steps", __doc__)
    parser.add_argument("--suite", choices=SUITES, default=None, help="one suite's figure (default: every suite's)")
    args = parser.parse_args(argv)
    for suite in [args.suite] if args.suite else SUITES:
        points, lines = figure_points(RESULTS, suite)
        draw(points, lines, ROOT / figure_path(suite), suite)
        print(points_table(points))
        print(f"wrote {ROOT / figure_path(suite)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
