"""Tables of ``docs/results/other.md`` and ``docs/ray.md`` (``ray-sweep``), printed from committed results files.

``python -m antmaze_lab.other_tables SECTION`` prints one generated block (``--list`` names them): ``demo``,
``maze-families``, ``import-time``, ``sweeps``, ``ray-sweep``. Loading, formatting and the command are
:mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import sys

from antmaze_lab.tables import Sections, load, rate_cell, rate_cell_of, table, times

SECTIONS = Sections("antmaze_lab.other_tables", __doc__)
"""Each generated block's builder, by the section name the command line takes."""


@SECTIONS.add("demo")
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


@SECTIONS.add("maze-families")
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


@SECTIONS.add("import-time")
def import_time() -> str:
    """``import antmaze_hirl`` against ``import gymnasium_robotics`` in fresh interpreters: medians, their ratio."""
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


@SECTIONS.add("sweeps")
def sweeps() -> str:
    """A small trial grid on the serial backend against Ray: wall seconds, start-up, the same ``episodes.csv``."""
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


@SECTIONS.add("ray-sweep")
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


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
