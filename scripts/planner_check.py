"""A grid-level check of high-level learners: oracle labels on sampled states, greedy next-cell rollouts.

No simulation: agents stand at random free cells (centre +- 0.35 cells, at rest), the scripted oracle labels
them (the trial's reach and clearance, as ``scripts/learner_ablation.py``'s held-out states), a learner is
fitted on ``--labels`` of them from the family's ``train`` part, then rolled out on the grid: from the start
cell, take the argmax next cell, move to its centre; a move into a wall or diagonally past a wall's corner
fails, as does not reaching the goal's cell within ``2 * (rows + cols)`` moves. Scored on the ``selection``
part (by shortest path length in cells) and, for learners that run on any grid, zero-shot on fixed maps.

This is a screen for the planning-learner issue (cheap, seconds per variant), not a result: the learner in the
env must meet its own goals under DAgger (``scripts/learner_ablation.py``).

Usage: python scripts/planner_check.py --body ant --variants next_cell_cnn,next_cell_plan --seeds 0,1
           [--labels 1000] [--steps 1500] [--tasks 200] [--maps medium,large,giant] [--selection-sizes 6,8]
           [--move-any-planner] [--out FILE]
       python scripts/planner_check.py --shipped-failures --body ant [--learner-zip ZIP] [--tasks 200]
           [--maps u,medium,large,giant] [--selection-sizes 6,8] [--out FILE]

Bad input (an unknown variant or map, a count below 1, a maze size without a selection part, a learner zip that
is missing or another body's) is refused in one line naming the value, exit status 2, before any work.

``--selection-sizes`` scores the learner zero-shot on the ``selection`` part of random mazes larger than its
family's: a screen for carrying to larger maps that reads no fixed map (the fixed maps are benchmark suites).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import torch as th

from antmaze_hirl.cli_validation import IntBounds, bounded_int
from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy, planning_rounds
from antmaze_hirl.dagger.network import NEXT_CELL_MOVES
from antmaze_hirl.dagger.shipped import load_shipped_learner
from antmaze_hirl.envs.layouts import STANDARD_MAPS, shortest_path
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.envs.suites import fixed_map, suite_tasks
from antmaze_hirl.experiments.config import LEARNERS, ExperimentConfig, body_settings, learner_settings
from antmaze_hirl.experts.oracle import sample_labelled_states
from antmaze_hirl.sb3_ext.shipped import make_maze_env


def _env(body: str, *, split: str | None = None, maze_map: Any = None, maze_size: int | None = None) -> Any:
    kwargs: dict[str, Any] = {"low_level": lambda *_: None}
    if isinstance(maze_map, str) and maze_map in SUITE_SPECS:  # a fixed map by its suite name (giant included)
        maze_map = fixed_map(SUITE_SPECS[maze_map])
    if split is not None:
        kwargs["split"] = split
    if maze_size is not None and maze_map is None:
        kwargs["maze_size"] = maze_size
    return make_maze_env(body, maze_map, **kwargs)


def grid_rollouts(policy: HighLevelPolicy, env: Any, tasks: int, seed: int) -> dict[int, list[bool]]:
    """Greedy next-cell rollouts on ``tasks`` tasks of ``env``: success lists keyed by shortest path (cells)."""
    return successes_of(grid_rollout_ends(policy, env, tasks, seed))


def successes_of(ends: dict[int, list[str]]) -> dict[int, list[bool]]:
    """Rollout ends keyed by path length, as success lists (an end is a success or not)."""
    return {length: [end == "success" for end in outcomes] for length, outcomes in ends.items()}


ENDS = ("success", "into_wall", "past_corner", "stay", "timeout")
"""How a grid rollout ends: the goal's cell reached; a move into a wall (or off the map); a diagonal past a wall's
corner (one or both of its orthogonal cells a wall); the agent's own cell chosen; no goal within the moves."""


