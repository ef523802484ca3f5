"""The README's tables of a paper-experiment results folder, printed from its ``summary.json``.

Every figure of the README's experiment tables comes from this command, so each is traceable to a committed
file. Two tables: final success and expert cost, then learning per label (success at label budgets, the
normalised area under the success-vs-labels curve, labels to match plain DAgger), each paired by seed
against DAgger (Wilcoxon signed-rank p; with 5 seeds it cannot go below 0.0625). With ``--beside`` a third
table sets each method's final success beside another run's of the same methods and seeds (the same
experiment with another low level, say), paired by seed: per method and pooled over every method, over
the seeds both runs hold. The two runs must share the final mazes (body, maze size, layout split and
episodes); a note names every other setting they differ in.

Usage:
  python -m antmaze_lab.paper_tables results/paper_experiment/point [--tables cost,per-label,effort]
  python -m antmaze_lab.paper_tables results/paper_experiment/ant --beside OTHER_FOLDER --names 'this run,other'
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from antmaze_hirl.experiments.curves import LABEL_BUDGETS
from antmaze_hirl.experiments.results_folder import read_summary
from antmaze_hirl.experiments.summary import median_range
from antmaze_hirl.experiments.uncertainty import paired_comparison
from antmaze_lab.claims import NEVER
from antmaze_lab.tables import lab_parser

TABLES = ("cost", "per-label", "effort", "beside")
"""The tables this prints, in order; ``beside`` only with ``--beside``."""
SMOOTHED = "labels_to_match_dagger_per_seed_smoothed"
"""The paired figure whose per-seed target averages DAgger's last evaluations (its count: ``target_evaluations``)."""

# The settings that fix a seed's final evaluation mazes: two runs are paired by seed only when they agree.
SAME_MAZES = ("body", "maze_size", "held_out_layouts", "final_eval_episodes")


def _methods_run(summary: dict[str, Any]) -> Iterator[tuple[str, dict[str, Any]]]:
    # Methods named but without trials (seeds 0) have no figures to print.
    return ((name, method) for name, method in summary["methods"].items() if method.get("seeds"))


def _percent(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.0f}%"


def _spread(figure: dict[str, Any], fmt: Any = _percent) -> str:
    if figure.get("median") is None:
        return "n/a"
    return f"{fmt(figure['median'])} ({fmt(figure['min'])}-{fmt(figure['max'])})"


def _p_value(method: dict[str, Any], figure: str) -> str:
    test = method.get("vs_dagger", {}).get(figure)
    return "" if not test or test.get("wilcoxon_p") is None else f", p = {test['wilcoxon_p']:.3g}"


def _minutes(seconds: dict[str, float], method: str) -> str:
    times = [value / 60 for key, value in seconds.items() if key.rsplit("_seed", 1)[0] == method]
    return f"{min(times):.1f}-{max(times):.1f} min" if times else "n/a"


def pooled_interval(pooled: dict[str, Any]) -> tuple[float, float]:
    """A pooled rate's 95% interval: its cluster bootstrap (protocol 2), else its Wilson interval (protocol 1)."""
    low, high = pooled.get("cluster_bootstrap_95") or pooled["wilson_95"]
    return low, high


def _interval_name(summary: dict[str, Any]) -> str:
    pooled = [m["final_success"]["pooled"] for _, m in _methods_run(summary) if m["final_success"].get("pooled")]
    return "cluster bootstrap" if pooled and "cluster_bootstrap_95" in pooled[0] else "Wilson"


def _rate_cell(pooled: dict[str, Any] | None) -> str:
    if not pooled:
        return "n/a"
    low, high = pooled_interval(pooled)
    return f"{100 * pooled['rate']:.1f}% [{100 * low:.1f}, {100 * high:.1f}]"


