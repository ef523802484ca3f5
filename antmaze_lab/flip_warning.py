"""What comes before a flip, and whether a reflex at inference can stop it (flips end the ant's walks in mazes).

The scripted oracle (2 m subgoals) drives a low level (default the shipped ant) through ``--mazes`` ``select6``
mazes (``antmaze_lab.in_maze``'s selection family: 6x6 layouts of the ``selection`` part of the layout partition, step
limits scaled to the path, maze seed 2,000,000 as ``antmaze_lab.select_low_level``): no reported figure uses them, so
what is tuned here does not peek at the held-out sets.

* **Warning.** Every low-level step's *uprightness* (world z of the torso's up axis: 1 upright, 0 on its
  side; the env ends the episode below 0 or under 0.2 m of torso height) is recorded. For each threshold ``U``
  of ``--thresholds``: the *lead* of each flip, the steps from the last step at or above ``U`` to the flip
  (the time a reflex triggered at ``U`` would have); and the *false alarms*, the share of the steps of
  episodes that did not flip spent below ``U``.
* **Reflexes.** Each ``--reflexes K@U`` entry plays the same mazes with :class:`TiltReflex`: while uprightness
  is below ``U`` the policy's action is multiplied by ``K`` (``0@U``: limp legs). Success and flips with 95%
  Wilson intervals, beside the low level without a reflex.

The dense reward term that the lead motivates is ``ReachEnv(tilt_penalty=...)``
(``scripts/configs/ant_maze_tilt.yml``).

Usage: python -m antmaze_lab.flip_warning [--mazes 100] [--low-level ZIP] [--thresholds 0.8,0.7,0.6,0.5]
           [--reflexes 0@0.8,0.3@0.8] [--jobs 1]
Writes results/flip_warning/flip_warning.json (or ``--out``), with the command that made it, and prints both tables.
Files written before it moved into the lab record ``python scripts/flip_warning.py`` (earlier
``benchmarks/flip_warning.py``): the same options replay them here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.controllers import GoalObservation, as_controller, reset_controller
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.simulator import uprightness
from antmaze_hirl.experiments import wilson_interval
from antmaze_hirl.experiments.config import BODY_DEFAULTS
from antmaze_hirl.experiments.runner import low_level_identity
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.rollout import play_episode
from antmaze_lab.commands import recorded_command
from antmaze_lab.in_maze_protocol import OUTCOMES, chunks_of, family_env, map_tasks, outcome, worker_low_level
from antmaze_lab.tables import lab_parser

FAMILY = "select6"
QUATERNION = slice(1, 5)
"""Where the torso quaternion ``(qw, qx, qy, qz)`` sits in the ant's ``observation`` (after the torso height)."""

RESULTS = Path(__file__).resolve().parents[1] / "results" / "flip_warning"
SELECTION_MAZE_SEED = SEEDS.low_level_selection_mazes
"""``antmaze_lab.select_low_level``'s maze seed of episode 0."""


class TiltReflex:
    """A controller that scales another's actions by ``scale`` while the torso's uprightness is below ``threshold``.

    It also records the uprightness it saw at every step of the current episode (:attr:`trace`).

    Args:
        controller: The controller (or SB3 model) it wraps.
        threshold: Uprightness below which the reflex acts; ``-1`` never acts (a recorder only).
        scale: Multiplier on the actions while it acts, in ``[0, 1]``.

    Raises:
        ValueError: If ``threshold`` is outside ``[-1, 1]`` or ``scale`` outside ``[0, 1]``.
    """

    def __init__(self, controller: Any, threshold: float = -1.0, scale: float = 1.0) -> None:
        if not -1.0 <= threshold <= 1.0:
            raise ValueError(f"reflex threshold must lie in [-1, 1], got {threshold}")
        if not 0.0 <= scale <= 1.0:
            raise ValueError(f"reflex scale must lie in [0, 1], got {scale}")
        self.controller = as_controller(controller)
        self.threshold, self.scale = threshold, scale
        self.trace: list[float] = []
        self.acted = 0

    def reset(self) -> None:
        """Starts a new episode's trace (and resets the inner controller, if it has state)."""
        self.trace = []
        reset_controller(self.controller)

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """The inner controller's action, scaled while the torso tilts past the threshold."""
        upright = uprightness(observation["observation"][QUATERNION])
        self.trace.append(upright)
        action = np.asarray(self.controller(observation), dtype=np.float64)
        if upright < self.threshold:
            self.acted += 1
            return self.scale * action
        return action


