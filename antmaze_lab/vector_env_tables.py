"""Tables of lockstep play and vector envs, printed from committed results files.

Pages: ``docs/guides/vector-envs.md``.

``python -m antmaze_lab.vector_env_tables SECTION`` prints one generated block (``--list`` names them):
``lockstep-agreement``, ``hierarchy-throughput``, ``lockstep-paths``, ``high-level-ppo``, ``paper-trial-speed``.
Loading, formatting and the command are :mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import sys
from typing import Any

from antmaze_lab.tables import ResultsFileError, Sections, load, table, times

SECTIONS = Sections("antmaze_lab.vector_env_tables", __doc__)
"""Each generated block's builder, by the section name the command line takes."""


@SECTIONS.add("lockstep-agreement")
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


@SECTIONS.add("hierarchy-throughput")
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


@SECTIONS.add("lockstep-paths")
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


@SECTIONS.add("high-level-ppo")
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


@SECTIONS.add("paper-trial-speed")
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


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