def grid_rollout_ends(policy: HighLevelPolicy, env: Any, tasks: int, seed: int) -> dict[int, list[str]]:
    """:func:`grid_rollouts` with how each rollout ended (one of :data:`ENDS`), keyed by shortest path (cells)."""
    maze = env.unwrapped
    at_rest = STATE_LAYOUT.body_observation(env.reset(seed=0)[0]["state"])
    rng = np.random.default_rng(seed)
    results: dict[int, list[str]] = defaultdict(list)
    policy.network.eval()
    for _ in range(tasks):
        task = maze.sample_task(rng)
        cell, goal = maze.geometry.xy_to_cell(task.start_xy), maze.geometry.xy_to_cell(task.goal_xy)
        length = len(shortest_path(task.layout.walls, cell, goal)) - 1
        results[length].append(rollout_end(policy, task.layout.walls, cell, goal, at_rest, task.goal_xy))
    return results


def rollout_end(
    policy: HighLevelPolicy,
    walls: np.ndarray,
    cell: tuple[int, int],
    goal: tuple[int, int],
    at_rest: np.ndarray,
    goal_xy: np.ndarray | None = None,
) -> str:
    """One greedy next-cell rollout from ``cell`` to the ``goal`` cell (at ``goal_xy``, default its centre) on
    ``walls``: how it ended (:data:`ENDS`)."""
    geometry = policy.geometry
    goal_xy = geometry.cell_to_xy(goal) if goal_xy is None else goal_xy
    for _ in range(2 * (walls.shape[0] + walls.shape[1])):
        if cell == goal:
            return "success"
        batch = policy.encoder.encode([walls], [geometry.cell_to_xy(cell)], [goal_xy], [at_rest])
        with th.no_grad():
            move = int(policy.network(th.from_numpy(batch.grids), th.from_numpy(batch.vectors)).argmax(1)[0])
        dx, dy = NEXT_CELL_MOVES[move]
        row, col = cell[0] - dy, cell[1] + dx
        if (dx, dy) == (0, 0):
            return "stay"
        if not (0 <= row < walls.shape[0] and 0 <= col < walls.shape[1]) or walls[row, col]:
            return "into_wall"
        if dx and dy and (walls[cell[0] - dy, cell[1]] or walls[cell[0], cell[1] + dx]):
            return "past_corner"
        cell = (row, col)
    return "timeout"


def ends_summary(results: dict[int, list[str]]) -> dict[str, Any]:
    """How many rollouts ended each way (:data:`ENDS`), over all path lengths and on paths of 7 cells or more."""
    every = [end for ends in results.values() for end in ends]
    long = [end for length, ends in results.items() if length >= 7 for end in ends]
    return {
        "tasks": len(every),
        "ends": {end: every.count(end) for end in ENDS},
        "ends_on_paths_of_7_cells_or_more": {end: long.count(end) for end in ENDS},
    }


MAPS = tuple(sorted({name for name, spec in SUITE_SPECS.items() if spec.source != "random"} | set(STANDARD_MAPS)))
"""What ``--maps`` takes: the fixed-map suites' names (``giant`` and the point suites' included) and
gymnasium-robotics' maps."""


def load_learner(body: str, path: Path | None) -> HighLevelPolicy:
    """The learner ``--shipped-failures`` scores: the shipped one of ``body``, or the saved learner at ``path``.

    Raises:
        ValueError: Naming the file, if there is none, it cannot be loaded, or it is another body's learner (its
            cells are not ``body``'s).
    """
    if path is None:
        return load_shipped_learner(body)
    try:
        learner = HighLevelPolicy.load(path)
    except (FileNotFoundError, ValueError) as error:
        raise ValueError(f"--learner-zip: {error}") from None
    scale = load_shipped_learner(body).geometry.scale
    if learner.geometry.scale != scale:
        raise ValueError(
            f"--learner-zip {path}: its cells are {learner.geometry.scale} m, the {body}'s are {scale} m "
            "(another body's learner)"
        )
    return learner


