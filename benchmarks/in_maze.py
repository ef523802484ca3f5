"""In-maze success: the scripted oracle driving a low-level policy through held-out mazes (issue 16).

For each low level (default the shipped ant; ``--low-level ZIP`` for candidates, repeatable, run side by side on
the same mazes) and each maze family:

* ``ant3``: the ant experiment's family (random 3x3 layouts, 500-step limit), the mazes of
  ``paper_experiment.py --ceiling-only``;
* ``ant4``: the held-out-layouts protocol's ant family (random 4x4 layouts from the ``eval`` part of the layout
  partition, 500-step limit), the mazes of ``paper_experiment.py --body ant --oracle-only --held-out-layouts``;
* ``u``, ``medium``, ``large``: gymnasium-robotics' standard maps, random start corner and goal (at least 3 grid
  steps apart), with the step limit scaled to the episode's shortest path (:func:`step_limit`).

The oracle's subgoals are at most 2 m away (the ant experiment's ``expert_max_distance``). Episode ``i`` of every
family resets with seed ``HELD_OUT_SEED + i`` (1,000,000 + i, as every held-out figure): for ``ant3`` these are the
ceiling's mazes. Note the 3x3 family has only 48 distinct wall grids, so a training run that sees random 3x3
layouts (``ReachEnv(maze_probability=...)``) has seen these grids; only the seeds are held out.

Each episode ends in exactly one outcome: ``success``, ``flip`` (the ant turned over: the env ends the episode),
``frozen`` (truncated, and over its last :data:`FROZEN_SUBGOALS` subgoals the body never got
:data:`FROZEN_RADIUS` m from where it stood when the first of them was set) or ``timeout`` (any other truncation).
Success rates carry a 95% Wilson interval; ``flips_per_subgoal`` is flips over subgoals set.

Usage: python benchmarks/in_maze.py [--episodes 100] [--families ant3,ant4,u,medium,large] [--low-level cand.zip ...]
Writes benchmarks/results/in_maze.json (or ``--out``), with the command that made it, and prints a table.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from paper_experiment import RESULTS

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED
from antmaze_hirl.envs.layouts import STANDARD_MAPS, shortest_path
from antmaze_hirl.experiments import ExperimentConfig, wilson_interval
from antmaze_hirl.experiments.config import BODY_DEFAULTS, body_settings, evaluation_sets
from antmaze_hirl.experiments.runner import low_level_identity, make_env
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.rollout import play_episode
from antmaze_hirl.sb3_ext.loading import load_low_level

FAMILIES = ("ant3", "ant4", "u", "medium", "large")
STEPS_PER_METRE = 40
"""Step budget per metre of shortest cell path: a 0.5 m/s average, half the ~1 m/s of a straight walk."""
MIN_STEPS = 500
"""No standard-map episode gets fewer steps than the high-level env's default budget."""
FROZEN_SUBGOALS = 5
FROZEN_RADIUS = 1.0
"""Metres: a walking ant covers this in ~1 s (20 steps); 5 subgoals give it up to 500 steps."""
OUTCOMES = ("success", "flip", "frozen", "timeout")
COUNT_KEYS = {"success": "successes", "flip": "flips", "frozen": "frozen", "timeout": "timeouts"}
"""The JSON key of each outcome's count."""


def step_limit(walls: np.ndarray, start_cell: tuple[int, int], goal_cell: tuple[int, int], scale: float) -> int:
    """``max(MIN_STEPS, ceil(STEPS_PER_METRE * L))``, ``L`` the shortest 4-connected cell path in metres.

    ``L`` counts cell centre to cell centre (grid steps times ``scale``), so the detours around walls count.
    """
    metres = (len(shortest_path(walls, start_cell, goal_cell)) - 1) * scale
    return max(MIN_STEPS, math.ceil(STEPS_PER_METRE * metres))