def parse_reflexes(text: str) -> list[tuple[float, float]]:
    """``K@U`` entries, comma-separated, as ``(scale, threshold)`` pairs; an empty text gives none.

    Raises:
        ValueError: Naming the first entry that is not ``K@U`` with numbers ``K`` in [0, 1], ``U`` in [-1, 1].
    """
    reflexes = []
    for entry in filter(None, (part.strip() for part in text.split(","))):
        try:
            scale, threshold = (float(value) for value in entry.split("@"))
        except ValueError:
            raise ValueError(f"reflex {entry!r} is not K@U (e.g. 0.3@0.8)") from None
        if not (0.0 <= scale <= 1.0 and -1.0 <= threshold <= 1.0):
            raise ValueError(f"reflex {entry!r}: K must lie in [0, 1] and U in [-1, 1]")
        reflexes.append((scale, threshold))
    return reflexes


def play_chunk(path: Path | None, scale: float, threshold: float, seeds: range) -> dict[str, Any]:
    """One chunk of ``select6`` episodes with a reflex.

    Returns its outcomes, the steps the reflex acted, the uprightness traces and the low level's fingerprint.
    """
    torch.set_num_threads(1)
    model = worker_low_level(path)
    reflex = TiltReflex(model, threshold, scale)
    env = family_env(FAMILY, reflex)
    oracle = PathOracle.for_env(env, subgoal_reach_m=BODY_DEFAULTS["ant"]["subgoal_reach_m"])
    outcomes, traces = [], []
    try:
        for seed in seeds:
            info = play_episode(env, oracle, seed=seed).info
            outcomes.append(outcome(info, env.paths))
            traces.append(reflex.trace)
    finally:
        env.close()
    return {
        "first_seed": seeds.start,
        "outcomes": outcomes,
        "traces": traces,
        "acted": reflex.acted,
        "low_level_id": low_level_identity("ant", model),
    }


def flip_lead(trace: np.ndarray, threshold: float) -> int:
    """Steps from the last step of a flipped episode's ``trace`` at or above ``threshold`` to its end.

    The trace's last entry is the step before the env saw the flip; a trace never at or above the threshold
    leads by its whole length.
    """
    above = np.nonzero(np.asarray(trace) >= threshold)[0]
    return len(trace) - 1 - (int(above[-1]) if above.size else -1)


def warning_figures(outcomes: list[str], traces: list[list[float]], thresholds: list[float]) -> dict[str, Any]:
    """Per threshold: the flips' lead (median, min, max steps) and the false-alarm share of non-flip steps."""
    flipped = [np.asarray(trace) for trace, result in zip(traces, outcomes, strict=True) if result == "flip"]
    calm = [np.asarray(trace) for trace, result in zip(traces, outcomes, strict=True) if result != "flip"]
    calm_steps = np.concatenate(calm) if calm else np.zeros(0)
    figures = {}
    for threshold in thresholds:
        leads = [flip_lead(trace, threshold) for trace in flipped]
        figures[f"{threshold:g}"] = {
            "flips": len(leads),
            "lead_steps_median": float(np.median(leads)) if leads else None,
            "lead_steps_min": int(min(leads)) if leads else None,
            "lead_steps_max": int(max(leads)) if leads else None,
            "non_flip_steps_below": int((calm_steps < threshold).sum()),
            "non_flip_steps": int(calm_steps.size),
            "non_flip_episodes_ever_below": int(sum(bool((trace < threshold).any()) for trace in calm)),
        }
    return figures