def shipped_failures(
    body: str, maps: list[str], tasks: int, *, sizes: tuple[int, ...] = (), learner: HighLevelPolicy | None = None
) -> dict[str, Any]:
    """How the shipped learner's grid rollouts end on the ``selection`` part of its family and on ``maps``.

    ``sizes`` adds the ``selection`` part of random mazes of those sizes (``selection_NxN``); ``learner`` scores a
    learner of the body (:func:`load_learner`) instead of the shipped one.
    """
    trained = load_shipped_learner(body) if learner is None else learner
    config = ExperimentConfig(body=body, **body_settings(body, held_out_layouts=True), held_out_layouts=True)
    places = [("selection", config.maze_size), *((f"selection_{n}x{n}", n) for n in sizes), *((m, None) for m in maps)]
    rows: dict[str, Any] = {}
    for name, size in places:
        env = _env(body, maze_map=name) if size is None else _env(body, split="selection", maze_size=size)
        policy = moved_to(trained, env)
        rows[name] = ends_summary(grid_rollout_ends(policy, env, tasks, 0))
        if name in SUITE_SPECS:  # the suite's own tasks, in task-id order, as the benchmark plays them
            at_rest = STATE_LAYOUT.body_observation(env.reset(seed=0)[0]["state"])
            rows[name]["suite_task_ends"] = [
                rollout_end(policy, task.layout.walls, task.layout.start_cell, task.layout.goal_cell, at_rest)
                for task in suite_tasks(name)
            ]
        env.close()
    return rows


def moved_to(policy: HighLevelPolicy, env: Any, *, any_planner: bool = False) -> HighLevelPolicy:
    """The same weights on ``env``'s map: a learner shaped for its geometry, planning rounds for its size.

    ``any_planner`` also moves a planning learner that is not ``any_map`` (its correction reads the goal offset),
    which :meth:`HighLevelPolicy.on_map` refuses: the screen's evidence for that refusal.
    """
    maze = env.unwrapped
    settings = policy.settings
    if not any_planner or policy.runs_on_any_map or settings.planning_iterations == 0:
        return policy.on_map(maze.geometry, pixels_per_cell=maze.pixels_per_cell)
    geometry = maze.geometry
    moved = HighLevelPolicy(
        geometry,
        pixels_per_cell=maze.pixels_per_cell,
        body_dim=policy.body_dim,
        rng=np.random.default_rng(0),
        settings=settings.replace(planning_iterations=planning_rounds(geometry.n_rows, geometry.n_cols)),
    )
    moved.network.load_state_dict(policy.network.state_dict())
    return moved


def fit_on_oracle_labels(policy: HighLevelPolicy, env: Any, labels: int, steps: int, rng: np.random.Generator) -> float:
    """Fits ``policy`` for ``steps`` on ``labels`` oracle-labelled states of ``env``'s tasks; the last loss."""
    data = sample_labelled_states(env, labels, subgoal_reach_m=policy.subgoal_reach_m, rng=rng)
    batch = policy.encoder.encode(data.walls, data.agents, data.goals, data.bodies)
    return policy.fit(batch, policy.targets(np.stack(data.agents), np.stack(data.labels)), steps)


def learning_gain(seed: int, *, labels: int = 200, steps: int = 300, tasks: int = 30) -> dict[str, float]:
    """The planning learner's grid-level success on random 4x4 point mazes before and after ``labels`` labels.

    The tests' learning check (``tests/test_planning_learner.py``), its spread measured by
    ``scripts/learning_margins.py planner_gain``: one torch thread, every draw seeded by ``seed``.
    """
    env = _env("point", maze_size=4)
    policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(seed), **learner_settings("next_cell_plan", 4))
    untrained = summary(grid_rollouts(policy, env, tasks, 10_000 + seed))["success"]
    fit_on_oracle_labels(policy, env, labels, steps, np.random.default_rng(20_000 + seed))
    trained = summary(grid_rollouts(policy, env, tasks, 10_000 + seed))["success"]
    env.close()
    return {"untrained": untrained, "trained": trained, "gain": trained - untrained}


