"""The paper's claims, one by one, against the committed results folders.

**Protocol 1** (the default, ``python -m antmaze_lab.paper_claims [--folders A,B]``): the figures that the
hand-written table of ``docs/paper-claims.md`` quotes, per body and method, from the old folders
(``results/paper_experiment/{point,ant}``, with the flaws the audit of protocol 1 found). It prints final
success (median, min-max over seeds, the paired Wilcoxon p against DAgger), labels per trial, labels to
DAgger's median final success and that ratio, the training episodes and labels at which each trial's
learner first scored >= 60% on a periodic evaluation, and the share of labels that reward-based pruning
removed.

**Protocol 2** (``--protocol2 POINT_FOLDER ANT_FOLDER [--json OUT]``): the claims table with its
verdicts, computed from each folder's ``summary.json`` (and ``episodes.csv`` where the folder has it). It
prints one markdown row per claim: the claim, what was measured on each body, and the verdict.

The verdict rules are stated once, in the docstring of :mod:`antmaze_lab.claims`, which
computes every verdict; the table's footnote summarises them.

Usage:
  python -m antmaze_lab.paper_claims                       # protocol 1, the committed folders
  python -m antmaze_lab.paper_claims --protocol2 POINT_FOLDER ANT_FOLDER [--json claims.json] [--brief]
      (the committed: results/protocol2/point results/protocol2/ant)
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_lab.claims import (
    ALPHA,
    EPISODE_LIMIT,
    FULL_SEEDS,
    LABEL_EFFECT,
    SAVING_RATIO,
    SUCCESS_EFFECT,
    Body,
    ClaimsReport,
    evaluate_folders,
    protocol1_figures,
)
from antmaze_lab.tables import lab_parser

RESULTS = Path(__file__).resolve().parents[1] / "results" / "paper_experiment"
FOLDERS = [RESULTS / "point", RESULTS / "ant"]


def _seed_range(body: Body) -> str:
    low, high = body.seeds
    return f"{low}" if low == high else f"{low}-{high}"


def _folder_line(body: Body) -> str:
    seeds = _seed_range(body)
    state = f"INTERIM: fewer than {FULL_SEEDS} seeds, no verdict is final" if body.interim else "complete"
    return f"- {body.name}: `{body.folder}`, {seeds} seeds per method ({state})"


FOOTNOTE = (
    "Verdict rules (the docstring of `antmaze_lab.claims`). Each method is paired by seed against "
    f"DAgger: two-sided Wilcoxon signed-rank test at p < {ALPHA}, split over the methods a claim tries "
    "(two reward-based: 0.025; five active: 0.01). CI is the 95% Hodges-Lehmann interval of the paired "
    "differences, unbounded with 5 pairs or fewer. With n pairs, p cannot go below 2/2^n (the floor). A body "
    "supports a claim when the median difference points the claimed way with p under the threshold. It "
    "contradicts it when the other way is significant, or when the CI excludes the claimed effect "
    f"({100 * SUCCESS_EFFECT:.0f} points of success; {100 * LABEL_EFFECT:.0f}% of DAgger's median labels). A "
    "claim holds when every body supports it, does not hold when one contradicts it, and is inconclusive "
    "otherwise. With two readings, one that holds is enough. Labels: to DAgger's median final success on the "
    "same set; a seed that never gets there ranks above every count. Claim 4: a sign test of the seeds passing "
    f"60% in under {EPISODE_LIMIT} episodes, counted from the measured untrained success (`episodes.csv`). "
    f"Claim 6: some active method at a median <= {SAVING_RATIO}x DAgger's labels whose paired test passes; "
    f"contradicted when every method's CI of labels - {SAVING_RATIO}x DAgger's is above 0. A folder with "
    f"fewer than {FULL_SEEDS} seeds in some method is INTERIM. Its rows lean, they do not decide: the "
    "verdict where the tests decide it, else the direction of the medians (direction only)."
)


def markdown(report: ClaimsReport) -> str:
    """The claims table, with its folders (INTERIM marked) above and the verdict rules below."""
    title = "Protocol 2 claims" + (" (INTERIM: not a result)" if report.interim else "")
    lines = [f"{title}:", "", *(_folder_line(body) for body in report.bodies), ""]
    lines += ["| # | the paper's claim | this project's measurement (protocol 2) | verdict |", "|---|---|---|---|"]
    lines += [f"| {row.number} | {row.claim} | {row.measurement} | **{row.printed}** |" for row in report.verdicts]
    return "\n".join([*lines, "", FOOTNOTE])


def brief_markdown(report: ClaimsReport) -> str:
    """The claims table in brief, for the README: each body's headline figures and the verdict."""
    state = " INTERIM (fewer than 10 seeds in some method): no verdict is final." if report.interim else ""
    seeds = ", ".join(f"{body.name} {_seed_range(body)}" for body in report.bodies)
    lines = [
        "| # | the paper's claim | measured: median over seeds, paired Wilcoxon p against DAgger | verdict |",
        "|---|---|---|---|",
        *(f"| {row.number} | {row.claim} | {row.brief} | **{row.printed}** |" for row in report.verdicts),
        "",
        f"Protocol 2, seeds per method: {seeds}.{state} Each figure's interval and seed count, and the verdict "
        "rules: the paper's claims page (`docs/paper-claims.md`).",
    ]
    return "\n".join(lines)


