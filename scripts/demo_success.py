"""How often ``antmaze-hirl demo`` succeeds on its defaults, and why it fails when it does.

Runs the demo (the scripted oracle driving the shipped low level, per-body default maze size and subgoal
distance) for seeds 0..N-1 and records each episode's outcome: success, flip or timeout. Goal: the ant
succeeds at least as often as the oracle on the demo's maze family (``paper_experiment/oracle_success_ant_3.json``, from
``paper_experiment.py --body ant --oracle-only``: 100 held-out 3x3 mazes), and on seed 0 (the demo's default).

The seeds play ``--num-envs`` at a time in lockstep (default 20: all of them at once), the oracle labelling every
maze that needs a subgoal and the shipped low level acting in one batch for every maze still walking, without
the demo's picture; the same mazes and seeds, though batched float rounding can change an ant episode now and
then (``docs/guides/vector-envs.md``). ``--num-envs 1`` runs the demo itself seed after seed, as the results
committed before lockstep were made.

Usage: python scripts/demo_success.py [--bodies ant,point] [--seeds 20] [--num-envs 20]
Updates results/demo_success/demo_success.json (one entry per body run; other bodies' entries are kept).
"""

from __future__ import annotations

import argparse
import collections
import json
import time
from pathlib import Path

import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.demo import lockstep_outcomes, serial_outcomes
from antmaze_hirl.experiments.config import BODY_DEFAULTS
from antmaze_hirl.experiments.runner import low_level_identity

RESULTS = Path(__file__).resolve().parents[1] / "results"
OUT = RESULTS / "demo_success" / "demo_success.json"


def oracle_success(body: str) -> float | None:
    path = RESULTS / "paper_experiment" / f"oracle_success_{body}_{BODY_DEFAULTS[body]['maze_size']}.json"
    return json.loads(path.read_text())["success_rate"] if path.exists() else None


def measure(body: str, seeds: int, num_envs: int = 1) -> dict:
    start = time.perf_counter()
    outcomes = serial_outcomes(body, seeds) if num_envs == 1 else lockstep_outcomes(body, seeds, num_envs)
    successes = outcomes.count("success")
    oracle = oracle_success(body)
    return {
        "low_level_id": low_level_identity(body),  # the shipped policy the demo runs
        "seeds": f"0-{seeds - 1}",
        "num_envs": num_envs,
        "settings": BODY_DEFAULTS[body],
        "successes": successes,
        "episodes": seeds,
        "success_rate": successes / seeds,
        "failures": dict(collections.Counter(outcome for outcome in outcomes if outcome != "success")),
        "outcome_per_seed": outcomes,
        "default_seed_succeeds": outcomes[0] == "success",
        "oracle_success_rate": oracle,
        "goal_met": None if oracle is None else successes / seeds >= oracle and outcomes[0] == "success",
        "seconds": round(time.perf_counter() - start, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bodies", default="ant,point", help="comma-separated bodies")
    parser.add_argument("--seeds", type=int, default=20, help="seeds 0..N-1 per body")
    parser.add_argument(
        "--num-envs",
        type=int,
        default=20,
        help="mazes played at once in lockstep; 1: the demo itself, seed after seed (exact replays)",
    )
    args = parser.parse_args()
    for name in ("seeds", "num_envs"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    torch.set_num_threads(1)
    results = json.loads(OUT.read_text()) if OUT.exists() else {}
    for body in args.bodies.split(","):
        results[body] = measure(body, args.seeds, args.num_envs)
        summary = {key: results[body][key] for key in ("successes", "episodes", "failures", "goal_met")}
        print(f"{body}: {summary}")
        atomic_write_json(OUT, results)  # after each body, so a long run keeps what it has
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
