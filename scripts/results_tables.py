"""Prints the Markdown tables of the hand-written results pages from the committed JSON files under ``results/``.

Each section is one generated block of ``docs/results/low-level.md``, ``ant-in-mazes.md``,
``learner-ablation.md`` or ``other.md``, of the guides ``docs/guides/vector-envs.md``, ``low-level.md`` or
``protocol.md``, or of ``docs/ray.md``::

    <!-- generated: python scripts/results_tables.py in-maze-stage6 -->

so every figure of those tables comes from a committed file through a command a reader can rerun; the results
pages' prose names no figure of its own, and a guide's prose names a figure only beside its file. A success
rate measured on a known number of episodes carries its 95% Wilson interval
(:func:`antmaze_hirl.experiments.uncertainty.wilson_interval`). What a row is called (its label, its heads, a
goal it is held to) is written here; what it scored is read from the file.

A missing or damaged file, or a file without a field a section reads, is a one-line error naming the file.

Usage: python scripts/results_tables.py SECTION   (``--list`` names the sections)
"""

from __future__ import annotations

import argparse
import json
import posixpath
import re
import statistics
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from antmaze_hirl.experiments.claims import exact_percent
from antmaze_hirl.experiments.uncertainty import wilson_interval

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
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


class ResultsFileError(ValueError):
    """A results file that is missing, is not JSON, or lacks a field a section reads."""


LOADED: list[str] = []
"""The files read so far in this process (``main`` names them when a field is missing)."""


@dataclass(frozen=True)
class Results:
    """One committed results file: its path under ``results/`` and its parsed JSON."""

    name: str
    data: Any

    def get(self, *keys: str | int) -> Any:
        """The value at ``keys`` (nested dict keys or list indices).

        Raises:
            ResultsFileError: Naming the file and the missing field.
        """
        value = self.data
        for depth, key in enumerate(keys):
            try:
                value = value[key]
            except (KeyError, IndexError, TypeError):
                where = "".join(f"[{k!r}]" for k in keys[: depth + 1])
                raise ResultsFileError(f"results/{self.name}: no field {where}") from None
        return value


def load(name: str, results: Path | None = None) -> Results:
    """The results file ``results/<name>``.

    Raises:
        ResultsFileError: If the file does not exist or is not JSON, naming it.
    """
    path = (results or RESULTS) / name
    LOADED.append(name)
    try:
        return Results(name, json.loads(path.read_text()))
    except FileNotFoundError:
        raise ResultsFileError(f"results/{name}: no such results file") from None
    except json.JSONDecodeError as error:
        raise ResultsFileError(f"results/{name} is not JSON: {error}") from None


# --- formatting -------------------------------------------------------------------------------------------


def percent(rate: float, trials: int | None = None) -> str:
    """``rate`` in percent: whole on 100 trials or fewer dividing 100, else one decimal."""
    decimals = 0 if trials is not None and trials <= 100 and 100 % trials == 0 else 1
    return f"{100 * rate:.{decimals}f}%"


def count(rate: float, trials: int) -> int:
    """The whole number of successes behind ``rate`` on ``trials``.

    Raises:
        ResultsFileError: If ``rate * trials`` is not a whole number (to 1e-6).
    """
    successes = round(rate * trials)
    if abs(successes - rate * trials) > 1e-6:
        raise ResultsFileError(f"a success rate of {rate} is no whole count of {trials} episodes")
    return successes


def rate_cell(successes: int, trials: int) -> str:
    """``"92.5% [88.0, 95.4]"``: the rate and its 95% Wilson interval, in percent."""
    low, high = wilson_interval(successes, trials)
    return f"{percent(successes / trials, trials)} [{100 * low:.1f}, {100 * high:.1f}]"


def rate_cell_of(rate: float, trials: int) -> str:
    """:func:`rate_cell` of a recorded ``rate`` on ``trials`` episodes."""
    return rate_cell(count(rate, trials), trials)


def times(ratio: float) -> str:
    """``"2.05x"``: a speed or throughput ratio, two decimals."""
    return f"{ratio:.2f}x"


def median_range(spread: dict[str, float]) -> str:
    """``"89% (80%-91%)"``: a per-seed spread's median and its min-max, as success rates on 100 mazes."""
    return f"{percent(spread['median'], 100)} ({percent(spread['min'], 100)}-{percent(spread['max'], 100)})"


def share(value: float) -> str:
    """A share of subgoals or steps, in percent with two decimals (flip rates are small)."""
    return f"{100 * value:.2f}%"


def share_range(values: Sequence[float]) -> str:
    """``"0.55-2.10%"``: the lowest and highest of ``values`` as shares."""
    return f"{100 * min(values):.2f}-{100 * max(values):.2f}%"


def table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


# --- in-maze files (scripts/in_maze.py) ----------------------------------------------------------------------


def families(results: Results, row: str) -> dict[str, Any]:
    """The per-family outcomes of one row (one low level at one smoothing) of an in-maze file."""
    return results.get("results", row, "families")


def success(family: dict[str, Any]) -> str:
    """One family's success with its interval."""
    return rate_cell(family["successes"], family["episodes"])


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


# --- selection files (scripts/select_low_level.py) ----------------------------------------------------------


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


# --- the low level ----------------------------------------------------------------------------------------


def low_level_eval() -> str:
    """Eval-low of the shipped point and ant per disjoint set of subgoals and pooled, then the ant's eval-low files."""
    summary = load("low_level/low_level.json")
    bodies = [("point", summary.get("eval_low", "point")), ("ant", summary.get("eval_low", "ant"))]
    seeds = list(bodies[0][1]["disjoint_sets"])
    lines = []
    for body, entry in bodies:
        episodes, pooled = entry["episodes"], entry["pooled_episodes"]
        hits = count(entry["pooled_success_rate"], pooled)
        lines.append(
            [
                f"{body} (`{entry['low_level_id']}`)",
                f"{entry['max_distance_m']:g} m",
                *(rate_cell_of(entry["disjoint_sets"][seed], episodes) for seed in seeds),
                f"{hits} of {pooled}: {rate_cell(hits, pooled)}",
                f"{entry['mean_steps']:.1f}",
            ]
        )
    header = ["shipped", "subgoals up to", *(f"seed {seed} ({bodies[0][1]['episodes']})" for seed in seeds)]
    header += ["pooled", "mean steps, seed 0"]
    files = []
    for seed in ("", "_200", "_400", "_600"):
        entry = load(f"low_level/eval_low_ant{seed}.json")
        files.append(
            [
                f"`low_level/eval_low_ant{seed}.json`",
                f"`{entry.get('low_level_id')}`",
                rate_cell_of(entry.get("success_rate"), entry.get("episodes")),
                f"{entry.get('mean_steps'):.1f}",
            ]
        )
    goal = summary.get("goals", "ant_success_rate")
    return (
        table(header, lines)
        + f"\n\nThe ant's goal: {goal}. Its `antmaze-hirl eval-low` files:\n\n"
        + table(["file", "low level", "success [95% Wilson]", "mean steps"], files)
    )


