"""Renders the study's results (the content of ``stats.json``) as ``report.md``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def _fmt(value: float | None, digits: int = 3) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _p(value: float | None) -> str:
    return "n/a" if value is None else "< .001" if value < 0.001 else f"{value:.3f}"


def _f_line(name: str, test: Mapping[str, Any]) -> str:
    df = f"{_fmt(test['df_num'], 0)}, {_fmt(test['df_den'], 0)}"
    return f"- {name}: F({df}) = {_fmt(test['F'], 2)}, p = {_p(test['p'])}"


def _design(design: Mapping[str, Any]) -> list[str]:
    practice = f'{design["practice"]} episodes of plain DAgger, labelled "Practice", recorded but not analysed'
    lines = [
        "## Design",
        "",
        f"- Body: {design['body']}; study seed {design['seed']}.",
        f"- Participants planned: {design['participants']}.",
        f"- Episodes per trial: {design['episodes']}; practice trial: {practice if design['practice'] else 'none'}.",
        f"- Order: Williams design over {len(design['methods'])} methods ({design['design_rows']} rows, "
        f"shuffled by the seed); {design['distinct_orders']} distinct orders used. Position and first-order "
        f"carryover are balanced exactly when the number of participants is a multiple of {design['design_rows']}.",
        "",
        "| method | neutral label (what participants saw) |",
        "| --- | --- |",
        *[f"| {m['method']} | {m['label']} |" for m in design["methods"]],
        "",
        "| participant | order (labels) | order (methods) |",
        "| --- | --- | --- |",
        *[f"| {o['participant']} | {' → '.join(o['labels'])} | {' → '.join(o['methods'])} |" for o in design["orders"]],
        "",
    ]
    return lines


def _figures(figures: Mapping[str, Any]) -> list[str]:
    lines = ["## Figures and who contributed", ""]
    for name, figure in figures.items():
        per_method = ", ".join(f"{method}: {n}" for method, n in figure["per_method"].items())
        lines.append(f"- `{name}`: {figure['description']}; {figure['participants']} participant(s) ({per_method}).")
    return [*lines, ""]


def _measure(key: str, measure: Mapping[str, Any], names: Mapping[str, str]) -> list[str]:
    lines = [
        f"### {measure['title']} (`{key}`)",
        "",
        measure["description"] + ".",
        "",
        "| method | n | mean | SE | median | min | max |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for method, s in measure["methods"].items():
        row = " | ".join(_fmt(s[k]) for k in ("mean", "se", "median", "min", "max"))
        lines.append(f"| {names[method]} | {s['n']} | {row} |")
    tests = measure["tests"]
    lines.append("")
    if not tests["run"]:
        return [*lines, f"Tests not run: {tests['reason']}.", ""]
    lines += [
        f"Tests over the {len(tests['participants'])} participants with a value for every method:",
        "",
        _f_line("One-way ANOVA (as in the paper)", tests["anova"]),
        _f_line("Repeated-measures ANOVA (subject = participant, within = method)", tests["rm_anova"]),
        "",
        "| pair | mean difference (first - second) | t | df | p | p (Holm) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for pair in tests["posthoc"]:
        cells = f"{_fmt(pair['mean_difference'])} | {_fmt(pair['t'])} | {pair['df']} | {_p(pair['p'])}"
        lines.append(f"| {names[pair['a']]} vs {names[pair['b']]} | {cells} | {_p(pair['p_holm'])} |")
    return [*lines, ""]


def render_report(results: Mapping[str, Any]) -> str:
    """The Markdown report of a study's results.

    Args:
        results: What :func:`antmaze_hirl.study.analysis.analyze` writes to ``stats.json``.

    Returns:
        The report's text.
    """
    names = {m["method"]: f"{m['label']} ({m['method']})" for m in results["design"]["methods"]}
    lines = [
        "# User study report",
        "",
        "Practice trials are excluded from every figure and test. Episode measures use the trials whose every "
        "planned episode was recorded; questionnaire measures use every answered trial.",
        "",
        *_design(results["design"]),
        *_figures(results["figures"]),
        "## Measures",
        "",
    ]
    for key, measure in results["measures"].items():
        lines += _measure(key, measure, names)
    return "\n".join(lines)
