"""Tables of the planning-learner pages (issue 50), printed from committed results files.

``python -m antmaze_lab.planning_tables screen FILE``: the grid-level screen (``scripts/planner_check.py``);
``by-path FILE``: success by shortest path length (``scripts/planner_by_path.py``); ``trials FILE [FILE ...]``:
DAgger trials of ``scripts/learner_ablation.py`` (one JSON a trial); ``speed FILE``: ``benchmarks/learner_speed.py``;
``ends FILE``: how the shipped learner's grid rollouts end (``scripts/planner_check.py --shipped-failures``);
``ends-seeds LEARNER:SEED=FILE [...]``: those ends of several learners and training seeds side by side, with each
learner's medians over its seeds;
``tasks ENDS REPORT [REPORT ...]``: those ends on each suite task beside the benchmark reports' episodes;
``labels REPORT [REPORT ...]``: learners' benchmark reports at each label budget beside each suite's oracle report.

A file that is missing, is not JSON, or is not what the table reads (a screen file given to ``ends``, a second
file given to a one-file table), and ``tasks`` or ``trials`` files that do not belong together
(:func:`check_together`, :func:`check_trials`: trials of two bodies, or two of one variant and seed), and
``ends-seeds`` arguments that are not ``LEARNER:SEED=FILE``, one file given twice or files not rolled out alike
(:func:`seed_labels`, :func:`check_seeds`), are refused in one line naming the file or argument, exit status 2.
"""

from __future__ import annotations

import argparse
import json
import shlex
import statistics
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

from antmaze_hirl.experiments.uncertainty import rate_with_interval
from antmaze_lab.commands import command_arguments

MAPS = ("u", "medium", "large", "giant", "point-u", "point-medium", "point-large", "point-giant")


def _rate(successes: int, total: int) -> str:
    figures = rate_with_interval(successes / total, total)
    low, high = figures["wilson_95"]
    return f"{successes}/{total} ({100 * successes / total:.0f}%) [{100 * low:.0f}, {100 * high:.0f}]"


def _median_range(values: list[float]) -> str:
    return f"{100 * statistics.median(values):.0f}% ({100 * min(values):.0f}-{100 * max(values):.0f})"


def _success_cell(parts: list[dict[str, Any]]) -> str:
    """Grid-level success over seeds: median (range), or one seed's tasks solved with a Wilson 95% interval.

    A range over one seed is a single value and says nothing of its spread; the interval needs the tasks, which
    every screen file records (a part without them falls back to the range).
    """
    if len(parts) == 1 and "tasks" in parts[0]:
        tasks = parts[0]["tasks"]
        return _rate(round(parts[0]["success"] * tasks), tasks)
    return _median_range([part["success"] for part in parts])


def screen_table(data: dict[str, Any]) -> str:
    """One row per variant: median (range) over seeds of each grid-level success (one seed: :func:`_success_cell`).

    A table holding both kinds of row ends with a note saying which statistic each kind shows.
    """
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
        cells.append(_success_cell([r["untrained_selection"] for r in rows]))
        cells.append(_success_cell([r["selection"] for r in rows]))
        for name in maps:
            parts = [r[name] for r in rows if "success" in r.get(name, {})]
            cells.append(_success_cell(parts) if parts else "cannot act on the map")
        lines.append("| " + " | ".join(cells) + " |")
    seeds_per_variant = {len(rows) for rows in by_variant.values()}
    if 1 in seeds_per_variant and len(seeds_per_variant) > 1:  # two statistics share the columns: say which is which
        lines += [
            "",
            "One-seed rows give that seed's tasks solved with a Wilson 95% interval; rows of several seeds give the "
            "median (range) of success over seeds. The two are different statistics: compare a row with a row of "
            "its own kind.",
        ]
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


def _where(place: str) -> str:
    """A place of an ends file as its tables name it: the family's selection part, or a map rolled out zero-shot."""
    return "selection part" if place == "selection" else f"`{place}` (zero-shot)"