def cost_table(summary: dict[str, Any]) -> str:
    """Final learner-only success and what it cost, one row per method, and the oracle's success.

    In protocol 2 a column gives the untrained learner's success on the same mazes (where the curve starts).
    """
    untrained = any("untrained_success" in method for _, method in _methods_run(summary))
    lines = [
        "| method |"
        + (" untrained success, pooled [95% cluster bootstrap] |" if untrained else "")
        + f" final success, median (min-max) | pooled [95% {_interval_name(summary)}] | labels / episode "
        "| attempts / episode | labels per trial, median (min-max) | trial time |",
        "|---|" + ("---|" if untrained else "") + "---|---|---|---|---|---|",
    ]
    for name, method in _methods_run(summary):
        interval = _rate_cell(method["final_success"]["pooled"])
        start = f" {_rate_cell(method.get('untrained_success', {}).get('pooled'))} |" if untrained else ""
        lines.append(
            f"| {name} |{start} {_spread(method['final_success'])}{_p_value(method, 'final_success')} | {interval} "
            f"| {method['mean_expert_cost_per_episode']:.1f} | {method['mean_attempts_per_episode']:.1f} "
            f"| {_spread(method.get('total_labels', {}), lambda v: f'{v:.0f}')} "
            f"| {_minutes(summary.get('trial_seconds', {}), name)} |"
        )
    oracle = summary.get("oracle_success")
    if oracle:
        low, high = oracle["wilson_95"]
        successes = round(oracle["success_rate"] * oracle["episodes"])
        blank = " |" if untrained else ""
        lines.append(
            f"| oracle success |{blank} | {successes} of {oracle['episodes']}: {100 * oracle['success_rate']:.0f}% "
            f"[{100 * low:.1f}, {100 * high:.1f}] | | {oracle['mean_attempts']:.1f} | | |"
        )
    return "\n".join(lines)


def per_label_table(summary: dict[str, Any]) -> str:
    """Learning per label: success at each budget, normalised AUC and labels to match DAgger's success."""
    budgets = " | ".join(f"success at {budget} labels" for budget in LABEL_BUDGETS)
    run = [method for _, method in _methods_run(summary)]
    horizon = next((m["normalised_auc"].get("label_horizon") for m in run if "normalised_auc" in m), None)
    auc = "normalised AUC" if horizon is None else f"normalised AUC over 0-{horizon:.0f} labels"
    # Protocol 2 summaries also pair the question by seed (summary.py); older ones print as they did.
    paired = any("labels_to_match_dagger_per_seed" in m for m in run)
    # The count of evaluations each smoothed target averaged, as the summary recorded it.
    counts = sorted({int(m[SMOOTHED]["target_evaluations"]) for m in run if SMOOTHED in m})
    smoothed = bool(counts)
    lines = [
        f"| method | {budgets} | {auc} | labels to match DAgger, median (seeds reaching) | ratio to DAgger |"
        + (
            " ratio to DAgger paired by seed, median (seeds reaching; Wilcoxon p of the paired labels) |"
            if paired
            else ""
        )
        + (f" paired, target the mean of DAgger's last {'/'.join(map(str, counts))} evaluations |" if smoothed else ""),
        "|---|" + "---|" * (len(LABEL_BUDGETS) + 3 + paired + smoothed),
    ]
    for name, method in _methods_run(summary):
        cells = [
            _spread(method["success_at_labels"][str(budget)]) + _p_value(method, f"success_at_{budget}_labels")
            for budget in LABEL_BUDGETS
        ]
        auc = _spread(method["normalised_auc"], lambda v: f"{v:.2f}") + _p_value(method, "normalised_auc")
        match = method.get("labels_to_match_dagger", {})
        labels = "n/a" if match.get("median") is None else f"{match['median']:.0f}"
        reached = f" ({match['seeds_reached']} of {method['seeds']})" if match else ""
        ratio = "n/a" if match.get("ratio_vs_dagger") is None else f"{match['ratio_vs_dagger']:.2f}x"
        row = f"| {name} | {' | '.join(cells)} | {auc} | {labels}{reached} | {ratio} |"
        if paired:
            row += f" {_paired_ratio(method.get('labels_to_match_dagger_per_seed'))} |"
        if smoothed:
            row += f" {_paired_ratio(method.get(SMOOTHED))} |"
        lines.append(row)
    # Summaries from before same_set was recorded print no note.
    same = {m["labels_to_match_dagger"].get("same_set") for m in run if "labels_to_match_dagger" in m} - {None}
    if same:
        lines.append("")
        if same == {True}:
            lines.append(
                "Labels to match DAgger: same_set true: DAgger's target and every curve are read on one "
                "evaluation set (protocol 2)."
            )
        elif same == {False}:
            lines.append(
                "Labels to match DAgger: same_set false: DAgger's target is read on the final set and the "
                "curves' earlier points on the periodic set (protocol 1)."
            )
        else:
            lines.append("Labels to match DAgger: same_set differs between methods.")
    return "\n".join(lines)


