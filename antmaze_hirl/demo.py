"""The demo: the scripted oracle drives the hierarchy through one random maze and draws the path."""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.envs.vector import copies_of
from antmaze_hirl.experiments.config import BODY_DEFAULTS
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.plotting import plot_played_episode
from antmaze_hirl.rollout import episode_outcome, play_episode, play_in_lockstep


@dataclass(frozen=True)
class DemoResult:
    """Outcome of :func:`run_demo`.

    Attributes:
        success: Whether the body reached the goal.
        outcome: ``"success"``, ``"flip"`` or ``"timeout"`` (see :attr:`HighLevelEpisode.outcome`).
        subgoals: Subgoals the oracle chose.
        low_level_steps: Low-level steps in all.
        picture: The written PNG.
    """

    success: bool
    outcome: str
    subgoals: int
    low_level_steps: int
    picture: Path


def demo_setup(
    body: str, *, maze_size: int | None = None, subgoal_reach_m: float | None = None, **env_kwargs: Any
) -> tuple[gym.Env, PathOracle]:
    """The demo's env and oracle (:func:`run_demo`'s arguments, same defaults), for playing its episodes elsewhere.

    Raises:
        ValueError: If ``body`` is unknown.
    """
    if body not in BODY_DEFAULTS:
        raise ValueError(f"unknown body {body!r}; choose one of {sorted(BODY_DEFAULTS)}")
    defaults = BODY_DEFAULTS[body]
    maze_size = maze_size if maze_size is not None else defaults["maze_size"]
    distance = subgoal_reach_m if subgoal_reach_m is not None else defaults["subgoal_reach_m"]
    env = gym.make(maze_env_id(body), maze_size=maze_size, **env_kwargs)
    return env, PathOracle.for_env(env, subgoal_reach_m=distance)


def run_demo(
    body: str = "point",
    seed: int = 0,
    out_dir: str | Path = "runs/demo",
    *,
    maze_size: int | None = None,
    subgoal_reach_m: float | None = None,
    **env_kwargs: Any,
) -> DemoResult:
    """Runs one oracle-driven episode on a random maze and writes ``out_dir/demo.png``.

    Args:
        body: ``"point"`` or ``"ant"``.
        seed: Seed of the maze, start, goal and simulation.
        out_dir: Folder for the picture.
        maze_size: Free cells per side. Default per body, as in the body's experiment
            (:data:`~antmaze_hirl.experiments.config.BODY_DEFAULTS`): point 5, ant 3.
        subgoal_reach_m: The oracle's farthest subgoal, metres. Default per body: point one cell
            (1 m), ant 2 m (the shipped ant reaches 2 m subgoals far more reliably than 4 m ones).
        **env_kwargs: Passed to ``gym.make`` (e.g. ``low_level=``, ``max_steps=``).

    Raises:
        ValueError: If ``body`` is unknown.
    """
    env, oracle = demo_setup(body, maze_size=maze_size, subgoal_reach_m=subgoal_reach_m, **env_kwargs)
    episode = play_episode(env, oracle, seed=seed)
    env.close()
    steps = int(episode.info["total_low_level_steps"])
    picture = plot_played_episode(
        env,
        episode,
        Path(out_dir) / "demo.png",
        title=f"{body}, seed {seed}: {episode.outcome}, {len(episode.subgoals)} subgoals, {steps} steps",
    )
    return DemoResult(episode.success, episode.outcome, len(episode.subgoals), steps, picture)


def serial_outcomes(body: str, seeds: int) -> list[str]:
    """Each of seeds ``0 .. seeds - 1``'s outcome from the demo itself (:func:`run_demo`, picture and all), in turn.

    Prints one line per seed (outcome, subgoals, low-level steps): a long run shows its progress.
    """
    outcomes = []
    with tempfile.TemporaryDirectory() as pictures:
        for seed in range(seeds):
            result = run_demo(body=body, seed=seed, out_dir=pictures)
            outcomes.append(result.outcome)
            print(f"{body} seed {seed}: {result.outcome}, {result.subgoals} subgoals, {result.low_level_steps} steps")
    return outcomes


def lockstep_outcomes(body: str, seeds: int, num_envs: int) -> list[str]:
    """:func:`serial_outcomes` on the demo's env and oracle, ``num_envs`` mazes at once in lockstep (no picture).

    The same seeds; a batched low-level forward pass may round the last bits differently from a batch of one,
    which MuJoCo can turn into another outcome now and then (the lab's ``antmaze_lab.lockstep_paths`` counts how often).
    Prints one line per seed, as :func:`serial_outcomes`.
    """
    env, oracle = demo_setup(body)
    copies = copies_of(env, min(num_envs, seeds))
    try:
        played = play_in_lockstep(oracle, copies, range(seeds))
    finally:
        for copy in copies:
            copy.close()
        env.close()
    outcomes = [episode_outcome(episode.info, truncated=episode.truncated) for episode in played]
    for episode, outcome in zip(played, outcomes, strict=True):
        steps, subgoals = episode.info["total_low_level_steps"], episode.info["attempts"]
        print(f"{body} seed {episode.seed}: {outcome}, {subgoals} subgoals, {steps} steps")
    return outcomes