def low_level_throughput() -> str:
    """``train_low_level`` against plain SB3 ``learn``: steps per second and their ratios."""
    speed = load("low_level/low_level.json").get("training_throughput")
    goal = load("low_level/low_level.json").get("goals", "ratio_checkpoint_every_50k")
    return table(
        [
            "steps per block",
            "ours, steps/s",
            "plain SB3, steps/s",
            "checkpoint save",
            "ratio, one checkpoint per block",
            f"ratio, checkpoint every 50k (goal {goal})",
        ],
        [
            [
                speed["steps_per_block"],
                speed["ours_steps_per_s"],
                speed["plain_sb3_steps_per_s"],
                f"{speed['checkpoint_save_s']} s",
                speed["ratio_one_checkpoint_per_block"],
                speed["ratio_checkpoint_every_50k"],
            ]
        ],
    )


def selection_oracle(name: str, rows: Sequence[tuple[str, str]]) -> str:
    """Rows (label, key) of an early selection file, which scored eval-low and the oracle's success (``ceiling``)."""
    results = load(name)
    episodes, mazes = results.get("settings", "episodes"), results.get("settings", "mazes")
    best = results.get("best")
    lines = []
    for label, key in rows:
        row = results.get("scores", key)
        lines.append(
            [
                f"{label}{' (the best row)' if key == best else ''}",
                rate_cell_of(row["eval_low"], episodes),
                rate_cell_of(row["ceiling"], mazes),
                f"{row['score']:.3f}",
            ]
        )
    return table(["row", f"eval-low ({episodes} subgoals)", f"oracle success ({mazes} mazes)", "score"], lines)


def low_level_selection() -> str:
    """Stage 2's selection: the pick and stage 1."""
    name = "select_low_level/low_level_selection.json"
    results = load(name)
    rows = [("the pick (stage 2)", results.get("best")), ("stage 1", "antmaze_hirl/policies/ant_td3.zip")]
    return f"{len(results.get('scores'))} rows scored.\n\n" + selection_oracle(name, rows)


def selection_held_out() -> str:
    """The held-out-layouts fine-tune's first snapshots beside stage 2 and the maze fine-tune (4x4 mazes only)."""
    name = "select_low_level/low_level_selection_held_out.json"
    labels = {"/work/main/antmaze_hirl/policies/ant_td3.zip": "stage 2"}
    return selection_oracle(name, [(labels.get(key, snapshot_label(key)), key) for key in load(name).get("scores")])


def env_throughput() -> str:
    """AntReach against raw AntMaze steps/s, and the point oracle's random mazes."""
    results = load("env_throughput/env_throughput.json")
    low, oracle = results.get("low_level"), results.get("high_level_point_oracle")
    goals = results.get("goals")
    return table(
        ["figure", "value", "goal"],
        [
            ["AntReach-v0, steps/s (random actions)", low["ours_steps_per_s"], ""],
            ["raw `AntMaze_UMaze-v5`, steps/s", low["raw_AntMaze_UMaze_v5_steps_per_s"], ""],
            ["ratio", low["ratio"], goals["low_level_ratio"]],
            [
                f"PointMaze-v0, oracle and scripted controller, {oracle['mazes']} random mazes",
                rate_cell_of(oracle["success_rate"], oracle["mazes"]),
                goals["oracle_success_rate"],
            ],
            [
                "episodes/s, mean subgoals, mean steps",
                f"{oracle['episodes_per_s']}, {oracle['mean_subgoals']}, {oracle['mean_low_level_steps']:.0f}",
                "",
            ],
        ],
    )


HEADLINE_PAGES = {
    "low level": "results/low-level.md",
    "the ant in mazes": "results/ant-in-mazes.md",
    "the paper's question": "results/protocol2.md",
    "user study": "guides/user-study.md",
}
"""The page each headline row links to, relative to ``docs/``."""


def misses(family: dict[str, Any]) -> str:
    """``"2 flips, 1 timeout"``: how an in-maze family's failed episodes ended (empty when none failed)."""
    plural = {"flips": ("flip", "flips"), "frozen": ("frozen", "frozen"), "timeouts": ("timeout", "timeouts")}
    return ", ".join(f"{family[key]} {words[family[key] > 1]}" for key, words in plural.items() if family[key])


def protocol2_headline(body: str) -> list[str]:
    """One body's protocol-2 headline: what was run, the untrained and DAgger figures and the oracle's, the file."""
    results = load(f"protocol2/{body}/summary.json")
    dagger = results.get("methods", "dagger")
    untrained = dagger["untrained_success"]["pooled"]
    low, high = untrained["cluster_bootstrap_95"]
    oracle = results.get("oracle_success")
    config = results.get("config")
    what = (
        f"protocol 2, {body}: {dagger['seeds']} seeds x {config['episodes']} episodes, scored on "
        f"{untrained['mazes']} held-out {config['maze_size']}x{config['maze_size']} mazes: the untrained learner "
        "(pooled, cluster bootstrap), then DAgger's final success, median (min-max); the oracle on the same mazes"
    )
    figure = (
        f"{percent(untrained['rate'], 1000)} [{100 * low:.1f}, {100 * high:.1f}] → "
        f"{median_range(dagger['final_success'])}, {dagger['total_labels']['median']:.0f} labels per trial; "
        f"oracle {rate_cell_of(oracle['success_rate'], oracle['episodes'])}"
    )
    return [what, figure, f"`protocol2/{body}/summary.json`"]


