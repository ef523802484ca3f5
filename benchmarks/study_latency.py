"""How long a participant waits after a click: the study server's time from click to the next state.

Runs a simulated participant (the oracle, through the page's HTTP API on loopback) for one trial per
body and reports p50 / p95 / max of the server's own time per click (the ``Server-Timing`` header)
and of the HTTP round trip, for all clicks and for the clicks that end an episode, and the wait between
mazes (``POST next``: the learner's update and checkpoint, sent by the page while it animates the last
walk). Evaluations are left out of the clicks measured by evaluating
only after the trial (``eval_every`` = episodes), and the final evaluation uses 5 mazes: a real study's
evaluation every 10 episodes adds a wait on about one click in 60-100 (see the README).

Goal, so that a participant does not wait on the page: ant p95 <= 300 ms.

The wait between mazes (``--part between``): for every method, with 1 and with 4 participants playing at
once (threads, one HTTP client each), the ``next`` round trip with the update before the next maze
("old": ``background_updates`` off, as the experiments run) and with the update in the background ("new",
``study init``'s default: the learner lags one maze), side by side in one run, p50 / p95 / max and the
new/old ratio of the p95. The simulated participants click after an exponential delay of mean
``--click-seconds`` (people take seconds; a participant who clicks at once leaves the background update
no time). The trial's last ``next`` (before the questionnaire) is reported apart: "old" runs the trial's last
update and final evaluation in it; "new" closes the trial at once and writes them after
(:class:`~antmaze_hirl.study.session.TrialClosing`), ``final_update_lag`` seconds later (each trial's
``final_update`` event). Goals: p95 <= 2 s with 1 participant, <= 5 s with 4, for every method, between mazes
and after the last.

Usage: python benchmarks/study_latency.py [--part clicks|between|all] [--episodes 10] [--bodies point,ant]
    [--methods dagger,noise,multi_policy,reward] [--participants 1,4] [--between-episodes 8]
    [--final-eval-episodes 5] [--eval-every 0] [--modes old,new] [--out FILE.json]
Each row of ``--part between`` records the CPU seconds its run took (``cpu_seconds``: every thread of the process).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.study.data import read_episode_rows
from antmaze_hirl.study.logs import read_json_records
from antmaze_hirl.study.plan import make_plan, save_plan
from antmaze_hirl.study.server import StudyServer
from antmaze_hirl.study.settings import StudySettings, save_settings
from antmaze_hirl.study.simulate import SimulatedParticipant, StudyClient, play_participant, simulate_study

GOAL_ANT_P95_SECONDS = 0.3
GOAL_BETWEEN_P95_SECONDS = {1: 2.0, 4: 5.0}
"""The wait between mazes at p95, by participants playing at once."""


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
    between = [wait for wait in result["between"] if not wait["closed_trial"]]
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


def measure_between(
    body: str,
    method: str,
    participants: int,
    background: bool,
    args: argparse.Namespace,
) -> dict:
    """The ``next`` waits of ``participants`` simulated participants playing one ``method`` trial at once."""
    episodes, click_seconds, seed = args.between_episodes, args.click_seconds, args.seed
    cpu_started = time.process_time()  # every thread of this process: the server's, the updates', the clients'
    with tempfile.TemporaryDirectory() as folder:
        save_plan(make_plan(body, [method], participants, episodes=episodes, practice=0, seed=seed), folder)
        # The study's own evaluation settings, but for the last evaluation (reported apart, 5 mazes by default
        # where a study's is 100: --final-eval-episodes 100 times a study's own).
        every = args.eval_every or max(episodes // 2, 1)
        settings = StudySettings.for_body(
            body, background_updates=background, eval_every=every, final_eval_episodes=args.final_eval_episodes
        )
        save_settings(settings, folder)
        results: dict[str, dict] = {}
        with StudyServer(folder).running() as server:

            def play(position: int, participant_id: str) -> None:
                rng = np.random.default_rng([seed, position])
                behaviour = SimulatedParticipant(delay=click_seconds, seed=seed)
                results[participant_id] = play_participant(StudyClient(server.url), participant_id, behaviour, rng=rng)

            threads = [
                threading.Thread(target=play, args=(position, participant.id))
                for position, participant in enumerate(server.study.plan.participants)
            ]
            for thread in threads:
                thread.start()
            for thread in threads:
                thread.join()
            # Read before the server stops: it waits for the closed trials' final updates, which write the lag.
            assert server.study.wait_for_closed_trials()
            folders = [Path(folder) / "participants" / participant.id for participant in server.study.plan.participants]
            lags = [
                record["lag_seconds"]
                for participant in folders
                for _, record in read_json_records(participant / "events.jsonl")
                if record["event"] == "final_update"
            ]
            rows = [row for participant in folders for row in read_episode_rows(participant / "episodes.csv")]
    if len(results) != participants:
        raise RuntimeError(f"{participants - len(results)} simulated participant(s) failed")
    waits = [wait for result in results.values() for wait in result["between"]]
    return {
        "between_mazes": percentiles([wait["round_trip"] for wait in waits if not wait["closed_trial"]]),
        "mazes_walked_unasked": sum(wait["walked"] for wait in waits),
        "after_last_maze": percentiles([wait["round_trip"] for wait in waits if wait["closed_trial"]]),
        "final_update_lag": percentiles(lags),
        # The scripted participant's mazes (clicks after --click-seconds, no page animation): not a person's.
        "labels_per_maze": round(float(np.mean([float(row["expert_cost"]) for row in rows])), 2),
        "scripted_time_per_maze": percentiles([float(row["time_on_task"]) for row in rows]),
        "evaluated_every": every,
        "final_eval_episodes": args.final_eval_episodes,
        "cpu_seconds": round(time.process_time() - cpu_started, 1),
    }


def run_between(args: argparse.Namespace, results: dict) -> None:
    table = results.setdefault("between_mazes", {})
    for body in args.bodies.split(","):
        for method in args.methods.split(","):
            for participants in (int(count) for count in args.participants.split(",")):
                entry = {}
                for mode, background in (("old", False), ("new", True)):
                    if mode in args.modes.split(","):
                        entry[mode] = measure_between(body, method, participants, background, args)
                empty = {"p50_ms": None, "p95_ms": None}
                old = entry["old"]["between_mazes"] if "old" in entry else empty
                new = entry["new"]["between_mazes"] if "new" in entry else empty
                goal = GOAL_BETWEEN_P95_SECONDS.get(participants)
                both = old["p95_ms"] and new["p95_ms"] is not None
                entry["new_over_old_p95"] = round(new["p95_ms"] / old["p95_ms"], 3) if both else None
                entry["goal_p95_ms"] = goal * 1000 if goal is not None else None
                entry["goal_met"] = _within(new, goal)
                last_old = entry["old"]["after_last_maze"] if "old" in entry else empty
                last_new = entry["new"]["after_last_maze"] if "new" in entry else empty
                entry["goal_met_after_last_maze"] = _within(last_new, goal)
                table[f"{body}/{method}/{participants}"] = entry
                atomic_write_json(args.out, results)  # each row as it is timed: a long run cut short keeps its rows
                lag = entry["new"]["final_update_lag"] if "new" in entry else empty
                print(
                    f"{body:5s} {method:14s} {participants} participant(s): next p50/p95 old {old['p50_ms']}/"
                    f"{old['p95_ms']} ms, new {new['p50_ms']}/{new['p95_ms']} ms (p95 new/old "
                    f"{entry['new_over_old_p95']}); goal p95 <= {entry['goal_p95_ms']} ms: "
                    f"{'met' if entry['goal_met'] else 'NOT met'}; after the last maze p50/p95 old "
                    f"{last_old['p50_ms']}/{last_old['p95_ms']} ms, new {last_new['p50_ms']}/{last_new['p95_ms']} ms "
                    f"({'met' if entry['goal_met_after_last_maze'] else 'NOT met'}); final update written "
                    f"p50/p95 {lag['p50_ms']}/{lag['p95_ms']} ms after; CPU seconds "
                    f"{ {mode: entry[mode]['cpu_seconds'] for mode in ('old', 'new') if mode in entry} }",
                    flush=True,
                )


def run_clicks(args: argparse.Namespace, results: dict) -> None:
    """The ``clicks`` part: each body's click and maze-end latencies into ``results["bodies"]``, the ant's goal."""
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


def _within(figures: dict, goal: float | None) -> bool:
    return goal is not None and figures["p95_ms"] is not None and figures["p95_ms"] <= goal * 1000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("clicks", "between", "all"), default="all")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--bodies", default="point,ant")
    parser.add_argument("--methods", default="dagger,noise,multi_policy,reward", help="for --part between")
    parser.add_argument("--participants", default="1,4", help="participants at once, for --part between")
    parser.add_argument("--between-episodes", type=int, default=8, help="mazes per trial, for --part between")
    parser.add_argument("--click-seconds", type=float, default=1.0, help="mean delay before a simulated click")
    parser.add_argument(
        "--final-eval-episodes", type=int, default=5, help="mazes of a trial's final evaluation, for --part between"
    )
    parser.add_argument(
        "--eval-every", type=int, default=0, help="mazes between evaluations, for --part between (0: half the mazes)"
    )
    parser.add_argument("--modes", default="old,new", help="old (update before the next maze), new, for --part between")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(__file__).resolve().parents[1] / "results" / "study_latency" / "study_latency.json",
    )
    args = parser.parse_args()
    if not args.modes or not set(args.modes.split(",")) <= {"old", "new"}:
        parser.error(f"--modes must be old, new or old,new, got {args.modes!r}")
    torch.set_num_threads(1)
    results = {
        "cpu": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "load_average_at_start": os.getloadavg(),
        "torch_threads": 1,
        "click_seconds": args.click_seconds,
        "command": "python benchmarks/study_latency.py " + " ".join(sys.argv[1:]),
        "bodies": {},
    }
    if args.part in ("between", "all"):
        run_between(args, results)
    if args.part in ("clicks", "all"):
        run_clicks(args, results)
    atomic_write_json(args.out, results)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
