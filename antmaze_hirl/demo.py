"""The demo: the scripted oracle drives the hierarchy through one random maze and draws the path."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.plotting import plot_played_episode
from antmaze_hirl.rollout import play_episode


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
    episode = play_episode(env, PathOracle.for_env(env), seed=seed)
    env.close()
    steps = int(episode.info["total_low_level_steps"])
    outcome = "success" if episode.success else "failure"
    picture = plot_played_episode(
        env,
        episode,
        Path(out_dir) / "demo.png",
        title=f"{body}, seed {seed}: {outcome}, {len(episode.subgoals)} subgoals, {steps} steps",
    )
    return DemoResult(episode.success, len(episode.subgoals), steps, picture)
