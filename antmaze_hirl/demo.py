"""The demo: the scripted oracle drives the hierarchy through one random maze and draws the path."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.plotting import plot_episode


@dataclass(frozen=True)
class DemoResult:
    """Outcome of :func:`run_demo`."""

    success: bool
    subgoals: int
    low_level_steps: int
    picture: Path


def run_demo(body: str = "point", seed: int = 0, out_dir: str | Path = "runs/demo", **env_kwargs: Any) -> DemoResult:
    """Runs one oracle-driven episode on a random maze and writes ``out_dir/demo.png``.

    Args:
        body: ``"point"`` or ``"ant"``.
        seed: Seed of the maze, start, goal and simulation.
        out_dir: Folder for the picture.
        **env_kwargs: Passed to ``gym.make`` (e.g. ``low_level=``, ``maze_size=``).

    """
    env = gym.make(f"antmaze_hirl/{body.capitalize()}Maze-v0", **env_kwargs)
    oracle = PathOracle.for_env(env)
    obs, _ = env.reset(seed=seed)
    inner = env.unwrapped
    paths, subgoals = [], []
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(oracle.label(obs))
        paths.append(info["agent_path"])
        subgoals.append(info["subgoal"])
        done = terminated or truncated
    env.close()
    success = bool(info["is_success"])
    picture = plot_episode(
        inner.layout.walls,
        inner.geometry,
        np.concatenate(paths),
        subgoals,
        inner.goal_xy,
        Path(out_dir) / "demo.png",
        title=f"{body}, seed {seed}: {'success' if success else 'failure'}, {len(subgoals)} subgoals, "
        f"{info['total_low_level_steps']} steps",
    )
    return DemoResult(success, len(subgoals), int(info["total_low_level_steps"]), picture)
