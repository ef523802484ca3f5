"""The study report: figures, statistics and a Markdown summary from the data on disk.

Data format (what the study server writes; ``DIR`` is the study folder):

- ``DIR/plan.json``: the plan (:mod:`antmaze_hirl.study.plan`).
- ``DIR/participants/<pid>/episodes.csv``: one row per finished episode, columns
  ``participant, trial, method, label, practice, seed, episode, success, expert_cost,
  cumulative_expert_cost, attempts, low_level_steps, beta, dataset_size, removed, eval_success,
  eval_attempts, eval_mazes, layout, seconds_per_label, time_on_task, learner_updates``. ``practice`` and ``success``
  are ``True``/``False``; ``episode`` counts from 0 within the trial (as the trainer's records do);
  ``eval_*`` are empty except at evaluated episodes (``eval_mazes``: how many mazes); ``layout`` is
  the episode's maze (:func:`~antmaze_hirl.envs.layouts.canonical_layout`); ``seconds_per_label`` is
  the mean time from a query being shown to the click over the episode's labels (empty if the
  episode had none); ``time_on_task`` is the seconds the episode took; ``learner_updates`` is how many
  learner updates the policy that played the maze had had (with background updates one fewer than the
  episodes before it; empty in files written before the column existed).
- ``DIR/participants/<pid>/answers.jsonl``: one JSON object per line, ``{"participant": "P01",
  "trial": 1, "method": "noise", "label": "Method B", "ratings": {"mental_demand": 3, ...},
  "comment": "...", "time": 1764000000.0}``.
- ``DIR/participants/<pid>/clicks.jsonl``: the raw clicks, one JSON object per line
  (:data:`~antmaze_hirl.study.data.CLICK_COLUMNS`; read by :func:`~antmaze_hirl.study.data.load_clicks`,
  not used by the report).

Practice trials are excluded from all analysis. Participants who are missing or part-way through
contribute what they finished: episode measures use the trials whose every planned episode is on
disk, questionnaire measures every answered trial, and the tests the participants with a value for
every method. The report (``DIR/report/``) says how many participants each figure rests on.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_text
from antmaze_hirl.plotting import plot_panels
from antmaze_hirl.study.consistency import check_study_files
from antmaze_hirl.study.data import finished_trials, load_answers, load_episodes
from antmaze_hirl.study.figures import save_likert, save_per_participant
from antmaze_hirl.study.plan import StudyPlan, load_plan, williams_design
from antmaze_hirl.study.questionnaire import TLX_ITEMS
from antmaze_hirl.study.report import render_report
from antmaze_hirl.study.stats import compare_methods

OUTCOMES: tuple[tuple[str, str, str], ...] = (
    ("final_success", "Final learner success", "Learner-only success rate at the trial's last evaluation"),
    ("total_labels", "Total labels (expert cost)", "Labels the participant gave in the trial"),
    ("seconds_per_label", "Seconds per label", "The participant's median, over episodes, of the seconds per label"),
)
"""``(key, title, description)`` of the per-trial measures taken from ``episodes.csv``."""


def trial_outcomes(finished: pd.DataFrame) -> pd.DataFrame:
    """One row per finished compared trial: ``participant, method`` and each of :data:`OUTCOMES`.

    Args:
        finished: Rows of finished non-practice trials, sorted by episode (each participant does a
            method once, so ``(participant, method)`` names a trial).

    Returns:
        The per-trial measures.
    """
    grouped = finished.groupby(["participant", "method"], sort=False)
    return grouped.agg(
        # groupby's "last" skips NaN: the last evaluated episode's success, not the last episode's.
        final_success=("eval_success", "last"),
        total_labels=("cumulative_expert_cost", "last"),
        seconds_per_label=("seconds_per_label", "median"),
    ).reset_index()


def _values(frame: pd.DataFrame, column: str) -> pd.DataFrame:
    return frame[["participant", "method", column]].rename(columns={column: "value"})


def _design(plan: StudyPlan) -> dict[str, Any]:
    orders = [
        {"participant": p.id, "labels": [plan.label_of(m) for m in p.order], "methods": list(p.order)}
        for p in plan.participants
    ]
    return {
        "body": plan.body,
        "seed": plan.seed,
        "participants": len(plan.participants),
        "episodes": plan.episodes,
        "practice": plan.practice,
        "methods": [{"method": method, "label": label} for method, label in plan.labels],
        "design_rows": len(williams_design(len(plan.methods))),
        "distinct_orders": len({tuple(o["methods"]) for o in orders}),
        "orders": orders,
    }


def _contributors(frame: pd.DataFrame, methods: tuple[str, ...], description: str) -> dict[str, Any]:
    """How many participants have data in ``frame`` (columns ``participant``, ``method``), per method."""
    per_method = {m: int(frame.loc[frame["method"] == m, "participant"].nunique()) for m in methods}
    return {"description": description, "participants": int(frame["participant"].nunique()), "per_method": per_method}


def _panel_rows(finished: pd.DataFrame, names: dict[str, str]) -> list[dict[str, Any]]:
    # plot_panels draws one curve per method over "seeds"; here the participants play the seeds.
    rows = finished.drop(columns=["seed"]).rename(columns={"participant": "seed"}).to_dict("records")
    return [{**row, "method": names[row["method"]]} for row in rows]


def analyze(study_dir: str | Path) -> Path:
    """Writes the report folder ``study_dir/report/`` from the data on disk (format: module docstring).

    The folder gets ``panels.png`` (the experiment's three panels), ``likert.png`` (NASA-TLX),
    ``seconds_per_label.png``, ``outcomes.png`` (final success and labels per participant),
    ``stats.json`` (every figure) and ``report.md``.

    Args:
        study_dir: The study folder.

    Returns:
        The report folder.

    Raises:
        ValueError: If the plan or a data file is missing a required part or contradicts the plan
            (the message names the file).
    """
    study_dir = Path(study_dir)
    plan = load_plan(study_dir)
    check_study_files(study_dir, plan)  # every log's damage, and files that disagree (a deleted episodes.csv)
    episodes = load_episodes(study_dir, plan)
    finished = finished_trials(episodes.loc[~episodes["practice"].astype(bool)], plan)
    answers = load_answers(study_dir, plan)
    answered = answers.loc[~answers["practice"].astype(bool)]
    outcomes = trial_outcomes(finished)
    measures = _measures(outcomes, answered, plan.methods)
    out = study_dir / "report"
    results = {
        "design": _design(plan),
        "figures": _write_figures(out, plan, finished, outcomes, answered, measures),
        "measures": measures,
    }
    atomic_write_json(out / "stats.json", results)
    atomic_write_text(out / "report.md", render_report(results))
    return out


def _measures(outcomes: pd.DataFrame, answered: pd.DataFrame, methods: tuple[str, ...]) -> dict[str, Any]:
    """Every measure's descriptives and tests, keyed by measure (OUTCOMES, then the TLX items)."""
    measures = {}
    for key, title, description in OUTCOMES:
        measures[key] = {"title": title, "description": description, **compare_methods(_values(outcomes, key), methods)}
    for item in TLX_ITEMS:
        anchors = f"1 = {item.low_anchor.lower()} ... 5 = {item.high_anchor.lower()}"
        measures[item.key] = {
            "title": item.title,
            "description": f"NASA-TLX rating, {anchors}: {item.question}",
            **compare_methods(_values(answered, item.key), methods),
        }
    return measures


def _write_figures(
    out: Path,
    plan: StudyPlan,
    finished: pd.DataFrame,
    outcomes: pd.DataFrame,
    answered: pd.DataFrame,
    measures: dict[str, Any],
) -> dict[str, Any]:
    """Writes the PNGs; returns, per file, what it shows and how many participants it rests on."""
    names = {m: f"{plan.label_of(m)} ({m})" for m in plan.methods}
    panel_rows = _panel_rows(finished, names)
    panel_names = [names[m] for m in plan.methods]
    title = f"User study ({plan.body})"
    plot_panels(panel_rows, panel_names, out / "panels.png", title=title)
    likert = [(item.title, measures[item.key]["methods"]) for item in TLX_ITEMS]
    save_likert(likert, plan.methods, names, out / "likert.png")
    seconds = _values(outcomes, "seconds_per_label").dropna()
    save_per_participant([("median seconds per label", seconds)], plan.methods, names, out / "seconds_per_label.png")
    final, labels = _values(outcomes, "final_success"), _values(outcomes, "total_labels")
    panels = [("final learner success", final), ("total labels", labels)]
    save_per_participant(panels, plan.methods, names, out / "outcomes.png")
    return {
        "panels.png": _contributors(
            finished, plan.methods, "success, expert cost and attempts per episode (finished trials)"
        ),
        "likert.png": _contributors(
            answered, plan.methods, "NASA-TLX ratings, mean and standard error (answered trials)"
        ),
        "seconds_per_label.png": _contributors(seconds, plan.methods, "each participant's median seconds per label"),
        "outcomes.png": _contributors(
            outcomes, plan.methods, "each participant's final learner success and total labels"
        ),
    }