def ends_table(data: dict[str, Any]) -> str:
    """How the shipped learner's grid rollouts end (``planner_check.py --shipped-failures``), one row a place."""
    rows = data["rows"]
    ends = list(next(iter(rows.values()))["ends"])
    header = ["where", "tasks", *[end.replace("_", " ") for end in ends], "into a wall, paths >= 7 cells"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, row in rows.items():
        long = row["ends_on_paths_of_7_cells_or_more"]
        failed_long = sum(count for end, count in long.items() if end != "success")
        cells = [_where(name), str(row["tasks"]), *[str(row["ends"][end]) for end in ends]]
        if not sum(long.values()):
            cells.append("no such path")
        else:
            cells.append(f"{long['into_wall']} of {failed_long} failures" if failed_long else "no failure")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


ENDS_READ = ("success", "into_wall")
"""The ends ``ends-seeds`` gives first, and takes the median of."""
OTHER_ENDS = ("stay", "past_corner", "timeout")
"""The ends ``ends-seeds`` gives in brackets after success and into a wall, in that order."""


def ends_seeds_table(labels: list[tuple[str, str]], ends: list[dict[str, Any]]) -> str:
    """Per learner and training seed, how its grid rollouts end on each place; then the learner's medians.

    ``labels`` are each file's (learner, seed), ``ends`` the files (``planner_check.py --shipped-failures``), rolled
    out alike (:func:`check_seeds`). A cell is success / into a wall (stay, past a corner, timeout) of the place's
    tasks; a learner's median row gives the medians over its seeds of success and of into a wall, in bold. The
    learners keep the order of their first file, the seeds the order given.
    """
    places = ends[0]["rows"]
    header = ["learner", "seed", *[f"{_where(place)}, {row['tasks']} tasks" for place, row in places.items()]]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    by_learner: dict[str, list[tuple[str, dict[str, Any]]]] = defaultdict(list)
    for (learner, seed), data in zip(labels, ends, strict=True):
        by_learner[learner].append((seed, data))
    for learner, seeds in by_learner.items():
        for seed, data in seeds:
            cells = [f"`{learner}`", seed]
            for place in places:
                counts = data["rows"][place]["ends"]
                other = ", ".join(str(counts[end]) for end in OTHER_ENDS)
                cells.append(f"{counts['success']} / {counts['into_wall']} ({other})")
            lines.append("| " + " | ".join(cells) + " |")
        medians = []
        for place in places:
            counts = [data["rows"][place]["ends"] for _, data in seeds]
            success, wall = (statistics.median(count[end] for count in counts) for end in ENDS_READ)
            medians.append(f"**{success:g} / {wall:g}**")
        lines.append("| " + " | ".join([f"`{learner}`", "**median**", *medians]) + " |")
    lines += [
        "",
        "Each cell: success / into a wall (stay, past a corner, timeout), of the tasks its column names; a median "
        "row gives the medians over the learner's seeds of success and of into a wall.",
    ]
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


def _labels(report: dict[str, Any]) -> int:
    """The label budget of a learner's leaderboard submission (``"300 oracle labels (DAgger)"``: 300)."""
    budget = str((report.get("submission") or {}).get("budget", ""))
    words = budget.split()
    if len(words) < 2 or not words[0].isdigit() or words[1:3] != ["oracle", "labels"]:
        raise ValueError(f"{report['suite']}: {report['policy']} has no label budget (its budget: {budget!r})")
    return int(words[0])


def labels_table(reports: list[dict[str, Any]]) -> str:
    """Per suite: its oracle's success, and a learner's at each label budget with its ratio to the oracle's.

    Each success is given with its Wilson 95% interval; the ratio is of the two point estimates.

    ``reports`` are ``antmaze-hirl benchmark`` reports: one oracle report a suite (``--policy oracle``) and the
    learners' submissions (``--budget "N oracle labels (DAgger)"``), at most one a suite and budget. A learner's
    policy name says "zero-shot" where it played a map it was never trained on.
    """
    oracle: dict[str, dict[str, Any]] = {}
    learners: dict[str, dict[int, dict[str, Any]]] = defaultdict(dict)
    for report in reports:
        suite = report["suite"]
        if report["policy"] == "oracle":
            if suite in oracle:
                raise ValueError(f"two oracle reports of suite {suite!r} (one a suite)")
            oracle[suite] = report
            continue
        labels = _labels(report)
        if labels in learners[suite]:
            raise ValueError(f"two reports of suite {suite!r} at {labels} labels (one a suite and budget)")
        learners[suite][labels] = report
    missing = sorted(set(learners) - set(oracle))
    if missing:
        raise ValueError(f"no oracle report of suite(s) {', '.join(missing)}: the ratio needs one")
    budgets = sorted({labels for by_labels in learners.values() for labels in by_labels})
    header = "| suite | oracle | " + " | ".join(f"{labels:,} labels" for labels in budgets) + " |"
    lines = [header, "|---" * (2 + len(budgets)) + "|"]
    for suite, by_labels in learners.items():
        reference = oracle[suite]
        cells = []
        for labels in budgets:
            report = by_labels.get(labels)
            if report is None:
                cells.append("")
                continue
            ratio = report["success_rate"] / reference["success_rate"] if reference["success_rate"] else float("nan")
            zero_shot = " zero-shot" if "zero-shot" in report["policy"] else ""
            cells.append(f"{_rate(report['successes'], report['episodes'])}: {ratio:.2f}x{zero_shot}")
        oracle_cell = _rate(reference["successes"], reference["episodes"])
        lines.append(f"| `{suite}` | {oracle_cell} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def file_kind(data: Any) -> str:
    """What a results file is, by its fields: one of :data:`TABLE_FILES`' kinds, or ``"unknown"``."""
    if isinstance(data, list) or not isinstance(data, dict):
        return "unknown"
    rows = data.get("rows")
    if str(data.get("format", "")).startswith("antmaze_hirl.benchmark_result/"):
        return "benchmark report"
    if "variant" in data and "trial_seconds" in data:
        return "trial"
    if "learners" in data:
        return "by-path"
    if isinstance(rows, list) and all(isinstance(row, dict) and "variant" in row for row in rows):
        return "screen"
    if isinstance(rows, dict) and rows and all(isinstance(row, dict) for row in rows.values()):
        if all("ends" in row for row in rows.values()):
            return "ends"
        if all("gradient_steps_per_s" in row for row in rows.values()):
            return "speed"
    return "unknown"


TABLE_FILES = {
    "screen": ("screen", None),
    "by-path": ("by-path", None),
    "trials": ("trial", "trial"),
    "speed": ("speed", None),
    "ends": ("ends", None),
    "ends-seeds": ("ends", "ends"),
    "tasks": ("ends", "benchmark report"),
    "labels": ("benchmark report", "benchmark report"),
}
"""Per table: the kind of its first file, and of the files after it (``None``: it reads one file)."""


def _learner(ends: dict[str, Any]) -> str:
    """The learner an ends file scored: ``"shipped"``, or its ``--learner-zip`` (from the command if not recorded)."""
    if "learner" in ends:
        return str(ends["learner"])
    arguments = command_arguments(ends["command"])
    return arguments[arguments.index("--learner-zip") + 1] if "--learner-zip" in arguments else "shipped"


def _policy(report: dict[str, Any]) -> str:
    """The ``--policy`` a benchmark report was scored with (``planner``: the shipped planning learner)."""
    words = shlex.split(report.get("command", ""))
    return words[words.index("--policy") + 1] if "--policy" in words[:-1] else "not recorded"


def check_together(ends: tuple[str, dict[str, Any]], reports: list[tuple[str, dict[str, Any]]]) -> None:
    """Refuses ``tasks`` files that do not belong together, naming them.

    Each report must be of the ends file's body and learner (the shipped learner's ends with ``--policy planner``
    reports, a ``--learner-zip`` file's with that zip), of a suite the ends file rolled out, with as many tasks as
    it rolled out there; the reports must be one run's (one suite each, the same seed and episodes per task).

    Raises:
        ValueError: One line naming the files that do not match, and how.
    """
    ends_name, ends_data = ends
    learner = _learner(ends_data)
    wanted = "planner" if learner == "shipped" else learner
    suites = [name for name, row in ends_data["rows"].items() if "suite_task_ends" in row]
    if not reports:
        raise ValueError(f"tasks needs at least one benchmark report after {ends_name}")
    first_name, first = reports[0]
    seen: dict[str, str] = {}
    for name, report in reports:
        suite, policy = report["suite"], _policy(report)
        if report["body"] != ends_data["body"]:
            raise ValueError(f"{name} is a {report['body']} report, {ends_name} holds {ends_data['body']} rollouts")
        if policy != wanted and Path(policy) != Path(wanted):
            raise ValueError(f"{name} scored --policy {policy}, {ends_name} rolled out the {learner} learner")
        if suite not in suites:
            raise ValueError(f"{name} scores suite {suite!r}, {ends_name} rolled out {', '.join(suites) or 'no suite'}")
        if len(report["tasks"]) != len(ends_data["rows"][suite]["suite_task_ends"]):
            raise ValueError(
                f"{name} has {len(report['tasks'])} tasks of {suite!r}, {ends_name} rolled out "
                f"{len(ends_data['rows'][suite]['suite_task_ends'])}"
            )
        for key in ("seed", "episodes_per_task"):
            if report.get(key) != first.get(key):
                raise ValueError(
                    f"{name} has {key} {report.get(key)}, {first_name} {first.get(key)} (one run's reports)"
                )
        if suite in seen:
            raise ValueError(f"{seen[suite]} and {name} both score suite {suite!r} (one report a suite)")
        seen[suite] = name


def check_trials(trials: list[tuple[str, dict[str, Any]]]) -> None:
    """Refuses ``trials`` files whose rows could not be told apart or read against each other, naming them.

    The files must be of one body: its selection mazes are what the rows' success is measured on, so a point
    row beside an ant row compares nothing (the table has no body column, and each page's table is one body's).
    No two files may be the same variant and seed (two runs of one trial: their rows would differ in nothing the
    table names).

    Raises:
        ValueError: One line naming the files that do not belong together, and how.
    """
    first_name, first = trials[0]
    seen: dict[tuple[str, int], str] = {}
    for name, trial in trials:
        if trial.get("body") != first.get("body"):
            bodies = f"{name} is the {trial.get('body')}'s trial, {first_name} the {first.get('body')}'s"
            raise ValueError(f"{bodies} (one body a table)")
        key = (trial["variant"], trial["seed"])
        if key in seen:
            raise ValueError(f"{seen[key]} and {name} are both variant {key[0]} seed {key[1]} (one file a trial)")
        seen[key] = name


def seed_labels(arguments: list[str]) -> list[tuple[str, str, Path]]:
    """Each ``LEARNER:SEED=FILE`` argument of ``ends-seeds`` as (learner, seed, file).

    The labels are given, not read: an ends file records the learner's zip, not its variant or training seed. The
    file is what follows the first ``=``, the learner what precedes the first ``:``; neither label may be empty, and
    each is read without the spaces around it (``switch :0`` is ``switch:0``).

    Raises:
        ValueError: One line naming the argument that is not of that form, the two files of one learner and seed,
            or the file given twice (the same file however spelt: one run counted as two).
    """
    labelled: list[tuple[str, str, Path]] = []
    seen: dict[tuple[str, str], str] = {}
    files: dict[Path, tuple[str, str]] = {}
    for argument in arguments:
        label, equals, path = argument.partition("=")
        learner, colon, seed = (part.strip() for part in label.partition(":"))
        if not (equals and colon and learner and seed and path):
            raise ValueError(f"ends-seeds reads LEARNER:SEED=FILE arguments, got {argument!r}")
        if (learner, seed) in seen:
            raise ValueError(
                f"{seen[learner, seed]} and {path} are both learner {learner} seed {seed} (one file a seed)"
            )
        if (file := Path(path).resolve()) in files:
            first_path, first_label = files[file]
            raise ValueError(f"{first_path} is given twice (as {first_label} and {learner}:{seed}; one file a seed)")
        seen[learner, seed] = path
        files[file] = (path, f"{learner}:{seed}")
        labelled.append((learner, seed, Path(path)))
    return labelled


def _rolled_out(ends: dict[str, Any]) -> str:
    """What an ends file rolled out: its body, and each place with its tasks (``ant: selection 200, ...``)."""
    return f"{ends['body']}: " + ", ".join(f"{place} {row['tasks']}" for place, row in ends["rows"].items())


def check_seeds(files: list[tuple[str, dict[str, Any]]]) -> None:
    """Refuses ``ends-seeds`` files that were not rolled out alike, naming them.

    The files must be of one body, with the same places in the same order and as many tasks on each: the table
    sets them in one column a place, and a median over seeds of counts out of different totals is no count.

    Raises:
        ValueError: One line naming the file that differs from the first, and both files' places and tasks.
    """
    first_name, first = files[0]
    for name, ends in files[1:]:
        if _rolled_out(ends) != _rolled_out(first):
            raise ValueError(
                f"{name} rolled out {_rolled_out(ends)}; {first_name} {_rolled_out(first)} (one body, places and "
                "tasks a table)"
            )


def load_files(table: str, paths: list[Path]) -> list[Any]:
    """The files of ``table``, each checked to be the kind it reads (:data:`TABLE_FILES`).

    Raises:
        ValueError: One line naming the file that is missing, not JSON or of another kind, or the files'
            count if the table reads one.
    """
    head, rest = TABLE_FILES[table]
    if rest is None and len(paths) != 1:
        raise ValueError(f"{table} reads one {head} file, got {len(paths)}: {' '.join(map(str, paths))}")
    if table == "tasks" and len(paths) < 2:
        raise ValueError(f"tasks reads an ends file and at least one benchmark report, got {' '.join(map(str, paths))}")
    loaded = []
    for index, path in enumerate(paths):
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ValueError(f"{path}: no such file") from None
        except json.JSONDecodeError as error:
            raise ValueError(f"{path} is not JSON: {error}") from None
        except UnicodeDecodeError:
            raise ValueError(f"{path} is not a text (JSON) file") from None
        except OSError as error:  # a folder, no permission: named, not a traceback
            raise ValueError(f"{path}: {error.strerror or error}") from None
        wanted = head if index == 0 or table == "trials" else rest
        if file_kind(data) != wanted:
            raise ValueError(f"{path} is of kind {file_kind(data)!r}; {table} reads {wanted!r} files here")
        loaded.append(data)
    return loaded


def main(argv: list[str] | None = None) -> int:
    """Prints the table named by the first argument from the files after it; a bad file: one line, exit 2."""
    parser = argparse.ArgumentParser(prog="python -m antmaze_lab.planning_tables", description=__doc__.splitlines()[0])
    parser.add_argument("table", choices=tuple(TABLE_FILES), help="the table to print (required)")
    parser.add_argument("files", nargs="+", help="its results files, as the module's description gives them (required)")
    args = parser.parse_args(argv)
    try:
        labelled = seed_labels(args.files) if args.table == "ends-seeds" else []
        paths = [path for *_, path in labelled] if labelled else [Path(file) for file in args.files]
        loaded = load_files(args.table, paths)
        if args.table == "tasks":
            check_together(
                (str(args.files[0]), loaded[0]), list(zip(map(str, args.files[1:]), loaded[1:], strict=True))
            )
        if args.table in ("trials", "ends-seeds"):
            check = check_trials if args.table == "trials" else check_seeds
            check(list(zip(map(str, paths), loaded, strict=True)))
        print(build(args.table, loaded, [(learner, seed) for learner, seed, _ in labelled]))
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except (KeyError, IndexError, TypeError) as error:  # a file of the right kind that lacks a field
        print(f"error: {' '.join(map(str, args.files))}: a field is missing or malformed ({error!r})", file=sys.stderr)
        return 2
    return 0


def build(table: str, loaded: list[Any], labels: list[tuple[str, str]] | None = None) -> str:
    """The Markdown of ``table`` from its loaded files (``ends-seeds``: and each file's (learner, seed) labels)."""
    if table == "ends-seeds":
        return ends_seeds_table(labels or [], loaded)
    if table == "screen":
        return screen_table(loaded[0])
    if table == "speed":
        return speed_table(loaded[0])
    if table == "tasks":
        return tasks_table(loaded[0], loaded[1:])
    if table == "ends":
        return ends_table(loaded[0])
    if table == "by-path":
        return by_path_table(loaded[0])
    if table == "labels":
        return labels_table(loaded)
    return trials_table(loaded)


if __name__ == "__main__":
    sys.exit(main())
