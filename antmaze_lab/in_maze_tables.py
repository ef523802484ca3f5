"""Tables of the ant in mazes, printed from committed results files.

Pages: ``docs/results/ant-in-mazes.md`` (``antmaze_lab.in_maze`` and ``antmaze_lab.select_low_level`` files).

``python -m antmaze_lab.in_maze_tables SECTION`` prints one generated block (``--list`` names them):
``in-maze-stage6``, ``selection-stage6``, ``selection-ensembles``, ``selection-stage3``, ``selection-stage3-later``,
``selection-held-out``, ``candidates``, ``selection-tilt``, ``in-maze-tilt``, ``algorithms``, ``smoothing``,
``flip-diagnostics``, ``flip-warning``. Loading, formatting and the command are :mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import itertools
import re
import shlex
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from antmaze_lab import tables
from antmaze_lab.commands import command_arguments
from antmaze_lab.tables import (
    Sections,
    families,
    load,
    percent,
    rate_cell,
    rate_cell_of,
    selection_oracle,
    share,
    success,
    table,
)

SECTIONS = Sections("antmaze_lab.in_maze_tables", __doc__)
"""Each generated block's builder, by the section name the command line takes."""

FAMILIES = ("ant3", "ant4", "u", "medium", "large")


FAMILY_LABELS = {
    "ant3": "ant3 (3x3, 500 steps)",
    "ant4": "ant4 (4x4 held-out layouts, 500 steps)",
    "u": "u",
    "medium": "medium",
    "large": "large",
}


FAMILY_GOALS = {"ant4": 0.95, "u": 0.90, "medium": 0.90, "large": 0.90}
"""The in-maze success goals per family (the oracle driving the shipped ant); ant3 has none (held out by seed only)."""


def share_range(values: Sequence[float]) -> str:
    """``"0.55-2.10%"``: the lowest and highest of ``values`` as shares."""
    return f"{100 * min(values):.2f}-{100 * max(values):.2f}%"


def seconds_per_step(family: dict[str, Any]) -> float:
    """Wall seconds per mean episode step (the files time a family, not a step)."""
    return family["seconds"] / family["mean_low_level_steps"]


def goal_cell(name: str, family: dict[str, Any]) -> str:
    """The in-maze goal for ``name`` and whether the row's rate meets it."""
    if name not in FAMILY_GOALS:
        return "held out by seed only"
    goal = FAMILY_GOALS[name]
    return f">= {percent(goal, 100)}: {'met' if family['success_rate'] >= goal else 'not met'}"


def in_maze_pair(name: str, new_row: str, old_row: str, new_name: str, old_name: str) -> str:
    """Two low levels of one in-maze run side by side, per family, then their flips over every episode."""
    results = load(name)
    new, old = families(results, new_row), families(results, old_row)
    header = [
        "family",
        f"{new_name} [95% Wilson]",
        "flips, frozen, timeouts",
        "flips / subgoal",
        "mean episode steps",
        f"{old_name} [95% Wilson]",
        "flips, frozen, timeouts",
        "flips / subgoal",
        "mean episode steps",
        f"success ratio ({new_name} / {old_name})",
        "time per step ratio",
        "in-maze goal",
    ]
    rows = []
    for family in FAMILIES:
        a, b = new[family], old[family]
        rows.append(
            [
                FAMILY_LABELS[family],
                success(a),
                f"{a['flips']}, {a['frozen']}, {a['timeouts']}",
                share(a["flips_per_subgoal"]),
                f"{a['mean_low_level_steps']:.0f}",
                success(b),
                f"{b['flips']}, {b['frozen']}, {b['timeouts']}",
                share(b["flips_per_subgoal"]),
                f"{b['mean_low_level_steps']:.0f}",
                f"{a['success_rate'] / b['success_rate']:.2f}",
                f"{seconds_per_step(a) / seconds_per_step(b):.2f}",
                goal_cell(family, a),
            ]
        )
    episodes = sum(new[family]["episodes"] for family in FAMILIES)
    rows.append(
        [
            f"all {episodes} episodes",
            "",
            f"{sum(new[f]['flips'] for f in FAMILIES)} flips",
            share_range([new[f]["flips_per_subgoal"] for f in FAMILIES]),
            "",
            "",
            f"{sum(old[f]['flips'] for f in FAMILIES)} flips",
            share_range([old[f]["flips_per_subgoal"] for f in FAMILIES]),
            "",
            "",
            "",
            "",
        ]
    )
    return table(header, rows)