def headline(links_from: str = "docs/results") -> str:
    """The current headline figures, each with its file and page, the links relative to ``links_from``.

    The README (``links_from="."``) and ``docs/results/index.md`` print the same rows, so the figures have one home.
    """

    def page(name: str) -> str:
        target = posixpath.relpath(posixpath.join("docs", HEADLINE_PAGES[name]), links_from)
        return f"[{name}]({target})"

    low = load("low_level/low_level.json")
    rows = []
    for body, what in (
        ("point", "shipped point low level"),
        ("ant", "shipped ant low level (stage 6)"),
    ):
        entry = low.get("eval_low", body)
        pooled = entry["pooled_episodes"]
        hits = count(entry["pooled_success_rate"], pooled)
        sets = len(entry["disjoint_sets"])
        reach = f" up to {entry['max_distance_m']:g} m" if body == "ant" else ""
        rows.append(
            [
                f"{what}, {sets} disjoint sets of {entry['episodes']} subgoals{reach}",
                f"{hits} of {pooled}: {rate_cell(hits, pooled)}",
                "`low_level/low_level.json`",
                page("low level"),
            ]
        )
    in_maze = families(load("in_maze/in_maze.json"), "shipped")
    for family, what in (
        ("ant4", "oracle driving the shipped ant, 100 4x4 mazes held out by raw grid (protocol 1), 500 steps"),
        ("large", "the same, gymnasium-robotics `large` map"),
    ):
        outcome = in_maze[family]
        ends = misses(outcome)
        rows.append(
            [
                what,
                success(outcome) + (f" ({ends})" if ends else ""),
                "`in_maze/in_maze.json`",
                page("the ant in mazes"),
            ]
        )
    for body in ("point", "ant"):
        rows.append([*protocol2_headline(body), page("the paper's question")])
    latency = load("study_latency/study_latency.json").get("bodies", "ant", "all", "server", "p95_ms")
    rows.append(
        [
            "study page, ant, server time from a click to the next state, p95",
            f"{latency} ms",
            "`study_latency/study_latency.json`",
            page("user study"),
        ]
    )
    return table(["what", "figure", "file (`results/`)", "page"], rows)


# --- the ant in mazes -----------------------------------------------------------------------------------------

STAGE6_ROWS = [
    ("stage 5 (sequential heads)|5", "antmaze_hirl/policies/ant_td3.zip"),
    ("stage 5 + x|6", "runs/device/s5x.zip"),
    ("stage 5 + y|6", "runs/device/s5y.zip"),
    ("stage 5 + x + y (stage 6, shipped)|7", "runs/device/s5xy.zip"),
    ("stage 5 + x + x2 + y + y2|9", "runs/device/s5xxyy.zip"),
    ("x + y|2", "runs/device/xy.zip"),
    ("x alone|1", "runs/device/x.zip"),
    ("y alone|1", "runs/device/y.zip"),
]
ENSEMBLES = "train_runs/ensembles/"
STAGE5_MEMBERS = "t750_b325_b225_s3_t700"


def ensemble_row(name: str) -> tuple[str, str]:
    """An ensemble's selection row: ``t750_s3`` -> (``"t750 + s3|2"``, its zip)."""
    members = name.split("_")
    label = " + ".join(members) + (" (stage 5)" if name == STAGE5_MEMBERS else "")
    return f"{label}|{len(members)}", f"{ENSEMBLES}{name}.zip"


ENSEMBLE_ROWS = [
    ("stage 4 (tilt 750k alone)|1", "train_runs/ant_stage4.zip"),
    *map(
        ensemble_row,
        (
            "t750_b325",
            "t750_b325_b225",
            "t750_b325_b225_s3",
            "t750_t700",
            "b325_b225",
            "t750_b325_s3",
            STAGE5_MEMBERS,
            "t750_s3",
            "t750_b325_b225_s3_t700_k350",
            "t750_b325_s3_k350",
            "t750_b325_b225_s3_t700_s650",
        ),
    ),
]
TILT = "train_runs/ant_maze_tilt/snapshots/step_{}000.zip"
TILT3 = "train_runs/ant_maze_tilt3/snapshots/step_{}000.zip"
TILT_BUFFER = "train_runs/ant_maze_tilt_buffer/snapshots/step_{}000.zip"
TILT_ROWS = [
    ("stage 3 (`ant_maze` 700k)", "train_runs/ant_maze/snapshots/step_700000.zip"),
    *(
        (f"`ant_maze_tilt.yml` (w = 1, empty buffer) {k}k{' (stage 4, shipped)' if k == 750 else ''}", TILT.format(k))
        for k in (150, 350, 500, 650, 700, 750)
    ),
    *((f"`ant_maze_tilt3.yml` (w = 3) {k}k", TILT3.format(k)) for k in (150, 350)),
    *(
        (f"w = 1, stage 3's replay buffer carried (`--init-buffer`) {k}k", TILT_BUFFER.format(k))
        for k in (125, 225, 275, 325)
    ),
]
STAGE2 = "stage 2"
CANDIDATES = [
    InMazeRow(STAGE2, "in_maze/in_maze_smoothing.json", "shipped"),
    InMazeRow(
        "maze fine-tune (`ant_maze.yml`), 75k steps",
        "in_maze/in_maze_ant_maze_75k.json",
        "/work/runs/ant_maze_step_75000.zip",
    ),
    *(
        InMazeRow(
            f"the same, {k}k", f"in_maze/in_maze_ant_maze_{k}k.json", f"/work/runs/ant_maze/snapshots/step_{k}000.zip"
        )
        for k in (125, 475, 650)
    ),
    InMazeRow(
        "the same, 700k (stage 3)",
        "in_maze/in_maze_ant_maze_700k_smoothing.json",
        "/work/runs/ant_maze/snapshots/step_700000.zip",
    ),
    InMazeRow(
        "the same, 700k, smoothing 0.5",
        "in_maze/in_maze_ant_maze_700k_smoothing.json",
        "/work/runs/ant_maze/snapshots/step_700000.zip smoothing=0.5",
    ),
    InMazeRow(
        "smoothing fine-tune (`ant_maze_smoothed.yml`), 375k, smoothing 0.5",
        "in_maze/in_maze_ant_maze_smoothed_375k.json",
        "/work/runs/ant_maze_smoothed/snapshots/step_375000.zip smoothing=0.5",
    ),
    InMazeRow(
        "stage 2, smoothing 0.5 (beside the row above)",
        "in_maze/in_maze_ant_maze_smoothed_375k.json",
        "shipped smoothing=0.5",
    ),
]
SMOOTHING_ROWS = [
    InMazeRow("2 m, none (stage 2)", "in_maze/in_maze_smoothing.json", "shipped"),
    *(
        InMazeRow(f"2 m, {s}", "in_maze/in_maze_smoothing.json", f"shipped smoothing={s}")
        for s in ("0.25", "0.5", "0.75")
    ),
    *(InMazeRow(f"{d} m, none", f"in_maze/in_maze_distance_{d}.json", "shipped") for d in ("1.5", "3", "4")),
]


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


