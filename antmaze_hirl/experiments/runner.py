"""The paper's experiment: DAgger with each active-learning method, several seeds, one table of episodes."""

from __future__ import annotations

import csv
import io
import json
import math
import multiprocessing
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from tqdm.auto import tqdm

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_text
from antmaze_hirl.dagger import DAggerTrainer, ExponentialBetaSchedule, HighLevelPolicy, evaluate_high_level
from antmaze_hirl.dagger.strategies import make_strategy
from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.plots import plot_panels
from antmaze_hirl.experiments.summary import summarise
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.sb3_ext.loading import policy_fingerprint
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy

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
)


def low_level_identity(body: str, low_level: Any = None) -> str:
    """What a results folder records of the low level: the weights' fingerprint, or the callable's name.

    ``None`` stands for the policy shipped for ``body`` (what the high-level env loads by default).
    """
    model = load_shipped_policy(body) if low_level is None else low_level
    if isinstance(getattr(model, "policy", None), torch.nn.Module) or isinstance(model, torch.nn.Module):
        return f"sha256:{policy_fingerprint(model)}"
    named = model if hasattr(model, "__qualname__") else type(model)
    return f"callable:{named.__module__}.{named.__qualname__}"  # weights unknown: only what it is is checked


def make_env(config: ExperimentConfig, low_level: Any = None) -> gym.Env:
    """The high-level env of the experiment."""
    return gym.make(f"antmaze_hirl/{config.body.capitalize()}Maze-v0", maze_size=config.maze_size, low_level=low_level)


def run_trial(
    method: str, seed: int, config: ExperimentConfig, *, low_level: Any = None, progress: tqdm | None = None
) -> list[dict[str, Any]]:
    """Trains one learner with ``method`` from seed ``seed``; returns one row per training episode.

    Rows at every ``eval_every``-th episode (and the last) carry the learner-only evaluation.
    """
    env, eval_env = make_env(config, low_level), make_env(config, low_level)
    rng = np.random.default_rng(seed)
    trainer = DAggerTrainer(
        env=env,
        expert=PathOracle.for_env(env, max_distance=config.expert_max_distance),
        policy=HighLevelPolicy.for_env(env, rng=rng),
        rng=rng,
        strategy=make_strategy(method),
        beta_schedule=ExponentialBetaSchedule(config.decay),
        mixing=config.mixing,  # type: ignore[arg-type]
        episodes_per_update=config.episodes_per_update,
        gradient_steps=config.gradient_steps,
    )
    rows: list[dict[str, Any]] = []
    for episode in range(config.episodes):
        record = trainer.run_episode()
        row = {"method": method, "seed": seed, **record.to_dict(), "cumulative_expert_cost": trainer.total_expert_cost}
        final = episode == config.episodes - 1
        if final or (episode + 1) % config.eval_every == 0:
            result = evaluate_high_level(
                trainer.policy, eval_env, episodes=config.final_eval_episodes if final else config.eval_episodes
            )
            row.update(eval_success=result["success_rate"], eval_attempts=result["mean_attempts"])
        rows.append({column: row.get(column, math.nan) for column in COLUMNS})
        if progress is not None:
            progress.update(1)
    env.close()
    eval_env.close()
    return rows


def run_and_save_trial(
    method: str,
    seed: int,
    config: ExperimentConfig,
    out_dir: Path,
    *,
    low_level: Any = None,
    progress: tqdm | None = None,
) -> Path:
    """Runs one trial and saves it atomically: ``trials/<method>_seed<k>.csv`` and its wall time in ``.json``."""
    start = time.perf_counter()
    rows = run_trial(method, seed, config, low_level=low_level, progress=progress)
    seconds = round(time.perf_counter() - start, 1)
    path = _trial_path(out_dir, method, seed)
    atomic_write_json(path.with_suffix(".json"), {"seconds": seconds})
    atomic_write_text(path, rows_to_csv(rows))  # last: its existence marks the trial done
    return path