@dataclass(frozen=True)
class InMazeRow:
    """One low level (at one smoothing) of one in-maze file, as a table row names it."""

    label: str
    file: str
    row: str


def in_maze_rows(rows: Sequence[InMazeRow], with_file: bool = False) -> str:
    """One row per low level: per-family success, the flips' range per subgoal and total, ant4's walk."""
    header = ["low level", *(["file"] if with_file else []), *FAMILIES]
    header += ["flips / subgoal", "flips (episodes)", "ant4 mean steps", "ant4 timeouts"]
    lines = []
    for spec in rows:
        outcome = families(load(spec.file), spec.row)
        run = [name for name in FAMILIES if name in outcome]
        cells = [success(outcome[name]) if name in outcome else "not run" for name in FAMILIES]
        ant4 = outcome.get("ant4")
        lines.append(
            [
                spec.label,
                *([f"`{spec.file}`"] if with_file else []),
                *cells,
                share_range([outcome[name]["flips_per_subgoal"] for name in run]),
                f"{sum(outcome[name]['flips'] for name in run)} ({sum(outcome[name]['episodes'] for name in run)})",
                f"{ant4['mean_low_level_steps']:.0f}" if ant4 else "not run",
                ant4["timeouts"] if ant4 else "not run",
            ]
        )
    return table(header, lines)


def in_maze_columns(name: str, columns: Sequence[tuple[str, str]]) -> str:
    """Several low levels of one in-maze run as columns (label, row), one row per family."""
    results = load(name)
    outcomes = [(label, families(results, row)) for label, row in columns]
    lines = []
    for family in FAMILIES:
        cells = []
        for _, outcome in outcomes:
            f = outcome[family]
            cells.append(f"{success(f)}; {f['flips']} flips, {f['timeouts']} timeouts")
        lines.append([family, *cells])
    lines.append(
        ["flips / subgoal", *(share_range([o[f]["flips_per_subgoal"] for f in FAMILIES]) for _, o in outcomes)]
    )
    lines.append(
        [
            "mean episode steps",
            *(", ".join(f"{o[f]['mean_low_level_steps']:.0f}" for f in FAMILIES) for _, o in outcomes),
        ]
    )
    return table(["family", *(f"{label} [95% Wilson]" for label, _ in outcomes)], lines)


def selection(name: str, rows: Sequence[tuple[str, str]], extra: str | None = None) -> str:
    """Selection rows (label, key in ``scores``): eval-low, the select4/select6 oracle success, flips, score.

    ``extra`` names a column written with the labels (``label`` is then ``"text|extra"``): the heads of an
    ensemble, say, which the file does not record.
    """
    results = load(name)
    episodes, mazes = results.get("settings", "episodes"), results.get("settings", "mazes")
    header = ["row", *([extra] if extra else []), f"eval-low ({episodes})", f"select4 ({mazes})", f"select6 ({mazes})"]
    header += ["flips / subgoal (4x4, 6x6)", "score"]
    best = results.get("best")
    lines = []
    for label, key in rows:
        row = results.get("scores", key)
        text, _, more = label.partition("|")
        flips = row["flips_per_subgoal"]
        lines.append(
            [
                f"{text}{' (the best row)' if key == best else ''}",
                *([more] if extra else []),
                rate_cell_of(row["eval_low"], episodes),
                rate_cell_of(row["success"]["select4"], mazes),
                rate_cell_of(row["success"]["select6"], mazes),
                f"{share(flips['select4'])}, {share(flips['select6'])}",
                f"{row['score']:.3f}",
            ]
        )
    return table(header, lines)


SNAPSHOT = re.compile(r"(?:.*/)?(?P<run>[^/]+)/snapshots/step_(?P<steps>\d+)\.zip")


def snapshot_label(key: str) -> str:
    """``train_runs/ant_maze/snapshots/step_700000.zip smoothing=0.5`` -> ``ant_maze 700k, smoothing 0.5``."""
    path, _, smoothing = key.partition(" smoothing=")
    match = SNAPSHOT.fullmatch(path)
    label = f"`{match['run']}` {int(match['steps']) // 1000}k" if match else f"`{path}`"
    return f"{label}, smoothing {smoothing}" if smoothing else label


def selection_ranked(name: str, keys: Sequence[str] | None = None, labels: dict[str, str] | None = None) -> str:
    """The selection rows ``keys`` (default: all) of a file, best score first, labelled by run and snapshot."""
    results = load(name)
    scores = results.get("scores")
    chosen = list(scores) if keys is None else list(keys)
    chosen.sort(key=lambda key: -scores[key]["score"])
    names = labels or {}
    return selection(name, [(names.get(key, snapshot_label(key)), key) for key in chosen])


