"""Tables of the learner ablation, printed from committed results files.

Pages: ``docs/results/learner-ablation.md``.

``python -m antmaze_lab.learner_tables SECTION`` prints one generated block (``--list`` names them):
``learner-point``, ``learner-ant``, ``next-cell-labels``. Loading, formatting and the command are
:mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import statistics
import sys

from antmaze_lab.tables import Sections, families, load, percent, rate_cell, share, success, table

SECTIONS = Sections("antmaze_lab.learner_tables", __doc__)
"""Each generated block's builder, by the section name the command line takes."""


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


@SECTIONS.add("learner-point")
def learner_point() -> str:
    """The point's learner ablation: one row per variant."""
    return learner_table(
        "learner_ablation/learner_ablation.json",
        {
            "heading_cnn": "previous default: CNN + MLP, 16 heading bins + distance",
            "next_cell_cnn": "same CNN, classifies the next cell (3x3)",
            "next_cell_vin": "next cell read from value iteration's Q (16 rounds, learned costs)",
            "next_cell_vin_walls": "the same, moves into walls ruled out: **the point's default**",
        },
    )


@SECTIONS.add("learner-ant")
def learner_ant() -> str:
    """The ant's learner ablation: one row per variant, with the oracle's in-maze success on ant4 beside it."""
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


@SECTIONS.add("next-cell-labels")
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


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