def protocol2_json(report: ClaimsReport) -> dict[str, Any]:
    """The table as data: the folders (seeds, interim), the rules' constants and every row."""
    return {
        "folders": {
            body.name: {"folder": str(body.folder), "seeds": list(body.seeds), "interim": body.interim}
            for body in report.bodies
        },
        "interim": report.interim,
        "rules": {
            "alpha": ALPHA,
            "full_seeds": FULL_SEEDS,
            "success_effect": SUCCESS_EFFECT,
            "label_effect": LABEL_EFFECT,
            "saving_ratio": SAVING_RATIO,
            "episode_limit": EPISODE_LIMIT,
        },
        "claims": [asdict(row) for row in report.verdicts],
    }


def _plain(value: Any) -> Any:
    return None if isinstance(value, float) and np.isnan(value) else value


def main(argv: Sequence[str] | None = None) -> None:
    """The command line (the module docstring)."""
    parser = lab_parser("antmaze_lab.paper_claims", __doc__)
    parser.add_argument("--folders", default=None, help="protocol 1: comma-separated folders (default: the committed)")
    parser.add_argument(
        "--protocol2", nargs=2, type=Path, metavar=("POINT_FOLDER", "ANT_FOLDER"), help="protocol 2: the claims table"
    )
    parser.add_argument("--brief", action="store_true", help="protocol 2: the README's short table")
    parser.add_argument("--json", type=Path, default=None, help="also write what is printed, as JSON, to this file")
    args = parser.parse_args(argv)
    if args.brief and args.protocol2 is None:
        parser.error("--brief is the protocol-2 table's short form: give --protocol2 POINT_FOLDER ANT_FOLDER")
    if args.protocol2 is not None:
        if args.folders is not None:
            parser.error("--folders names protocol-1 folders; --protocol2 takes its two folders itself")
        try:
            report = evaluate_folders(*args.protocol2)
        except ValueError as error:
            parser.error(str(error))
        print(brief_markdown(report) if args.brief else markdown(report))
        output: Any = protocol2_json(report)
    else:
        folders = FOLDERS if args.folders is None else [Path(f) for f in args.folders.split(",")]
        output = []
        for folder in folders:
            try:
                result = protocol1_figures(folder)
            except ValueError as error:
                parser.error(str(error))
            output.append(result)
            print(f"== {folder.name} (body {result['config']['body']}, protocol 1)")
            for method, figures in result["methods"].items():
                print(method, json.dumps(figures, default=_plain))
    if args.json is not None:
        args.json.write_text(json.dumps(output, indent=1, default=_plain) + "\n")


if __name__ == "__main__":
    main()