@SECTIONS.add("selection-held-out")
def selection_held_out() -> str:
    """The held-out-layouts fine-tune's first snapshots beside stage 2 and the maze fine-tune (4x4 mazes only)."""
    name = "select_low_level/low_level_selection_held_out.json"
    labels = {"/work/main/antmaze_hirl/policies/ant_td3.zip": "stage 2"}
    return selection_oracle(name, [(labels.get(key, snapshot_label(key)), key) for key in load(name).get("scores")])


STAGE6_LABELS = {
    "antmaze_hirl/policies/ant_td3.zip": "stage 5 (sequential heads)|5",
    "runs/device/s5x.zip": "stage 5 + x|6",
    "runs/device/s5y.zip": "stage 5 + y|6",
    "runs/device/s5xy.zip": "stage 5 + x + y (stage 6, shipped)|7",
    "runs/device/s5xxyy.zip": "stage 5 + x + x2 + y + y2|9",
    "runs/device/xy.zip": "x + y|2",
    "runs/device/x.zip": "x alone|1",
    "runs/device/y.zip": "y alone|1",
}
"""The names (and heads) of the stage-6 selection's policies; its rows are the ones the run scored, in its order."""


def scored_rows(name: str, label: Callable[[str], str]) -> list[tuple[str, str]]:
    """Every row a selection file scored, in the run's order, labelled by ``label(key)``: the run's own inventory."""
    return [(label(key), key) for key in load(name).get("scores")]


def run_policies(name: str) -> list[str]:
    """The policies the run that wrote selection file ``name`` was given (its command's positional arguments).

    A file merged from several runs holds more rows than its last run scored; the command names that run's own.
    """
    arguments = command_arguments(load(name).get("command"))
    return list(itertools.takewhile(lambda argument: not argument.startswith("-"), arguments))


ENSEMBLES = "train_runs/ensembles/"


STAGE5_MEMBERS = "t750_b325_b225_s3_t700"


def ensemble_row(name: str) -> tuple[str, str]:
    """An ensemble's selection row: ``t750_s3`` -> (``"t750 + s3|2"``, its zip)."""
    members = name.split("_")
    label = " + ".join(members) + (" (stage 5)" if name == STAGE5_MEMBERS else "")
    return f"{label}|{len(members)}", f"{ENSEMBLES}{name}.zip"


STAGE4 = "train_runs/ant_stage4.zip"


def ensemble_label(key: str) -> str:
    """An ensemble selection row's label: ``train_runs/ensembles/t750_s3.zip`` -> ``"t750 + s3|2"``."""
    if key == STAGE4:
        return "stage 4 (tilt 750k alone)|1"
    return ensemble_row(key.removeprefix(ENSEMBLES).removesuffix(".zip"))[0]


TILT = "train_runs/ant_maze_tilt/snapshots/step_{}000.zip"


TILT_BUFFER = "train_runs/ant_maze_tilt_buffer/snapshots/step_{}000.zip"


def tilt_label(key: str) -> str:
    """A tilt selection row's label, by its fine-tune run and snapshot."""
    match = SNAPSHOT.fullmatch(key)
    run, k = match["run"], int(match["steps"]) // 1000
    labels = {
        "ant_maze": f"stage 3 (`ant_maze` {k}k)",
        "ant_maze_tilt": f"`ant_maze_tilt.yml` (w = 1, empty buffer) {k}k{' (stage 4, shipped)' if k == 750 else ''}",
        "ant_maze_tilt3": f"`ant_maze_tilt3.yml` (w = 3) {k}k",
        "ant_maze_tilt_buffer": f"w = 1, stage 3's replay buffer carried (`--init-buffer`) {k}k",
    }
    return labels[run]


def tilt_rows(name: str) -> list[tuple[str, str]]:
    """The tilt run's own rows (its command's policies), by fine-tune run then snapshot step."""

    def order(key: str) -> tuple[str, int]:
        match = SNAPSHOT.fullmatch(key)
        return match["run"], int(match["steps"])

    return [(tilt_label(key), key) for key in sorted(run_policies(name), key=order)]


STAGE2 = "stage 2"


def trained_row(label: str, name: str, smoothing: str = "") -> InMazeRow:
    """The row of in-maze file ``name`` that its run scored beside the shipped policy.

    That is the ``--low-level`` policy its command names (at ``smoothing``, if given): the lab names no machine's path.
    """
    arguments = shlex.split(load(name).get("command"))
    policy = arguments[arguments.index("--low-level") + 1]
    return InMazeRow(label, name, f"{policy} smoothing={smoothing}" if smoothing else policy)


