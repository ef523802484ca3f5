"""Tables of the protocol, printed from committed results files.

Pages: ``docs/guides/protocol.md`` and ``docs/results/protocol2.md`` (``protocol2-goals``).

``python -m antmaze_lab.protocol_tables SECTION`` prints one generated block (``--list`` names them):
``untrained-learners``, ``learner-selection``, ``protocol2-goals``. Loading, formatting and the command are
:mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import sys

from antmaze_lab import tables
from antmaze_lab.claims import exact_percent
from antmaze_lab.tables import Sections, count, load, percent, rate_cell, table, times

SECTIONS = Sections("antmaze_lab.protocol_tables", __doc__)
"""Each generated block's builder, by the section name the command line takes."""

UNTRAINED_LABELS = {
    "heading_cnn": "`heading_cnn`",
    "next_cell_cnn": "`next_cell_cnn` (protocol 2's default)",
    "next_cell_vin": "`next_cell_vin` (value iteration, no wall blocking)",
    "next_cell_vin_walls": '`next_cell_vin_walls` (the "strong prior")',
}
"""The learners of the untrained-learner files, in the table's order, as protocol 2's page calls them."""


@SECTIONS.add("untrained-learners")
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


@SECTIONS.add("learner-selection")
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
"""Claim 6's outcome on one method and body, in words (``antmaze_lab.claims``)."""


@SECTIONS.add("protocol2-goals")
def protocol2_goals() -> str:
    """Protocol 2's three goals, each body's measured figure beside it, met or missed, from the final folders."""
    from antmaze_lab import claims

    summaries = {body: load(f"protocol2/{body}/summary.json") for body in PROTOCOL2_BODIES}
    report = claims.evaluate_folders(*(tables.RESULTS / "protocol2" / body for body in PROTOCOL2_BODIES))
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


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