def ended_summary(ends: dict[int, list[str]]) -> dict[str, Any]:
    """:func:`summary` of rollouts keyed by path length, with how many ended each way (:data:`ENDS`)."""
    return {**summary(successes_of(ends)), "ends": ends_summary(ends)["ends"]}


def summary(results: dict[int, list[bool]]) -> dict[str, Any]:
    everything = [s for outcomes in results.values() for s in outcomes]
    return {
        "success": float(np.mean(everything)) if everything else None,
        "tasks": len(everything),
        "by_path_cells": {str(k): [int(sum(v)), len(v)] for k, v in sorted(results.items())},
    }


def names(option: str, text: str, known: tuple[str, ...]) -> list[str]:
    """A comma-separated list of ``known`` names (empty entries dropped).

    Raises:
        ValueError: One line naming ``option``, the unknown name and the known ones.
    """
    chosen = list(filter(None, (name.strip() for name in text.split(","))))
    for name in chosen:
        if name not in known:
            raise ValueError(f"{option}: unknown name {name!r}; choose from {', '.join(known)}")
    return chosen


def whole_numbers(option: str, text: str, *, least: int) -> tuple[int, ...]:
    """A comma-separated list of whole numbers, each at least ``least`` (empty entries dropped).

    Raises:
        ValueError: One line naming ``option`` and the entry that is no such number.
    """
    values = []
    for entry in filter(None, (entry.strip() for entry in text.split(","))):
        try:
            value = int(entry)
        except ValueError:
            raise ValueError(f"{option}: {entry!r} is not a whole number") from None
        if value < least:
            raise ValueError(f"{option}: {value} is below {least}")
        values.append(value)
    return tuple(values)


