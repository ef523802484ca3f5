"""In-maze success: the scripted oracle driving an ant low level through held-out mazes, the protocol.

The episode and protocol code of :mod:`antmaze_lab.in_maze` (its command line), shared with the lab's
:mod:`~antmaze_lab.select_low_level`, :mod:`~antmaze_lab.flip_warning`, :mod:`~antmaze_lab.low_level` and
:mod:`~antmaze_lab.lockstep_paths` (whose workers import it by this name):

* the maze families (:data:`FAMILIES`, reported; :data:`SELECTION_FAMILIES`, for picking a policy only), each
  built by :func:`family_env`: ``ant3`` and ``ant4`` at 500 steps, the standard maps and ``select6`` with a step
  limit scaled to the episode's shortest path (:func:`~antmaze_hirl.envs.suites.path_step_limit`);
* an episode's outcome (:func:`outcome`): exactly one of :data:`OUTCOMES` (``success``, ``flip``, ``frozen``:
  truncated, and over its last :data:`FROZEN_SUBGOALS` subgoals the body never got :data:`FROZEN_RADIUS` m from
  where it stood, or ``timeout``);
* the figures (:func:`summarise`): outcome counts, the success rate with its 95% Wilson interval, flips per
  subgoal and where flips happen (:func:`flip_diagnostics`);
* playing them (:func:`run`): every low level, action-smoothing weight and family, in chunks that
  worker processes may play (:func:`run_chunk`, :func:`map_tasks`) and that add up (:func:`merge_raw`) to what
  one process gives, since every episode resets with its own seed. ``num_envs`` > 1 plays a chunk's mazes in
  lockstep (one batched low-level forward pass per step); ``1`` plays them one after another, the path of every
  ``in_maze/in_maze*.json`` committed before lockstep.
"""

from __future__ import annotations

import itertools
import multiprocessing
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from tqdm import tqdm

from antmaze_hirl.envs import profiles
from antmaze_hirl.envs.controllers import SmoothedController, as_controller
from antmaze_hirl.envs.layouts import STANDARD_MAPS
from antmaze_hirl.envs.suites import path_step_limit as step_limit
from antmaze_hirl.experiments.config import BODY_DEFAULTS, ExperimentConfig, body_settings, evaluation_sets
from antmaze_hirl.experiments.runner import low_level_identity, make_env
from antmaze_hirl.experiments.uncertainty import wilson_interval
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.rollout import OUTCOMES as EPISODE_OUTCOMES
from antmaze_hirl.rollout import episode_outcome, play_episode, play_in_lockstep
from antmaze_hirl.sb3_ext.loading import load_low_level