STEADY_ANT_SUMMARIES = ("steady_ant/summary.json", "steady_ant/summary_student199.json", "steady_ant/summary_tilt.json")
"""``scripts/steady_ant_table.py``'s summaries, each a candidate beside the ensemble on the same maps and episodes."""


def steady_ant_maps(names: Sequence[str] = STEADY_ANT_SUMMARIES) -> str:
    """The oracle on the fixed maps with the ensemble and each one-network candidate: success and flips, intervals.

    The ensemble's row of a map is listed once however many summaries hold it on the same tasks (they read the
    same file).
    """
    rows: dict[tuple[str, str, str], list[object]] = {}
    for name in names:
        for pair in load(name).get("benchmark"):
            tasks = pair.get("tasks", "all")  # a pair read on a subset of the tasks says which
            where = pair["suite"] if tasks == "all" else f"{pair['suite']}, tasks {','.join(map(str, tasks))}"
            for side in ("ensemble", "candidate"):
                row = pair[side]
                low, high = row["flips_per_10k_steps_ci95"]
                rows.setdefault(
                    (pair["suite"], row["file"], str(tasks)),
                    [
                        f"`{where}`",
                        f"`{row['low_level']}`",
                        rate_cell(row["successes"], row["episodes"]),
                        f"{row['flips']} / {row['low_level_steps']:,}",
                        f"{row['flips_per_10k_steps']:.2f} [{low:.2f}, {high:.2f}]",
                    ],
                )
    suites = list(dict.fromkeys(suite for suite, _, _ in rows))
    return table(
        ["map (oracle, K = 20)", "low level", "success [95% CI]", "flips / low-level steps", "flips per 10k [95% CI]"],
        [rows[key] for suite in suites for key in rows if key[0] == suite],
    )


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


# --- the learner ablation -------------------------------------------------------------------------------------


def agreement(cell_agreement: dict[str, float]) -> str:
    """``"97.3% / 64.9%"``: the oracle's cell on the trial's own labels / on held-out states."""
    return f"{percent(cell_agreement['training_labels'])} / {percent(cell_agreement['held_out_states'])}"


def learner_table(name: str, labels: dict[str, str]) -> str:
    """One row per variant: per-seed final success with intervals, median, selection, labels, agreement, minutes."""
    results = load(name)
    lines = []
    for variant, label in labels.items():
        spec = results.get("variants", variant)
        trials = spec["trials"]
        selection_rates = [t["selection_success"]["rate"] for t in trials]
        lines.append(
            [
                f"`{variant}` ({label}), seeds {','.join(str(s) for s in spec['seeds'])}",
                "; ".join(rate_cell(t["final_success"]["successes"], t["final_success"]["episodes"]) for t in trials),
                percent(spec["final_success_median"]),
                ", ".join(percent(rate, 100) for rate in selection_rates)
                + f" (mean {percent(statistics.mean(selection_rates))})",
                ", ".join(str(t["labels"]) for t in trials),
                "; ".join(agreement(t["oracle_cell_agreement"]) for t in trials),
                ", ".join(f"{t['trial_seconds'] / 60:.1f}" for t in trials)
                + f" (median {spec['trial_seconds_median'] / 60:.1f})",
            ]
        )
    final, selection_mazes = results.get("protocol", "final_mazes"), results.get("protocol", "selection_mazes")
    return table(
        [
            "variant",
            f"final success per seed [95% Wilson], {final} eval mazes",
            "median",
            f"selection success per seed ({selection_mazes} mazes)",
            "labels per seed",
            "oracle cell agreement per seed: own labels / held-out states",
            "trial minutes per seed",
        ],
        lines,
    )


def learner_point() -> str:
    return learner_table(
        "learner_ablation/learner_ablation.json",
        {
            "heading_cnn": "previous default: CNN + MLP, 16 heading bins + distance",
            "next_cell_cnn": "same CNN, classifies the next cell (3x3)",
            "next_cell_vin": "next cell read from value iteration's Q (16 rounds, learned costs)",
            "next_cell_vin_walls": "the same, moves into walls ruled out: **the point's default**",
        },
    )


def learner_ant() -> str:
    oracle = families(load("in_maze/in_maze_smoothing.json"), "shipped")["ant4"]
    return (
        learner_table(
            "learner_ablation/learner_ablation_ant.json",
            {
                "heading_cnn": "CNN + MLP, 16 heading bins + distance: the ant's previous head, "
                "here with the 2 m reach",
                "next_cell_cnn": "same CNN, classifies the next cell: **the ant's default**",
                "next_cell_vin": "next cell from value iteration's Q, 14 rounds",
                "next_cell_vin_walls": "the same, wall moves ruled out: the point's default",
            },
        )
        + "\n\n"
        + table(
            ["the oracle driving the stage-2 low level on the same 100 ant4 mazes", "success [95% Wilson]"],
            [["`in_maze/in_maze_smoothing.json`, row `shipped` (then stage 2)", success(oracle)]],
        )
    )


def next_cell_labels() -> str:
    """The oracle's 2 m labels on the ant read by the old and the new rule."""
    results = load("next_cell_labels/next_cell_labels.json")
    lines = [
        [rule, share(r["stay"]), share(r["matches_grid_path"]), share(r["goal_within_reach_moved"])]
        for rule, r in results.get("rules").items()
    ]
    return f"{results.get('states'):,} sampled states.\n\n" + table(
        [
            "rule",
            "labels read as stay",
            "labels matching the grid path's next cell",
            "goal labels moved out of the goal's cell",
        ],
        lines,
    )


# --- other results --------------------------------------------------------------------------------------------


def demo() -> str:
    """``antmaze-hirl demo`` per body, with the ant oracle's success on that family."""
    results = load("demo_success/demo_success.json")
    oracle = load("paper_experiment/oracle_success_ant_3.json")
    lines = []
    for body in ("point", "ant"):
        d = results.get(body)
        settings = ", ".join(f"{k} {v}" for k, v in d["settings"].items() if v is not None)
        lines.append(
            [
                f"{body} (`{d['low_level_id']}`; {settings})",
                d["seeds"],
                f"{d['successes']} of {d['episodes']}: {rate_cell(d['successes'], d['episodes'])}",
                "yes" if d["default_seed_succeeds"] else "no",
                ", ".join(f"{k}: {v}" for k, v in d["failures"].items()) or "none",
            ]
        )
    lines.append(
        [
            "the ant oracle, held-out 3x3 mazes (`paper_experiment/oracle_success_ant_3.json`)",
            f"maze seed {oracle.get('maze_seed'):,}-",
            rate_cell_of(oracle.get("success_rate"), oracle.get("episodes")),
            "",
            "",
        ]
    )
    return table(["run", "seeds", "success [95% Wilson]", "seed 0 (the default) succeeds", "failures"], lines)


