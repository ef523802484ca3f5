"""Tables of the low level's tables, printed from committed results files.

Pages: ``docs/results/low-level.md`` and ``docs/guides/low-level.md``'s ``ensemble-speed``.

``python -m antmaze_lab.low_level_tables SECTION`` prints one generated block (``--list`` names them):
``low-level-eval``, ``low-level-throughput``, ``low-level-selection``, ``env-throughput``, ``ensemble-speed``,
``steady-ant-maps``, ``steady-ant-in-maze``, ``steady-ant-eval-low``.
Loading, formatting and the command are :mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from antmaze_lab.tables import Sections, count, load, rate_cell, rate_cell_of, selection_oracle, table, times

SECTIONS = Sections("antmaze_lab.low_level_tables", __doc__)
"""Each generated block's builder, by the section name the command line takes."""


@SECTIONS.add("low-level-eval")
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


@SECTIONS.add("low-level-throughput")
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


@SECTIONS.add("low-level-selection")
def low_level_selection() -> str:
    """Stage 2's selection: the pick and stage 1."""
    name = "select_low_level/low_level_selection.json"
    results = load(name)
    rows = [("the pick (stage 2)", results.get("best")), ("stage 1", "antmaze_hirl/policies/ant_td3.zip")]
    return f"{len(results.get('scores'))} rows scored.\n\n" + selection_oracle(name, rows)


@SECTIONS.add("env-throughput")
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


@SECTIONS.add("ensemble-speed")
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


STEADY_ANT_SUMMARIES = ("steady_ant/summary.json", "steady_ant/summary_student199.json", "steady_ant/summary_tilt.json")
"""``scripts/steady_ant_table.py``'s summaries, each a candidate beside the ensemble on the same maps and episodes."""

STEADY_ANT_SUITES = ("ant4", "u", "medium", "large", "giant")
"""The order of the ant suites in the steady-ant tables (smallest first); a suite not listed comes last."""


def flips_cells(row: dict[str, object]) -> list[str]:
    """``flips / steps`` and ``rate [low, high]`` per 10,000 steps of a ``steady_ant_table.py`` row."""
    low, high = row["flips_per_10k_steps_ci95"]  # type: ignore[misc]
    return [f"{row['flips']} / {row['low_level_steps']:,}", f"{row['flips_per_10k_steps']:.2f} [{low:.2f}, {high:.2f}]"]


@SECTIONS.add("steady-ant-maps")
def steady_ant_maps(names: Sequence[str] = STEADY_ANT_SUMMARIES) -> str:
    """The oracle on the fixed maps with the ensemble and each one-network candidate: success and flips, intervals.

    The ensemble's row of a map is listed once however many summaries hold it on the same tasks (they read the
    same file). A suite played with other than 20 episodes per task says its K.
    """
    rows: dict[tuple[str, str, str], list[object]] = {}
    for name in names:
        for pair in load(name).get("benchmark"):
            tasks = pair.get("tasks", "all")  # a pair read on a subset of the tasks says which
            where = f"`{pair['suite']}`" + (
                "" if pair["episodes_per_task"] == 20 else f" (K = {pair['episodes_per_task']})"
            )
            where += "" if tasks == "all" else f", tasks {','.join(map(str, tasks))}"
            for side in ("ensemble", "candidate"):
                row = pair[side]
                rows.setdefault(
                    (pair["suite"], row["file"], str(tasks)),
                    [where, f"`{row['low_level']}`", rate_cell(row["successes"], row["episodes"]), *flips_cells(row)],
                )
    order = {suite: rank for rank, suite in enumerate(STEADY_ANT_SUITES)}
    suites = sorted(dict.fromkeys(suite for suite, _, _ in rows), key=lambda suite: order.get(suite, len(order)))
    return table(
        ["map (oracle, K = 20)", "low level", "success [95% CI]", "flips / low-level steps", "flips per 10k [95% CI]"],
        [rows[key] for suite in suites for key in rows if key[0] == suite],
    )


@SECTIONS.add("steady-ant-in-maze")
def steady_ant_in_maze(names: Sequence[str] = STEADY_ANT_SUMMARIES) -> str:
    """``in_maze.py``'s held-out families with the ensemble and a candidate played side by side in one run.

    Only the summaries holding in-maze rows contribute; each run's ensemble row is its own (other episodes).
    """
    rows: list[tuple[int, list[object]]] = []
    for name in names:
        in_maze = load(name).data.get("in_maze")  # older summaries may lack the field
        if not in_maze:
            continue
        for rank, (family, entry) in enumerate(in_maze["families"].items()):
            for side in ("ensemble", "candidate"):
                row = entry[side]
                low_level = f"`{row['name']}`: `{row['low_level_id']}`"
                cells = [
                    f"`{family}`, {row['episodes']} mazes",
                    low_level,
                    rate_cell(row["successes"], row["episodes"]),
                ]
                rows.append((rank, [*cells, *flips_cells(row)]))
    return table(
        [
            "family (held-out mazes)",
            "low level",
            "success [95% CI]",
            "flips / low-level steps",
            "flips per 10k [95% CI]",
        ],
        [cells for _, cells in sorted(rows, key=lambda item: item[0])],
    )


@SECTIONS.add("steady-ant-eval-low")
def steady_ant_eval_low(names: Sequence[str] = STEADY_ANT_SUMMARIES) -> str:
    """``eval-low`` of the ensemble and a candidate on disjoint sets of held-out subgoals, per set and pooled."""
    blocks = []
    for name in names:
        eval_low = load(name).data.get("eval_low")  # summaries made before --eval-low lack the field
        if not eval_low:
            continue
        sets = eval_low["sets"]
        header = ["low level", *(f"seed {row['seed']} ({row['episodes']})" for row in sets), "pooled"]
        lines = []
        for side in ("ensemble", "candidate"):
            pooled = eval_low["pooled"][side]
            hits, trials = pooled["successes"], pooled["episodes"]
            lines.append(
                [
                    f"`{sets[0][side]['low_level_id']}`",
                    *(rate_cell(row[side]["successes"], row["episodes"]) for row in sets),
                    f"{hits} of {trials}: {rate_cell(hits, trials)}",
                ]
            )
        blocks.append(table(header, lines))
    return "\n\n".join(blocks)


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
