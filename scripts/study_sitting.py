"""How long one sitting of the default study takes: seconds per maze from measured parts, and one assumed.

**No person was timed.** A maze's time on the page is its clicks times (the time to think of a click + the
server's answer), plus the page's walk animations, plus the wait for the next maze. Measured here:

* clicks (labels) and high-level steps per maze: the oracle's trials on the point (``--episodes-csv``: the
  paper experiment's 5 seeds a method, the study's maze family and settings), mazes ``0..N-1`` of each trial as
  a study trial plays them (the practice: DAgger's first ``--practice``);
* the walk animation: ``study.js``'s ``animate()`` shows a walk's path points in ``min(2 s, 12 ms x points)``
  (:data:`ANIMATION_SECONDS_PER_POINT`, :data:`ANIMATION_MAX_SECONDS`), with a walk's points taken as the
  maze's low-level steps over its high-level steps, + 1 for the walk's start;
* the server's click round trip (``--latency``: ``study_latency.json``, point, p50 within an episode) and the
  wait between mazes with background updates (``--between``: ``last_maze.json``, dagger, 1 participant, p50).

Assumed: ``--think-seconds`` per click (default 3 s; printed also for 2 and 5 s) and 90 s a questionnaire
(:data:`~antmaze_hirl.study.settings.QUESTIONNAIRE_SECONDS`).

Usage: python scripts/study_sitting.py [--practice 10] [--episodes 25] [--methods dagger,noise,multi_policy,reward]
    [--think-seconds 3.0] [--out results/study_latency/sitting.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.study.cli import _DEFAULT_METHODS, DEFAULT_EPISODES, DEFAULT_PRACTICE
from antmaze_hirl.study.settings import QUESTIONNAIRE_SECONDS, SECONDS_PER_MAZE_PRIOR

ROOT = Path(__file__).resolve().parents[1]
ANIMATION_SECONDS_PER_POINT = 0.012
"""study.js animate(): 12 ms per path point ..."""
ANIMATION_MAX_SECONDS = 2.0
"""... and at most 2 s a walk."""
THINK_SECONDS_SHOWN = (2.0, 3.0, 5.0)


def maze_parts(rows: pd.DataFrame, mazes: int) -> dict[str, float]:
    """Mean clicks, high-level steps and animation seconds per maze over the first ``mazes`` of every trial."""
    first = rows[rows["episode"] < mazes]
    points = first["low_level_steps"] / first["attempts"] + 1
    animation = first["attempts"] * np.minimum(ANIMATION_MAX_SECONDS, ANIMATION_SECONDS_PER_POINT * points)
    return {
        "mazes": len(first),
        "trials": int(first.groupby("seed").ngroups),
        "clicks_per_maze": round(float(first["expert_cost"].mean()), 3),
        "walks_per_maze": round(float(first["attempts"].mean()), 3),
        "animation_seconds_per_maze": round(float(animation.mean()), 3),
    }


def seconds_per_maze(parts: dict[str, float], think: float, click_round_trip: float, between: float) -> float:
    """A maze's seconds on the page: its clicks, its walks' animations and the wait for the next maze."""
    return parts["clicks_per_maze"] * (think + click_round_trip) + parts["animation_seconds_per_maze"] + between


def shown(path: Path) -> str:
    """``path`` from the repository's root where it lies under it."""
    resolved = path.resolve()
    return str(resolved.relative_to(ROOT)) if resolved.is_relative_to(ROOT) else str(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--practice", type=int, default=DEFAULT_PRACTICE, help="practice mazes (default: %(default)s)")
    parser.add_argument("--episodes", type=int, default=DEFAULT_EPISODES, help="mazes a method (default: %(default)s)")
    parser.add_argument("--methods", default=_DEFAULT_METHODS, help="compared methods (default: %(default)s)")
    parser.add_argument(
        "--think-seconds", type=float, default=3.0, help="ASSUMED seconds to think of a click (default: %(default)s)"
    )
    files = ROOT / "results"
    for flag, default, what in (
        ("--episodes-csv", files / "paper_experiment" / "point" / "episodes.csv", "the oracle's trials, a row a maze"),
        ("--latency", files / "study_latency" / "study_latency.json", "the click latencies"),
        ("--between", files / "study_latency" / "last_maze.json", "the waits between mazes"),
        ("--out", files / "study_latency" / "sitting.json", "where to write"),
    ):
        parser.add_argument(flag, type=Path, default=default, help=f"{what} (default: %(default)s)")
    args = parser.parse_args()
    methods = args.methods.split(",")
    rows = pd.read_csv(args.episodes_csv)
    missing = sorted(set(methods) - set(rows["method"]))
    if missing:
        parser.exit(2, f"error: --episodes-csv {args.episodes_csv} has no trials of {missing}\n")
    latency = json.loads(args.latency.read_text())
    click = latency["bodies"]["point"]["within_episode"]["round_trip"]["p50_ms"] / 1000
    between = json.loads(args.between.read_text())["between_mazes"]["point/dagger/1"]["new"]["between_mazes"]
    wait = between["p50_ms"] / 1000
    parts = {"practice (dagger)": maze_parts(rows[rows["method"] == "dagger"], args.practice)}
    parts.update({method: maze_parts(rows[rows["method"] == method], args.episodes) for method in methods})
    counts = {"practice (dagger)": args.practice, **dict.fromkeys(methods, args.episodes)}
    questionnaires = len(methods) * QUESTIONNAIRE_SECONDS
    sittings = {}
    for think in sorted({*THINK_SECONDS_SHOWN, args.think_seconds}):
        total = questionnaires + sum(
            counts[name] * seconds_per_maze(p, think, click, wait) for name, p in parts.items()
        )
        mazes = sum(counts.values())
        sittings[f"{think:g}"] = {
            "minutes": round(total / 60, 1),
            "seconds_per_maze": round((total - questionnaires) / mazes, 1),
        }
    for part in parts.values():
        part["seconds_per_maze_at_think"] = {
            think: round(seconds_per_maze(part, float(think), click, wait), 1) for think in sittings
        }
    chosen = sittings[f"{args.think_seconds:g}"]
    result = {
        "no_person_timed": True,
        "assumed": {"think_seconds_per_click": args.think_seconds, "questionnaire_seconds": QUESTIONNAIRE_SECONDS},
        "measured_from": {
            "clicks_and_walks": shown(args.episodes_csv),
            "click_round_trip_s": round(click, 4),
            "between_mazes_s": round(wait, 4),
            "sources": [shown(args.latency), shown(args.between)],
        },
        "study": {"practice": args.practice, "episodes": args.episodes, "methods": methods},
        "parts": parts,
        "sitting_by_think_seconds": sittings,
        "prior_seconds_per_maze": SECONDS_PER_MAZE_PRIOR,
    }
    for name, p in parts.items():
        print(
            f"{name:18s} {counts[name]:3d} mazes: {p['clicks_per_maze']:.2f} clicks, "
            f"{p['animation_seconds_per_maze']:.2f} s of walks a maze; seconds a maze at "
            + ", ".join(f"{t} s/click {s}" for t, s in p["seconds_per_maze_at_think"].items())
        )
    for think, sitting in sittings.items():
        print(f"think {think} s a click: {sitting['seconds_per_maze']} s a maze, the sitting {sitting['minutes']} min")
    print(
        f"at the assumed {args.think_seconds:g} s: {chosen['seconds_per_maze']} s a maze (prior "
        f"{SECONDS_PER_MAZE_PRIOR:g} s), {chosen['minutes']} min; no person was timed"
    )
    atomic_write_json(args.out, result)
    print(f"wrote {shown(args.out)}")


if __name__ == "__main__":
    main()