def maze_families() -> str:
    """Distinct wall grids per family in the draws, per part of the layout partition."""
    results = load("maze_families/maze_families.json")
    lines = []
    for name, f in results.get("families").items():
        parts = f["distinct_wall_grids_per_split"]
        lines.append(
            [
                name,
                f"{f['draws']:,}",
                f"{f['distinct_wall_grids']:,}",
                f"{parts['train']:,}",
                f"{parts['eval']:,}",
                f"{parts['selection']:,}",
            ]
        )
    return table(
        ["family", "draws", "distinct wall grids", "training part", "evaluation part", "selection part"], lines
    )


def import_time() -> str:
    results = load("import_time/import_time.json")
    median = results.get("median_seconds")
    return table(
        ["fresh interpreters", "`import antmaze_hirl`", "`import gymnasium_robotics`", "ratio", "goal", "loads torch"],
        [
            [
                f"median of {results.get('repeats')} (Python {results.get('python')})",
                f"{median['antmaze_hirl']:.3f} s",
                f"{median['gymnasium_robotics']:.3f} s",
                results.get("ratio"),
                f"<= {results.get('goal_ratio_at_most')}",
                "yes" if results.get("antmaze_hirl_loads_torch") else "no",
            ]
        ],
    )


def sweeps() -> str:
    results = load("sweep_scaling/sweep_scaling.json")
    machine = results.get("machine")
    return table(
        ["grid", "serial", "Ray, grid only", "Ray start-up", "Ray end to end", "same `episodes.csv`", "machine"],
        [
            [
                f"{results.get('grid', 'trials')} {results.get('grid', 'body')} trials, "
                f"{results.get('ray_workers')} Ray workers",
                f"{results.get('serial_seconds')} s",
                f"{results.get('ray_grid_seconds')} s",
                f"{results.get('ray_startup_seconds')} s",
                f"{results.get('ray_end_to_end_seconds')} s",
                "yes" if results.get("episodes_csv_identical") else "no",
                f"{machine['cpu_count']} cores, load average {machine['load_average_1_5_15_before'][0]:.0f} before",
            ]
        ],
    )


# --- the guides -----------------------------------------------------------------------------------------------


def lockstep_agreement() -> str:
    """Serial against lockstep evaluation on the same mazes: agreement, successes, time; then what differed."""
    results = load("lockstep_agreement/lockstep_agreement.json")
    rows = results.get("rows")
    lines = [
        [
            f"{r['body']} ({r['maze_size']}x{r['maze_size']})",
            r["high_level"],
            r["mazes"],
            r["same_success"],
            r["same_episode"],
            f"{r['serial_successes']} / {r['lockstep_successes']}",
            r["serial_s"],
            r["lockstep_s"],
            times(r["speedup"]),
        ]
        for r in rows
    ]
    differed = "; ".join(
        f"{r['body']} {r['high_level']}: {r['mazes'] - r['same_success']} of {r['mazes']}" for r in rows
    )
    bodies = dict.fromkeys(r["body"] for r in rows)
    alike = ", ".join(
        f"{body} {sum(r['same_episode'] for r in rows if r['body'] == body)} of "
        f"{sum(r['mazes'] for r in rows if r['body'] == body)}"
        for body in bodies
    )
    return (
        f"{results.get('num_envs')} mazes at once.\n\n"
        + table(
            [
                "body",
                "high level",
                "mazes",
                "same success outcome",
                "same episode (success, attempts, steps)",
                "successes serial / lockstep",
                "serial s",
                "lockstep s",
                "speedup",
            ],
            lines,
        )
        + f"\n\nRead from it: success outcomes that differed, {differed}. Episodes the same step for step: {alike}."
    )


HIERARCHY_GOAL_RATIO_AT_16 = 0.7
"""The lockstep ant's goal: at least this share of the raw simulator's steps/s at N = 16, at each thread setting."""
HIERARCHY_GOAL_THREAD_RATIO = 0.5
"""The thread scope's goal: no thread setting below this share of the other's steps/s, at the same mode and N."""


def hierarchy_throughput() -> str:
    """Low-level steps/s of the hierarchy per body, mode, N and torch threads; the raw baselines; the goals."""
    results = load("hierarchy_throughput/hierarchy_throughput.json")
    rows = results.get("rows")
    raw = results.get("raw_baselines")
    idle = load("env_throughput/env_throughput.json").get("low_level", "raw_AntMaze_UMaze_v5_steps_per_s")
    lines = [
        [
            r["body"],
            r["mode"],
            r["num_envs"],
            r["torch_threads"],
            f"{r['steps_per_s']:,.0f}",
            f"{r['ratio_to_raw']:.2f}",
            f"{r['ratio_to_best']:.2f}",
        ]
        for r in rows
    ]

    def row(body: str, mode: str, num_envs: int, threads: int) -> dict[str, Any]:
        for r in rows:
            if (r["body"], r["mode"], r["num_envs"], r["torch_threads"]) == (body, mode, num_envs, threads):
                return r
        raise ResultsFileError(
            f"results/{results.name}: no row for {body}, {mode}, N = {num_envs}, {threads} torch threads"
        )

    def raw_ratio(body: str, num_envs: int, threads: int) -> float:
        return row(body, "lockstep", num_envs, threads)["ratio_to_raw"]

    at_16 = [raw_ratio("ant", 16, threads) for threads in (1, 2)]
    point_64 = [raw_ratio("point", 64, threads) for threads in (1, 2)]
    pairs = []
    for r in rows:
        other = [o for o in rows if (o["body"], o["mode"], o["num_envs"]) == (r["body"], r["mode"], r["num_envs"])]
        if r["torch_threads"] == 1 and len(other) == 2:
            slow, fast = sorted(o["steps_per_s"] for o in other)
            pairs.append((slow / fast, r, {o["torch_threads"]: o["steps_per_s"] for o in other}))
    worst, widest, speeds = min(pairs, key=lambda pair: pair[0])
    baselines = ", ".join(f"{body} `{b['id']}` {b['before']:,}/{b['after']:,}" for body, b in raw.items())
    return (
        table(["body", "mode", "N", "torch threads", "steps/s", "x raw", "x best of body"], lines)
        + f"\n\nRaw baselines (before/after the rows): {baselines} steps/s; the ratios divide by their mean. "
        f"Idle, raw `AntMaze_UMaze-v5` ran {idle:,.0f} steps/s (`env_throughput/env_throughput.json`)."
        + "\n\nRead from it: the thread scope alone takes the serial ant from "
        f"{row('ant', 'serial, unscoped', 1, 2)['steps_per_s']:.0f} to {row('ant', 'serial', 1, 2)['steps_per_s']:.0f} "
        "low-level steps/s at 2 threads. Lockstep reached "
        f"{times(at_16[0])} (1 thread) and {times(at_16[1])} (2 threads) the raw simulator at N = 16, and "
        f"{times(raw_ratio('ant', 64, 1))} and {times(raw_ratio('ant', 64, 2))} at N = 64: the goal of >= "
        f"{times(HIERARCHY_GOAL_RATIO_AT_16)} at N = 16 is "
        f"{'met' if min(at_16) >= HIERARCHY_GOAL_RATIO_AT_16 else 'not met'} at both thread settings "
        f"in this run. The point at N = 64: {min(point_64):.2f}-{times(max(point_64))} raw. At the same mode and N, "
        f"no thread setting fell below {times(worst)} of the other (the widest gap: the {widest['body']}'s "
        f"{widest['mode']} env at N = {widest['num_envs']}, {speeds[1]:.0f} steps/s at 1 thread against "
        f"{speeds[2]:.0f} at 2): the goal of no thread setting below {times(HIERARCHY_GOAL_THREAD_RATIO)} of the "
        f"best {'holds' if worst >= HIERARCHY_GOAL_THREAD_RATIO else 'fails'} in this run."
    )


