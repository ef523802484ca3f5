"""Rewrites a results folder's reports from its finished trials with this checkout's code, into another folder.

An experiment folder's trials (``trials/<method>_seed<k>.csv`` and their per-maze ``.evaluations.csv``) are
its data; ``episodes.csv``, ``evaluations.csv``, ``summary.json`` and ``panels.png`` are reports computed
from them. A figure added to the summary after the trials ran (``labels_to_match_dagger_per_seed``, say)
needs the reports rewritten, not the trials rerun. This copies the folder's ``config.json``,
``provenance.json`` and trials into ``OUT`` (the source is never written: it may be a running experiment's),
rewrites the reports there, and records this code beside the trials' in ``summary.json``
(``reports_provenance``). The source summary's ``oracle_success`` (measured apart from the trials) is kept.
``evaluations.csv`` can be left gzipped (``--gzip``) for committing: one protocol-2 trial's per-maze outcomes
are about 160 KB, 8 KB gzipped. ``--without-trials`` leaves the copied trials out of
``OUT`` once the reports are written: for a folder whose trials are committed elsewhere already (protocol 2's
``results/protocol2/runs/<body>.tar.gz``), so that git holds each trial's rows once.

Usage: python scripts/rewrite_reports.py FOLDER OUT [--methods m1,m2,...] [--seeds N] [--gzip] [--without-trials]
       (default methods and seeds: those of the trials on disk)
"""

from __future__ import annotations

import argparse
import gzip
import json
import shutil
import sys
from dataclasses import fields
from pathlib import Path

from antmaze_hirl.atomic_io import atomic_write_bytes, atomic_write_json
from antmaze_hirl.experiments import ExperimentConfig
from antmaze_hirl.experiments.old_folders import experiment_settings
from antmaze_hirl.experiments.provenance import code_provenance
from antmaze_hirl.experiments.results_folder import write_reports

COPIED = ("config.json", "provenance.json", "eval_layouts.csv")
"""The settings files copied from the source folder as they are (the trials are copied too)."""
KEPT = ("oracle_success",)
"""Figures of the source's ``summary.json`` that no trial holds, kept as they are: the oracle's own success on
the final mazes is a measurement of its own (``scripts/paper_experiment.py`` adds it), not a report."""


def trials_on_disk(folder: Path) -> list[tuple[str, int]]:
    """The ``(method, seed)`` of every finished trial (its ``.json`` wall-time record) in ``folder/trials``."""
    found = []
    for record in sorted((folder / "trials").glob("*_seed*.json")):
        method, _, seed = record.stem.rpartition("_seed")
        if seed.isdigit():
            found.append((method, int(seed)))
    return found


def kept_figures(folder: Path) -> dict:
    """The :data:`KEPT` figures of ``folder/summary.json`` (none without one).

    Raises:
        ValueError: One line naming the file if it is there but not JSON.
    """
    path = folder / "summary.json"
    if not path.is_file():
        return {}
    try:
        source = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON: {error}") from None
    return {key: source[key] for key in KEPT if key in source}


def rewrite(folder: Path, out: Path, methods: list[str] | None = None, seeds: int | None = None) -> dict:
    """Copies ``folder``'s settings and trials into ``out`` and writes the reports there; returns the summary.

    Raises:
        ValueError: One line naming the folder: no ``config.json``, a ``config.json`` or ``summary.json`` that
            is not JSON, a setting under its old and new keys with two values, no finished trial, a method in
            ``methods`` without finished trials, or ``out`` not empty.
    """
    if not (folder / "config.json").is_file():
        raise ValueError(f"no config.json in {folder}: not an experiment results folder")
    try:
        recorded = json.loads((folder / "config.json").read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{folder / 'config.json'} is not JSON: {error}") from None
    kept = kept_figures(folder)
    found = trials_on_disk(folder)
    if not found:
        raise ValueError(f"no finished trial in {folder / 'trials'}")
    on_disk = list(dict.fromkeys(method for method, _ in found))
    # A method without trials would only write empty reports for it: a misspelling, most likely.
    missing = [method for method in methods or () if method not in on_disk]
    if missing:
        raise ValueError(f"no finished trial of {missing} in {folder / 'trials'}; on disk: {on_disk}")
    if out.exists() and any(out.iterdir()):
        raise ValueError(f"{out} is not empty: pass a new folder")
    methods = methods or on_disk
    seeds = seeds or 1 + max(seed for _, seed in found)
    out.mkdir(parents=True, exist_ok=True)
    for name in COPIED:
        if (folder / name).is_file():
            shutil.copy2(folder / name, out / name)
    shutil.copytree(folder / "trials", out / "trials")
    known = {field.name for field in fields(ExperimentConfig)}
    settings = experiment_settings(recorded, folder / "config.json")  # an older folder as what it was made with
    config = ExperimentConfig(**{key: value for key, value in settings.items() if key in known})
    summary = write_reports(out, methods, seeds, config)
    summary.update(kept)
    summary["reports_provenance"] = {
        key: value for key, value in code_provenance().items() if key in ("git_commit", "git_dirty", "source_sha256")
    }
    atomic_write_json(out / "summary.json", summary)
    return summary


def main(argv: list[str] | None = None) -> int:
    """Command-line entry: see the module docstring."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path, help="an experiment results folder (read only)")
    parser.add_argument("out", type=Path, help="a new folder for the copy and its rewritten reports")
    parser.add_argument("--methods", default=None, help="comma-separated (default: those with trials on disk)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds 0..N-1 (default: up to the largest on disk)")
    parser.add_argument("--gzip", action="store_true", help="leave evaluations.csv as evaluations.csv.gz")
    parser.add_argument("--without-trials", action="store_true", help="remove OUT/trials once the reports are written")
    args = parser.parse_args(argv)
    if args.seeds is not None and args.seeds < 1:
        parser.error(f"--seeds must be >= 1, got {args.seeds}")
    methods = [m.strip() for m in args.methods.split(",") if m.strip()] if args.methods else None
    try:
        summary = rewrite(args.folder, args.out, methods, args.seeds)
    except ValueError as error:
        parser.error(str(error))
    evaluations = args.out / "evaluations.csv"
    if args.gzip and evaluations.exists():
        # mtime=0: the same outcomes give the same bytes, so a rewrite that changes nothing shows no diff.
        atomic_write_bytes(evaluations.with_suffix(".csv.gz"), gzip.compress(evaluations.read_bytes(), mtime=0))
        evaluations.unlink()
    if args.without_trials:
        shutil.rmtree(args.out / "trials")
    done = {method: figures.get("seeds", 0) for method, figures in summary["methods"].items()}
    written = sorted(path.name for path in args.out.iterdir() if path.is_file() and path.name not in COPIED)
    print(f"rewrote {', '.join(written)} in {args.out}: seeds per method {done}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
