"""Scoring a high-level policy on a benchmark suite: ``antmaze-hirl benchmark`` and :func:`score_policy`.

A policy picks subgoals for the suite's registered env (:mod:`antmaze_hirl.envs.suite_specs`), which drives
the body's shipped low level unless another is given. Every task of the suite is played
``episodes_per_task`` times; episode ``j`` of task ``k`` resets with seed ``seed + k * episodes_per_task + j``
and ``options={"task_id": k}``, so a score is a pure function of (suite, policy, low level, K, seed) on one
machine. The spec's ``max_episode_steps`` (a ``TimeLimit`` in subgoals) and the task's low-level budget
both apply; an episode that hits either without reaching the goal is a failure.

The report: success rate with its 95% Wilson interval, the mean number of subgoals (attempts) and of
low-level steps, per suite and per task. With ``episodes_per_task > 1`` the episodes of a task share its
maze, so the suite figure also carries a bootstrap interval over tasks (``task_bootstrap_95``), which
respects that; with one episode per task the Wilson interval is already over independent mazes.

Episodes are played by :data:`EPISODE_RUNNER`: with ``num_envs=1`` one after another on one env
(:func:`play_serial`, how the committed results were made), with more on that many lockstep copies of the
suite env (:func:`play_episodes`, the [fast-hierarchy] vector env's parts: one batched low-level forward per
low-level step for every maze still walking, one batched subgoal prediction where the policy has
``predict_batch``). Both play the same ``(task_id, seed)`` episodes with the same step limits. On the point
suites the outcomes are identical (``tests/test_benchmark_lockstep.py``); a batched forward may round the last
bits differently, which MuJoCo can turn into another ant episode now and then
(``results/lockstep_agreement/lockstep_agreement.json``). The random policy draws its subgoals from one generator in
the order it is asked, which the lockstep runner interleaves: same distribution, other draws than serial.
Both runners are thin: the loops are :mod:`antmaze_hirl.rollout`'s. The policies named on the command line
are :mod:`antmaze_hirl.experiments.benchmark_policies`', the command and its table
:mod:`antmaze_hirl.experiments.benchmark_command`'s.
"""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.envs.suite_specs import SuiteSpec, check_suite_name
from antmaze_hirl.experiments.benchmark_policies import check_oracle_settings, resolve_policy
from antmaze_hirl.experiments.uncertainty import wilson_interval
from antmaze_hirl.rollout import play_episode, play_on_copies, release_copies, subgoal_function, time_limit

DEFAULT_NUM_ENVS = 8
"""Lockstep mazes of :func:`score_policy` and ``antmaze-hirl benchmark``: faster than serial for the oracle and
the learner on both bodies (docs/guides/vector-envs.md, "Lockstep evaluation"), and a whole number of rounds on
100-episode protocols is not needed (a finished maze starts the next episode at once)."""
BOOTSTRAP_RESAMPLES = 2000
RESULTS_FORMAT = "antmaze_hirl.benchmark_result/1"


@dataclass(frozen=True)
class EpisodeOutcome:
    """One played episode.

    Attributes:
        task_id: The suite task.
        seed: The reset seed.
        success: Whether the goal was reached.
        attempts: Subgoals set.
        low_level_steps: Low-level steps taken.
        flipped: Whether the ant ended on its back.
    """

    task_id: int
    seed: int
    success: bool
    attempts: int
    low_level_steps: int
    flipped: bool


def play_serial(
    make_env: Callable[[], Any], policy: Any, episodes: Sequence[tuple[int, int]], *, progress: bool = False
) -> list[EpisodeOutcome]:
    """Plays ``episodes`` (``(task_id, seed)`` pairs) one after another on one env from ``make_env``.

    Each is :func:`~antmaze_hirl.rollout.play_episode` with ``options={"task_id": task_id}``: the policy's
    subgoal (an array, or SB3's ``(action, state)`` tuple) is clipped to the action space.
    """
    act = subgoal_function(policy)  # refused before any env is made
    env = make_env()
    outcomes = []
    bar = _progress_bar(len(episodes), progress)
    try:
        for task_id, seed in episodes:
            info = play_episode(env, act, seed=seed, options={"task_id": task_id}).info
            outcomes.append(_outcome(task_id, seed, info))
            if bar is not None:
                bar.update()
    finally:
        env.close()
        if bar is not None:
            bar.close()
    return outcomes