LOCKSTEP_TOOLS = {"in_maze": "`in_maze`", "demo_success": "`demo_success`", "eval_low": "`eval-low`"}
"""How the tools of ``lockstep_paths.json`` are called on the page."""


def lockstep_paths() -> str:
    """The tools' serial against lockstep runs on the same seeds: agreement, successes, speed-up."""
    results = load("lockstep_paths/lockstep_paths.json")
    lines = [
        [
            LOCKSTEP_TOOLS.get(r["tool"], f"`{r['tool']}`"),
            r["case"],
            r["episodes"],
            r["same_outcome"],
            r["same_success"],
            f"{r['serial_successes']} / {r['lockstep_successes']}",
            times(r["speedup"]) + (" (slower)" if r["speedup"] < 1 else ""),
        ]
        for r in results.get("rows")
    ]
    return table(
        [
            "tool",
            "case",
            "episodes",
            "same outcome (`eval-low`: same step count)",
            "same success",
            "successes serial / lockstep",
            "speed-up",
        ],
        lines,
    )


def high_level_ppo() -> str:
    """PPO on the high level: one env against the lockstep env."""
    results = load("high_level_ppo/high_level_ppo.json")
    return table(
        ["env", "high-level steps", "one `gym.make` env, steps/s", "lockstep env, steps/s", "N", "ratio"],
        [
            [
                f"`{results.get('env_id')}`",
                results.get("steps"),
                results.get("single_steps_per_s"),
                results.get("lockstep_steps_per_s"),
                results.get("num_envs"),
                times(results.get("ratio")),
            ]
        ],
    )


def minutes(seconds: float) -> str:
    """``"19.8 min"``."""
    return f"{seconds / 60:.1f} min"


def paper_trial_speed() -> str:
    """One protocol-2 ant trial, serial against lockstep evaluation: wall and CPU time, agreement, the goal."""
    results = load("paper_trial_speed/paper_trial_speed.json")
    lines = [
        [
            f"{'serial' if r['evaluation_envs'] == 1 else 'lockstep'} ({r['evaluation_envs']})",
            f"{r['total_s']:,} s",
            f"{r['training_s']} s",
            f"{r['evaluation_s']:,} s",
            f"{r['cpu_total_s']} s",
            f"{r['cpu_evaluation_s']} s",
            minutes(r["cpu_scaled_full_trial_s"]),
            r["labels"],
            f"{r['final_successes']} of {r['final_mazes']}",
            "{:.1f} to {:.1f}".format(*r["load_average_1min"]),
        ]
        for r in results.get("rows")
    ]
    serial, lockstep = results.get("rows", 0), results.get("rows", -1)
    goal = results.get("goal_full_trial_s")
    wall, wall_evaluations = times(results.get("speedup_total")), times(results.get("speedup_evaluation"))
    cpu, cpu_evaluations = times(results.get("cpu_speedup_total")), times(results.get("cpu_speedup_evaluation"))
    return (
        table(
            [
                "evaluation (envs)",
                "wall",
                "training, wall",
                "evaluations, wall",
                "CPU",
                "evaluations, CPU",
                "a whole trial, CPU (scaled)",
                "labels",
                "final success",
                "1-minute load average, start to end",
            ],
            lines,
        )
        + f"\n\nRead from it: lockstep is {wall} faster in wall time ({wall_evaluations} on the evaluations) "
        f"and {cpu} in CPU time ({cpu_evaluations} on the evaluations); the training was "
        f"{'identical' if results.get('same_training') else 'not identical'}, and "
        f"{results.get('maze_plays_same_success')} of {results.get('maze_plays')} maze plays had the same outcome. "
        f"The goal of <= {goal / 60:g} min per ant trial is "
        f"{'met' if lockstep['cpu_scaled_full_trial_s'] <= goal else '**missed**'} "
        f"(CPU, scaled: {minutes(serial['cpu_scaled_full_trial_s'])} serial, "
        f"{minutes(lockstep['cpu_scaled_full_trial_s'])} in lockstep)."
    )


def ensemble_speed() -> str:
    """The shipped ensemble's two layouts, sequential and batched heads, timed side by side."""
    results = load("ensemble_speed/ensemble_speed.json")
    median = results.get("median_microseconds")
    goal = results.get("goal_predict_speedup_at_least")
    predict = results.get("predict_speedup")
    return table(
        [
            "policy",
            "heads",
            "`predict`, sequential",
            "`predict`, batched",
            "`predict` speed-up (goal)",
            "a whole low-level step, speed-up",
            "largest action gap",
            "calls x rounds",
        ],
        [
            [
                f"`{results.get('policy')}` (`{results.get('fingerprints', 'batched')}`)",
                results.get("heads"),
                f"{median['sequential']:.0f} us",
                f"{median['batched']:.0f} us",
                f"{times(predict)} (>= {goal}x: {'met' if predict >= goal else 'missed'})",
                times(results.get("low_level_step_speedup")),
                results.get("max_action_gap"),
                f"{results.get('settings', 'calls')} x {results.get('settings', 'rounds')}",
            ]
        ],
    )


