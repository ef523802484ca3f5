"""Side by side: a candidate ant low level against the shipped ensemble, from result files of the repo's own tools.

Reads

* ``antmaze_lab.in_maze`` rows of the ensemble and the candidate, same mazes and seeds: one file with both (the ensemble
  first) or two files of one row each (the ensemble's first);
* pairs of ``antmaze-hirl benchmark`` reports (``--benchmark ENSEMBLE.json CANDIDATE.json``, repeatable), same
  suite, seed and episodes per task, differing only in ``--low-level`` (and perhaps ``--tasks``: a pair whose
  reports played other tasks is read on the tasks both played, its counts recounted from their episodes);
* pairs of ``antmaze-hirl eval-low`` files on one set of subgoals (``--eval-low SEED ENSEMBLE.json
  CANDIDATE.json``, repeatable, the sets disjoint: seeds at least the episodes apart), pooled over the sets; a file
  that records its seed must record SEED (older files do not: their seed is taken from the command line, with a note);

and writes one JSON (``--out``) and a Markdown table with, per family or suite and low level: success with its
95% Wilson interval, flips and flips per 10,000 low-level steps with an exact Poisson 95% interval (Garwood).
For the benchmark pairs, whose reports keep every episode, also the paired outcome counts (both succeed, only
one does) and the exact two-sided McNemar p-value over the discordant episodes (episodes share mazes and seeds,
so they pair), and the exact conditional p-value of equal flip rates per step (:func:`flip_rate_p`). The first
report of a pair is called the ensemble's; it may be any reference (such as a fine-tune's start): every row
names its low level. A suite played with several episodes per task repeats mazes: its Wilson interval understates the
spread (the reports' task bootstrap is printed beside it).

``--run STATE.json`` adds the distillation run's own curve (student-driven episodes on its training mazes, per
``--block`` iterations): a health check of the run, not a score.

Usage: python scripts/steady_ant_table.py --in-maze E.json [C.json] --benchmark E.json C.json [...]
           [--eval-low SEED E.json C.json ...] [--run STATE.json] --out summary.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from pathlib import Path
from typing import Any

from scipy.stats import binomtest, chi2

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.experiments.uncertainty import wilson_interval

PER_STEPS = 10_000


def poisson_interval(events: int, exposure: float, per: float = PER_STEPS) -> list[float]:
    """Exact (Garwood) 95% interval of a Poisson rate of ``events`` over ``exposure``, per ``per`` units."""
    low = 0.0 if events == 0 else chi2.ppf(0.025, 2 * events) / 2
    high = chi2.ppf(0.975, 2 * events + 2) / 2
    return [float(low * per / exposure), float(high * per / exposure)]


def rate_row(successes: int, episodes: int, flips: int, steps: int) -> dict[str, Any]:
    """Success with its Wilson interval, flips per 10,000 steps with its Poisson interval."""
    return {
        "episodes": episodes,
        "successes": successes,
        "success_rate": successes / episodes,
        "success_ci95": list(wilson_interval(successes, episodes)),
        "flips": flips,
        "low_level_steps": steps,
        "flips_per_10k_steps": flips * PER_STEPS / steps,
        "flips_per_10k_steps_ci95": poisson_interval(flips, steps),
    }


def in_maze_rows(paths: list[Path]) -> dict[str, Any]:
    """Per family: the ensemble's and the candidate's ``antmaze_lab.in_maze`` rows.

    One file holding two rows (the ensemble first), or two files of one row each (the ensemble's first), made
    with the same episodes, seed and families.
    """
    files = [json.loads(path.read_text()) for path in paths]
    rows = [(data, name) for data in files for name in data["results"]]
    if len(rows) != 2 or len(paths) > 2:
        raise ValueError(f"{[str(p) for p in paths]} hold {len(rows)} rows; this table needs two, the ensemble first")
    keys = ("subgoal_reach_m", "num_envs")
    if len(files) == 2 and any(files[0].get(key) != files[1].get(key) for key in keys):
        raise ValueError(f"{paths[0]} and {paths[1]} differ in {keys}: not the same episodes")
    families: dict[str, Any] = {}
    for role, (data, name) in zip(("ensemble", "candidate"), rows, strict=True):
        row = data["results"][name]
        for family, figures in row["families"].items():
            steps = round(figures["mean_low_level_steps"] * figures["episodes"])
            entry = families.setdefault(family, {"maze_seed": figures["maze_seed"], "episodes": figures["episodes"]})
            if (entry["maze_seed"], entry["episodes"]) != (figures["maze_seed"], figures["episodes"]):
                raise ValueError(
                    f"family {family}: the rows play {entry['episodes']} episodes from maze seed {entry['maze_seed']} "
                    f"and {figures['episodes']} from {figures['maze_seed']}"
                )
            entry[role] = {
                "name": name,
                "low_level_id": row["low_level_id"],
                **rate_row(figures["successes"], figures["episodes"], figures["flips"], steps),
            }
    incomplete = sorted(
        family for family, entry in families.items() if "candidate" not in entry or "ensemble" not in entry
    )
    if incomplete:
        raise ValueError(f"families {incomplete} are missing from one of the rows")
    return {
        "files": [str(path) for path in paths],
        "commands": [data.get("command") for data in files],
        "families": families,
    }


def benchmark_pair(ensemble_path: Path, candidate_path: Path) -> dict[str, Any]:
    """One suite's two reports side by side, with the paired outcome counts and McNemar's exact p."""
    reports = [json.loads(Path(path).read_text()) for path in (ensemble_path, candidate_path)]
    keys = ("suite", "seed", "episodes_per_task", "policy")
    differ = [key for key in keys if reports[0].get(key) != reports[1].get(key)]
    if differ:
        raise ValueError(f"{ensemble_path} and {candidate_path} differ in {differ}: not the same episodes")
    tasks = [{episode["task_id"] for episode in report["episode_outcomes"]} for report in reports]
    shared = sorted(tasks[0] & tasks[1])
    if not shared:
        raise ValueError(f"{ensemble_path} and {candidate_path} share no task")
    if tasks[0] != tasks[1]:  # one played a subset (--tasks): both are read on the tasks they share
        reports = [on_tasks(report, shared) for report in reports]
    first, second = ([(e["task_id"], e["seed"], e["success"]) for e in r["episode_outcomes"]] for r in reports)
    if [pair[:2] for pair in first] != [pair[:2] for pair in second]:
        raise ValueError(f"{ensemble_path} and {candidate_path} played other episodes")
    only_ensemble = sum(a[2] and not b[2] for a, b in zip(first, second, strict=True))
    only_candidate = sum(b[2] and not a[2] for a, b in zip(first, second, strict=True))
    both = sum(a[2] and b[2] for a, b in zip(first, second, strict=True))
    discordant = only_ensemble + only_candidate
    rows = {}
    for role, path, report in zip(("ensemble", "candidate"), (ensemble_path, candidate_path), reports, strict=True):
        rows[role] = {
            "file": str(path),
            "command": report.get("command"),
            "low_level": report["low_level"],
            "task_bootstrap_95": report.get("task_bootstrap_95"),
            **rate_row(report["successes"], report["episodes"], report["flips"], report["low_level_steps_total"]),
        }
    return {
        "suite": reports[0]["suite"],
        "episodes_per_task": reports[0]["episodes_per_task"],
        "tasks": "all" if tasks[0] == tasks[1] and reports[0].get("task_ids") == "all" else shared,
        **rows,
        "paired": {
            "both_succeed": both,
            "only_ensemble": only_ensemble,
            "only_candidate": only_candidate,
            "mcnemar_exact_p": float(binomtest(only_candidate, discordant).pvalue) if discordant else 1.0,
        },
        "flip_rate_exact_p": flip_rate_p(rows["ensemble"], rows["candidate"]),
    }


def on_tasks(report: dict[str, Any], task_ids: list[int]) -> dict[str, Any]:
    """A benchmark report cut to the episodes of ``task_ids``, its counts recounted from those episodes (its task
    bootstrap, made over all its tasks, is dropped)."""
    episodes = [episode for episode in report["episode_outcomes"] if episode["task_id"] in task_ids]
    return {
        **report,
        "task_ids": ",".join(map(str, task_ids)),
        "episode_outcomes": episodes,
        "episodes": len(episodes),
        "successes": sum(episode["success"] for episode in episodes),
        "flips": sum(episode["flipped"] for episode in episodes),
        "low_level_steps_total": sum(episode["low_level_steps"] for episode in episodes),
        "task_bootstrap_95": None,
    }


def flip_rate_p(first: dict[str, Any], second: dict[str, Any]) -> float:
    """Two-sided exact p of equal flip rates per step: given the pair's flips, the second's count is binomial by
    its share of the steps (the conditional test of two Poisson counts); 1.0 when neither flipped."""
    flips = first["flips"] + second["flips"]
    if flips == 0:
        return 1.0
    share = second["low_level_steps"] / (first["low_level_steps"] + second["low_level_steps"])
    return float(binomtest(second["flips"], flips, share).pvalue)


EVAL_LOW_KEYS = ("success_rate", "episodes")
"""The fields every ``eval-low`` file has; ``seed`` and ``sample_radius_m`` are recorded since the 28th session."""


def eval_low_file(path: Path) -> dict[str, Any]:
    """One ``eval-low`` JSON file.

    Raises:
        ValueError: If it is not JSON, lacks a field of :data:`EVAL_LOW_KEYS`, or holds a field of the wrong
            type or range (``episodes`` an integer >= 1, ``success_rate`` in [0, 1], ``seed`` an integer), naming
            the file.
    """
    try:
        data = json.loads(Path(path).read_text())
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise ValueError(f"{path} is not a JSON file") from None
    missing = [key for key in EVAL_LOW_KEYS if not isinstance(data, dict) or key not in data]
    if missing:
        raise ValueError(f"{path} has no {missing[0]!r}: not an antmaze-hirl eval-low file")
    episodes, rate = data["episodes"], data["success_rate"]
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"{path}: episodes must be an integer >= 1, got {episodes!r}")
    if isinstance(rate, bool) or not isinstance(rate, int | float) or not 0 <= rate <= 1:
        raise ValueError(f"{path}: success_rate must be a number in [0, 1], got {rate!r}")
    if "seed" in data and (isinstance(data["seed"], bool) or not isinstance(data["seed"], int)):
        raise ValueError(f"{path}: seed must be an integer, got {data['seed']!r}")
    return data


def eval_low_sets(sets: list[tuple[str, Path, Path]]) -> dict[str, Any]:
    """``eval-low`` files of the ensemble and the candidate per disjoint set of subgoals (its seed), and pooled.

    A file that records its ``seed`` (``eval-low`` does since the 28th session) must record the typed one; for an
    older file the typed seed is taken on faith, and its role's ``seed_from`` says ``"command line"`` (else
    ``"file"``).

    Raises:
        ValueError: If a seed is not an integer or contradicts a file's, a pair played other numbers of subgoals or
            other recorded radii, a pair's two files hold the same low level, or two sets overlap.
    """
    rows: list[dict[str, Any]] = []
    for seed_text, *paths in sets:
        try:
            seed = int(seed_text)
        except ValueError:
            raise ValueError(f"--eval-low seed {seed_text!r} is not an integer") from None
        files = [eval_low_file(path) for path in paths]
        for path, data in zip(paths, files, strict=True):
            if "seed" in data and data["seed"] != seed:
                raise ValueError(f"{path} records seed {data['seed']}, not the typed {seed}: another set of subgoals")
        if files[0]["episodes"] != files[1]["episodes"]:
            counts = f"{files[0]['episodes']} and {files[1]['episodes']}"
            raise ValueError(f"{paths[0]} and {paths[1]} tried {counts} subgoals: not the same set")
        radii = [data.get("sample_radius_m") for data in files]
        if None not in radii and radii[0] != radii[1]:
            raise ValueError(
                f"{paths[0]} and {paths[1]} drew subgoals up to {radii[0]} and {radii[1]} m: not the same set"
            )
        identities = [data.get("low_level_id") for data in files]
        if identities[0] is not None and identities[0] == identities[1]:
            raise ValueError(f"{paths[0]} and {paths[1]} both hold low level {identities[0]}: not two low levels")
        row: dict[str, Any] = {"seed": seed, "episodes": files[0]["episodes"]}
        for role, path, data in zip(("ensemble", "candidate"), paths, files, strict=True):
            successes = round(data["success_rate"] * data["episodes"])
            row[role] = {
                "file": str(path),
                "low_level_id": data.get("low_level_id"),
                "num_envs": data.get("num_envs", 1),  # files made before lockstep played one subgoal at a time
                "seed_from": "file" if "seed" in data else "command line",
                "successes": successes,
                "success_rate": successes / data["episodes"],
                "success_ci95": list(wilson_interval(successes, data["episodes"])),
            }
        rows.append(row)
    spans = sorted((row["seed"], row["seed"] + row["episodes"]) for row in rows)
    for (_, end), (start, _) in itertools.pairwise(spans):
        if start < end:
            raise ValueError(f"eval-low sets from seeds {[seed for seed, _ in spans]} overlap (subgoal i uses seed+i)")
    episodes = sum(row["episodes"] for row in rows)
    pooled = {}
    for role in ("ensemble", "candidate"):
        successes = sum(row[role]["successes"] for row in rows)
        pooled[role] = {
            "successes": successes,
            "episodes": episodes,
            "success_rate": successes / episodes,
            "success_ci95": list(wilson_interval(successes, episodes)),
        }
    return {"sets": rows, "pooled": pooled}


def training_curve(state_path: Path, block: int) -> list[dict[str, Any]]:
    """A distillation run's own curve from its ``state.json``: per block of iterations, the student-driven episodes.

    These are training mazes (the ``train`` part of the layout partition, the run's maze sizes and reach episodes),
    not the held-out families: a check that the run is healthy, not a score.
    """
    history = json.loads(state_path.read_text())["history"]
    rows = []
    for start in range(0, len(history), block):
        part = history[start : start + block]
        driven = {
            key: sum(record[driver][key] for record in part)
            for driver in ("student",)
            for key in ("episodes", "successes", "flips", "steps")
        }
        if not driven["episodes"]:
            continue
        rows.append(
            {
                "iterations": [part[0]["iteration"], part[-1]["iteration"]],
                **rate_row(driven["successes"], driven["episodes"], driven["flips"], driven["steps"]),
                "fit_loss_mean": sum(record["fit_loss"] for record in part) / len(part),
                "on_policy_mse_before_fit_mean": sum(record["on_policy_mse_before_fit"] for record in part) / len(part),
            }
        )
    return rows


def success_text(successes: int, episodes: int, interval: list[float]) -> str:
    """``successes/episodes [low%, high%]``."""
    return f"{successes}/{episodes} [{interval[0]:.0%}, {interval[1]:.0%}]"


def table(summary: dict[str, Any]) -> str:
    """The Markdown table of the summary."""
    lines = [
        "| where | low level | success [95% CI] | flips / steps | flips per 10k steps [95% CI] |",
        "|---|---|---|---|---|",
    ]

    def line(where: str, role: str, row: dict[str, Any]) -> str:
        flow, fhigh = row["flips_per_10k_steps_ci95"]
        return (
            f"| {where} | {role} | {success_text(row['successes'], row['episodes'], row['success_ci95'])} | "
            f"{row['flips']} / {row['low_level_steps']:,} | "
            f"{row['flips_per_10k_steps']:.2f} [{flow:.2f}, {fhigh:.2f}] |"
        )

    for family, rows in (summary.get("in_maze") or {}).get("families", {}).items():
        lines += [line(f"in_maze {family}", role, rows[role]) for role in ("ensemble", "candidate")]
    eval_low = summary.get("eval_low") or {}
    for row in eval_low.get("sets", []):
        lines += [
            f"| eval-low seed {row['seed']} | {role}: {row[role]['low_level_id']} | "
            f"{success_text(row[role]['successes'], row['episodes'], row[role]['success_ci95'])} | | |"
            for role in ("ensemble", "candidate")
        ]
    if eval_low:
        lines += [
            f"| eval-low pooled | {role} | {success_text(row['successes'], row['episodes'], row['success_ci95'])} | | |"
            for role, row in eval_low["pooled"].items()
        ]
    for row in summary.get("training_curve") or []:
        first, last = row["iterations"]
        lines.append(line(f"training mazes, iterations {first}-{last}", "student", row))
    for pair in summary.get("benchmark", []):
        tasks = pair.get("tasks", "all")
        where = f"benchmark {pair['suite']} (K={pair['episodes_per_task']}" + (
            ")" if tasks == "all" else f", tasks {','.join(map(str, tasks))})"
        )
        lines += [line(where, f"{role}: {pair[role]['low_level']}", pair[role]) for role in ("ensemble", "candidate")]
        paired = pair["paired"]
        flips_p = pair.get("flip_rate_exact_p")
        lines.append(
            f"| {where} | paired | both {paired['both_succeed']}, only ensemble {paired['only_ensemble']}, only "
            f"candidate {paired['only_candidate']} | McNemar p = {paired['mcnemar_exact_p']:.3g} | "
            + ("" if flips_p is None else f"equal rates p = {flips_p:.3g}")
            + " |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--in-maze",
        type=Path,
        nargs="+",
        default=None,
        help="antmaze_lab.in_maze file(s): the ensemble's row, then the candidate's",
    )
    parser.add_argument(
        "--benchmark", type=Path, nargs=2, action="append", default=[], metavar=("ENSEMBLE", "CANDIDATE")
    )
    parser.add_argument(
        "--eval-low",
        nargs=3,
        action="append",
        default=[],
        metavar=("SEED", "ENSEMBLE", "CANDIDATE"),
        help="eval-low files of one set of subgoals (its --seed), the ensemble's first; repeatable (default: none)",
    )
    parser.add_argument("--run", type=Path, default=None, help="a distillation run's state.json: its own curve")
    parser.add_argument("--block", type=int, default=20, help="iterations per row of the run's curve")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    try:
        summary = {
            "in_maze": in_maze_rows(args.in_maze) if args.in_maze else None,
            "benchmark": [benchmark_pair(first, second) for first, second in args.benchmark],
            "eval_low": eval_low_sets(args.eval_low) if args.eval_low else None,
            "training_curve": training_curve(args.run, args.block) if args.run else None,
        }
    except (OSError, ValueError, KeyError) as error:
        print(f"steady_ant_table.py: error: {error}", file=sys.stderr)
        return 2
    for row in (summary["eval_low"] or {}).get("sets", []):
        for role in ("ensemble", "candidate"):
            if row[role]["seed_from"] == "command line":
                note = f"{row[role]['file']} records no seed: seed {row['seed']} is taken from the command line"
                print(f"steady_ant_table.py: note: {note}", file=sys.stderr)
    summary["table_markdown"] = table(summary)
    summary["command"] = "python scripts/steady_ant_table.py " + " ".join(sys.argv[1:] if argv is None else argv)
    print(summary["table_markdown"])
    atomic_write_json(args.out, summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
