"""Hierarchy throughput: low-level steps/s of oracle + shipped low level, against the raw simulator, in one run.

Per body, side by side:

* the baseline: raw gymnasium-robotics ``AntMaze_UMaze-v5`` (point: ``PointMaze_UMaze-v3``) with random
  actions, the simulator's bound (measured before and after the hierarchy rows; their mean is the reference);
* the oracle choosing subgoals for the shipped low-level policy in
  ``gym.make_vec(id, N)`` (:class:`~antmaze_hirl.envs.vector.HighLevelVectorEnv`, the low level in lockstep)
  for each ``--num-envs`` N and each global torch thread count of ``--threads``, as low-level steps/s summed
  over the sub-envs;
* ``serial, unscoped``: one ``gym.make`` env at torch's 2 threads with the single-thread inference scope
  turned off (``SMALL_BATCH_ROWS = -1``), i.e. the low level as it ran before the scope;
* ``lockstep, SB3 predict``: the lockstep rows with the low level acting through SB3's ``model.predict``
  (``controllers.DIRECT_PREDICT = False``), as before :class:`~antmaze_hirl.envs.controllers.PredictController`
  ran the policy's predict steps itself (same actions bit for bit), just before each ``lockstep`` row.

* ``serial, <low level>`` (``--low-levels``, ant only): one ``gym.make`` env at one torch thread with another low
  level: ``one-head`` (the shipped ensemble's head 0 as a plain TD3 actor, the size of a distilled student,
  through :class:`~antmaze_hirl.envs.controllers.PredictController`), ``one-head-numpy`` and ``ensemble-numpy``
  (their :class:`~antmaze_hirl.sb3_ext.numpy_actor.NumpyActor` forward passes), or a zip (``ZIP`` through torch,
  ``ZIP:numpy`` through numpy). Each row walks as its own low level walks (its flips, its subgoals), so the
  rows differ in what they play as well as in speed; the rate counts low-level steps per second either way.

Ratios are to the raw baseline of the same body. Each row runs for ``--seconds`` (at least one high-level
step of every sub-env); seeded, so every row plays the same mazes.

    python benchmarks/hierarchy_throughput.py                       # both bodies, N = 1 4 16 64, 1 and 2 threads
    python benchmarks/hierarchy_throughput.py --bodies point --num-envs 1 8 --seconds 2
    python benchmarks/hierarchy_throughput.py --bodies ant --num-envs 1 --threads 1 --low-levels one-head-numpy
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import gymnasium_robotics
import numpy as np
import torch as th

import antmaze_hirl  # noqa: F401  (registers the ids)
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs import controllers
from antmaze_hirl.envs.profiles import BODY_PROFILES, maze_env_id
from antmaze_hirl.experts.oracle import PathOracle

RESULTS = Path(__file__).resolve().parents[1] / "results" / "hierarchy_throughput" / "hierarchy_throughput.json"
RAW_IDS = {"ant": "AntMaze_UMaze-v5", "point": "PointMaze_UMaze-v3"}
# The held-out-layouts families (ant 4x4, point 5x5): the ant's 4x4 mazes are those the hierarchy was
# profiled on before the low level batched.
MAZE_SIZES = {body: profile.held_out_maze_size for body, profile in BODY_PROFILES.items()}


def raw_steps_per_s(body: str, seconds: float, seed: int) -> float:
    """Random-action steps/s of the raw gymnasium-robotics maze (continuing task: it never ends)."""
    gym.register_envs(gymnasium_robotics)
    env = gym.make(RAW_IDS[body])
    env.reset(seed=seed)
    env.action_space.seed(seed)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        for _ in range(100):
            env.step(env.action_space.sample())
        steps += 100
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def hierarchy_steps_per_s(env: Any, oracle: PathOracle, seconds: float, seed: int) -> tuple[float, int]:
    """Low-level steps/s over all sub-envs of a vector env driven by ``oracle``, and the steps counted."""
    obs, _ = env.reset(seed=seed)
    steps, start = 0, time.perf_counter()
    while steps == 0 or time.perf_counter() - start < seconds:
        subgoals = np.stack([oracle({key: value[i] for key, value in obs.items()}) for i in range(env.num_envs)])
        obs, _, _, _, infos = env.step(subgoals.astype(np.float32))
        if "low_level_steps" in infos:  # absent when every sub-env was reset in this step
            steps += int(np.sum(infos["low_level_steps"] * infos["_low_level_steps"]))
    return steps / (time.perf_counter() - start), steps


LOW_LEVEL_ROWS = ("one-head", "one-head-numpy", "ensemble-numpy")
"""The named extra low levels of ``--low-levels`` (a zip path, optionally with ``:numpy``, is the other kind)."""


def extra_low_level(spec: str) -> Any:
    """The ant low level that a ``--low-levels`` entry names (module docstring).

    Raises:
        ValueError: If the entry is neither a name of :data:`LOW_LEVEL_ROWS` nor a loadable ant zip.
    """
    from antmaze_hirl.sb3_ext.distill import make_student
    from antmaze_hirl.sb3_ext.loading import load_low_level
    from antmaze_hirl.sb3_ext.numpy_actor import NumpyActor
    from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

    if spec in LOW_LEVEL_ROWS:
        model = load_low_level("ant") if spec == "ensemble-numpy" else make_student(shipped_policy_path("ant"))
        return NumpyActor.from_model(model) if spec.endswith("numpy") else controllers.PredictController(model)
    path, _, kind = spec.partition(":")
    if kind not in ("", "numpy"):
        raise ValueError(f"entry {spec!r}: a zip takes no suffix or ':numpy', not {kind!r}")
    model = load_low_level("ant", path)
    return NumpyActor.from_model(model) if kind == "numpy" else controllers.PredictController(model)


def serial_steps_per_s(
    body: str, subgoal_reach_m: float | None, seconds: float, seed: int, low_level: Any = None
) -> tuple[float, int]:
    """Low-level steps/s of one ``gym.make`` env, as :func:`hierarchy_steps_per_s` counts them."""
    env = gym.make(maze_env_id(body), maze_size=MAZE_SIZES[body], low_level=low_level)
    oracle = PathOracle.for_env(env, subgoal_reach_m=subgoal_reach_m)
    obs, _ = env.reset(seed=seed)
    steps, start = 0, time.perf_counter()
    while steps == 0 or time.perf_counter() - start < seconds:
        obs, _, terminated, truncated, info = env.step(oracle(obs))
        steps += info["low_level_steps"]
        if terminated or truncated:
            obs, _ = env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate, steps


def main(argv: list[str] | None = None) -> dict[str, Any]:
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bodies", nargs="+", default=["ant", "point"], choices=["ant", "point"])
    parser.add_argument("--num-envs", nargs="+", type=int, default=[1, 4, 16, 64])
    parser.add_argument("--threads", nargs="+", type=int, default=[1, 2], help="global torch thread counts")
    parser.add_argument("--seconds", type=float, default=4.0, help="wall time per row")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--low-levels",
        nargs="*",
        default=[],
        help=f"extra serial ant rows: {', '.join(LOW_LEVEL_ROWS)}, ZIP or ZIP:numpy (module docstring)",
    )
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if min(args.num_envs) < 1 or min(args.threads) < 1 or args.seconds <= 0:
        parser.error(f"--num-envs and --threads must be >= 1 and --seconds > 0, got {args}")
    try:  # loaded before any row is timed, so that a bad entry stops the run at once, in one line
        extras = {spec: extra_low_level(spec) for spec in (args.low_levels if "ant" in args.bodies else [])}
    except (ValueError, FileNotFoundError) as error:
        parser.error(f"--low-levels: {error}")
    caller_threads = th.get_num_threads()
    rows: list[dict[str, Any]] = []
    baselines = {}
    for body in args.bodies:
        subgoal_reach_m = BODY_PROFILES[body].subgoal_reach_m  # the experiment's oracle reach (ant 2 m)
        before = raw_steps_per_s(body, args.seconds, args.seed)
        body_rows = []
        th.set_num_threads(2)
        small, controllers.SMALL_BATCH_ROWS = controllers.SMALL_BATCH_ROWS, -1  # the low level as before the scope
        try:
            rate, steps = serial_steps_per_s(body, subgoal_reach_m, args.seconds, args.seed)
        finally:
            controllers.SMALL_BATCH_ROWS = small
        body_rows.append({"mode": "serial, unscoped", "num_envs": 1, "torch_threads": 2, "steps_per_s": rate})
        for threads in args.threads:
            th.set_num_threads(threads)
            rate, steps = serial_steps_per_s(body, subgoal_reach_m, args.seconds, args.seed)
            body_rows.append({"mode": "serial", "num_envs": 1, "torch_threads": threads, "steps_per_s": rate})
        for spec in args.low_levels if body == "ant" else []:
            th.set_num_threads(1)
            rate, steps = serial_steps_per_s(body, subgoal_reach_m, args.seconds, args.seed, extras[spec])
            body_rows.append({"mode": f"serial, {spec}", "num_envs": 1, "torch_threads": 1, "steps_per_s": rate})
            print(f"{body} serial {spec}: {rate:,.0f} steps/s ({steps})", flush=True)
        for num_envs in args.num_envs:
            env = gym.make_vec(maze_env_id(body), num_envs, maze_size=MAZE_SIZES[body])
            oracle = PathOracle.for_env(env.envs[0], subgoal_reach_m=subgoal_reach_m)
            for threads in args.threads:
                th.set_num_threads(threads)
                for mode, direct in (("lockstep, SB3 predict", False), ("lockstep", True)):
                    controllers.DIRECT_PREDICT = direct
                    try:
                        rate, steps = hierarchy_steps_per_s(env, oracle, args.seconds, args.seed)
                    finally:
                        controllers.DIRECT_PREDICT = True
                    body_rows.append(
                        {"mode": mode, "num_envs": num_envs, "torch_threads": threads, "steps_per_s": rate}
                    )
                    print(f"{body} {mode} N={num_envs} threads={threads}: {rate:,.0f} steps/s ({steps})", flush=True)
            env.close()
        th.set_num_threads(caller_threads)
        after = raw_steps_per_s(body, args.seconds, args.seed)
        raw = (before + after) / 2
        baselines[body] = {"id": RAW_IDS[body], "before": round(before), "after": round(after), "mean": round(raw)}
        best = max(row["steps_per_s"] for row in body_rows)
        for row in body_rows:
            row.update(
                body=body,
                steps_per_s=round(row["steps_per_s"], 1),
                ratio_to_raw=round(row["steps_per_s"] / raw, 3),
                ratio_to_best=round(row["steps_per_s"] / best, 3),
            )
        rows.extend(body_rows)
        print(f"{body} raw {RAW_IDS[body]}: {before:,.0f} before, {after:,.0f} after", flush=True)
    th.set_num_threads(caller_threads)
    width = max(21, *(len(row["mode"]) for row in rows))
    print(f"{'body':6} {'mode':{width}} {'N':>3} {'thr':>3} {'steps/s':>9} {'x raw':>6} {'x best':>6}")
    for row in rows:
        print(
            f"{row['body']:6} {row['mode']:{width}} {row['num_envs']:>3} {row['torch_threads']:>3} "
            f"{row['steps_per_s']:>9,.0f} {row['ratio_to_raw']:>6.2f} {row['ratio_to_best']:>6.2f}"
        )
    report = {
        "benchmark": "hierarchy_throughput",
        "command": "python benchmarks/hierarchy_throughput.py " + " ".join(argv),
        "seconds_per_row": args.seconds,
        "seed": args.seed,
        "maze_sizes": {body: MAZE_SIZES[body] for body in args.bodies},
        "machine": f"{platform.machine()} ({os.cpu_count()} CPUs), shared with other work while measured",
        "raw_baselines": baselines,
        "rows": rows,
    }
    print(f"wrote {atomic_write_json(args.out, report)}")
    return report


if __name__ == "__main__":
    main()
