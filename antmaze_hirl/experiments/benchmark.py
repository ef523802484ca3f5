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
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import time
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.envs.suite_specs import SUITE_SPECS, SuiteSpec, check_suite_name
from antmaze_hirl.experiments.uncertainty import wilson_interval

POLICY_KEYWORDS = ("oracle", "random")
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


def _action_of(policy: Any) -> Callable[[dict[str, np.ndarray]], np.ndarray]:
    act = policy.predict if hasattr(policy, "predict") else policy
    if not callable(act):
        raise ValueError(f"policy must be callable or have predict(observation), got {type(policy).__name__}")
    return act


def play_serial(
    make_env: Callable[[], Any], policy: Any, episodes: Sequence[tuple[int, int]], *, progress: bool = False
) -> list[EpisodeOutcome]:
    """Plays ``episodes`` (``(task_id, seed)`` pairs) one after another on one env from ``make_env``.

    The policy's subgoal (an array, or SB3's ``(action, state)`` tuple) is clipped to the action space.
    """
    act = _action_of(policy)
    env = make_env()
    space = env.action_space
    outcomes = []
    bar = _progress_bar(len(episodes), progress)
    try:
        for task_id, seed in episodes:
            obs, info = env.reset(seed=seed, options={"task_id": task_id})
            done = False
            while not done:
                action = act(obs)
                if isinstance(action, tuple):
                    action = action[0]
                obs, _, terminated, truncated, info = env.step(np.clip(action, space.low, space.high))
                done = terminated or truncated
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

    The lockstep copies are those of one env from ``make_env`` (module docstring); the spec's
    ``max_episode_steps`` truncates each episode there as ``gym.make``'s ``TimeLimit`` does serially.
    """
    if num_envs == 1:
        return play_serial(make_env, policy, episodes, progress=progress)
    from antmaze_hirl.dagger.evaluation import play_on_copies, release_copies

    _action_of(policy)  # the same refusal as serial, before any env is made
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
            # The unwrapped env's spec: a wrapper's ``spec`` deep-copies it, and with it a ``low_level`` that
            # cannot be copied (a model holding a lock), which Gymnasium reports as a warning.
            max_subgoals=getattr(inner.spec, "max_episode_steps", None),
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


class RandomSubgoalPolicy:
    """Subgoals drawn uniformly over the action space (the maze's inner bounds), from a seeded generator.

    Args:
        low: Lowest subgoal, metres.
        high: Highest subgoal, metres.
        seed: Seed of the draws.
    """

    def __init__(self, low: np.ndarray, high: np.ndarray, seed: int) -> None:
        self.low, self.high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        self.rng = np.random.default_rng(seed)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """A uniform subgoal (the observation is ignored)."""
        return self.rng.uniform(self.low, self.high)


def _suite_env_factory(spec: SuiteSpec, low_level: Any) -> Callable[[], Any]:
    import gymnasium as gym

    from antmaze_hirl.registration import register_envs

    register_envs()  # done by `import antmaze_hirl`, which this layer may not import
    return lambda: gym.make(spec.env_id, low_level=low_level)


def _space_text(space: Any) -> str:
    if hasattr(space, "spaces"):
        return ", ".join(f"{key} {tuple(sub.shape)}" for key, sub in space.spaces.items())
    return str(getattr(space, "shape", space))


def resolve_policy(
    spec: SuiteSpec,
    policy: str | os.PathLike[str],
    env: Any,
    *,
    seed: int,
    subgoal_reach_m: float | None = None,
    clearance_m: float | None = None,
) -> tuple[Any, str]:
    """The policy named by ``policy`` for suite ``spec`` (on ``env``, one of its envs) and its description.

    ``"oracle"``: the scripted oracle, its subgoals at most ``subgoal_reach_m`` metres away (default the
    body's experiment setting: one cell for the point, 2 m for the ant) and its straight walks ``clearance_m``
    from walls (default :class:`~antmaze_hirl.experts.PathOracle`'s, 0.2 cell); ``"random"``:
    :class:`RandomSubgoalPolicy` seeded with ``seed``; ``"planner"``: the planning learner shipped for the suite's
    body (:mod:`antmaze_hirl.dagger.shipped`), zero-shot on a map it was not trained on; else a path to an SB3
    zip of a high-level model (PPO, A2C, SAC, TD3/DDPG) or to a saved DAgger learner
    (:meth:`~antmaze_hirl.dagger.high_level_policy.HighLevelPolicy.save`, e.g. a study's ``learner.zip``).

    Raises:
        FileNotFoundError: If a path names no file.
        ValueError: If the file is neither kind, its policy is for another body or maze shape, or
            ``subgoal_reach_m`` or ``clearance_m`` is given for a policy other than the oracle or is not a
            finite number > 0.
    """
    for name, metres in (("subgoal_reach_m", subgoal_reach_m), ("clearance_m", clearance_m)):
        if metres is None:
            continue
        if policy != "oracle":
            raise ValueError(f"{name} is the oracle's setting; policy {str(policy)!r} takes none")
        number = isinstance(metres, int | float) and not isinstance(metres, bool)
        if not (number and np.isfinite(metres) and metres > 0):
            raise ValueError(f"{name} must be a finite number of metres > 0, got {metres!r}")
    if policy == "oracle":
        from antmaze_hirl.experiments.config import BODY_DEFAULTS
        from antmaze_hirl.experts import PathOracle

        reach = BODY_DEFAULTS[spec.body]["subgoal_reach_m"] if subgoal_reach_m is None else subgoal_reach_m
        return PathOracle.for_env(env, subgoal_reach_m=reach, clearance_m=clearance_m), "oracle"
    if policy == "random":
        space = env.action_space
        return RandomSubgoalPolicy(space.low, space.high, seed), "random"
    if policy == PLANNER:
        from antmaze_hirl.dagger.shipped import shipped_learner_path, shipped_learner_record

        record = shipped_learner_record(spec.body)
        path = shipped_learner_path(spec.body)
        learner, description = _learner_and_description(spec, path, env)
        return learner, (
            f"shipped {spec.body} planning learner sha256:{record['sha256'][:16]} ({record['labels']} labels)"
            + description.removeprefix(f"dagger learner {path}")
        )
    path = Path(policy)
    if not path.is_file():
        raise FileNotFoundError(
            f"no policy file at {path}; --policy takes oracle, random, or the path of an SB3 zip or a saved DAgger "
            "learner"
        )
    try:
        with zipfile.ZipFile(path) as archive:
            names = set(archive.namelist())
    except zipfile.BadZipFile:
        raise ValueError(f"{path} is not a zip (an SB3 model or a saved DAgger learner)") from None
    if "meta.json" in names:
        return _learner_and_description(spec, path, env)
    if "data" in names:
        return _load_sb3(spec, path, env), f"sb3 {path}"
    raise ValueError(f"{path} is neither an SB3 model zip (no 'data') nor a saved DAgger learner (no 'meta.json')")


PLANNER = "planner"
"""``--policy planner``: the planning learner shipped for the suite's body (:mod:`antmaze_hirl.dagger.shipped`)."""


def _learner_and_description(spec: SuiteSpec, path: Path, env: Any) -> tuple[Any, str]:
    """A saved DAgger learner for ``spec``'s maps and its description, which says when it plays zero-shot."""
    from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy, read_policy_file
    from antmaze_hirl.envs.bodies import BODY_SPECS
    from antmaze_hirl.envs.state_layout import STATE_LAYOUT

    config, _ = read_policy_file(path)
    rows, cols, scale = config["geometry"]
    inner = env.unwrapped
    bodies = [body for body, body_facts in BODY_SPECS.items() if body_facts.scale == scale]
    if scale != inner.geometry.scale:
        raise ValueError(
            f"policy {path} is a learner for the {bodies[0] if bodies else '?'} body ({scale:g} m cells); suite "
            f"{spec.name!r} is {spec.body}"
        )
    body_dim = STATE_LAYOUT.body_dim(inner.observation_space["state"].shape[0])
    if config.get("body_dim", body_dim) != body_dim:
        raise ValueError(
            f"policy {path} reads {config['body_dim']} body values per state; suite {spec.name!r} ({spec.body}) "
            f"gives {body_dim}: a learner for another body"
        )
    learner = HighLevelPolicy.load(path)
    description = f"dagger learner {path}"
    if (rows, cols) == (inner.geometry.n_rows, inner.geometry.n_cols):
        return learner, description
    if not learner.runs_on_any_map:
        raise ValueError(
            f"policy {path} is a CNN learner for {rows}x{cols} maps; suite {spec.name!r} has "
            f"{inner.geometry.n_rows}x{inner.geometry.n_cols} maps (only a planning learner runs on any map)"
        )
    # Zero-shot: the same weights, planning rounds for this map.
    moved = learner.on_map(inner.geometry, pixels_per_cell=inner.pixels_per_cell)
    return moved, f"{description} (zero-shot: trained on {rows}x{cols} maps)"


def _sb3_algorithm(path: Path) -> Any:
    from stable_baselines3 import PPO, SAC, TD3

    from antmaze_hirl.sb3_ext.loading import policy_class_of

    policy_class = policy_class_of(path)
    for algorithm in (PPO, SAC, TD3):  # A2C's policies are PPO's; DDPG's are TD3's
        if issubclass(policy_class, algorithm.policy_aliases["MlpPolicy"]):
            return algorithm
    raise ValueError(
        f"{path} holds a {policy_class.__module__}.{policy_class.__qualname__}, not a policy of PPO, A2C, SAC, "
        "TD3 or DDPG"
    )


def _load_sb3(spec: SuiteSpec, path: Path, env: Any) -> Any:
    from antmaze_hirl.sb3_ext.loading import LOAD_ERRORS

    algorithm = _sb3_algorithm(path)
    try:
        model = algorithm.load(path, device="cpu", custom_objects={"replay_buffer_class": None, "buffer_size": 1})
    except LOAD_ERRORS as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(f"{path} is not a loadable SB3 {algorithm.__name__} zip (damaged?): {reason}") from error
    if model.observation_space != env.observation_space or model.action_space.shape != env.action_space.shape:
        raise ValueError(
            f"policy {path} observes {_space_text(model.observation_space)}, but suite {spec.name!r} ({spec.body}) "
            f"gives {_space_text(env.observation_space)}: a policy of another body or maze size"
        )
    return lambda observation: model.predict(observation, deterministic=True)[0]


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
    make_env = _suite_env_factory(spec, low_level)
    if isinstance(policy, str | os.PathLike):
        probe = make_env()
        try:
            acting, description = resolve_policy(
                spec, policy, probe, seed=seed, subgoal_reach_m=subgoal_reach_m, clearance_m=clearance_m
            )
        finally:
            probe.close()
    elif subgoal_reach_m is not None or clearance_m is not None:
        raise ValueError(
            f"subgoal_reach_m and clearance_m are the oracle's settings; a {type(policy).__name__} policy takes none"
        )
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


def report_table(report: dict[str, Any], *, per_task: bool) -> str:
    """A plain-text table of a report: the suite line, then one line per task if ``per_task``."""

    def line(name: str, row: dict[str, Any]) -> str:
        low, high = row["wilson_95"]
        return (
            f"{name:<10} {row['successes']:>4}/{row['episodes']:<4} {row['success_rate']:>6.1%} "
            f"[{low:.1%}, {high:.1%}]  attempts {row['mean_attempts']:6.1f}  low-level steps "
            f"{row['mean_low_level_steps']:7.1f}"
        )

    lines = [f"{report['suite']} ({report['env_id']}), policy {report['policy']}, {report['seconds']} s"]
    lines.append(line("suite", report))
    if "task_bootstrap_95" in report:
        low, high = report["task_bootstrap_95"]
        lines.append(f"{'':<10} bootstrap over tasks 95%: [{low:.1%}, {high:.1%}]")
    if per_task:
        lines += [line(f"task {row['task_id']}", row) for row in report["tasks"]]
    return "\n".join(lines)


def add_benchmark_parser(subparsers: Any, formatter_class: type[argparse.HelpFormatter]) -> None:
    """Adds the ``benchmark`` subcommand (light: the handler imports the envs and SB3 when it runs)."""
    parser = subparsers.add_parser(
        "benchmark",
        help="score a high-level policy on a benchmark suite",
        description=(
            "Score a high-level policy on a benchmark suite: success with its 95% Wilson interval, attempts and "
            f"low-level steps, per suite and per task. Suites: {', '.join(SUITE_SPECS)} (docs/leaderboard.md)."
        ),
        epilog="example:\n  antmaze-hirl benchmark point5 --policy oracle --json runs/point5_oracle.json",
        formatter_class=formatter_class,
    )
    parser.add_argument("suite", help=f"suite name: one of {', '.join(SUITE_SPECS)} (required)")
    parser.add_argument(
        "--policy",
        required=True,
        help="oracle, random, planner (the planning learner shipped for the suite's body), or the path of an SB3 zip "
        "of a high-level model or a saved DAgger learner; SB3 zips hold pickles that can run code: load only files "
        "you trust (required)",
    )
    parser.add_argument(
        "--episodes-per-task",
        type=int,
        default=None,
        help="episodes per task, K (default: the suite's, 1 on point5/ant4, 20 on the fixed maps)",
    )
    parser.add_argument("--seed", type=int, default=0, help="episode j of task k resets with seed + k*K + j")
    parser.add_argument(
        "--num-envs",
        type=int,
        default=DEFAULT_NUM_ENVS,
        help="mazes played at once in lockstep, one batched low-level forward per step "
        "(1: one after another, as the committed results were made)",
    )
    parser.add_argument("--tasks", default=None, help="comma-separated task ids (default: all)")
    parser.add_argument(
        "--subgoal-reach-m",
        type=float,
        default=None,
        help="--policy oracle only: its farthest subgoal, metres (default: the body's experiment setting, "
        "1 cell for the point and 2 m for the ant)",
    )
    parser.add_argument(
        "--clearance-m",
        type=float,
        default=None,
        help="--policy oracle only: how far its straight walks to a subgoal keep from walls, metres "
        "(default: 0.2 cell, 0.8 m for the ant)",
    )
    parser.add_argument(
        "--json", type=Path, default=None, help="write the report here, atomically (default: print only)"
    )
    parser.add_argument(
        "--policy-name",
        default=None,
        help="the report's policy name, the leaderboard's entry (default: as --policy names it), e.g. "
        "'PPO on the high level'; its budget goes in --budget",
    )
    parser.add_argument(
        "--budget",
        default=None,
        help="for a leaderboard submission: the policy's training budget, e.g. '200k high-level steps', "
        "recorded in the report for antmaze-hirl submit (default: none)",
    )
    parser.add_argument(
        "--training-seed",
        type=int,
        default=None,
        help="for a leaderboard submission: the training run's seed (default: none)",
    )
    parser.add_argument(
        "--low-level",
        default=None,
        help="the low level: a zip path or a name, shipped or (the ant's) ensemble; the report records its "
        "fingerprint (default: the body's shipped low level)",
    )
    parser.add_argument(
        "--per-task", action="store_true", help="print one line per task (always done with 10 tasks or fewer)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(handler=run_benchmark_command)


def _parse_task_ids(text: str | None) -> list[int] | None:
    if text is None:
        return None
    try:
        return [int(entry) for entry in text.split(",")]
    except ValueError:
        raise ValueError(f"--tasks must be comma-separated integers, got {text!r}") from None


def run_benchmark_command(args: argparse.Namespace) -> int:
    """Handler of ``antmaze-hirl benchmark``: scores, prints the table, writes ``--json``."""
    spec = check_suite_name(args.suite)
    if args.episodes_per_task is not None and args.episodes_per_task < 1:
        raise ValueError(f"--episodes-per-task must be >= 1, got {args.episodes_per_task}")
    for option, value in (("--subgoal-reach-m", args.subgoal_reach_m), ("--clearance-m", args.clearance_m)):
        if value is not None and args.policy != "oracle":
            raise ValueError(f"{option} is the oracle's setting; --policy {args.policy} takes none")
    import torch

    torch.set_num_threads(1)  # small-batch forwards: a second thread only contends (shared/README.md)
    low_level = None
    if args.low_level is not None:
        from antmaze_hirl.sb3_ext.loading import load_low_level

        low_level = load_low_level(spec.body, args.low_level)  # a name, or a zip of this body (checked)
    report = score_policy(
        spec.name,
        args.policy,
        episodes_per_task=args.episodes_per_task,
        seed=args.seed,
        task_ids=_parse_task_ids(args.tasks),
        num_envs=args.num_envs,
        progress=not args.no_progress,
        subgoal_reach_m=args.subgoal_reach_m,
        clearance_m=args.clearance_m,
        low_level=low_level,
    )
    command = ["antmaze-hirl", "benchmark", spec.name, "--policy", str(args.policy)]
    command += ["--episodes-per-task", str(report["episodes_per_task"]), "--seed", str(args.seed)]
    command += ["--num-envs", str(args.num_envs)]
    command += [] if args.subgoal_reach_m is None else ["--subgoal-reach-m", f"{args.subgoal_reach_m:g}"]
    command += [] if args.clearance_m is None else ["--clearance-m", f"{args.clearance_m:g}"]
    command += [] if args.policy_name is None else ["--policy-name", args.policy_name]
    command += [] if args.budget is None else ["--budget", args.budget]
    command += [] if args.training_seed is None else ["--training-seed", str(args.training_seed)]
    command += [] if args.low_level is None else ["--low-level", str(args.low_level)]
    report["command"] = shlex.join(command + (["--tasks", args.tasks] if args.tasks else []))
    if args.policy_name is not None:
        report["policy"] = args.policy_name
    if args.low_level is not None:
        report["low_level"] = f"{args.low_level}: {report['low_level']}"
    submission = {"budget": args.budget, "seed": args.training_seed}
    if any(value is not None for value in submission.values()):
        report["submission"] = {key: value for key, value in submission.items() if value is not None}
    print(report_table(report, per_task=args.per_task or len(report["tasks"]) <= 10))
    if args.json is not None:
        save_report(report, args.json)
        print(f"wrote {args.json}")
    return 0


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