FAMILIES = tuple(name for name, family in profiles.MAZE_FAMILIES.items() if family.split != "selection")
"""The reported families (``--families``)."""
SELECTION_FAMILIES = {name: f.maze_size for name, f in profiles.MAZE_FAMILIES.items() if f.split == "selection"}
"""Families for picking a policy, never reported: random layouts of this many free cells per side from the
``selection`` part of the layout partition (no wall grid of ``ant4``'s ``eval`` part or of training's ``train``
part). ``select4`` is ``ant4``'s family (500 steps); ``select6`` has ``medium``'s 8x8 grid and, like the standard
maps, a step limit scaled to the path. ``antmaze_lab.select_low_level`` plays them from maze seed 2,000,000."""
STEPS_PER_METRE = profiles.STEPS_PER_METRE
"""Step budget per metre of shortest cell path: a 0.5 m/s average, half the ~1 m/s of a straight walk."""
MIN_STEPS = profiles.MIN_STEPS
"""No standard-map episode gets fewer steps than the high-level env's default budget."""
FROZEN_SUBGOALS = 5
FROZEN_RADIUS = 1.0
"""Metres: a walking ant covers this in ~1 s (20 steps); 5 subgoals give it up to 500 steps."""
OUTCOMES = tuple(name for name in EPISODE_OUTCOMES if name != "ended")
"""The in-maze outcomes counted per row (the keys of its results files' ``counts``): the episode outcomes but
``"ended"``, which an in-maze episode never has."""
TURN_BINS_DEG = (0, 45, 90, 135, 180)
"""Bins of the turn a subgoal asks for (direction of travel to subgoal direction), for :func:`flip_diagnostics`."""
TRAVEL_STEPS = 10
"""Half a second: the direction of travel when a subgoal is set is that of the body's last 10 steps."""
MIN_TRAVEL = 0.2
"""Metres: a body that moved less over those steps is at a standstill, and a subgoal then asks for no turn."""
EARLY_FLIP_STEPS = 10
"""Half a second: a flip this soon after a new subgoal is counted as one at the hand-off."""
PER_SUBGOAL = ("turns", "subgoal_flipped", "flip_steps")
"""The raw figures' lists with one entry per subgoal (or per flip), concatenated in episode order."""
LISTS = ("outcomes", "steps", "limits", *PER_SUBGOAL)
"""The per-episode and per-subgoal lists of the raw figures, concatenated in episode order by :func:`merge_raw`."""
LOCKSTEP_ENVS = 25
"""``--num-envs``'s default: mazes played at once (a chunk of 25 with ``--jobs``, 100 episodes in 4 rounds)."""
COUNT_KEYS = {"success": "successes", "flip": "flips", "frozen": "frozen", "timeout": "timeouts"}
"""The JSON key of each outcome's count."""


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
        self.turns: list[float] = []
        """Per subgoal of the episode: :func:`turn_degrees` when it was set (NaN from a standstill)."""

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Resets the env, then (if asked) sets its step budget from the new layout's start and goal."""
        obs, info = self.env.reset(**kwargs)
        self.begin_episode()
        return obs, info

    def begin_episode(self) -> None:
        """What :meth:`reset` does after the env's reset (the lockstep path calls it on the unwrapped env's)."""
        inner = self.env.unwrapped
        if self.scale_step_limit:
            layout = inner.layout
            inner.max_steps = step_limit(layout.walls, layout.start_cell, layout.goal_cell, inner.geometry.scale)
        self.paths, self.turns = [], []

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """One subgoal; its low-level path is kept in :attr:`paths`, its turn in :attr:`turns`."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.record(info)
        return obs, reward, terminated, truncated, info

    def record(self, info: dict[str, Any]) -> None:
        """Keeps one high-level step's path and turn (from its ``info``)."""
        path = np.asarray(info["agent_path"])
        walked = np.concatenate([*self.paths, path[:1]])[-(TRAVEL_STEPS + 1) :]  # the steps before this subgoal
        self.turns.append(turn_degrees(walked[0], walked[-1], info["subgoal"]))
        self.paths.append(path)

    @property
    def max_steps(self) -> int:
        """The current episode's step budget."""
        return int(self.env.unwrapped.max_steps)


def turn_degrees(walked_from: np.ndarray, position: np.ndarray, subgoal: np.ndarray) -> float:
    """Degrees (0-180) between the direction of travel ``walked_from -> position`` and ``position -> subgoal``.

    NaN when the body travelled less than :data:`MIN_TRAVEL` (a standstill has no direction). The ant's torso
    heading would not do: it walks sideways and backwards as readily as forwards.
    """
    travel = np.asarray(position, dtype=float) - np.asarray(walked_from, dtype=float)
    if np.linalg.norm(travel) < MIN_TRAVEL:
        return float("nan")
    offset = np.asarray(subgoal, dtype=float) - np.asarray(position, dtype=float)
    difference = np.arctan2(offset[1], offset[0]) - np.arctan2(travel[1], travel[0])
    return float(abs(np.degrees(np.arctan2(np.sin(difference), np.cos(difference)))))


def flip_diagnostics(raw: dict[str, Any]) -> dict[str, Any]:
    """Where flips happen: flips per subgoal by the turn the subgoal asked for, and how far into a subgoal.

    A flip soon after a subgoal is set points at the hand-off (a new goal mid-stride); a flip rate that grows
    with the turn points at turning. Subgoals set at a standstill (:func:`turn_degrees` NaN, the first of
    an episode among them) form their own bin.
    """
    turns, flipped = np.asarray(raw["turns"], dtype=float), np.asarray(raw["subgoal_flipped"], dtype=bool)
    standing = np.isnan(turns)
    bins = {f"{low}-{high}": (turns >= low) & (turns < high) for low, high in itertools.pairwise(TURN_BINS_DEG)}
    bins[f"{TURN_BINS_DEG[-2]}-{TURN_BINS_DEG[-1]}"] |= turns == TURN_BINS_DEG[-1]
    by_turn = {}
    for name, inside in {**bins, "standstill": standing}.items():
        subgoals, flips = int(inside.sum()), int((inside & flipped).sum())
        by_turn[name] = {
            "subgoals": subgoals,
            "flips": flips,
            "flips_per_subgoal": flips / subgoals if subgoals else None,
        }
    steps = np.asarray(raw["flip_steps"], dtype=float)
    return {
        "by_turn_degrees": by_turn,
        "flip_steps_into_subgoal_median": float(np.median(steps)) if steps.size else None,
        f"flips_within_{EARLY_FLIP_STEPS}_steps_of_a_new_subgoal": int((steps <= EARLY_FLIP_STEPS).sum()),
    }


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
    """The episode's outcome from its last ``info`` and subgoal paths: one of :data:`OUTCOMES`.

    :func:`~antmaze_hirl.rollout.episode_outcome`'s, with a timeout whose body stood still split off as
    ``"frozen"``.
    """
    # An in-maze episode ends by success, a flip or its step limit: never "ended".
    base = episode_outcome(info, truncated=True)
    return "frozen" if base == "timeout" and is_frozen(paths) else base