UNTRAINED_LABELS = {
    "heading_cnn": "`heading_cnn`",
    "next_cell_cnn": "`next_cell_cnn` (protocol 2's default)",
    "next_cell_vin": "`next_cell_vin` (value iteration, no wall blocking)",
    "next_cell_vin_walls": '`next_cell_vin_walls` (the "strong prior")',
}
"""The learners of the untrained-learner files, in the table's order, as protocol 2's page calls them."""


def untrained_learners() -> str:
    """Each learner's untrained success per body: selection and evaluation mazes per init, the rule's bound."""
    bodies = [load(f"untrained_learners/untrained_learners_{body}.json") for body in ("point", "ant")]
    header = ["learner"]
    for results in bodies:
        rows = results.get("rows")
        inits = len({r["seed"] for r in rows})
        size = results.get("maze_size")
        header.append(
            f"{results.get('body')}: selection / eval, {inits} init{'s' if inits > 1 else ''} x "
            f"{rows[0]['mazes']} {size}x{size} mazes"
        )
    header += [f"{results.get('body')}: 95% Wilson upper bound, largest selection count" for results in bodies] + [
        f"meets the {percent(bodies[0].get('untrained_limit'), 100)} rule (point, ant)"
    ]
    lines = []
    for variant, label in UNTRAINED_LABELS.items():
        cells, bounds, meets = [], [], []
        for results in bodies:
            rows = [r for r in results.get("rows") if r["variant"] == variant]
            if not rows:
                cells.append("not measured")
                bounds.append("")
                meets.append("not measured")
                continue
            splits = [
                " and ".join(f"{count(r['success_rate'], r['mazes'])}/{r['mazes']}" for r in rows if r["split"] == s)
                for s in ("selection", "eval")
            ]
            cells.append("; ".join(splits) if len(rows) > 2 else ", ".join(splits))
            worst = max((r for r in rows if r["split"] == "selection"), key=lambda r: r["success_rate"])
            bounds.append(
                f"{count(worst['success_rate'], worst['mazes'])}/{worst['mazes']}: {100 * worst['wilson_95'][1]:.1f}%"
            )
            meets.append("yes" if results.get("by_variant", variant, "meets_limit") else "no")
        lines.append([label, *cells, *bounds, ", ".join(meets)])
    return table(header, lines)


def learner_selection() -> str:
    """The learner choice rerun on the symmetry-closed selection part, per body: untrained, then trained."""
    bodies = {body: load(f"learner_ablation/learner_selection_{body}.json") for body in ("point", "ant")}
    first = bodies["point"]
    episodes, mazes = first.get("protocol", "episodes"), first.get("protocol", "selection_mazes")
    lines = []
    for body, results in bodies.items():
        for variant, spec in results.get("variants").items():
            untrained = spec["untrained_selection_successes"]
            lines.append(
                [
                    body,
                    f"`{variant}`",
                    f"{untrained['successes']} of {untrained['episodes']}: "
                    f"{rate_cell(untrained['successes'], untrained['episodes'])}",
                    " and ".join(str(t["selection_success"]["successes"]) for t in spec["trials"]),
                    f"{spec['selection_success_median']:.2f}",
                    f"{spec['labels_median']:.0f}",
                ]
            )
    return table(
        [
            "body",
            "learner",
            "untrained: selection plays solved [95% Wilson]",
            f"after {episodes} DAgger episodes: selection mazes solved per seed (of {mazes})",
            "median",
            "labels, median",
        ],
        lines,
    )


PROTOCOL2_BODIES = ("point", "ant")
UNTRAINED_GOAL = 0.2
"""Protocol 2's learner must fail before its first label: untrained success at most 20% on the evaluation set."""
ORACLE_GAP_GOAL = 0.03
"""On the ant, the best method's final learner-only success within 3 points of the oracle's on the same mazes."""


SAVING_WORDS = {
    "supports": "the paired test passes",
    "contradicts": "the paired interval of labels - 0.3x DAgger's lies above 0",
    "undecided": "the paired test does not decide",
}
"""Claim 6's outcome on one method and body, in words (``antmaze_hirl.experiments.claims``)."""


def protocol2_goals() -> str:
    """Protocol 2's three goals, each body's measured figure beside it, met or missed, from the final folders."""
    from antmaze_hirl.experiments import claims

    summaries = {body: load(f"protocol2/{body}/summary.json") for body in PROTOCOL2_BODIES}
    report = claims.evaluate_folders(*(RESULTS / "protocol2" / body for body in PROTOCOL2_BODIES))
    rows = []
    untrained = {body: summaries[body].get("methods", "dagger", "untrained_success", "pooled") for body in summaries}
    cells = [
        f"{percent(figure['rate'], 1000)} [{100 * figure['cluster_bootstrap_95'][0]:.1f}, "
        f"{100 * figure['cluster_bootstrap_95'][1]:.1f}]"
        for figure in untrained.values()
    ]
    met = all(figure["cluster_bootstrap_95"][1] <= UNTRAINED_GOAL for figure in untrained.values())
    rows.append(["the untrained learner scores <= 20% (pooled, upper bound of the cluster bootstrap)", *cells, met])
    cells, gaps = [], {}
    for body, summary in summaries.items():
        finals = {name: spec["final_success"]["median"] for name, spec in summary.get("methods").items()}
        best = max(finals, key=finals.get)
        oracle = summary.get("oracle_success")
        gaps[body] = oracle["success_rate"] - finals[best]
        aside = "" if body == "ant" else " (not a goal)"
        cells.append(
            f"`{best}` {exact_percent(finals[best])} vs the oracle's {exact_percent(oracle['success_rate'])}: "
            f"{exact_percent(gaps[body]).removesuffix('%')} points{aside}"
        )
    rows.append(
        [
            "on the ant, the best method's final learner-only success (median of seeds) within 3 points of the "
            "oracle's on the same mazes",
            *cells,
            gaps["ant"] <= ORACLE_GAP_GOAL + 1e-9,  # rates are whole percents on 100 mazes: 3 points is 0.03
        ]
    )
    saving = report.verdicts[5]  # claim 6: DAgger's final success at <= 0.3x its labels, paired test
    cells = []
    for body in PROTOCOL2_BODIES:
        ratios = {name: summaries[body].get("methods", name, claims.PAIRED) for name in claims.ACTIVE}
        reached = {name: paired for name, paired in ratios.items() if paired["median_ratio"] is not None}
        if not reached:
            cells.append("no active method's median seed reaches it")
            continue
        name = min(reached, key=lambda method: reached[method]["median_ratio"])
        paired = reached[name]
        cells.append(
            f"`{name}` {times(paired['median_ratio'])} DAgger's labels ({paired['seeds_reached']} of "
            f"{paired['seeds']} seeds): {SAVING_WORDS[saving.outcomes[name][body]]}"
        )
    rows.append(
        [
            "the best active method reaches DAgger's final success with <= 0.3x its labels (median of 10 seeds, "
            "paired by seed), and a paired test supports it",
            *cells,
            saving.verdict == claims.HOLDS,
        ]
    )
    return table(
        ["goal", "point", "ant", "met"],
        [[*row[:-1], "**met**" if row[-1] else "**missed**"] for row in rows],
    )