def _paired_ratio(figure: dict[str, Any] | None) -> str:
    """The median per-seed ratio, the seeds reaching their target, and the paired Wilcoxon p of labels.

    The test pairs each seed's labels to its target with DAgger's own labels to it; a seed that never gets
    there counts as ``claims.NEVER`` labels, as in the claims' own label tests.
    """
    if figure is None:  # DAgger, the baseline itself
        return "1.00x"
    median = "n/a" if figure["median_ratio"] is None else f"{figure['median_ratio']:.2f}x"
    differences = [
        NEVER if seed["labels"] is None else seed["labels"] - seed["baseline_labels"] for seed in figure["per_seed"]
    ]
    test = paired_comparison(differences, [0.0] * len(differences))
    p_value = "" if test["wilcoxon_p"] is None else f", p = {test['wilcoxon_p']:.3g}"
    return f"{median} ({figure['seeds_reached']} of {figure['seeds']}{p_value})"


def effort_table(summary: dict[str, Any]) -> str:
    """Each method's labels over a trial against plain DAgger's, and whether its final success is DAgger's.

    The ask-less goal reads off it: ``gated`` at <= 0.3x DAgger's labels, its median final success
    inside DAgger's pooled 95% interval (or above it): Wilson in protocol 1, cluster bootstrap in protocol 2.
    """
    dagger = summary["methods"].get("dagger", {})
    if not dagger.get("seeds") or not dagger["final_success"].get("pooled"):
        return "(no plain DAgger trials with counted evaluations to compare with)"
    low, _ = pooled_interval(dagger["final_success"]["pooled"])
    dagger_labels = dagger["total_labels"]["median"]
    lines = [
        "| method | labels per trial, median | ratio to DAgger | final success, median "
        "| DAgger's success (median >= its pooled lower bound) |",
        "|---|---|---|---|---|",
    ]
    for name, method in _methods_run(summary):
        labels, final = method["total_labels"]["median"], method["final_success"]["median"]
        matched = "yes" if final >= low else "no"
        lines.append(
            f"| {name} | {labels:.0f} | {labels / dagger_labels:.2f}x | {_percent(final)} "
            f"| {matched} (bound {100 * low:.1f}%) |"
        )
    return "\n".join(lines)


def _rates_by_seed(method: dict[str, Any]) -> dict[int, float]:
    return {entry["seed"]: entry["rate"] for entry in method["final_success"].get("per_seed", [])}


def _paired_cell(values: list[float], baseline: list[float]) -> str:
    test = paired_comparison(values, baseline)
    if not test["pairs"]:
        return "| n/a | |"
    p_value = "n/a" if test["wilcoxon_p"] is None else f"{test['wilcoxon_p']:.3g}"
    ups, downs = sum(d > 0 for d in test["differences"]), sum(d < 0 for d in test["differences"])
    points = round(100 * test["median_difference"], 1) + 0.0  # + 0.0 turns -0.0 into 0.0
    return f"| {points:+g} ({ups} up, {downs} down of {test['pairs']}) | {p_value} |"


