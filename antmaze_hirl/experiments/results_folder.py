"""A results folder on disk: trial CSVs, the checks before resuming one, and the reports built from it.

Each finished trial is ``trials/<method>_seed<k>.csv`` plus its record ``trials/<method>_seed<k>.json``:
``{"seconds", "rows", "sha256"}``, the row count and the SHA-256 of the CSV's bytes, written just before
the CSV (:func:`trial_record`); in protocol 2 also ``"evaluations": {"rows", "sha256"}`` of the trial's
per-maze part ``trials/<method>_seed<k>.evaluations.csv``, which is checked with the CSV.
:func:`check_trial` tells a damaged trial (a cut line, a duplicated or
dropped row, an empty file, garbage, or a CSV that does not match its record) and names the file; on
resume :func:`trial_is_done` moves such a file aside to ``<name>.csv.damaged`` (its bytes are kept) and
the trial is run again. Trials written before the record held a hash get the structural checks only.
:func:`write_reports` never replaces ``episodes.csv`` and ``summary.json`` with ones that lack a trial
the old ``episodes.csv`` had (while a damaged trial is re-run, the old reports stay).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_text
from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.old_folders import experiment_settings
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

REQUIRED_COLUMNS = tuple(column for column in COLUMNS if column not in ("eval_mazes", "layout"))
"""Columns every trial CSV has (trials from before ``eval_mazes`` and ``layout`` were recorded lack those)."""


class DamagedTrial(ValueError):
    """A trial CSV that is not what its run wrote (the message names the file and what is wrong)."""


def _count_and_hash(csv_text: str) -> dict[str, Any]:
    rows = max(csv_text.count("\n") - 1, 0)  # one line per row after the header; no cell holds a newline
    return {"rows": rows, "sha256": hashlib.sha256(csv_text.encode()).hexdigest()}


def trial_record(csv_text: str, seconds: float, evaluations_text: str | None = None) -> dict[str, Any]:
    """The record saved beside a trial CSV: wall time, row count and SHA-256 of the CSV's UTF-8 bytes.

    With protocol 2's per-maze part (``evaluations_text``, :func:`evaluations_path`) its row count and
    SHA-256 go under ``"evaluations"``, so a missing or damaged part marks the trial damaged too.
    """
    record = {"seconds": seconds, **_count_and_hash(csv_text)}
    if evaluations_text is not None:
        record["evaluations"] = _count_and_hash(evaluations_text)
    return record


def _check_evaluations_part(path: Path, record: dict[str, Any], record_path: Path) -> None:
    # The trial's per-maze part against its record (protocol 2; records without "evaluations" are not checked).
    expected = record.get("evaluations")
    if expected is None:
        return
    part = evaluations_path(path)
    if not isinstance(expected, dict) or "sha256" not in expected:
        raise DamagedTrial(f'{record_path}: its "evaluations" entry is not a row count and SHA-256')
    try:
        data = part.read_bytes()
    except FileNotFoundError:
        raise DamagedTrial(f"{part}: missing (its trial's record {record_path.name} lists it)") from None
    except OSError as error:
        raise DamagedTrial(f"{part}: unreadable ({error})") from None
    if hashlib.sha256(data).hexdigest() != expected["sha256"]:
        lines = max(data.count(b"\n") - 1, 0)
        raise DamagedTrial(
            f"{part}: its bytes do not match the SHA-256 in {record_path.name} ({lines} rows, "
            f"{expected.get('rows')} written): cut, edited or damaged"
        )


def check_trial(path: Path, episodes: int) -> list[dict[str, Any]]:
    """A finished trial's rows, after checking them against its record and the experiment's episode count.

    Args:
        path: ``trials/<method>_seed<k>.csv``.
        episodes: Episodes per trial in this experiment (the rows must be episodes ``0..episodes-1``).

    Raises:
        DamagedTrial: Naming ``path`` and what is wrong.
    """
    try:
        data = path.read_bytes()
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise DamagedTrial(f"{path}: unreadable ({error})") from None
    record_path = path.with_suffix(".json")
    try:
        record = json.loads(record_path.read_text()) if record_path.exists() else {}
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise DamagedTrial(f"{record_path}: the trial's record is unreadable ({error})") from None
    if not isinstance(record, dict):
        raise DamagedTrial(f"{record_path}: the trial's record is not a JSON object")
    if "sha256" in record and hashlib.sha256(data).hexdigest() != record["sha256"]:
        lines = max(text.count("\n") - 1, 0)
        raise DamagedTrial(
            f"{path}: its bytes do not match the SHA-256 in {record_path.name} ({lines} rows, {record.get('rows')} "
            "written): cut, edited or damaged"
        )
    if not text.strip():
        raise DamagedTrial(f"{path}: empty")
    if not text.endswith("\n"):  # the writer ends every row with one: this file was cut
        raise DamagedTrial(f"{path}:{text.count(chr(10)) + 1}: the last line has no newline: the file was cut")
    reader = csv.DictReader(io.StringIO(text))
    header = reader.fieldnames or []
    missing = [column for column in REQUIRED_COLUMNS if column not in header]
    if missing or not set(header) <= set(COLUMNS):
        raise DamagedTrial(f"{path}: header {header[:20]} is not a trial's (missing {missing})"[:300])
    rows = []
    for number, row in enumerate(reader, start=2):
        if None in row or None in row.values():
            raise DamagedTrial(f"{path}:{number}: {len(header)} cells expected: a cut or glued line")
        try:
            rows.append({key: _parse(key, value) for key, value in row.items()})
        except ValueError as error:
            raise DamagedTrial(f"{path}:{number}: not a trial row ({error})") from None
        layout = row.get("layout", "")
        if layout and not _is_layout(layout):
            raise DamagedTrial(f"{path}:{number}: layout {layout[:60]!r} is not a maze (cut or edited)")
    found = [row["episode"] for row in rows]
    if found != list(range(episodes)):
        repeated = sorted({e for e in found if found.count(e) > 1}, key=str)
        absent = sorted(set(range(episodes)) - set(found))
        raise DamagedTrial(
            f"{path}: episodes {_span(found)} where 0..{episodes - 1} were expected"
            + (f"; repeated {repeated[:5]}" if repeated else "")
            + (f"; missing {absent[:5]}" if absent else "")
        )
    _check_evaluations_part(path, record, record_path)
    return rows


def _is_layout(text: str) -> bool:
    # canonical_layout's form: equal rows of 0/1 with one S (unless it is the goal) and one G.
    rows = text.split("/")
    return (
        len(rows) >= 3
        and len({len(row) for row in rows}) == 1
        and set(text) <= set("01SG/")
        and text.count("G") == 1
        and text.count("S") <= 1
    )


def _span(values: list[Any]) -> str:
    return f"[{', '.join(map(str, values[:6]))}{', ...' if len(values) > 6 else ''}] ({len(values)} rows)"


def trial_is_done(out_dir: Path, method: str, seed: int, episodes: int) -> bool:
    """Whether the trial's CSV is on disk and sound; a damaged one is moved aside (warning naming it), to re-run.

    The damaged bytes are kept as ``<name>.csv.damaged`` (``.damaged1``, ... if that exists), never deleted.
    """
    path = trial_path(out_dir, method, seed)
    if not path.exists():
        return False
    try:
        check_trial(path, episodes)
    except DamagedTrial as damaged:
        aside = _free_name(path.with_name(path.name + ".damaged"))
        path.rename(aside)
        moved = [aside.name]
        part = evaluations_path(path)
        if part.exists():  # its per-maze part goes with it (the re-run writes both again)
            part_aside = _free_name(part.with_name(part.name + ".damaged"))
            part.rename(part_aside)
            moved.append(part_aside.name)
        warnings.warn(f"{damaged}; moved to {' and '.join(moved)}, and the trial runs again", stacklevel=2)
        return False
    return True


def _free_name(path: Path) -> Path:
    candidate, number = path, 0
    while candidate.exists():
        number += 1
        candidate = path.with_name(f"{path.name}{number}")
    return candidate


def rows_to_csv(rows: Sequence[dict[str, Any]], columns: Sequence[str] = COLUMNS) -> str:
    """The rows as CSV text with ``columns`` (default :data:`COLUMNS`; a missing value is an empty cell)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def read_summary(folder: str | Path) -> dict[str, Any]:
    """The ``summary.json`` of a paper-experiment results folder, checked to be one.

    Its ``config`` (the folder's ``config.json``) reads as today's settings
    (:func:`~antmaze_hirl.experiments.old_folders.experiment_settings`: current keys, and a protocol-1 folder's
    ``protocol``, ``held_out_layouts`` and ``evaluation_envs`` where it lacks them), so old summaries compare
    with new ones.

    Raises:
        ValueError: One line naming the file: no ``summary.json``, not JSON, no ``methods`` object, or a
            setting in ``config`` under its old and new keys with two values.
    """
    path = Path(folder) / "summary.json"
    if not path.is_file():
        raise ValueError(f"no summary.json in {folder} (a paper-experiment results folder)")
    try:
        summary = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"{path} is not JSON: {error}") from None
    if not isinstance(summary, dict) or not isinstance(summary.get("methods"), dict):
        raise ValueError(f"{path} has no 'methods' object: not a paper-experiment summary")
    if isinstance(summary.get("config"), dict):
        summary["config"] = experiment_settings(summary["config"], path)
    return summary


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
    # An older folder's keys and missing settings read as what it was made with (old_folders).
    saved = experiment_settings(json.loads((out_dir / "config.json").read_text()), out_dir / "config.json")
    saved_low_level = saved.pop("low_level", "not recorded (a folder from before low levels were recorded)")
    # Other settings added since the folder was written count at their defaults, which have not changed.
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
    """Writes ``episodes.csv``, ``summary.json`` and ``panels.png`` from the sound finished trials on disk.

    A damaged trial is left out with a warning naming it. When the old ``episodes.csv`` holds a trial of
    this grid that the new one would lack (damaged, or moved aside to run again), nothing is replaced:
    the old reports stay, and the summary they hold is returned.
    """
    done = []
    for m, s in ((m, s) for m in methods for s in range(seeds)):
        if trial_path(out_dir, m, s).exists():
            try:
                done.append((m, s, check_trial(trial_path(out_dir, m, s), config.episodes)))
            except DamagedTrial as damaged:
                warnings.warn(f"left out of the reports: {damaged}", stacklevel=2)
    lost = _trials_in(out_dir / "episodes.csv") & {(m, s) for m in methods for s in range(seeds)}
    lost -= {(m, s) for m, s, _ in done}
    if lost and (out_dir / "summary.json").exists():
        warnings.warn(
            f"kept {out_dir / 'episodes.csv'} and summary.json: they hold trial(s) {sorted(lost)[:5]} that are not "
            "on disk sound now (re-run pending)",
            stacklevel=2,
        )
        return json.loads((out_dir / "summary.json").read_text())
    rows = [row for _, _, trial in done for row in with_eval_mazes(trial, config)]
    atomic_write_text(out_dir / "episodes.csv", rows_to_csv(rows))
    parts = [evaluations_path(trial_path(out_dir, m, s)) for m, s, _ in done]
    evaluations = [row for part in parts if part.exists() for row in read_evaluations(part)]
    if evaluations:
        atomic_write_text(out_dir / "evaluations.csv", rows_to_csv(evaluations, EVALUATION_COLUMNS))
    timed = sorted(trial_path(out_dir, m, s).with_suffix(".json") for m, s, _ in done)
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
    plot_panels(
        rows,
        methods,
        out_dir / "panels.png",
        title=f"{config.body}: DAgger + active learning",
        untrained=untrained_by_seed(evaluations) or None,  # protocol 2: the curves start at the untrained success
    )
    return summary


def untrained_by_seed(evaluations: Sequence[dict[str, Any]]) -> dict[str, dict[int, float]]:
    """``{method: {seed: success at episode 0}}`` of protocol 2's per-maze outcomes (``{}`` for none)."""
    outcomes: dict[str, dict[int, list[bool]]] = {}
    for row in evaluations:
        if int(row["episode"]) == 0:
            outcomes.setdefault(row["method"], {}).setdefault(int(row["seed"]), []).append(bool(row["success"]))
    return {m: {s: sum(o) / len(o) for s, o in seeds.items()} for m, seeds in outcomes.items()}


def _trials_in(episodes_csv: Path) -> set[tuple[str, int]]:
    # The (method, seed) trials an episodes.csv holds; none when it is missing or unreadable.
    try:
        with episodes_csv.open() as handle:
            return {(row["method"], int(row["seed"])) for row in csv.DictReader(handle)}
    except (OSError, UnicodeDecodeError, KeyError, TypeError, ValueError, csv.Error):
        return set()


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