class MazeEpisodeRecorder(gym.Wrapper):
    """Keeps each high-level step's ``agent_path``; optionally scales the step budget to each episode's path.

    Args:
        env: A (wrapped) high-level maze env.
        scale_step_limit: After every reset, set the env's ``max_steps`` to :func:`step_limit` of the drawn layout.
    """

    def __init__(self, env: gym.Env, *, scale_step_limit: bool) -> None:
        super().__init__(env)
        self.scale_step_limit = scale_step_limit
        self.paths: list[np.ndarray] = []

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Resets the env, then (if asked) sets its step budget from the new layout's start and goal."""
        obs, info = self.env.reset(**kwargs)
        inner = self.env.unwrapped
        if self.scale_step_limit:
            layout = inner.layout
            inner.max_steps = step_limit(layout.walls, layout.start_cell, layout.goal_cell, inner.geometry.scale)
        self.paths = []
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """One subgoal; its low-level path is kept in :attr:`paths`."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.paths.append(np.asarray(info["agent_path"]))
        return obs, reward, terminated, truncated, info

    @property
    def max_steps(self) -> int:
        """The current episode's step budget."""
        return int(self.env.unwrapped.max_steps)


def is_frozen(paths: list[np.ndarray], subgoals: int = FROZEN_SUBGOALS, radius: float = FROZEN_RADIUS) -> bool:
    """Whether, over the last ``subgoals`` subgoals' paths, the body stayed within ``radius`` m of where they began.

    Raises:
        ValueError: If ``paths`` is empty.
    """
    if not paths:
        raise ValueError("is_frozen needs the path of at least one subgoal, got none")
    recent = np.concatenate(paths[-subgoals:])
    return bool(np.max(np.linalg.norm(recent - recent[0], axis=1)) < radius)


def outcome(info: dict[str, Any], paths: list[np.ndarray]) -> str:
    """The episode's outcome from its last ``info`` and subgoal paths: one of :data:`OUTCOMES`."""
    if info["is_success"]:
        return "success"
    if info["flipped"]:
        return "flip"
    return "frozen" if is_frozen(paths) else "timeout"


def evaluate_family(env: MazeEpisodeRecorder, oracle: Any, *, episodes: int, seed: int) -> dict[str, Any]:
    """The oracle's episodes ``seed .. seed + episodes - 1`` on ``env``: outcome counts, interval, flips per subgoal.

    Raises:
        ValueError: If ``episodes`` < 1.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    counts = dict.fromkeys(OUTCOMES, 0)
    subgoals, steps, limits = 0, [], []
    started = time.perf_counter()
    for episode in range(episodes):
        info = play_episode(env, oracle, seed=seed + episode).info
        counts[outcome(info, env.paths)] += 1
        subgoals += info["attempts"]
        steps.append(info["total_low_level_steps"])
        limits.append(env.max_steps)
    return {
        "episodes": episodes,
        "maze_seed": seed,
        "success_rate": counts["success"] / episodes,
        "success_ci95": list(wilson_interval(counts["success"], episodes)),
        **{COUNT_KEYS[name]: count for name, count in counts.items()},
        "subgoals": subgoals,
        "flips_per_subgoal": counts["flip"] / subgoals,
        "mean_low_level_steps": float(np.mean(steps)),
        "step_limit_range": [int(min(limits)), int(max(limits))],
        "seconds": round(time.perf_counter() - started, 1),
    }


def parse_families(text: str) -> list[str]:
    """Comma-separated family names, each one of :data:`FAMILIES`.

    Raises:
        ValueError: Naming every unknown (or empty) entry, in one line.
    """
    families = [family.strip() for family in text.split(",")]
    unknown = [family for family in families if family not in FAMILIES]
    if unknown:
        raise ValueError(f"unknown families {unknown}; choose from {list(FAMILIES)}")
    return families


def family_env(family: str, low_level: Any) -> MazeEpisodeRecorder:
    """The high-level ant env of ``family`` driving ``low_level`` (``None``: the shipped policy).

    Raises:
        ValueError: For a family not in :data:`FAMILIES`.
    """
    if family == "ant3":
        config = ExperimentConfig(body="ant", **BODY_DEFAULTS["ant"])
        return MazeEpisodeRecorder(make_env(config, low_level), scale_step_limit=False)
    if family == "ant4":
        config = ExperimentConfig(body="ant", held_out_layouts=True, **body_settings("ant", held_out_layouts=True))
        split = evaluation_sets(config)["final"][0]
        return MazeEpisodeRecorder(make_env(config, low_level, split=split), scale_step_limit=False)
    if family not in STANDARD_MAPS or family == "open":
        raise ValueError(f"unknown maze family {family!r}; choose from {list(FAMILIES)}")
    return MazeEpisodeRecorder(
        gym.make("antmaze_hirl/AntMaze-v0", maze_map=family, low_level=low_level), scale_step_limit=True
    )


def run(low_levels: list[Path | None], families: list[str], *, episodes: int, seed: int) -> dict[str, Any]:
    """Figures per low level (``None``: shipped) and family, with each family's success ratio to the first."""
    max_distance = BODY_DEFAULTS["ant"]["expert_max_distance"]
    results: dict[str, Any] = {}
    for path in low_levels:
        model = None if path is None else load_low_level("ant", path)
        name = "shipped" if path is None else str(path)
        figures: dict[str, Any] = {"low_level_id": low_level_identity("ant", model), "families": {}}
        for family in families:
            env = family_env(family, model)
            oracle = PathOracle.for_env(env, max_distance=max_distance)
            figures["families"][family] = evaluate_family(env, oracle, episodes=episodes, seed=seed)
            env.close()
            print(f"{name} {family}: {figures['families'][family]}", flush=True)
        results[name] = figures
    first = next(iter(results.values()))["families"]
    for figures in results.values():
        for family, row in figures["families"].items():
            base = first[family]["success_rate"]
            row["success_ratio_to_first"] = row["success_rate"] / base if base > 0 else None
    return results