def beside_table(summary: dict[str, Any], other: dict[str, Any], names: tuple[str, str]) -> str:
    """Final success of each method in ``summary`` beside ``other``'s, paired by seed.

    Only seeds both runs hold are paired (a seed is the same evaluation mazes and random streams in each);
    the medians are over those seeds. The pooled row puts every method's pairs into one signed-rank test;
    the methods of one seed share its mazes, so those pairs are not independent and its p is optimistic.
    Notes under the table name the methods only one run holds and the settings the two configs differ in.

    Raises:
        ValueError: If the two runs' final mazes differ (a setting of :data:`SAME_MAZES`), or they share no
            method with per-seed final success on a common seed.
    """
    configs = summary.get("config", {}), other.get("config", {})
    differing = sorted(
        key for key in configs[0].keys() | configs[1].keys() if configs[0].get(key) != configs[1].get(key)
    )
    if mazes := [f"{key} {configs[0].get(key)!r} vs {configs[1].get(key)!r}" for key in SAME_MAZES if key in differing]:
        raise ValueError(f"the runs' final mazes differ ({'; '.join(mazes)}), so their seeds do not pair")
    lines = [
        f"| method | {names[0]}, median (min-max) | {names[1]}, median (min-max) "
        "| paired difference, median (points) | Wilcoxon p |",
        "|---|---|---|---|---|",
    ]
    pooled: tuple[list[float], list[float]] = ([], [])
    alone = [name for name, _ in _methods_run(summary) if not other["methods"].get(name, {}).get("seeds")]
    alone += [name for name, _ in _methods_run(other) if not summary["methods"].get(name, {}).get("seeds")]
    for name, method in _methods_run(summary):
        if name in alone:
            continue
        mine, theirs = _rates_by_seed(method), _rates_by_seed(other["methods"][name])
        seeds = sorted(mine.keys() & theirs.keys())
        values, baseline = [mine[seed] for seed in seeds], [theirs[seed] for seed in seeds]
        pooled[0].extend(values)
        pooled[1].extend(baseline)
        spreads = [_spread(median_range(v)) for v in (values, baseline)]
        lines.append(f"| {name} | {spreads[0]} | {spreads[1]} {_paired_cell(values, baseline)}")
    if not pooled[0]:
        raise ValueError("the two summaries share no method with per-seed final success on a common seed")
    lines.append(f"| every method pooled | | {_paired_cell(*pooled)}")
    oracles = [run.get("oracle_success") for run in (summary, other)]
    if all(oracles):
        cells = [f"{100 * oracle['success_rate']:.0f}% of {oracle['episodes']}" for oracle in oracles]
        lines.append(f"| oracle success | {cells[0]} | {cells[1]} | | |")
    settings = [f"{key} ({configs[0].get(key)!r} vs {configs[1].get(key)!r})" for key in differing]
    lines.append("")
    lines.append(f"Methods in one run only (not compared): {', '.join(alone) or 'none'}.")
    lines.append(f"The configs differ in: {', '.join(settings) or 'nothing'}.")
    return "\n".join(lines)


def _load_summary(parser: argparse.ArgumentParser, folder: Path, *, per_label: bool = True) -> dict[str, Any]:
    path = folder / "summary.json"
    try:
        summary = read_summary(folder)
    except ValueError as error:
        parser.error(str(error))
    runs = [method for method in summary["methods"].values() if isinstance(method, dict) and method.get("seeds")]
    if any("final_success" not in method for method in runs):
        parser.error(f"{path} has a method with trials but no 'final_success': not a paper-experiment summary")
    if per_label and any("success_at_labels" not in method for method in runs):
        parser.error(f"{path} predates the per-label figures (success at label budgets): rerun the experiment")
    return summary


def main() -> None:
    """The command line (the module docstring): prints the tables of one folder."""
    parser = lab_parser("antmaze_lab.paper_tables", __doc__)
    parser.add_argument("folder", type=Path, help="a results folder with summary.json")
    parser.add_argument(
        "--beside", type=Path, default=None, help="another results folder to set final success beside (default: none)"
    )
    parser.add_argument(
        "--names", default="this run,beside", help="the two runs' column names, comma-separated (default: %(default)s)"
    )
    parser.add_argument(
        "--tables",
        default=None,
        help=f"print only these tables, comma-separated from {list(TABLES)}, without the goals "
        "(what the docs' generated blocks paste; default: every table and the goals)",
    )
    args = parser.parse_args()
    names = tuple(part.strip() for part in args.names.split(","))
    if len(names) != 2 or not all(names):
        parser.error(f"--names takes two comma-separated names, got {args.names!r}")
    if args.beside is None and args.names != parser.get_default("names"):
        parser.error(f"--names {args.names!r} names the --beside columns: pass --beside too")
    chosen = list(TABLES) if args.tables is None else [name.strip() for name in args.tables.split(",")]
    unknown = [name for name in chosen if name not in TABLES]
    if unknown or not chosen:
        parser.error(f"--tables takes names from {list(TABLES)}, got {args.tables!r}")
    if "beside" in chosen and args.beside is None and args.tables is not None:
        parser.error("--tables beside needs --beside FOLDER")
    summary = _load_summary(parser, args.folder)
    # Both summaries are read before anything is printed, so a bad --beside fails alone on one line.
    beside = None
    if args.beside is not None:
        try:
            beside = beside_table(summary, _load_summary(parser, args.beside, per_label=False), names)
        except ValueError as error:
            parser.error(f"--beside {args.beside}: {error}")
    tables = {"cost": cost_table(summary), "per-label": per_label_table(summary), "effort": effort_table(summary)}
    if beside is not None:
        tables["beside"] = beside
    print("\n\n".join(tables[name] for name in chosen if name in tables))
    if args.tables is None:
        print("\ngoals:", json.dumps(summary.get("goals", {}), indent=1))


if __name__ == "__main__":
    main()