def ray_sweep() -> str:
    """The small grid on the serial backend against a local Ray instance, with the ratios."""
    results = load("sweep_scaling/sweep_scaling.json")
    machine = results.get("machine")
    before, after = machine["load_average_1_5_15_before"][0], machine["load_average_1_5_15_after"][0]
    return (
        table(
            [
                f"measured (commit {results.get('git_commit')[:7]}, {machine['cpu_model']}, {machine['cpu_count']} "
                f"cores, 1-minute load average {before:.1f} before, {after:.1f} after)",
                "seconds",
            ],
            [
                ["serial backend, the whole grid", results.get("serial_seconds")],
                ["Ray start-up: `ray.init()` + first trivial task", results.get("ray_startup_seconds")],
                [
                    f"Ray with {results.get('ray_workers')} workers, the grid on the started instance",
                    results.get("ray_grid_seconds"),
                ],
                ["Ray, start-up and grid together", results.get("ray_end_to_end_seconds")],
                [
                    f"sum of the {results.get('grid', 'trials')} trials' own wall times: serial / Ray",
                    f"{results.get('serial_trial_seconds_sum')} / {results.get('ray_trial_seconds_sum')}",
                ],
            ],
        )
        + f"\n\nSerial over Ray: {times(results.get('speedup_serial_over_ray_grid'))} for the grid alone, "
        f"{times(results.get('speedup_serial_over_ray_end_to_end'))} with the start-up. The same `episodes.csv` "
        f"from both: {'yes' if results.get('episodes_csv_identical') else 'no'}."
    )


SECTIONS: dict[str, Callable[[], str]] = {
    # docs/results/low-level.md
    "low-level-eval": low_level_eval,
    "low-level-throughput": low_level_throughput,
    "low-level-selection": low_level_selection,
    "env-throughput": env_throughput,
    # docs/results/ant-in-mazes.md
    "in-maze-stage6": lambda: in_maze_pair(
        "in_maze/in_maze.json", "shipped", "runs/device/stage5.zip", "stage 6", "stage 5"
    ),
    "selection-stage6": lambda: selection(
        "select_low_level/low_level_selection_stage6.json", STAGE6_ROWS, extra="heads"
    ),
    "selection-ensembles": lambda: selection(
        "select_low_level/low_level_selection_ensembles.json", ENSEMBLE_ROWS, extra="members"
    ),
    "selection-stage3": lambda: selection_ranked(
        "select_low_level/low_level_selection_held_out_large.json",
        labels={
            "antmaze_hirl/policies/ant_td3.zip": "stage 2",
            "antmaze_hirl/policies/ant_td3.zip smoothing=0.5": "stage 2, smoothing 0.5",
        },
    ),
    "selection-stage3-later": lambda: selection_ranked(
        "select_low_level/low_level_selection_held_out_large_775k.json",
        [
            f"train_runs/ant_maze/snapshots/step_{k}000.zip{s}"
            for k in (700, 725, 750, 775)
            for s in ("", " smoothing=0.5")
        ],
    ),
    "selection-held-out": selection_held_out,
    "candidates": lambda: in_maze_rows(CANDIDATES, with_file=True),
    "selection-tilt": lambda: selection("select_low_level/low_level_selection_tilt.json", TILT_ROWS),
    "in-maze-tilt": lambda: in_maze_columns(
        "in_maze/in_maze_tilt.json",
        [
            ("stage 3", "shipped"),
            ("tilt w = 1, 750k", TILT.format(750)),
            ("tilt w = 1 + buffer, 325k", TILT_BUFFER.format(325)),
        ],
    ),
    "algorithms": algorithms,
    "smoothing": lambda: in_maze_rows(SMOOTHING_ROWS),
    "flip-diagnostics": flip_diagnostics,
    "flip-warning": flip_warning,
    # docs/guides/low-level.md
    "steady-ant-maps": steady_ant_maps,
    # README.md and docs/results/index.md
    "headline": headline,
    "headline-readme": lambda: headline(links_from="."),
    # docs/results/learner-ablation.md
    "learner-point": learner_point,
    "learner-ant": learner_ant,
    "next-cell-labels": next_cell_labels,
    # docs/results/other.md
    "demo": demo,
    "maze-families": maze_families,
    "import-time": import_time,
    "sweeps": sweeps,
    # docs/guides/vector-envs.md
    "lockstep-agreement": lockstep_agreement,
    "hierarchy-throughput": hierarchy_throughput,
    "lockstep-paths": lockstep_paths,
    "high-level-ppo": high_level_ppo,
    "paper-trial-speed": paper_trial_speed,
    # docs/guides/low-level.md
    "ensemble-speed": ensemble_speed,
    # docs/guides/protocol.md
    "untrained-learners": untrained_learners,
    "learner-selection": learner_selection,
    "protocol2-goals": protocol2_goals,
    # docs/ray.md
    "ray-sweep": ray_sweep,
}
"""Each generated block's section, by the name the command line takes."""


def main(argv: list[str] | None = None) -> int:
    """Prints one section; returns the exit status (2 with a one-line error on a bad results file)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("section", nargs="?", choices=list(SECTIONS), help="the table to print")
    parser.add_argument("--list", action="store_true", help="print the section names")
    args = parser.parse_args(argv)
    if args.list or args.section is None:
        print("\n".join(SECTIONS))
        return 0 if args.list else 2
    LOADED.clear()
    try:
        print(SECTIONS[args.section]())
    except ResultsFileError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except KeyError as error:
        print(f"error: no field {error} in {', '.join(f'results/{name}' for name in LOADED)}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