def episode_figures(info: dict[str, Any], recorder: MazeEpisodeRecorder) -> dict[str, Any]:
    """One finished episode's raw figures, from its last ``info`` and the recorder that watched it."""
    return {
        "outcome": outcome(info, recorder.paths),
        "subgoals": int(info["attempts"]),
        "steps": int(info["total_low_level_steps"]),
        "limit": recorder.max_steps,
        "turns": list(recorder.turns),
        "subgoal_flipped": [False] * (len(recorder.turns) - 1) + [bool(info["flipped"])],
        "flip_steps": [int(info["low_level_steps"])] if info["flipped"] else [],
    }


def raw_figures(episodes: list[dict[str, Any]], *, seconds: float, first_seed: int) -> dict[str, Any]:
    """:func:`play_episodes`'s raw figures from each episode's :func:`episode_figures`, in seed order."""
    counts = dict.fromkeys(OUTCOMES, 0)
    for episode in episodes:
        counts[episode["outcome"]] += 1
    return {
        "counts": counts,
        "subgoals": sum(episode["subgoals"] for episode in episodes),
        "outcomes": [episode["outcome"] for episode in episodes],
        "steps": [episode["steps"] for episode in episodes],
        "limits": [episode["limit"] for episode in episodes],
        **{key: [value for episode in episodes for value in episode[key]] for key in PER_SUBGOAL},
        "seconds": seconds,
        "first_seed": first_seed,
    }


def play_episodes(env: MazeEpisodeRecorder, oracle: Any, seeds: range) -> dict[str, Any]:
    """The oracle's episodes with ``seeds`` on ``env``, one after another: raw outcome counts, subgoals, steps, limits.

    The raw form of :func:`evaluate_family`'s figures, so that chunks of one family run in separate
    processes add up (:func:`merge_raw`) to what one process would give. The serial path: exact replays of
    committed results.
    """
    started = time.perf_counter()
    episodes = [episode_figures(play_episode(env, oracle, seed=seed).info, env) for seed in seeds]
    return raw_figures(episodes, seconds=time.perf_counter() - started, first_seed=seeds.start)


def play_episodes_lockstep(recorders: list[MazeEpisodeRecorder], oracle: Any, seeds: range) -> dict[str, Any]:
    """:func:`play_episodes` on ``len(recorders)`` mazes at once, in lockstep (``play_in_lockstep``).

    The same mazes and seeds; the oracle labels every maze that needs a subgoal, the shared low level acts
    in one batch for every maze still walking. A batched forward pass may round the last bits differently
    from a batch of one, which MuJoCo can amplify into another outcome (``docs/guides/vector-envs.md``).

    Args:
        recorders: Recorder-wrapped envs of one family sharing one low-level controller object.
        oracle: The high level.
        seeds: One episode per seed.
    """
    started = time.perf_counter()
    figures: dict[int, dict[str, Any]] = {}

    def after_subgoal(index: int, seed: int, info: dict[str, Any], done: bool) -> None:
        recorders[index].record(info)
        if done:
            figures[seed] = episode_figures(info, recorders[index])

    play_in_lockstep(
        oracle,
        [recorder.unwrapped for recorder in recorders],
        seeds,
        after_reset=lambda index, seed: recorders[index].begin_episode(),
        after_subgoal=after_subgoal,
    )
    episodes = [figures[seed] for seed in seeds]
    return raw_figures(episodes, seconds=time.perf_counter() - started, first_seed=seeds.start)


