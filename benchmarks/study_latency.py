"""How long a participant waits after a click: the study server's time from click to the next state.

Runs a simulated participant (the oracle, through the page's HTTP API on loopback) for one trial per
body and reports p50 / p95 / max of the server's own time per click (the ``Server-Timing`` header)
and of the HTTP round trip, for all clicks and for the clicks that end an episode, and the wait between
mazes (``POST next``: the learner's update and checkpoint, sent by the page while it animates the last
walk). Evaluations are left out of the clicks measured by evaluating
only after the trial (``eval_every`` = episodes), and the final evaluation uses 5 mazes: a real study's
evaluation every 10 episodes adds a wait on about one click in 60-100 (see the README).

Goal, so that a participant does not wait on the page: ant p95 <= 300 ms.

Usage: python benchmarks/study_latency.py [--episodes 10] [--bodies point,ant] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import platform
import tempfile
from pathlib import Path

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.study.plan import make_plan, save_plan
from antmaze_hirl.study.server import StudyServer
from antmaze_hirl.study.settings import StudySettings, save_settings
from antmaze_hirl.study.simulate import SimulatedParticipant, simulate_study

GOAL_ANT_P95_SECONDS = 0.3


def percentiles(values: list[float]) -> dict[str, float | int | None]:
    if not values:
        return {"n": 0, "p50_ms": None, "p95_ms": None, "max_ms": None}
    array = np.asarray(values) * 1000
    return {
        "n": len(values),
        "p50_ms": round(float(np.percentile(array, 50)), 1),
        "p95_ms": round(float(np.percentile(array, 95)), 1),
        "max_ms": round(float(array.max()), 1),
    }


def measure(body: str, episodes: int, seed: int) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        save_plan(make_plan(body, ["dagger"], 1, episodes=episodes, practice=0, seed=seed), folder)
        settings = StudySettings.for_body(body, eval_every=episodes, final_eval_episodes=5)
        save_settings(settings, folder)
        with StudyServer(folder).running() as server:
            (result,) = simulate_study(server.url, ["P01"], SimulatedParticipant(seed=seed))
    clicks = result["latencies"][:-1]  # the trial's last click also runs the final evaluation
    figures = {"episodes": episodes, "clicks": len(clicks)}
    # The wait between mazes (POST next: the learner's update, a checkpoint, the next maze), which the
    # page overlaps with the animation of the last walk; the trial's last one also runs the final evaluation.
    between = result["between"][:-1]
    figures["between_episodes"] = {
        "server": percentiles([b["server"] for b in between]),
        "round_trip": percentiles([b["round_trip"] for b in between]),
    }
    for name, chosen in (
        ("all", clicks),
        ("within_episode", [c for c in clicks if not c["episode_end"]]),
        ("episode_end", [c for c in clicks if c["episode_end"]]),
    ):
        figures[name] = {
            "server": percentiles([c["server"] for c in chosen]),
            "round_trip": percentiles([c["round_trip"] for c in chosen]),
        }
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--bodies", default="point,ant")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(__file__).resolve().parents[1] / "results" / "study_latency" / "study_latency.json",
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    results = {"cpu": platform.processor() or platform.machine(), "torch_threads": 1, "bodies": {}}
    for body in args.bodies.split(","):
        figures = measure(body, args.episodes, args.seed)
        results["bodies"][body] = figures
        for name in ("all", "within_episode", "episode_end"):
            server, trip = figures[name]["server"], figures[name]["round_trip"]
            print(
                f"{body:5s} {name:14s} n={server['n']:3d}  server p50 {server['p50_ms']} ms, "
                f"p95 {server['p95_ms']} ms, max {server['max_ms']} ms;  round trip p95 {trip['p95_ms']} ms"
            )
        wait = figures["between_episodes"]["server"]
        print(f"{body:5s} between mazes  n={wait['n']:3d}  server p50 {wait['p50_ms']} ms, p95 {wait['p95_ms']} ms")
    ant = results["bodies"].get("ant")
    if ant is not None:
        p95 = ant["all"]["server"]["p95_ms"]
        results["goal_ant_p95_ms"] = GOAL_ANT_P95_SECONDS * 1000
        results["goal_met"] = p95 is not None and p95 <= GOAL_ANT_P95_SECONDS * 1000
        print(
            f"goal ant p95 <= {GOAL_ANT_P95_SECONDS * 1000:.0f} ms: "
            f"{'met' if results['goal_met'] else 'NOT met'} ({p95} ms)"
        )
    atomic_write_json(args.out, results)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
