"""The paper's experiment: DAgger with each active-learning method, several seeds, one table of episodes."""

from __future__ import annotations

import contextlib
import functools
import math
import os
import socket
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym
import torch
from tqdm.auto import tqdm

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_text
from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy, InverseDecayBetaSchedule, evaluate_high_level
from antmaze_hirl.dagger.strategies import METHODS, make_strategy
from antmaze_hirl.dagger.streams import trial_streams
from antmaze_hirl.envs.layout_splits import LayoutSplit
from antmaze_hirl.envs.layouts import canonical_layout
from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.experiments.backends import Backend, import_ray, run_tasks
from antmaze_hirl.experiments.config import (
    ExperimentConfig,
    evaluation_schedule,
    evaluation_sets,
    learner_settings,
    trial_learner,
)
from antmaze_hirl.experiments.outcomes import EVALUATION_COLUMNS, play_mazes, summarise_mazes
from antmaze_hirl.experiments.provenance import code_provenance, source_sha256
from antmaze_hirl.experiments.results_folder import (
    COLUMNS,
    check_resumable,
    evaluations_path,
    read_rows,
    rows_to_csv,
    trial_is_done,
    trial_path,
    trial_record,
    write_reports,
)
from antmaze_hirl.experiments.tensorboard import DAggerTensorBoard, trial_log_dir
from antmaze_hirl.experts.base import Expert
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.sb3_ext.loading import policy_fingerprint
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy

__all__ = [
    "ExperimentConfig",
    "check_methods",
    "check_worker",
    "checked_trial",
    "evaluation_layouts",
    "low_level_identity",
    "make_env",
    "make_trainer",
    "read_rows",
    "run_and_save_trial",
    "run_experiment",
    "run_trial",
    "run_trial_with_evaluations",
    "save_trial",
    "timed_trial",
    "worker_identity",
]


def low_level_identity(body: str, low_level: Any = None) -> str:
    """What a results folder records of the low level: the weights' fingerprint, or the callable's name.

    ``None`` stands for the policy shipped for ``body`` (what the high-level env loads by default).
    """
    model = load_shipped_policy(body) if low_level is None else low_level
    if isinstance(getattr(model, "policy", None), torch.nn.Module) or isinstance(model, torch.nn.Module):
        return f"sha256:{policy_fingerprint(model)}"
    named = model if hasattr(model, "__qualname__") else type(model)
    return f"callable:{named.__module__}.{named.__qualname__}"  # weights unknown: only what it is is checked


def make_env(config: ExperimentConfig, low_level: Any = None, *, split: LayoutSplit | None = None) -> gym.Env:
    """The high-level env of the experiment, drawing its mazes from the part ``split`` if given.

    ``split`` is ignored unless ``config.held_out_layouts``: the original protocol draws every maze
    from the whole family. Both are ``gym.make`` of the body's maze id (its factory,
    :func:`~antmaze_hirl.sb3_ext.shipped.make_maze_env`, plugs in the shipped policy for ``low_level=None``).
    """
    split = split if config.held_out_layouts else None
    return gym.make(maze_env_id(config.body), maze_size=config.maze_size, low_level=low_level, split=split)


class TrialEnvs:
    """The envs of one trial: training mazes, and the periodic and final evaluation sets (:func:`evaluation_sets`).

    The experiment and the user study both train and evaluate through this, so a study trial plays the
    experiment's mazes. With ``held_out_layouts`` each draws from its part of the layout partition; the
    original protocol plays both evaluation sets on one env, as it always has.

    Args:
        config: The trial's settings.
        low_level: The low-level controller (``None``: the body's shipped policy).
    """

    def __init__(self, config: ExperimentConfig, low_level: Any = None) -> None:
        self.sets = evaluation_sets(config)
        self.train = make_env(config, low_level, split="train")
        by_split = {
            split: make_env(config, low_level, split=split)
            for split in dict.fromkeys(s for s, _, _ in self.sets.values())
        }
        self.evaluation = {name: by_split[split] for name, (split, _, _) in self.sets.items()}
        self.evaluation_envs = config.evaluation_envs  # 1: serial, as committed results were made

    def evaluate(self, policy: Any, *, final: bool) -> dict[str, float]:
        """The learner alone on the final (or periodic) set: ``eval_success``, ``eval_attempts``, ``eval_mazes``."""
        name = "final" if final else "periodic"
        _, first_seed, mazes = self.sets[name]
        env = self.evaluation[name]
        result = evaluate_high_level(policy, env, episodes=mazes, seed=first_seed, num_envs=self.evaluation_envs)
        return {"eval_success": result["success_rate"], "eval_attempts": result["mean_attempts"], "eval_mazes": mazes}

    def evaluate_mazes(self, policy: Any, *, final: bool) -> list[dict[str, Any]]:
        """The learner alone on the final (or periodic) set, one outcome per maze (:func:`play_mazes`)."""
        name = "final" if final else "periodic"
        _, first_seed, mazes = self.sets[name]
        return play_mazes(policy, self.evaluation[name], episodes=mazes, seed=first_seed, num_envs=self.evaluation_envs)

    def close(self) -> None:
        """Closes every env."""
        for env in {id(env): env for env in (self.train, *self.evaluation.values())}.values():
            env.close()