def merge_raw(chunks: list[dict[str, Any]]) -> dict[str, Any]:
    """One family's raw figures from its chunks, in episode order whatever order the chunks finished in."""
    chunks = sorted(chunks, key=lambda chunk: chunk["first_seed"])
    return {
        "counts": {name: sum(chunk["counts"][name] for chunk in chunks) for name in OUTCOMES},
        "subgoals": sum(chunk["subgoals"] for chunk in chunks),
        **{key: [value for chunk in chunks for value in chunk[key]] for key in LISTS},
        "seconds": sum(chunk["seconds"] for chunk in chunks),
        "first_seed": chunks[0]["first_seed"],
    }


def summarise(raw: dict[str, Any]) -> dict[str, Any]:
    """Outcome counts, success rate with its 95% Wilson interval and flips per subgoal, from raw figures."""
    counts, episodes = raw["counts"], len(raw["steps"])
    return {
        "episodes": episodes,
        "maze_seed": raw["first_seed"],
        "success_rate": counts["success"] / episodes,
        "success_ci95": list(wilson_interval(counts["success"], episodes)),
        **{COUNT_KEYS[name]: count for name, count in counts.items()},
        "subgoals": raw["subgoals"],
        "flips_per_subgoal": counts["flip"] / raw["subgoals"],
        "mean_low_level_steps": float(np.mean(raw["steps"])),
        "step_limit_range": [int(min(raw["limits"])), int(max(raw["limits"]))],
        "flip_diagnostics": flip_diagnostics(raw),
        "seconds": round(raw["seconds"], 1),
    }


def evaluate_family(env: MazeEpisodeRecorder, oracle: Any, *, episodes: int, seed: int) -> dict[str, Any]:
    """The oracle's episodes ``seed .. seed + episodes - 1`` on ``env``: outcome counts, interval, flips per subgoal.

    Raises:
        ValueError: If ``episodes`` < 1.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    return summarise(play_episodes(env, oracle, range(seed, seed + episodes)))


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
        ValueError: For a family in neither :data:`FAMILIES` nor :data:`SELECTION_FAMILIES`.
    """
    if family == "ant3":
        # The whole 3x3 family, held out by seed only (its few wall grids cannot be held out: protocol 1).
        config = ExperimentConfig(body="ant", held_out_layouts=False, protocol=1, **BODY_DEFAULTS["ant"])
        return MazeEpisodeRecorder(make_env(config, low_level), scale_step_limit=False)
    if family == "ant4" or family in SELECTION_FAMILIES:
        settings = body_settings("ant", held_out_layouts=True, maze_size=SELECTION_FAMILIES.get(family))
        config = ExperimentConfig(body="ant", held_out_layouts=True, **settings)
        split = "selection" if family in SELECTION_FAMILIES else evaluation_sets(config)["final"][0]
        scaled = profiles.MAZE_FAMILIES[family].step_limit is None  # ant4's 500 steps; larger mazes scale to the path
        return MazeEpisodeRecorder(make_env(config, low_level, split=split), scale_step_limit=scaled)
    if family not in STANDARD_MAPS or family == "open":
        raise ValueError(f"unknown maze family {family!r}; choose from {[*FAMILIES, *SELECTION_FAMILIES]}")
    return MazeEpisodeRecorder(
        gym.make("antmaze_hirl/AntMaze-v0", maze_map=family, low_level=low_level), scale_step_limit=True
    )


def row_name(path: Path | None, smoothing: float) -> str:
    """A result row's name: ``shipped`` or the candidate's path, with ``smoothing=A`` unless ``A`` is 0."""
    name = "shipped" if path is None else str(path)
    return name if smoothing == 0 else f"{name} smoothing={smoothing:g}"


def row_names(low_levels: list[Path | None], smoothing: tuple[float, ...]) -> list[str]:
    """The result rows' names, low level by low level, weight by weight.

    Raises:
        ValueError: If a name repeats (the same low level or weight given twice): its chunks would merge
            into one row, every maze counted twice.
    """
    names = [row_name(path, alpha) for path in low_levels for alpha in smoothing]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ValueError(f"rows {repeated} are asked for twice: give each low level and smoothing weight once")
    return names


def parse_smoothing(text: str) -> list[float]:
    """Comma-separated action-smoothing weights, each in ``[0, 1)``.

    Raises:
        ValueError: Naming the first entry that is not a number in ``[0, 1)``, in one line.
    """
    values = []
    for entry in text.split(","):
        try:
            value = float(entry)
        except ValueError:
            raise ValueError(f"action smoothing {entry.strip()!r} is not a number") from None
        if not 0.0 <= value < 1.0:
            raise ValueError(f"action smoothing must lie in [0, 1), got {entry.strip()}")
        values.append(value)
    return values


_MODELS: dict[Path | None, Any] = {}
"""Each worker process loads a low level once, however many chunks it plays with it."""