def candidate_rows() -> list[InMazeRow]:
    """The stage-3 candidates: the maze fine-tune's snapshots and the smoothing fine-tune, beside stage 2."""
    smoothed = "in_maze/in_maze_ant_maze_smoothed_375k.json"
    return [
        InMazeRow(STAGE2, SMOOTHING, "shipped"),
        trained_row("maze fine-tune (`ant_maze.yml`), 75k steps", "in_maze/in_maze_ant_maze_75k.json"),
        *(trained_row(f"the same, {k}k", f"in_maze/in_maze_ant_maze_{k}k.json") for k in (125, 475, 650)),
        trained_row("the same, 700k (stage 3)", "in_maze/in_maze_ant_maze_700k_smoothing.json"),
        trained_row("the same, 700k, smoothing 0.5", "in_maze/in_maze_ant_maze_700k_smoothing.json", "0.5"),
        trained_row("smoothing fine-tune (`ant_maze_smoothed.yml`), 375k, smoothing 0.5", smoothed, "0.5"),
        InMazeRow("stage 2, smoothing 0.5 (beside the row above)", smoothed, "shipped smoothing=0.5"),
    ]


SMOOTHING = "in_maze/in_maze_smoothing.json"
"""The smoothing sweep of the stage-2 ant at the default subgoal distance."""


DISTANCES = "in_maze/in_maze_distance_*.json"
"""The subgoal-distance sweep: one file per distance, each run written by ``in_maze --subgoal-distance``."""


def smoothing_rows() -> list[InMazeRow]:
    """The smoothing sweep's rows, then each distance file's (shortest first): the rows the runs wrote.

    Each row is labelled by the subgoal distance and the smoothing its file records.
    """
    distances = [str(path.relative_to(tables.RESULTS)) for path in tables.RESULTS.glob(DISTANCES)]
    files = [SMOOTHING, *sorted(distances, key=lambda name: load(name).get("expert_max_distance"))]
    rows = []
    for name in files:
        results = load(name)
        distance_m = results.get("expert_max_distance")
        for key in results.get("results"):
            smoothing = key.partition(" smoothing=")[2] or "none"
            rows.append(InMazeRow(f"{distance_m:g} m, {smoothing}", name, key))
    # The first row is the shipped ant as it was: stage 2, unsmoothed.
    rows[0] = replace(rows[0], label=f"{rows[0].label} (stage 2)")
    return rows


@SECTIONS.add("flip-diagnostics")
def flip_diagnostics() -> str:
    """Where the stage-2 ant flips, pooled over the five families: by turn, then per family."""
    outcome = families(load("in_maze/in_maze_smoothing.json"), "shipped")
    bins = list(outcome["ant3"]["flip_diagnostics"]["by_turn_degrees"])
    lines = []
    for name in bins:
        subgoals = sum(outcome[f]["flip_diagnostics"]["by_turn_degrees"][name]["subgoals"] for f in FAMILIES)
        flips = sum(outcome[f]["flip_diagnostics"]["by_turn_degrees"][name]["flips"] for f in FAMILIES)
        label = name if name == "standstill" else f"{name} degrees"
        lines.append([label, f"{subgoals:,}", flips, share(flips / subgoals)])
    lines.append(
        ["all", f"{sum(outcome[f]['subgoals'] for f in FAMILIES):,}", sum(outcome[f]["flips"] for f in FAMILIES), ""]
    )
    per_family = table(
        ["family", "median steps into a subgoal at a flip", "flips within 10 steps of a new subgoal"],
        [
            [
                f,
                f"{outcome[f]['flip_diagnostics']['flip_steps_into_subgoal_median']:g}",
                outcome[f]["flip_diagnostics"]["flips_within_10_steps_of_a_new_subgoal"],
            ]
            for f in FAMILIES
        ],
    )
    return table(["turn to the subgoal", "subgoals", "flips", "flips / subgoal"], lines) + "\n\n" + per_family