def evaluation_layouts(config: ExperimentConfig, low_level: Any = None) -> list[dict[str, Any]]:
    """Every evaluation maze of the experiment: ``{"set", "seed", "layout"}`` rows for ``eval_layouts.csv``.

    Each maze is the one an evaluation episode with that seed plays: the same env is reset with
    the same seed (an episode's layout is drawn at reset, before the policy acts).
    """
    rows = []
    sets = evaluation_sets(config)
    if sets["periodic"] == sets["final"]:  # protocol 2: one set
        sets = {"curve": sets["final"]}
    for name, (split, first_seed, mazes) in sets.items():
        env = make_env(config, low_level, split=split)
        for seed in range(first_seed, first_seed + mazes):
            env.reset(seed=seed)
            rows.append({"set": name, "seed": seed, "layout": canonical_layout(maze_env(env).layout)})
        env.close()
    return rows


def make_trainer(
    method: str,
    seed: int,
    config: ExperimentConfig,
    env: Any,
    expert: Expert,
    *,
    policy_settings: dict[str, Any] | None = None,
) -> DAggerTrainer:
    """The trainer of one trial: a fresh learner seeded by ``seed``, ``method``'s strategy, ``config``'s settings.

    The experiment gives it the oracle; the user study gives it the person's page (same trainer, same numbers).
    The learner is ``config``'s (:func:`~antmaze_hirl.experiments.config.trial_learner`); ``policy_settings``
    are :class:`HighLevelPolicy` constructor settings over it (an ablation's variant).

    The learner and the trainer get independent streams spawned from ``seed`` (:func:`trial_streams`),
    and the trainer spawns its task and strategy streams from its own: on one seed, every method's learner
    starts from the same weights and trains on the same mazes and goals.
    """
    streams = trial_streams(seed)
    # The learner's reach is its teacher's (the ant's oracle gives 2 m subgoals in 4 m cells): a next-cell
    # head reads its labels and pulls its subgoals back by it (HighLevelPolicy.cell_steps).
    reach = {} if config.subgoal_reach_m is None else {"subgoal_reach_m": config.subgoal_reach_m}
    learner = trial_learner(config)
    if learner is not None:
        policy_settings = {**learner_settings(learner, config.maze_size), **(policy_settings or {})}
    strategy = make_strategy(method)
    if strategy.updates_every_step:
        strategy.step_gradient_steps = config.step_gradient_steps
    return DAggerTrainer(
        env=env,
        expert=expert,
        learner=HighLevelPolicy.for_env(env, rng=streams.learner, **{**reach, **(policy_settings or {})}),
        rng=streams.trainer,
        strategy=strategy,
        beta_schedule=InverseDecayBetaSchedule(config.decay),
        mixing=config.mixing,  # type: ignore[arg-type]
        episodes_per_update=config.episodes_per_update,
        gradient_steps=config.gradient_steps,
    )


def run_trial(
    method: str,
    seed: int,
    config: ExperimentConfig,
    *,
    low_level: Any = None,
    progress: tqdm | None = None,
    tensorboard_dir: Path | None = None,
) -> list[dict[str, Any]]:
    """Trains one learner with ``method`` from seed ``seed``; returns one row per training episode.

    Rows at the episodes of :func:`~antmaze_hirl.experiments.config.evaluation_schedule` carry the
    learner-only evaluation. With ``tensorboard_dir``, each row and each update's loss is logged there too
    (:class:`DAggerTensorBoard`); the rows are the same either way. :func:`run_trial_with_evaluations`
    also returns protocol 2's per-maze outcomes.
    """
    return run_trial_with_evaluations(
        method, seed, config, low_level=low_level, progress=progress, tensorboard_dir=tensorboard_dir
    )[0]


