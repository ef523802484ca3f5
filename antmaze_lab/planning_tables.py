"""Tables of the planning-learner pages (issue 50), printed from committed results files.

``python -m antmaze_lab.planning_tables screen FILE``: the grid-level screen (``scripts/planner_check.py``);
``by-path FILE``: success by shortest path length (``scripts/planner_by_path.py``); ``trials FILE [FILE ...]``:
DAgger trials of ``scripts/learner_ablation.py`` (one JSON a trial); ``speed FILE``: ``benchmarks/learner_speed.py``;
``ends FILE``: how the shipped learner's grid rollouts end (``scripts/planner_check.py --shipped-failures``);
``tasks ENDS REPORT [REPORT ...]``: those ends on each suite task beside the benchmark reports' episodes.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

from antmaze_hirl.experiments.uncertainty import rate_with_interval

MAPS = ("u", "medium", "large", "giant", "point-u", "point-medium", "point-large", "point-giant")


def _rate(successes: int, total: int) -> str:
    figures = rate_with_interval(successes / total, total)
    low, high = figures["wilson_95"]
    return f"{successes}/{total} ({100 * successes / total:.0f}%) [{100 * low:.0f}, {100 * high:.0f}]"


def _median_range(values: list[float]) -> str:
    return f"{100 * statistics.median(values):.0f}% ({100 * min(values):.0f}-{100 * max(values):.0f})"


def screen_table(data: dict[str, Any]) -> str:
    """One row per variant: median (range) over seeds of each grid-level success."""
    by_variant: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for row in data["rows"]:
        by_variant[row["variant"]].append(row)
    maps = [name for name in MAPS if any(name in row for row in data["rows"])]
    larger = sorted(
        {key for row in data["rows"] for key in row if key.startswith("selection_")},
        key=lambda key: int(key.removeprefix("selection_").split("x")[0]),  # 6x6 before 10x10
    )
    maps = [*larger, *maps]  # larger random selection mazes (planner_check --selection-sizes), then fixed maps
    header = [
        "variant",
        "seeds",
        "labels",
        "untrained (selection)",
        "trained (selection)",
        *[f"{m.removeprefix('selection_')} selection zero-shot" if m in larger else f"{m} zero-shot" for m in maps],
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for variant, rows in by_variant.items():
        cells = [f"`{variant}`", ",".join(str(r["seed"]) for r in rows), str(rows[0]["labels"])]
        cells.append(_median_range([r["untrained_selection"]["success"] for r in rows]))
        cells.append(_median_range([r["selection"]["success"] for r in rows]))
        for name in maps:
            values = [r[name]["success"] for r in rows if "success" in r.get(name, {})]
            cells.append(_median_range(values) if values else "cannot act on the map")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def by_path_table(data: dict[str, Any]) -> str:
    """Success by shortest path (cells) of each learner on the same mazes, with the all-mazes rate."""
    lengths = sorted({o["path_cells"] for row in data["learners"].values() for o in row["outcomes"]})
    header = ["learner", "all mazes [95% Wilson]", *[f"{n} cells" for n in lengths]]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, row in data["learners"].items():
        outcomes = row["outcomes"]
        cells = [f"`{name}`", _rate(sum(o["success"] for o in outcomes), len(outcomes))]
        for n in lengths:
            chosen = [o["success"] for o in outcomes if o["path_cells"] == n]
            cells.append(f"{sum(chosen)}/{len(chosen)}" if chosen else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def trials_table(trials: list[dict[str, Any]]) -> str:
    """One row per DAgger trial: untrained and final selection success with intervals, labels, minutes."""
    header = ["variant", "seed", "untrained (selection)", "after 100 episodes (selection)", "labels", "trial minutes"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for trial in sorted(trials, key=lambda t: (t["variant"], t["seed"])):
        cells = [f"`{trial['variant']}`", str(trial["seed"])]
        for key in ("untrained_selection_success", "selection_success"):
            figures = trial.get(key)
            if figures is None:
                cells.append("-")
                continue
            low, high = figures["wilson_95"]
            cells.append(f"{100 * figures['rate']:.0f}% [{100 * low:.0f}, {100 * high:.0f}]")
        cells += [str(trial["labels"]), f"{trial['trial_seconds'] / 60:.0f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def speed_table(data: dict[str, Any]) -> str:
    """One row per learner (and per map it was moved to): grid, rounds, gradient steps/s, batch-1 forward."""
    rows = data["rows"]
    first = next(iter(rows))
    header = ["learner", "grid", "rounds", "gradient steps/s", f"ratio to `{first}`", "batch-1 forward (ms)", "ratio"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, row in rows.items():
        cells = [
            f"`{name}`",
            f"{row['grid_size']}x{row['grid_size']}",
            str(row["planning_rounds"]),
            f"{row['gradient_steps_per_s']:.1f}",
            f"{row['gradient_steps_per_s'] / rows[first]['gradient_steps_per_s']:.2f}x",
            f"{row['batch1_forward_ms']:.2f}",
            f"{row['batch1_forward_ms'] / rows[first]['batch1_forward_ms']:.2f}x",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def ends_table(data: dict[str, Any]) -> str:
    """How the shipped learner's grid rollouts end (``planner_check.py --shipped-failures``), one row a place."""
    rows = data["rows"]
    ends = list(next(iter(rows.values()))["ends"])
    header = ["where", "tasks", *[end.replace("_", " ") for end in ends], "into a wall, paths >= 7 cells"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, row in rows.items():
        long = row["ends_on_paths_of_7_cells_or_more"]
        failed_long = sum(count for end, count in long.items() if end != "success")
        where = "selection part" if name == "selection" else f"`{name}` (zero-shot)"
        cells = [where, str(row["tasks"]), *[str(row["ends"][end]) for end in ends]]
        if not sum(long.values()):
            cells.append("no such path")
        else:
            cells.append(f"{long['into_wall']} of {failed_long} failures" if failed_long else "no failure")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def tasks_table(ends: dict[str, Any], reports: list[dict[str, Any]]) -> str:
    """Per suite task: how the shipped learner's grid rollout ends, beside its benchmark report's episodes.

    ``ends`` is ``planner_check.py --shipped-failures`` output; ``reports`` are ``antmaze-hirl benchmark`` reports
    of the same learner (``--policy planner``), one a suite.
    """
    lines = ["| suite | task | grid rollout | env successes | env flips |", "|---|---|---|---|---|"]
    for report in reports:
        suite = report["suite"]
        by_task: dict[int, list[dict[str, Any]]] = defaultdict(list)
        for episode in report["episode_outcomes"]:
            by_task[episode["task_id"]].append(episode)
        for task, end in enumerate(ends["rows"][suite]["suite_task_ends"]):
            played = by_task[task]
            successes, flips = sum(e["success"] for e in played), sum(e["flipped"] for e in played)
            lines.append(f"| `{suite}` | {task} | {end.replace('_', ' ')} | {successes}/{len(played)} | {flips} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Prints the table named by the first argument from the files after it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("table", choices=("screen", "by-path", "trials", "speed", "ends", "tasks"))
    parser.add_argument("files", type=Path, nargs="+")
    args = parser.parse_args(argv)
    loaded = [json.loads(path.read_text()) for path in args.files]
    if args.table == "screen":
        print(screen_table(loaded[0]))
    elif args.table == "speed":
        print(speed_table(loaded[0]))
    elif args.table == "tasks":
        print(tasks_table(loaded[0], loaded[1:]))
    elif args.table == "ends":
        print(ends_table(loaded[0]))
    elif args.table == "by-path":
        print(by_path_table(loaded[0]))
    else:
        print(trials_table(loaded))
    return 0


if __name__ == "__main__":
    sys.exit(main())