def reflex_row(outcomes: list[str], acted: int, steps: int) -> dict[str, Any]:
    """Success and flips of one reflex over its episodes, with 95% Wilson intervals."""
    episodes = len(outcomes)
    counts = {name: outcomes.count(name) for name in OUTCOMES}
    return {
        "episodes": episodes,
        **counts,
        "success_rate": counts["success"] / episodes,
        "success_ci95": list(wilson_interval(counts["success"], episodes)),
        "flip_rate": counts["flip"] / episodes,
        "flip_ci95": list(wilson_interval(counts["flip"], episodes)),
        "reflex_steps": acted,
        "reflex_share_of_steps": acted / steps if steps else 0.0,
    }


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``scripts/results_index.py --check`` parses recorded options with it)."""
    parser = lab_parser("antmaze_lab.flip_warning", __doc__)
    parser.add_argument("--mazes", type=int, default=100, help="select6 mazes (episodes) per row")
    parser.add_argument("--low-level", type=Path, default=None, help="policy .zip (default: the shipped ant)")
    parser.add_argument("--thresholds", default="0.8,0.7,0.6,0.5", help="uprightness thresholds of the warning")
    parser.add_argument("--reflexes", default="0@0.8,0.3@0.8,0.3@0.7,0.5@0.8", help="K@U entries, comma-separated")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (chunks of 25 mazes)")
    parser.add_argument("--out", type=Path, default=RESULTS / "flip_warning.json")
    return parser


def main() -> None:
    """The command line: play every reflex row on the ``select6`` mazes, write the file, print the figures."""
    parser = build_parser()
    args = parser.parse_args()
    try:
        reflexes = parse_reflexes(args.reflexes)
        thresholds = [float(value) for value in args.thresholds.split(",")]
    except ValueError as error:
        parser.error(str(error))
    if args.mazes < 1 or args.jobs < 1:
        parser.error(f"--mazes and --jobs must be >= 1, got {args.mazes} and {args.jobs}")
    if args.low_level is not None and not args.low_level.is_file():
        parser.error(f"--low-level file not found: {args.low_level}")
    rows = {"none": (1.0, -1.0), **{f"{k:g}@{u:g}": (k, u) for k, u in reflexes}}  # "none" never acts
    seeds = chunks_of(args.mazes, SELECTION_MAZE_SEED, 25)
    names = [name for name in rows for _ in seeds]
    tasks = [(args.low_level, *rows[name], chunk) for name in rows for chunk in seeds]
    done = list(tqdm(map_tasks(play_chunk, tasks, args.jobs), total=len(tasks), desc="chunks", unit="chunk"))
    by_row: dict[str, Any] = {}
    for name, chunk in zip(names, done, strict=True):
        row = by_row.setdefault(name, {"outcomes": [], "traces": [], "acted": 0})
        row["outcomes"] += chunk["outcomes"]
        row["traces"] += chunk["traces"]
        row["acted"] += chunk["acted"]
    plain = by_row["none"]
    warning = warning_figures(plain["outcomes"], plain["traces"], thresholds)
    results = {
        name: reflex_row(row["outcomes"], row["acted"], sum(map(len, row["traces"]))) for name, row in by_row.items()
    }
    atomic_write_json(
        args.out,
        {
            "command": recorded_command("antmaze_lab.flip_warning", sys.argv[1:]),
            "low_level_id": done[0]["low_level_id"],  # every chunk plays the same low level
            "family": FAMILY,
            "maze_seed": SELECTION_MAZE_SEED,
            "warning": warning,
            "reflexes": results,
        },
    )
    print(f"{'uprightness':<12} {'flips':>5} {'lead median (min-max)':>22} {'non-flip steps below':>22}")
    for threshold, row in warning.items():
        lead = "-"
        if row["flips"]:
            lead = f"{row['lead_steps_median']:g} ({row['lead_steps_min']}-{row['lead_steps_max']})"
        below = f"{row['non_flip_steps_below']}/{row['non_flip_steps']}"
        print(f"{threshold:<12} {row['flips']:>5} {lead:>22} {below:>22}")
    print(f"\n{'reflex K@U':<12} {'success [95% CI]':<22} {'flips':>5} {'reflex steps':>13}")
    for name, row in results.items():
        low, high = row["success_ci95"]
        success = f"{row['success_rate']:.0%} [{low:.0%}, {high:.0%}]"
        print(f"{name:<12} {success:<22} {row['flip']:>5} {row['reflex_share_of_steps']:>12.2%}")


if __name__ == "__main__":
    main()