def check_selection_sizes(body: str, sizes: tuple[int, ...]) -> None:
    """Refuses a size whose random mazes have no ``selection`` part (too few wall grids to hold any out).

    Raises:
        ValueError: One line naming the size and why.
    """
    for size in sizes:
        try:
            env = _env(body, split="selection", maze_size=size)
            env.unwrapped.sample_task(np.random.default_rng(0))
            env.close()
        except ValueError as error:
            raise ValueError(f"--selection-sizes {size}: {error}") from None


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """The command line: the screen (``--variants``), or the shipped learner's rollout ends (``--shipped-failures``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", choices=("point", "ant"), default="ant", help="the body (default: %(default)s)")
    parser.add_argument(
        "--variants",
        default="next_cell_cnn,next_cell_plan",
        help=f"comma-separated learners, of {', '.join(sorted(LEARNERS))} (default: %(default)s)",
    )
    parser.add_argument("--seeds", default="0", help="comma-separated learner seeds (default: %(default)s)")
    count = bounded_int(IntBounds(1, 1_000_000))
    parser.add_argument("--labels", type=count, default=1000, help="oracle labels fitted on (default: %(default)s)")
    parser.add_argument("--steps", type=count, default=1500, help="gradient steps (default: %(default)s)")
    parser.add_argument("--tasks", type=count, default=200, help="grid rollouts per place (default: %(default)s)")
    parser.add_argument(
        "--maps",
        default="medium,large,giant",
        help=f"fixed maps, zero-shot, of {', '.join(MAPS)} (default: %(default)s)",
    )
    parser.add_argument(
        "--selection-sizes",
        default="",
        help="also zero-shot on the selection part of random NxN mazes of these sizes, e.g. 6,8 (default: none)",
    )
    parser.add_argument("--out", type=Path, help="the JSON file written (default: none, printed only)")
    parser.add_argument(
        "--move-any-planner",
        action="store_true",
        help="also move planners that are not any_map (default: off)",
    )
    parser.add_argument(
        "--shipped-failures",
        action="store_true",
        help="instead: how the shipped learner's rollouts end on the selection part and --maps (default: off)",
    )
    parser.add_argument(
        "--learner-zip", type=Path, help="with --shipped-failures: a saved learner instead (default: the shipped one)"
    )
    args = parser.parse_args(argv)
    command = shlex.join(["python", "scripts/planner_check.py", *(argv if argv is not None else sys.argv[1:])])
    try:
        variants = names("--variants", args.variants, tuple(sorted(LEARNERS)))
        seeds = whole_numbers("--seeds", args.seeds, least=0)
        sizes = whole_numbers("--selection-sizes", args.selection_sizes, least=1)
        maps = names("--maps", args.maps, MAPS)
        if args.learner_zip is not None and not args.shipped_failures:
            raise ValueError(f"--learner-zip {args.learner_zip} is read with --shipped-failures only")
        if not (variants and seeds) and not args.shipped_failures:
            raise ValueError(f"nothing to screen: --variants {args.variants!r} --seeds {args.seeds!r}")
        check_selection_sizes(args.body, sizes)
        if args.out is not None:
            check_writable(args.out)
        learner = load_learner(args.body, args.learner_zip) if args.shipped_failures else None
    except ValueError as error:
        parser.error(str(error))
    th.set_num_threads(1)
    if args.shipped_failures:
        result = {"command": command, "body": args.body, "tasks": args.tasks}
        result["learner"] = "shipped" if args.learner_zip is None else str(args.learner_zip)
        result["rows"] = shipped_failures(args.body, maps, args.tasks, sizes=sizes, learner=learner)
        print(json.dumps({name: row["ends"] for name, row in result["rows"].items()}), flush=True)
        return _written(result, args.out)
    settings_ = body_settings(args.body, held_out_layouts=True)
    config = ExperimentConfig(body=args.body, **settings_, protocol=2, held_out_layouts=True)
    rows = []
    for variant in variants:
        for seed in seeds:
            start = time.perf_counter()
            train = _env(args.body, split="train", maze_size=config.maze_size)
            rng = np.random.default_rng(seed)
            settings = learner_settings(variant, config.maze_size)
            policy = HighLevelPolicy.for_env(train, rng=rng, subgoal_reach_m=config.subgoal_reach_m, **settings)
            selection = _env(args.body, split="selection", maze_size=config.maze_size)
            row: dict[str, Any] = {"variant": variant, "seed": seed, "labels": args.labels, "steps": args.steps}
            row["untrained_selection"] = summary(grid_rollouts(policy, selection, args.tasks, 7))
            row["loss"] = fit_on_oracle_labels(
                policy, train, args.labels, args.steps, np.random.default_rng(1000 + seed)
            )
            row["selection"] = ended_summary(grid_rollout_ends(policy, selection, args.tasks, 7))
            for size in sizes:
                larger = _env(args.body, split="selection", maze_size=size)
                try:
                    moved = moved_to(policy, larger)
                    row[f"selection_{size}x{size}"] = ended_summary(grid_rollout_ends(moved, larger, args.tasks, 7))
                except ValueError as error:  # a learner that cannot act on another map, as for --maps
                    row[f"selection_{size}x{size}"] = {"error": str(error)}
            for name in maps:
                try:
                    other = _env(args.body, maze_map=name)
                    moved = moved_to(policy, other, any_planner=args.move_any_planner)
                    row[name] = summary(grid_rollouts(moved, other, args.tasks, 11))
                except ValueError as error:
                    row[name] = {"error": str(error)}
            row["seconds"] = round(time.perf_counter() - start, 1)
            rows.append(row)
            brief = {k: (v["success"] if isinstance(v, dict) and "success" in v else v) for k, v in row.items()}
            print(json.dumps(brief), flush=True)
    return _written({"command": command, "rows": rows}, args.out)


def check_writable(out: Path) -> None:
    """Refuses ``out`` before any work if its folder cannot be made or written (a run here takes minutes to hours).

    Raises:
        ValueError: Naming ``out`` and why.
    """
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out.parent, prefix=f".{out.name}.", delete=True):
            pass
    except OSError as error:
        raise ValueError(f"--out {out}: cannot write there ({error.strerror or error})") from None


def _written(result: dict[str, Any], out: Path | None) -> dict[str, Any]:
    """``result``, written to ``out`` first if given (one JSON file, its folder made)."""
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result, indent=1) + "\n")
    return result


if __name__ == "__main__":
    main()