def run_trial_with_evaluations(
    method: str,
    seed: int,
    config: ExperimentConfig,
    *,
    low_level: Any = None,
    progress: tqdm | None = None,
    tensorboard_dir: Path | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """:func:`run_trial`'s rows and, in protocol 2, every evaluation's per-maze outcomes (else ``[]``).

    Protocol 2 evaluates the untrained learner first (``episode`` 0, 0 labels), then after each scheduled
    episode, always on the same mazes (:data:`~antmaze_hirl.experiments.outcomes.EVALUATION_COLUMNS`).
    """
    envs = TrialEnvs(config, low_level)
    env = envs.train
    trainer = make_trainer(method, seed, config, env, PathOracle.for_env(env, subgoal_reach_m=config.subgoal_reach_m))
    rows: list[dict[str, Any]] = []
    evaluations: list[dict[str, Any]] = []
    schedule = set(evaluation_schedule(config))

    def evaluate(episodes_done: int, final: bool) -> dict[str, Any]:
        if not config.evaluates_untrained:  # protocol 1, as it always ran
            return envs.evaluate(trainer.learner, final=final)
        outcomes = envs.evaluate_mazes(trainer.learner, final=final)
        trial = {"method": method, "seed": seed, "episode": episodes_done, "labels": trainer.total_expert_cost}
        evaluations.extend({**trial, **outcome} for outcome in outcomes)
        return summarise_mazes(outcomes)

    with contextlib.ExitStack() as stack:
        board = stack.enter_context(DAggerTensorBoard(tensorboard_dir)) if tensorboard_dir is not None else None
        if 0 in schedule:
            evaluate(0, final=False)
        for episode in range(config.episodes):
            record = trainer.run_episode()
            row = {
                "method": method,
                "seed": seed,
                **record.to_dict(),
                "cumulative_expert_cost": trainer.total_expert_cost,
                # The trainer drew this episode's maze and reset the env with it.
                "layout": canonical_layout(trainer.maze.layout),
            }
            final = episode == config.episodes - 1
            if episode + 1 in schedule:
                row.update(evaluate(episode + 1, final))
            rows.append({column: row.get(column, math.nan) for column in COLUMNS})
            if board is not None:
                board.write_episode(rows[-1], trainer)
            if progress is not None:
                progress.update(1)
    envs.close()
    return rows, evaluations


def run_and_save_trial(
    method: str,
    seed: int,
    config: ExperimentConfig,
    out_dir: Path,
    *,
    low_level: Any = None,
    progress: tqdm | None = None,
    tensorboard: bool = False,
) -> Path:
    """Runs one trial and saves it atomically: ``trials/<method>_seed<k>.csv`` and its wall time in ``.json``.

    With ``tensorboard``, the trial's curves go to :func:`trial_log_dir` (``out_dir/tb/<method>_seed<k>/``).
    """
    log_dir = trial_log_dir(out_dir, method, seed) if tensorboard else None
    return save_trial(out_dir, method, seed, *timed_trial(method, seed, config, low_level, log_dir, progress=progress))


def timed_trial(
    method: str,
    seed: int,
    config: ExperimentConfig,
    low_level: Any = None,
    tensorboard_dir: Path | None = None,
    *,
    progress: tqdm | None = None,
) -> tuple[list[dict[str, Any]], float, list[dict[str, Any]]]:
    """:func:`run_trial`'s rows, its wall time in seconds (rounded to 0.1 s) and its per-maze outcomes."""
    if progress is not None:
        progress.set_postfix_str(f"{method} seed {seed}")
    start = time.perf_counter()
    rows, evaluations = run_trial_with_evaluations(
        method, seed, config, low_level=low_level, progress=progress, tensorboard_dir=tensorboard_dir
    )
    return rows, round(time.perf_counter() - start, 1), evaluations


def checked_trial(
    method: str,
    seed: int,
    config: ExperimentConfig,
    low_level: Any,
    tensorboard_dir: Path | None = None,
    *,
    expected: dict[str, str],
) -> tuple[list[dict[str, Any]], float, list[dict[str, Any]]]:
    """:func:`timed_trial` on a worker, once :func:`check_worker` found the driver's low level and code there."""
    check_worker(config.body, low_level, expected)
    return timed_trial(method, seed, config, low_level, tensorboard_dir)


def worker_identity(body: str, low_level: Any = None) -> dict[str, str]:
    """What must be the same on every worker of a grid: the low level's identity and the package's sources.

    Returns:
        ``{"low_level": low_level_identity(body, low_level), "source_sha256": ...}``
        (:func:`~antmaze_hirl.experiments.provenance.source_sha256`).
    """
    return {"low_level": low_level_identity(body, low_level), "source_sha256": source_sha256()}


def check_worker(body: str, low_level: Any, expected: dict[str, str]) -> None:
    """Raises unless this process has the low level and code of ``expected`` (the driver's :func:`worker_identity`).

    A cluster node with another shipped policy or another version of the package would otherwise
    mix its trials into the driver's results.

    Raises:
        ValueError: One line naming the host, what differs, and both values.
    """
    found = worker_identity(body, low_level)
    for name, value in expected.items():
        if found[name] != value:
            raise ValueError(
                f"worker {socket.gethostname()} (pid {os.getpid()}) has {name} {found[name]}, the driver {value}: "
                "install the same antmaze_hirl (with its shipped policies) on every node"
            )


def save_trial(
    out_dir: Path,
    method: str,
    seed: int,
    rows: list[dict[str, Any]],
    seconds: float,
    evaluations: list[dict[str, Any]] | None = None,
) -> Path:
    """Saves a finished trial atomically: its rows in ``trials/<method>_seed<k>.csv``, its wall time beside it.

    Protocol 2's per-maze outcomes go to ``trials/<method>_seed<k>.evaluations.csv``, before the rows.
    """
    path, text = trial_path(out_dir, method, seed), rows_to_csv(rows)
    part = rows_to_csv(evaluations, EVALUATION_COLUMNS) if evaluations else None
    if part is not None:
        atomic_write_text(evaluations_path(path), part)
    # Rows and hashes (the rows' and the per-maze part's): damage to either is found.
    atomic_write_json(path.with_suffix(".json"), trial_record(text, seconds, part))
    atomic_write_text(path, text)  # last: its existence marks the trial done
    return path


def run_experiment(
    methods: Sequence[str],
    seeds: int,
    config: ExperimentConfig,
    out_dir: str | Path,
    *,
    low_level: Any = None,
    progress_bar: bool = True,
    jobs: int | None = None,
    allow_code_change: bool = False,
    backend: str | None = None,
    address: str | None = None,
    cpus_per_trial: int | None = None,
    max_retries: int = 3,
    tensorboard: bool = True,
) -> dict[str, Any]:
    """Runs every (method, seed) trial not yet on disk, then writes the tables, summary and panels.

    ``backend`` says where the trials run (:class:`~antmaze_hirl.experiments.backends.Backend`):
    ``"serial"`` one after the other in this process; ``"processes"`` in ``jobs`` local worker
    processes; ``"ray"`` one Ray task per trial, on a local Ray instance or the cluster at ``address``
    (or ``RAY_ADDRESS``), a task whose worker died retried up to ``max_retries`` times. ``None``:
    ``"processes"`` with ``jobs > 1``, else ``"serial"``. Each trial runs with ``cpus_per_trial``
    torch threads (``None``: this process's count), and Ray reserves that many CPUs for it. The
    numbers are the same on every backend (each trial is seeded by its own rng); the recorded trial
    wall times are those of the machine that ran it. Off the serial backend ``low_level`` must be
    picklable (``None``, the shipped policy, is), and each worker checks that it has the driver's
    low level and package sources (:func:`check_worker`) before a trial runs. A trial's error is
    raised once the trials already running have finished (each is saved).

    Only this process writes: each finished trial is saved atomically, as soon as it finishes, as
    ``out_dir/trials/<method>_seed<k>.csv`` (its wall time beside it in ``.json``), so an interrupted
    experiment resumes where it stopped (a trial is the unit of resumption).

    With ``tensorboard`` (the default) each trial also logs its episodes to ``out_dir/tb/<method>_seed<k>/``
    (``tensorboard --logdir out_dir/tb``); the logs are not part of the results and change no number.

    Writes ``out_dir/episodes.csv``, in protocol 2 ``out_dir/evaluations.csv`` (every evaluation's
    per-maze outcomes), ``out_dir/eval_layouts.csv`` (every evaluation maze:
    :func:`evaluation_layouts`), ``out_dir/summary.json`` and ``out_dir/panels.png``.

    ``out_dir/config.json`` records the settings and the low level's identity
    (:func:`low_level_identity`), ``out_dir/provenance.json`` the code and machine
    (:func:`~antmaze_hirl.experiments.provenance.code_provenance`; earlier writers under ``earlier``).
    A folder holding finished trials made with other settings or another low level is refused, not
    resumed; so is one written by other code (another commit, source or package versions, or none
    recorded) unless ``allow_code_change``.

    Raises:
        ValueError: On no or an unknown or repeated method, ``seeds`` or ``jobs`` below 1, an unknown
            backend or settings it does not take, ``"ray"`` where Ray is not installed, a results
            folder made with other settings, low level or (without ``allow_code_change``) code, or a
            worker with another low level or code.
    """
    check_methods(methods)
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"seeds must be an int >= 1 (trials per method, seeds 0..seeds-1), got {seeds!r}")
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    runner = Backend(
        kind=backend or ("processes" if jobs is not None and jobs > 1 else "serial"),
        jobs=jobs,
        address=address,
        cpus_per_task=cpus_per_trial,
        max_retries=max_retries,
    )
    if runner.kind == "ray":
        import_ray()  # before anything is written
    out_dir = Path(out_dir)
    config_path = out_dir / "config.json"
    settings = asdict(config)
    low_level_id = low_level_identity(config.body, low_level)
    provenance = code_provenance()
    earlier = check_resumable(out_dir, config, low_level_id, provenance, allow_code_change)
    atomic_write_json(config_path, {**settings, "low_level": low_level_id})
    atomic_write_json(out_dir / "provenance.json", {**provenance, "earlier": earlier})
    atomic_write_text(
        out_dir / "eval_layouts.csv", rows_to_csv(evaluation_layouts(config, low_level), ("set", "seed", "layout"))
    )
    # Seed-major order: an interrupted run still has every method on its first seeds.
    # TensorBoard logs are written where a trial runs: on a cluster, out_dir must be shared (or --no-tensorboard).
    pending = {
        (m, s): (m, s, config, low_level, trial_log_dir(out_dir, m, s) if tensorboard else None)
        for s in range(seeds)
        for m in methods
        if not trial_is_done(out_dir, m, s, config.episodes)  # a damaged trial is moved aside and runs again
    }
    serial = runner.kind == "serial"
    # Serial: the bar counts episodes (a trial takes minutes); elsewhere trials, as they come back.
    total, unit = (len(pending) * config.episodes, "episode") if serial else (len(pending), "trial")
    with tqdm(total=total, disable=not progress_bar, desc="experiment", unit=unit) as bar:

        def save(key: tuple[str, int], result: tuple[list[dict[str, Any]], float]) -> None:
            save_trial(out_dir, *key, *result)
            if not serial:
                bar.update(1)
            write_reports(out_dir, methods, seeds, config)  # partial results stay readable if stopped

        expected = {"low_level": low_level_id, "source_sha256": provenance["source_sha256"]}
        trial = (
            functools.partial(timed_trial, progress=bar)
            if serial
            else functools.partial(checked_trial, expected=expected)
        )
        run_tasks(trial, pending, runner, save)
    return write_reports(out_dir, methods, seeds, config)


def check_methods(methods: Sequence[str]) -> None:
    """Raises unless ``methods`` names at least one method, each known and none twice.

    Raises:
        ValueError: Naming the offending value and the known methods.
    """
    if isinstance(methods, str) or not methods:
        raise ValueError(f"methods must be a non-empty list of names from {list(METHODS)}, got {methods!r}")
    for method in methods:
        make_strategy(method)
    repeated = sorted({method for method in methods if list(methods).count(method) > 1})
    if repeated:
        raise ValueError(f"methods name {repeated} more than once, got {list(methods)}")