def play_episodes(
    make_env: Callable[[], Any],
    policy: Any,
    episodes: Sequence[tuple[int, int]],
    *,
    num_envs: int = DEFAULT_NUM_ENVS,
    progress: bool = False,
) -> list[EpisodeOutcome]:
    """Plays ``episodes``: :func:`play_serial` when ``num_envs == 1``, else on that many lockstep copies of an env.

    The lockstep copies are those of one env from ``make_env`` (:func:`~antmaze_hirl.rollout.play_on_copies`);
    its ``TimeLimit`` (:func:`~antmaze_hirl.rollout.time_limit`) truncates each episode there as it does serially.
    """
    if num_envs == 1:
        return play_serial(make_env, policy, episodes, progress=progress)
    subgoal_function(policy)  # the same refusal as serial, before any env is made
    env = make_env()
    inner = env.unwrapped
    bar = _progress_bar(len(episodes), progress)
    resets = [{"seed": seed, "options": {"task_id": task_id}} for task_id, seed in episodes]
    try:
        played = play_on_copies(
            policy,
            inner,
            resets,
            num_envs=num_envs,
            max_subgoals=time_limit(env),
            on_episode_end=None if bar is None else bar.update,
        )
    finally:
        release_copies(inner)
        env.close()
        if bar is not None:
            bar.close()
    return [_outcome(task_id, seed, episode.info) for (task_id, seed), episode in zip(episodes, played, strict=True)]


def _outcome(task_id: int, seed: int, info: dict[str, Any]) -> EpisodeOutcome:
    return EpisodeOutcome(
        task_id,
        seed,
        bool(info["is_success"]),
        int(info["attempts"]),
        int(info["total_low_level_steps"]),
        bool(info.get("flipped", False)),
    )


def _progress_bar(total: int, progress: bool) -> Any:
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="benchmark episodes", unit="episode")


EPISODE_RUNNER = play_episodes
"""Plays a list of ``(task_id, seed)`` episodes with ``num_envs`` mazes at once (1: serially)."""


def _suite_env_factory(spec: SuiteSpec, low_level: Any) -> Callable[[], Any]:
    import gymnasium as gym

    from antmaze_hirl.registration import register_envs

    register_envs()  # done by `import antmaze_hirl`, which this layer may not import
    return lambda: gym.make(spec.env_id, low_level=low_level)


def _low_level_text(spec: SuiteSpec, low_level: Any) -> str:
    from antmaze_hirl.sb3_ext.loading import policy_fingerprint

    if low_level is not None:
        # An SB3 model is named by its weights, so a report says which low level made it.
        policy = getattr(low_level, "policy", None)
        weights = f" {policy_fingerprint(low_level)}" if hasattr(policy, "state_dict") else ""
        return f"{type(low_level).__name__}{weights}"
    from antmaze_hirl.sb3_ext.shipped import load_shipped_policy

    return f"shipped {spec.body} policy {policy_fingerprint(load_shipped_policy(spec.body))}"


def _figures(outcomes: Sequence[EpisodeOutcome]) -> dict[str, Any]:
    successes = sum(outcome.success for outcome in outcomes)
    return {
        "episodes": len(outcomes),
        "successes": successes,
        "success_rate": successes / len(outcomes),
        "wilson_95": list(wilson_interval(successes, len(outcomes))),
        "mean_attempts": float(np.mean([outcome.attempts for outcome in outcomes])),
        "mean_low_level_steps": float(np.mean([outcome.low_level_steps for outcome in outcomes])),
        "flips": sum(outcome.flipped for outcome in outcomes),
    }


