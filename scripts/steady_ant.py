"""Distil the shipped ant ensemble into one actor network on in-maze states.

The lab's run of :func:`antmaze_hirl.sb3_ext.distill.distill`: the scripted oracle (2 m subgoals, the ant
experiment's reach) chooses subgoals in random mazes of ``--maze-sizes`` free cells per side, drawn from the
``train`` part of the layout partition (so no wall grid of ``ant4``'s evaluation mazes or of the selection
families is ever trained on), the step budget 500 low-level steps up to 4x4 and scaled to the shortest path
above (as ``in_maze.py``'s larger families). With ``--reach-share`` an extra source of chained random subgoals
(``ReachEnv``, eval-low's kind of subgoal, half of its episodes in random 3x3/5x5 train-part mazes) takes its
turn among the maze sizes. The teacher (default: the shipped ensemble) labels every state the student or
teacher visits; the student is fitted by regression on the aggregate.

A run is a folder (``--out``) that checkpoints every iteration; ``--resume`` continues it with the same
arguments (a run started with other settings is refused, naming them). Run it in the background from a frozen
clone, one torch thread::

    git clone /work/wt-steadyant /work/frozen-steadyant-SHA && cd /work/frozen-steadyant-SHA
    nohup env PYTHONPATH=$PWD /work/main/.venv/bin/python scripts/steady_ant.py --out /work/runs/steadyant/d1 \\
        >> /work/runs/steadyant/d1.log 2>&1 &

The latest student is ``OUT/<state.json's "student">``; snapshots every ``--snapshot-every`` iterations stay in
``OUT/students/``. Score one beside the shipped ensemble with ``python -m antmaze_lab.in_maze --low-level ZIP`` and
``antmaze-hirl benchmark large --policy oracle --low-level ZIP``.

Usage: python scripts/steady_ant.py --out DIR [--resume] [--iterations 100] [--steps-per-iteration 20000]
           [--maze-sizes 3 4 6] [--reach-share] [--flip-weight 1] [--action-noise-std 0] [--seed 0] [--teacher ZIP]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import fields
from pathlib import Path
from typing import Any

import gymnasium as gym
import torch

import antmaze_hirl  # noqa: F401  (registers the ids)
from antmaze_hirl.envs.profiles import BODY_PROFILES, maze_env_id
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.envs.suites import scaled_step_limit
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.sb3_ext.distill import (
    DistillSettings,
    EpisodeSource,
    HighLevelEpisodes,
    ReachEpisodes,
    RecordingController,
    distill,
)
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

FIXED_BUDGET_SIZES = 4
"""Mazes up to this many cells per side get the families' fixed 500-step budget; larger ones scale to the path."""


def maze_sources(
    controller: RecordingController, maze_sizes: list[int], reach: bool, subgoal_reach_m: float
) -> list[EpisodeSource]:
    """One oracle-driven source per maze size (train part of the partition), plus a reach source if asked."""
    sources: list[EpisodeSource] = []
    for size in maze_sizes:
        env = gym.make(maze_env_id("ant"), maze_size=size, low_level=controller, split="train")
        oracle = PathOracle.for_env(env, subgoal_reach_m=subgoal_reach_m)
        limit = None
        if size > FIXED_BUDGET_SIZES:
            # The family's own budget, read once: the env's max_steps is overwritten by each episode's limit, so
            # reading it inside the limit would give each episode the largest budget of all episodes before it.
            fixed_budget = int(env.unwrapped.max_steps)

            def limit(inner: Any, fixed_budget: int = fixed_budget) -> int:
                return max(fixed_budget, scaled_step_limit(inner.layout, inner.geometry.scale))

        sources.append(HighLevelEpisodes(env, oracle, limit))
    if reach:
        env = ReachEnv("ant", maze_probability=0.5, maze_sizes=(3, 5), maze_split="train")
        sources.append(ReachEpisodes(env, controller))
    return sources


NOT_OPTIONS = frozenset({"beta0"})
"""The :class:`DistillSettings` fields this script has no option for (they keep the dataclass default)."""


def distill_settings(args: argparse.Namespace) -> DistillSettings:
    """The run's settings from the parsed options: each field but :data:`NOT_OPTIONS` from the option of its name.

    ``--init-head -1`` is ``init_head=None``, a fresh actor.

    Raises:
        KeyError: If a field (not in :data:`NOT_OPTIONS`) has no option, naming it: a renamed or dropped option
            must not fall back to the dataclass default unnoticed.
    """
    names = {spec.name for spec in fields(DistillSettings)} - NOT_OPTIONS
    missing = sorted(names - vars(args).keys())
    if missing:
        raise KeyError(f"DistillSettings fields without a steady_ant.py option: {', '.join(missing)}")
    given = {name: getattr(args, name) for name in names}
    return DistillSettings(**{**given, "init_head": args.init_head if args.init_head >= 0 else None})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="the run folder (checkpoints every iteration)")
    parser.add_argument("--resume", action="store_true", help="continue the run in --out (same arguments)")
    parser.add_argument("--teacher", type=Path, default=None, help="the teacher zip (default: the shipped ant)")
    parser.add_argument("--iterations", type=int, default=DistillSettings.iterations)
    parser.add_argument("--steps-per-iteration", type=int, default=DistillSettings.steps_per_iteration)
    parser.add_argument("--gradient-steps", type=int, default=DistillSettings.gradient_steps)
    parser.add_argument("--batch-size", type=int, default=DistillSettings.batch_size)
    parser.add_argument("--learning-rate", type=float, default=DistillSettings.learning_rate)
    parser.add_argument("--beta-decay", type=float, default=DistillSettings.beta_decay)
    parser.add_argument("--action-noise-std", type=float, default=DistillSettings.action_noise_std)
    parser.add_argument("--flip-window", type=int, default=DistillSettings.flip_window)
    parser.add_argument("--flip-weight", type=float, default=DistillSettings.flip_weight)
    parser.add_argument("--max-rows", type=int, default=DistillSettings.max_rows)
    parser.add_argument("--init-head", type=int, default=DistillSettings.init_head, help="-1: a fresh actor")
    parser.add_argument(
        "--init-student", type=Path, default=None, help="start a new run from this student zip (not from a head)"
    )
    parser.add_argument("--snapshot-every", type=int, default=DistillSettings.snapshot_every)
    parser.add_argument("--seed", type=int, default=DistillSettings.seed)
    parser.add_argument("--maze-sizes", type=int, nargs="+", default=[3, 4, 6], help="free cells per side")
    parser.add_argument("--reach-share", action="store_true", help="add a source of chained random reach subgoals")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (1 on a shared machine)")
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    try:
        if min(args.maze_sizes) < 2:
            raise ValueError(f"--maze-sizes must be >= 2, got {args.maze_sizes}")
        settings = distill_settings(args)
        teacher = args.teacher if args.teacher is not None else shipped_policy_path("ant")
        subgoal_reach_m = float(BODY_PROFILES["ant"].subgoal_reach_m or 4.0)
        description = {
            "high_level": f"PathOracle(subgoal_reach_m={subgoal_reach_m:g})",
            "maze_sizes": args.maze_sizes,
            "split": "train",
            "reach_source": args.reach_share,
        }
        latest = distill(
            teacher,
            args.out,
            lambda controller: maze_sources(controller, args.maze_sizes, args.reach_share, subgoal_reach_m),
            settings,
            resume=args.resume,
            init_student=args.init_student,
            description=description,
        )
    except (ValueError, FileExistsError, FileNotFoundError) as error:
        print(f"steady_ant.py: error: {error}", file=sys.stderr)
        return 2
    print(f"latest student: {latest}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