def rows_to_csv(rows: Sequence[dict[str, Any]]) -> str:
    """The rows as CSV text with :data:`COLUMNS`."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=COLUMNS)
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def read_rows(path: Path) -> list[dict[str, Any]]:
    """Rows of a trial CSV with numbers parsed back."""
    with path.open() as handle:
        return [
            {
                key: value if key == "method" else (value == "True" if key == "success" else float(value))
                for key, value in row.items()
            }
            for row in csv.DictReader(handle)
        ]


def run_experiment(
    methods: Sequence[str],
    seeds: int,
    config: ExperimentConfig,
    out_dir: str | Path,
    *,
    low_level: Any = None,
    progress_bar: bool = True,
    jobs: int = 1,
) -> dict[str, Any]:
    """Runs every (method, seed) trial not yet on disk, then writes the tables, summary and panels.

    With ``jobs > 1`` the trials run in that many worker processes (each with this process's torch
    thread count); the numbers are the same as with one job, the recorded trial wall times are
    those of the busy machine. ``low_level`` must then be picklable (``None``, the shipped policy, is).
    A worker's error is raised once the trials already running have finished (each is saved).

    Each finished trial is saved atomically as ``out_dir/trials/<method>_seed<k>.csv`` (its wall time
    beside it in ``.json``), so an interrupted experiment resumes where it stopped (a trial is the
    unit of resumption).

    Writes ``out_dir/episodes.csv``, ``out_dir/summary.json`` and ``out_dir/panels.png``.

    ``out_dir/config.json`` records the settings and the low level's identity
    (:func:`low_level_identity`); a folder holding finished trials made with either different is
    refused, not resumed.

    Raises:
        ValueError: On an unknown method, or a results folder made with other settings or low level.
    """
    for method in methods:
        make_strategy(method)
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    out_dir = Path(out_dir)
    config_path = out_dir / "config.json"
    settings = asdict(config)
    low_level_id = low_level_identity(config.body, low_level)
    if config_path.exists() and any((out_dir / "trials").glob("*.csv")):
        saved = json.loads(config_path.read_text())
        saved_low_level = saved.pop("low_level", "not recorded (a folder from before low levels were recorded)")
        # Settings added since the folder was written count at their defaults.
        saved = {**asdict(ExperimentConfig(body=config.body)), **saved}
        if saved != settings:
            raise ValueError(f"{out_dir} holds results made with {saved}, not {settings}; use another --out")
        if saved_low_level != low_level_id:
            raise ValueError(
                f"{out_dir} holds results made with low-level policy {saved_low_level}, not {low_level_id}: "
                "use another --out, or delete its trials/ to rerun them with this low level"
            )
    atomic_write_json(config_path, {**settings, "low_level": low_level_id})
    # Seed-major order: an interrupted run still has every method on its first seeds.
    pending = [(m, s) for s in range(seeds) for m in methods if not _trial_path(out_dir, m, s).exists()]
    with tqdm(total=len(pending) * config.episodes, disable=not progress_bar, desc="experiment", unit="episode") as bar:
        if jobs == 1:
            for method, seed in pending:
                bar.set_postfix_str(f"{method} seed {seed}")
                run_and_save_trial(method, seed, config, out_dir, low_level=low_level, progress=bar)
                write_reports(out_dir, methods, seeds, config)  # partial results stay readable if stopped
        else:
            # Trials are independent and seeded by their own rng, so a pool gives the same numbers;
            # spawn: a fresh interpreter per worker (no forked MuJoCo or torch thread state).
            context = multiprocessing.get_context("spawn")
            initargs = (torch.get_num_threads(),)
            pool = ProcessPoolExecutor(jobs, mp_context=context, initializer=torch.set_num_threads, initargs=initargs)
            try:
                futures = [
                    pool.submit(run_and_save_trial, method, seed, config, out_dir, low_level=low_level)
                    for method, seed in pending
                ]
                for future in as_completed(futures):
                    future.result()  # re-raises a worker's error here
                    bar.update(config.episodes)
                    write_reports(out_dir, methods, seeds, config)  # partial results stay readable if stopped
            finally:
                pool.shutdown(cancel_futures=True)  # on an error, trials not started are dropped
    return write_reports(out_dir, methods, seeds, config)


def write_reports(out_dir: Path, methods: Sequence[str], seeds: int, config: ExperimentConfig) -> dict[str, Any]:
    """Writes ``episodes.csv``, ``summary.json`` and ``panels.png`` from the finished trials on disk."""
    done = [(m, s) for m in methods for s in range(seeds) if _trial_path(out_dir, m, s).exists()]
    rows = [row for m, s in done for row in read_rows(_trial_path(out_dir, m, s))]
    atomic_write_text(out_dir / "episodes.csv", rows_to_csv(rows))
    timed = sorted(_trial_path(out_dir, m, s).with_suffix(".json") for m, s in done)
    # Finished trials only (a parallel worker writes its .json just before its .csv); older folders lack some.
    seconds = {path.stem: json.loads(path.read_text())["seconds"] for path in timed if path.exists()}
    recorded = json.loads((out_dir / "config.json").read_text())  # the settings and the low level's identity
    summary = {"config": recorded, "methods": summarise(rows, methods), "trial_seconds": seconds}
    atomic_write_json(out_dir / "summary.json", summary)
    plot_panels(rows, methods, out_dir / "panels.png", title=f"{config.body}: DAgger + active learning")
    return summary


def _trial_path(out_dir: Path, method: str, seed: int) -> Path:
    return out_dir / "trials" / f"{method}_seed{seed}.csv"