def table(results: dict[str, Any]) -> str:
    """A plain-text table: one row per low level and family."""
    lines = [f"{'low level':<40} {'family':<7} {'success [95% CI]':<22} flips frozen timeouts flips/subgoal"]
    for name, figures in results.items():
        for family, row in figures["families"].items():
            low, high = row["success_ci95"]
            ci = f"{row['success_rate']:.0%} [{low:.0%}, {high:.0%}]"
            lines.append(
                f"{name[-40:]:<40} {family:<7} {ci:<22} {row['flips']:>5} {row['frozen']:>6} "
                f"{row['timeouts']:>8} {row['flips_per_subgoal']:>13.4f}"
            )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=100, help="held-out mazes (episodes) per family")
    parser.add_argument("--families", default=",".join(FAMILIES), help=f"comma-separated subset of {FAMILIES}")
    parser.add_argument(
        "--low-level",
        type=Path,
        action="append",
        default=None,
        help="candidate policy .zip (repeatable); the shipped policy always runs first",
    )
    parser.add_argument("--seed", type=int, default=HELD_OUT_SEED, help="maze seed of episode 0")
    parser.add_argument("--out", type=Path, default=RESULTS / "in_maze.json")
    args = parser.parse_args()
    try:
        families = parse_families(args.families)
    except ValueError as error:
        parser.error(str(error))
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    missing = [str(path) for path in args.low_level or [] if not path.is_file()]
    if missing:
        parser.error(f"--low-level files not found: {missing}")
    torch.set_num_threads(1)
    results = run([None, *(args.low_level or [])], families, episodes=args.episodes, seed=args.seed)
    atomic_write_json(
        args.out,
        {
            "command": shlex.join(["python", "benchmarks/in_maze.py", *sys.argv[1:]]),
            "expert_max_distance": BODY_DEFAULTS["ant"]["expert_max_distance"],
            "step_limit": (
                f"ant3, ant4: 500; standard maps: max({MIN_STEPS}, ceil({STEPS_PER_METRE} * shortest cell path m))"
            ),
            "frozen": f"truncated, and within {FROZEN_RADIUS} m over the last {FROZEN_SUBGOALS} subgoals",
            "results": results,
        },
    )
    print(table(results))


if __name__ == "__main__":
    main()
