"""A results folder on disk: trial CSVs, the checks before resuming one, and the reports built from it."""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_text
from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.outcomes import EVALUATION_COLUMNS, EVALUATION_TEXT_COLUMNS
from antmaze_hirl.experiments.provenance import check_same_code
from antmaze_hirl.experiments.summary import summarise
from antmaze_hirl.plotting import plot_panels

COLUMNS = (
    "method",
    "seed",
    "episode",
    "success",
    "expert_cost",
    "cumulative_expert_cost",
    "attempts",
    "low_level_steps",
    "beta",
    "dataset_size",
    "removed",
    "eval_success",
    "eval_attempts",
    "eval_mazes",
    "layout",
)
"""Columns of a trial's CSV and of ``episodes.csv``: the trainer's record, the evaluation of the episode's
learner (NaN where not evaluated; ``eval_mazes`` is how many mazes), and the training maze
(:func:`~antmaze_hirl.envs.layouts.canonical_layout`)."""

TEXT_COLUMNS = ("method", "layout")


def rows_to_csv(rows: Sequence[dict[str, Any]], columns: Sequence[str] = COLUMNS) -> str:
    """The rows as CSV text with ``columns`` (default :data:`COLUMNS`; a missing value is an empty cell)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def read_rows(path: Path) -> list[dict[str, Any]]:
    """Rows of a trial CSV with numbers parsed back.

    An empty cell (what a trial from before a column existed leaves in ``episodes.csv``) reads as NaN.
    """
    with path.open() as handle:
        return [{key: _parse(key, value) for key, value in row.items()} for row in csv.DictReader(handle)]


def read_evaluations(path: Path) -> list[dict[str, Any]]:
    """Rows of an ``evaluations.csv`` (or a trial's part of it) with numbers and successes parsed back."""
    with path.open() as handle:
        return [
            {key: value if key in EVALUATION_TEXT_COLUMNS else _parse(key, value) for key, value in row.items()}
            for row in csv.DictReader(handle)
        ]


def evaluations_path(trial: Path) -> Path:
    """Where a trial's per-maze outcomes live, beside its rows: ``trials/<method>_seed<k>.evaluations.csv``."""
    return trial.with_suffix(".evaluations.csv")


def _parse(column: str, value: str) -> Any:
    if column in TEXT_COLUMNS:
        return value
    if column == "success":
        return value == "True"
    if not value:
        return math.nan
    # Counts stay whole numbers, so episodes.csv writes them back as the trial CSVs have them ("8", not "8.0").
    return int(value) if value.lstrip("-").isdigit() else float(value)


def check_resumable(
    out_dir: Path,
    config: ExperimentConfig,
    low_level_id: str,
    provenance: dict[str, Any],
    allow_code_change: bool,
) -> list[dict[str, Any]]:
    """Refuses a folder whose finished trials another setting, low level or code made.

    Returns:
        The earlier writers to keep in ``provenance.json``: none for a fresh folder, and with
        ``allow_code_change`` the folder's last writer when its code differs.
    """
    if not (out_dir / "config.json").exists() or not any((out_dir / "trials").glob("*.csv")):
        return []
    saved = json.loads((out_dir / "config.json").read_text())
    saved_low_level = saved.pop("low_level", "not recorded (a folder from before low levels were recorded)")
    # Settings added since the folder was written count at their defaults.
    saved = {**asdict(ExperimentConfig(body=config.body)), **saved}
    settings = asdict(config)
    if saved != settings:
        raise ValueError(f"{out_dir} holds results made with {saved}, not {settings}; use another --out")
    if saved_low_level != low_level_id:
        raise ValueError(
            f"{out_dir} holds results made with low-level policy {saved_low_level}, not {low_level_id}: "
            "use another --out, or delete its trials/ to rerun them with this low level"
        )
    provenance_path = out_dir / "provenance.json"
    saved_provenance = json.loads(provenance_path.read_text()) if provenance_path.exists() else None
    earlier = saved_provenance.pop("earlier", []) if saved_provenance is not None else []
    try:
        check_same_code(saved_provenance, provenance, out_dir)
    except ValueError:
        if not allow_code_change:
            raise
        return [*earlier, saved_provenance if saved_provenance is not None else {"recorded": False}]
    return earlier


def write_reports(out_dir: Path, methods: Sequence[str], seeds: int, config: ExperimentConfig) -> dict[str, Any]:
    """Writes ``episodes.csv``, ``summary.json`` and ``panels.png`` from the finished trials on disk."""
    done = [(m, s) for m in methods for s in range(seeds) if trial_path(out_dir, m, s).exists()]
    rows = [row for m, s in done for row in with_eval_mazes(read_rows(trial_path(out_dir, m, s)), config)]
    atomic_write_text(out_dir / "episodes.csv", rows_to_csv(rows))
    parts = [evaluations_path(trial_path(out_dir, m, s)) for m, s in done]
    evaluations = [row for part in parts if part.exists() for row in read_evaluations(part)]
    if evaluations:
        atomic_write_text(out_dir / "evaluations.csv", rows_to_csv(evaluations, EVALUATION_COLUMNS))
    timed = sorted(trial_path(out_dir, m, s).with_suffix(".json") for m, s in done)
    # Finished trials only (save_trial writes the .json just before the .csv); older folders lack some.
    seconds = {path.stem: json.loads(path.read_text())["seconds"] for path in timed if path.exists()}
    recorded = json.loads((out_dir / "config.json").read_text())  # the settings and the low level's identity
    provenance = json.loads((out_dir / "provenance.json").read_text())
    summary = {
        "config": recorded,
        "provenance": provenance,
        "methods": summarise(rows, methods, evaluations=evaluations or None),
        "trial_seconds": seconds,
    }
    atomic_write_json(out_dir / "summary.json", summary)
    plot_panels(rows, methods, out_dir / "panels.png", title=f"{config.body}: DAgger + active learning")
    return summary


def with_eval_mazes(trial: list[dict[str, Any]], config: ExperimentConfig) -> list[dict[str, Any]]:
    """Fills ``eval_mazes`` in a trial written before it was recorded, from the folder's (checked) settings."""
    for index, row in enumerate(trial):
        if not math.isnan(row["eval_success"]) and math.isnan(row.get("eval_mazes", math.nan)):
            final = index == len(trial) - 1
            row["eval_mazes"] = config.final_eval_episodes if final else config.eval_episodes
    return trial


def trial_path(out_dir: Path, method: str, seed: int) -> Path:
    """Where a finished trial's rows live: ``out_dir/trials/<method>_seed<seed>.csv``."""
    return out_dir / "trials" / f"{method}_seed{seed}.csv"