@SECTIONS.add("flip-warning")
def flip_warning() -> str:
    """Uprightness before a flip, and the reflexes' success, on the select6 mazes."""
    results = load("flip_warning/flip_warning.json")
    warning = table(
        [
            "uprightness threshold",
            "flips",
            "steps from the last step at or above it to the flip: median (range)",
            "share of non-flip steps below it",
        ],
        [
            [
                t,
                w["flips"],
                f"{w['lead_steps_median']:g} ({w['lead_steps_min']}-{w['lead_steps_max']})",
                share(w["non_flip_steps_below"] / w["non_flip_steps"]),
            ]
            for t, w in results.get("warning").items()
        ],
    )
    reflexes = []
    for name, r in results.get("reflexes").items():
        label = "none" if name == "none" else "K = {}, U = {}".format(*name.split("@"))
        reflexes.append(
            [
                label,
                rate_cell(r["success"], r["episodes"]),
                r["flip"],
                r["frozen"],
                r["timeout"],
                share(r["reflex_share_of_steps"]),
            ]
        )
    return (
        warning
        + "\n\n"
        + table(
            [
                "reflex (torques x K below uprightness U)",
                "success [95% Wilson]",
                "flips",
                "frozen",
                "timeouts",
                "steps under the reflex",
            ],
            reflexes,
        )
    )


@SECTIONS.add("algorithms")
def algorithms() -> str:
    """TD3 against SAC from scratch: eval-low, in mazes, training speed."""
    results = load("low_level/low_level_algorithms.json")
    names = {"shipped": "stage 2 (then shipped)", "td3": "TD3, 250k", "sac": "SAC, 250k"}
    lines = []
    for key, label in names.items():
        eval_low = results.get("eval_low", key)
        outcome = results.get("in_maze", key, "families")
        training = results.get("training", key) if key != "shipped" else None
        lines.append(
            [
                label,
                rate_cell(eval_low["successes"], eval_low["episodes"]),
                *(success(outcome[f]) for f in ("ant4", "u", "medium", "large")),
                share_range([outcome[f]["flips_per_subgoal"] for f in ("ant4", "u", "medium", "large")]),
                f"{training['median_steps_per_s']} ({training['steps_per_s_ratio_to_first']}x)" if training else "",
            ]
        )
    return table(
        ["policy", "eval-low", "ant4", "u", "medium", "large", "flips / subgoal", "training steps/s (ratio to TD3)"],
        lines,
    )


@SECTIONS.add("in-maze-stage6")
def in_maze_stage6() -> str:
    """The ``in-maze-stage6`` block."""
    return in_maze_pair("in_maze/in_maze.json", "shipped", "runs/device/stage5.zip", "stage 6", "stage 5")


@SECTIONS.add("selection-stage6")
def selection_stage6() -> str:
    """The ``selection-stage6`` block."""
    name = "select_low_level/low_level_selection_stage6.json"
    return selection(name, scored_rows(name, STAGE6_LABELS.__getitem__), extra="heads")


@SECTIONS.add("selection-ensembles")
def selection_ensembles() -> str:
    """The ``selection-ensembles`` block."""
    name = "select_low_level/low_level_selection_ensembles.json"
    return selection(name, scored_rows(name, ensemble_label), extra="members")


@SECTIONS.add("selection-stage3")
def selection_stage3() -> str:
    """The ``selection-stage3`` block."""
    return selection_ranked(
        "select_low_level/low_level_selection_held_out_large.json",
        labels={
            "antmaze_hirl/policies/ant_td3.zip": "stage 2",
            "antmaze_hirl/policies/ant_td3.zip smoothing=0.5": "stage 2, smoothing 0.5",
        },
    )


@SECTIONS.add("selection-stage3-later")
def selection_stage3_later() -> str:
    """The ``selection-stage3-later`` block."""
    return selection_ranked(
        "select_low_level/low_level_selection_held_out_large_775k.json",
        [
            f"train_runs/ant_maze/snapshots/step_{k}000.zip{s}"
            for k in (700, 725, 750, 775)
            for s in ("", " smoothing=0.5")
        ],
    )


@SECTIONS.add("candidates")
def candidates() -> str:
    """The ``candidates`` block."""
    return in_maze_rows(candidate_rows(), with_file=True)


@SECTIONS.add("selection-tilt")
def selection_tilt() -> str:
    """The ``selection-tilt`` block."""
    name = "select_low_level/low_level_selection_tilt.json"
    return selection(name, tilt_rows(name))


@SECTIONS.add("in-maze-tilt")
def in_maze_tilt() -> str:
    """The ``in-maze-tilt`` block."""
    return in_maze_columns(
        "in_maze/in_maze_tilt.json",
        [
            ("stage 3", "shipped"),
            ("tilt w = 1, 750k", TILT.format(750)),
            ("tilt w = 1 + buffer, 325k", TILT_BUFFER.format(325)),
        ],
    )


@SECTIONS.add("smoothing")
def smoothing() -> str:
    """The ``smoothing`` block."""
    return in_maze_rows(smoothing_rows())


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
