"""Tables of the headline figures, printed from committed results files.

Pages: ``README.md`` (``headline-readme``) and ``docs/results/index.md`` (``headline``).

``python -m antmaze_lab.headline SECTION`` prints one generated block (``--list`` names them): ``headline``,
``headline-readme``. Loading, formatting and the command are :mod:`antmaze_lab.tables`'.
"""

from __future__ import annotations

import posixpath
import sys
from typing import Any

from antmaze_lab.tables import Sections, count, families, load, percent, rate_cell, rate_cell_of, success, table

SECTIONS = Sections("antmaze_lab.headline", __doc__)
"""Each generated block's builder, by the section name the command line takes."""


def median_range(spread: dict[str, float]) -> str:
    """``"89% (80%-91%)"``: a per-seed spread's median and its min-max, as success rates on 100 mazes."""
    return f"{percent(spread['median'], 100)} ({percent(spread['min'], 100)}-{percent(spread['max'], 100)})"


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


@SECTIONS.add("headline")
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


@SECTIONS.add("headline-readme")
def headline_readme() -> str:
    """The ``headline-readme`` block."""
    return headline(links_from=".")


main = SECTIONS.main

if __name__ == "__main__":
    sys.exit(main())