def worker_low_level(path: Path | None) -> Any:
    """The ant low level at ``path`` (``None``: the shipped policy's file), loaded once per process."""
    if path not in _MODELS:
        _MODELS[path] = load_low_level("ant", path)
    return _MODELS[path]


def run_chunk(
    path: Path | None, smoothing: float, family: str, seeds: range, subgoal_reach_m: float, num_envs: int = 1
) -> tuple[str, str, dict[str, Any], str]:
    """One chunk of episodes: ``(row name, family, raw figures, low-level id)``; runs in a worker process.

    ``num_envs`` 1 plays the episodes one after another (:func:`play_episodes`); more plays up to that
    many at once in lockstep (:func:`play_episodes_lockstep`), sharing one controller.
    """
    torch.set_num_threads(1)
    model = worker_low_level(path)
    # One controller object for every maze of the chunk (a model would be wrapped anew by each env): batched once.
    controller = as_controller(model) if smoothing == 0 else SmoothedController(model, smoothing)
    recorders = [family_env(family, controller) for _ in range(min(num_envs, len(seeds)))]
    oracle = PathOracle.for_env(recorders[0], subgoal_reach_m=subgoal_reach_m)
    try:
        if len(recorders) == 1:
            raw = play_episodes(recorders[0], oracle, seeds)
        else:
            raw = play_episodes_lockstep(recorders, oracle, seeds)
    finally:
        for recorder in recorders:
            recorder.close()
    return row_name(path, smoothing), family, raw, low_level_identity("ant", model)


def map_tasks(function: Any, tasks: list[tuple[Any, ...]], jobs: int) -> Iterator[Any]:
    """``function(*task)`` for every task, in order; in ``jobs`` spawned processes when ``jobs`` > 1."""
    if jobs <= 1:
        yield from (function(*task) for task in tasks)
        return
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        yield from pool.map(function, *zip(*tasks, strict=True))


def chunks_of(episodes: int, seed: int, size: int) -> list[range]:
    """Episode seeds ``seed .. seed + episodes - 1`` cut into consecutive ranges of at most ``size``."""
    return [range(first, min(first + size, seed + episodes)) for first in range(seed, seed + episodes, size)]


def run(
    low_levels: list[Path | None],
    families: list[str],
    *,
    episodes: int,
    seed: int,
    smoothing: tuple[float, ...] = (0.0,),
    subgoal_reach_m: float | None = None,
    jobs: int = 1,
    chunk_episodes: int = 25,
    num_envs: int = 1,
) -> dict[str, Any]:
    """Figures per low level (``None``: shipped), action smoothing and family, with success ratios to the first row.

    With ``jobs`` > 1 the episodes of every family are cut into chunks of ``chunk_episodes`` and played by a
    pool of processes; each episode resets with its own seed, so the figures are the same as with one.
    ``num_envs`` > 1 plays up to that many mazes of a chunk at once in lockstep (``1``, the default: one
    after another, as committed results were made).
    """
    row_names(low_levels, smoothing)
    subgoal_reach_m = BODY_DEFAULTS["ant"]["subgoal_reach_m"] if subgoal_reach_m is None else subgoal_reach_m
    tasks = [
        (path, alpha, family, seeds, subgoal_reach_m, num_envs)
        for path in low_levels
        for alpha in smoothing
        for family in families
        for seeds in (chunks_of(episodes, seed, chunk_episodes) if jobs > 1 else [range(seed, seed + episodes)])
    ]
    done = list(tqdm(map_tasks(run_chunk, tasks, jobs), total=len(tasks), desc="in-maze chunks", unit="chunk"))
    raw: dict[str, dict[str, list[dict[str, Any]]]] = {}
    identities: dict[str, str] = {}
    for name, family, chunk, identity in done:
        raw.setdefault(name, {}).setdefault(family, []).append(chunk)
        identities[name] = identity
    results: dict[str, Any] = {}
    for path in low_levels:
        for alpha in smoothing:
            name = row_name(path, alpha)
            figures = {family: summarise(merge_raw(raw[name][family])) for family in families}
            for family, row in figures.items():
                print(f"{name} {family}: {row}", flush=True)
            results[name] = {"low_level_id": identities[name], "action_smoothing": alpha, "families": figures}
    first = next(iter(results.values()))["families"]
    for figures in results.values():
        for family, row in figures["families"].items():
            base = first[family]["success_rate"]
            row["success_ratio_to_first"] = row["success_rate"] / base if base > 0 else None
    return results