def task_bootstrap_interval(task_rates: Sequence[float], seed: int) -> list[float]:
    """The 95% percentile bootstrap interval of the mean of ``task_rates``, resampling tasks: scipy's, seeded.

    ``scipy.stats.bootstrap`` with :data:`BOOTSTRAP_RESAMPLES` resamples drawn by ``default_rng(seed)``; it gives
    the intervals the hand-written bootstrap before it gave, to the last bit or two (a test checks it). One task
    has nothing to resample: its interval is its rate.
    """
    from scipy.stats import bootstrap  # here, not at import: scipy.stats takes seconds to import

    rates = np.asarray(task_rates, dtype=float)
    if len(rates) == 1:
        return [float(rates[0])] * 2
    result = bootstrap(
        (rates,),
        np.mean,
        n_resamples=BOOTSTRAP_RESAMPLES,
        confidence_level=0.95,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    return [float(result.confidence_interval.low), float(result.confidence_interval.high)]


def score_policy(
    suite: str,
    policy: Any,
    *,
    episodes_per_task: int | None = None,
    seed: int = 0,
    task_ids: Sequence[int] | None = None,
    low_level: Any = None,
    num_envs: int = DEFAULT_NUM_ENVS,
    progress: bool = False,
    subgoal_reach_m: float | None = None,
    clearance_m: float | None = None,
) -> dict[str, Any]:
    """Scores a high-level policy on every task (or ``task_ids``) of ``suite``.

    Args:
        suite: A suite name (:data:`~antmaze_hirl.envs.suite_specs.SUITE_SPECS`).
        policy: ``"oracle"``, ``"random"``, a path (see :func:`resolve_policy`), or a callable
            ``observation -> subgoal`` / an object with ``predict`` (SB3 models included).
        episodes_per_task: Episodes per task, K; default the suite's (:attr:`SuiteSpec.episodes_per_task`).
        seed: Episode ``j`` of task ``k`` resets with ``seed + k * K + j``; the random policy draws from it.
        task_ids: A subset of tasks (default all), e.g. for a quick check; the report says which ran.
        low_level: The low-level controller (default: the body's shipped policy).
        num_envs: Mazes played at once in lockstep; 1 plays them one after another (module docstring).
        progress: Show a progress bar.
        subgoal_reach_m: The oracle's farthest subgoal, metres (``policy="oracle"`` only); default the
            body's experiment setting (one cell for the point, 2 m for the ant).
        clearance_m: How far the oracle's straight walks keep from walls, metres (``policy="oracle"`` only);
            default 0.2 cell.

    Returns:
        The report (module docstring): suite figures, ``"tasks"`` per task, the policy, budget and wall time;
        for the oracle also ``"oracle_subgoal_reach_m"`` and ``"oracle_clearance_m"``, the settings it played
        with.

    Raises:
        ValueError: On an unknown suite, ``episodes_per_task < 1``, ``num_envs < 1``, a bad task id, a bad
            policy file, or a ``subgoal_reach_m`` or ``clearance_m`` that is not > 0 or is given for a policy
            other than the oracle.
        FileNotFoundError: If a policy path names no file.
    """
    spec = check_suite_name(suite)
    episodes_per_task = spec.episodes_per_task if episodes_per_task is None else episodes_per_task
    if isinstance(episodes_per_task, bool) or not isinstance(episodes_per_task, int) or episodes_per_task < 1:
        raise ValueError(f"episodes_per_task must be an integer >= 1, got {episodes_per_task!r}")
    from antmaze_hirl.envs.suites import check_task_id
    from antmaze_hirl.envs.vector import check_num_envs

    num_envs = check_num_envs(num_envs)

    ids = list(range(spec.n_tasks)) if task_ids is None else [check_task_id(k, spec.n_tasks, suite) for k in task_ids]
    if not ids:
        raise ValueError("task_ids is empty: give at least one task")
    repeated = sorted({k for k in ids if ids.count(k) > 1})
    if repeated:
        # A repeated task would replay the same seeded episode and count it as a second, independent one.
        raise ValueError(f"task_ids repeat {repeated}: name each task once (--episodes-per-task sets its episodes)")
    named = isinstance(policy, str | os.PathLike)
    check_oracle_settings(
        None if policy == "oracle" else f"policy {str(policy)!r}" if named else f"a {type(policy).__name__} policy",
        {"subgoal_reach_m": subgoal_reach_m, "clearance_m": clearance_m},
    )
    make_env = _suite_env_factory(spec, low_level)
    if named:
        probe = make_env()
        try:
            acting, description = resolve_policy(
                spec, policy, probe, seed=seed, subgoal_reach_m=subgoal_reach_m, clearance_m=clearance_m
            )
        finally:
            probe.close()
    else:
        acting, description = policy, getattr(policy, "__name__", type(policy).__name__)
    episodes = [(k, seed + k * episodes_per_task + j) for k in ids for j in range(episodes_per_task)]
    started = time.perf_counter()
    outcomes = EPISODE_RUNNER(make_env, acting, episodes, num_envs=num_envs, progress=progress)
    seconds = time.perf_counter() - started
    per_task = []
    for k in ids:
        mine = [outcome for outcome in outcomes if outcome.task_id == k]
        per_task.append({"task_id": k, **_figures(mine)})
    report: dict[str, Any] = {
        "format": RESULTS_FORMAT,
        "suite": spec.name,
        "env_id": spec.env_id,
        "suite_checksum": spec.checksum,
        "body": spec.body,
        "policy": description,
        "low_level": _low_level_text(spec, low_level),
        "episodes_per_task": episodes_per_task,
        "seed": seed,
        "num_envs": num_envs,
        "task_ids": "all" if task_ids is None else ids,
        **(
            {"oracle_subgoal_reach_m": acting.subgoal_reach_m, "oracle_clearance_m": acting.clearance_m}
            if policy == "oracle"
            else {}
        ),
        **_figures(outcomes),
        "low_level_steps_total": int(sum(outcome.low_level_steps for outcome in outcomes)),
        "seconds": round(seconds, 1),
        "machine": f"{platform.machine()} {platform.processor() or platform.system()}, {os.cpu_count()} cpus",
        "tasks": per_task,
        "episode_outcomes": [asdict(outcome) for outcome in outcomes],
    }
    if episodes_per_task > 1:
        report["task_bootstrap_95"] = task_bootstrap_interval([row["success_rate"] for row in per_task], seed)
    return report


def save_report(report: dict[str, Any], path: str | Path) -> Path:
    """Writes a :func:`score_policy` report to ``path`` atomically (fsynced; the folder is made if missing).

    A report scored from Python has no ``command``: set ``report["command"]`` (how to replay it) and
    ``report["policy"]`` (the leaderboard's entry name, with the training budget) before saving it.

    Returns:
        The path written.

    Raises:
        ValueError: If ``report`` is no benchmark report (its ``format`` is not this module's).
    """
    from antmaze_hirl.atomic_io import atomic_write_json

    if report.get("format") != RESULTS_FORMAT:
        raise ValueError(f"not a benchmark report: format {report.get('format')!r}, expected {RESULTS_FORMAT!r}")
    atomic_write_json(Path(path), report)
    return Path(path)


def load_report(path: str | Path) -> dict[str, Any]:
    """A report written by ``--json``.

    Raises:
        ValueError: If the file is not a benchmark report of this format.
    """
    data = json.loads(Path(path).read_text())
    if data.get("format") != RESULTS_FORMAT:
        raise ValueError(f"{path} has format {data.get('format')!r}, expected {RESULTS_FORMAT!r}")
    return data
