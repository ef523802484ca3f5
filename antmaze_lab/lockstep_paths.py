"""Serial against lockstep for the in-maze runs, demo_success.py and eval-low: same outcomes out of N, the speedup.

Each tool's serial path (``--num-envs 1``, the one results committed before lockstep were made with) and its
lockstep path play the same seeds, side by side in one run:

* ``in_maze``: the oracle driving the shipped ant on ``--mazes`` mazes of each of ``--families`` (outcome per
  maze: success, flip, frozen or timeout), ``in_maze.LOCKSTEP_ENVS`` mazes at once;
* ``demo_success``: the demo's episodes for seeds ``0 .. --demo-seeds - 1`` per body (serial: the demo
  itself, picture and all), all seeds at once;
* ``eval_low``: ``--subgoals`` seeded subgoals per body for the shipped low level (outcome per subgoal: the
  steps it took to reach it, or a miss; ``same_success`` compares reached or not), 25 at once (the ant's
  default; the point's default is serial, its copies costing more to build than batching saves).

With a controller that acts row by row the two paths are the same episodes bit for bit (the tests check
that); a batched forward pass of the shipped policies may round the last bits differently, and MuJoCo can
amplify that into another outcome. This counts how often.

    python -m antmaze_lab.lockstep_paths                # about 10 min on 2 loaded cores
    python -m antmaze_lab.lockstep_paths --mazes 10 --demo-seeds 4 --subgoals 20

(``python benchmarks/lockstep_paths.py`` before it moved into the lab, with the same options.)
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED
from antmaze_hirl.demo import lockstep_outcomes, serial_outcomes
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.evaluation import reach_outcomes
from antmaze_hirl.sb3_ext.loading import load_low_level
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy
from antmaze_lab import in_maze_protocol as in_maze
from antmaze_lab.commands import recorded_command
from antmaze_lab.tables import lab_parser, refuse_below_one

RESULTS = Path(__file__).resolve().parents[1] / "results" / "lockstep_paths" / "lockstep_paths.json"


def timed(play: Callable[[], list[Any]]) -> tuple[list[Any], float]:
    """``play()``'s outcomes and its wall time, seconds."""
    start = time.perf_counter()
    outcomes = play()
    return outcomes, time.perf_counter() - start


def succeeded(outcome: Any) -> bool:
    """An outcome's success: ``"success"`` (in_maze, demo) or a step count (eval-low; ``None`` failed)."""
    return outcome == "success" or isinstance(outcome, int)


def compare(tool: str, case: str, serial: Callable[[], list[Any]], lockstep: Callable[[], list[Any]]) -> dict:
    """One row: both paths' per-episode outcomes compared, and their wall times."""
    serial_outcomes, serial_s = timed(serial)
    lockstep_outcomes, lockstep_s = timed(lockstep)
    pairs = list(zip(serial_outcomes, lockstep_outcomes, strict=True))
    row = {
        "tool": tool,
        "case": case,
        "episodes": len(pairs),
        "same_outcome": sum(a == b for a, b in pairs),
        "same_success": sum(succeeded(a) == succeeded(b) for a, b in pairs),
        "serial_successes": sum(map(succeeded, serial_outcomes)),
        "lockstep_successes": sum(map(succeeded, lockstep_outcomes)),
        "serial_s": round(serial_s, 1),
        "lockstep_s": round(lockstep_s, 1),
        "speedup": round(serial_s / lockstep_s, 2),
    }
    print(row, flush=True)
    return row


def in_maze_rows(families: list[str], mazes: int) -> list[dict]:
    """One row per in-maze family: the shipped ant on ``mazes`` held-out mazes, one at a time and in lockstep."""

    def play(family: str, num_envs: int) -> list[str]:
        seeds = range(HELD_OUT_SEED, HELD_OUT_SEED + mazes)
        return in_maze.run_chunk(None, 0.0, family, seeds, 2.0, num_envs)[2]["outcomes"]

    return [
        compare(
            "in_maze",
            f"ant {family}",
            lambda family=family: play(family, 1),
            lambda family=family: play(family, in_maze.LOCKSTEP_ENVS),
        )
        for family in families
    ]


def demo_rows(seeds: int) -> list[dict]:
    """One row per body: the demo's first ``seeds`` episodes, serial and in lockstep."""
    return [
        compare(
            "demo_success",
            body,
            lambda body=body: serial_outcomes(body, seeds),
            lambda body=body: lockstep_outcomes(body, seeds, seeds),
        )
        for body in ("ant", "point")
    ]


def eval_low_rows(subgoals: int, num_envs: int = 25) -> list[dict]:
    """One row per body: eval-low's ``subgoals`` reach episodes, serial and ``num_envs`` at once."""
    rows = []
    for body in ("ant", "point"):
        policy, env = load_low_level(body), ReachEnv(body)

        def play(num_envs: int, policy: Any = policy, env: ReachEnv = env) -> list[int | None]:
            return reach_outcomes(policy, env, episodes=subgoals, seed=0, num_envs=num_envs)

        rows.append(compare("eval_low", body, lambda: play(1), lambda: play(num_envs)))
        env.close()
    return rows


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``scripts/results_index.py --check`` parses recorded options with it)."""
    parser = lab_parser("antmaze_lab.lockstep_paths", __doc__)
    parser.add_argument("--families", default="ant3,u", help="in_maze families, comma-separated")
    parser.add_argument("--mazes", type=int, default=50, help="in_maze mazes per family")
    parser.add_argument("--demo-seeds", type=int, default=20, help="demo seeds per body")
    parser.add_argument("--subgoals", type=int, default=200, help="eval-low subgoals per body")
    parser.add_argument("--out", type=Path, default=RESULTS)
    return parser


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """The command line: every row, written to ``--out`` and returned."""
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        families = in_maze.parse_families(args.families)
    except ValueError as error:
        parser.error(str(error))
    refuse_below_one(parser, args, ("mazes", "demo_seeds", "subgoals"))
    torch.set_num_threads(1)
    for body in ("ant", "point"):  # loaded once and cached, before any timing: no path pays for it
        load_shipped_policy(body)
    in_maze.worker_low_level(None)
    load = [os.getloadavg()[0]]
    rows = [*in_maze_rows(families, args.mazes), *demo_rows(args.demo_seeds), *eval_low_rows(args.subgoals)]
    load.append(os.getloadavg()[0])
    report = {
        "benchmark": "lockstep_paths",
        "command": recorded_command("antmaze_lab.lockstep_paths", argv),
        "machine": f"{platform.machine()} ({os.cpu_count()} CPUs), shared with other work while measured",
        "load_average_1min": [round(value, 2) for value in load],
        "rows": rows,
        "same_outcome_share": round(
            float(np.sum([row["same_outcome"] for row in rows]) / np.sum([row["episodes"] for row in rows])), 3
        ),
        "same_success_share": round(
            float(np.sum([row["same_success"] for row in rows]) / np.sum([row["episodes"] for row in rows])), 3
        ),
    }
    print(f"wrote {atomic_write_json(args.out, report)}")
    return report


if __name__ == "__main__":
    main()
