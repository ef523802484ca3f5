"""Low-level benchmark, one seeded run.

1. Training throughput (env steps/s) of our path (``train_low_level``: checkpoints, held-out evaluation,
   TensorBoard) vs plain SB3 TD3 + HerReplayBuffer with the same hyperparameters, policy and TensorBoard
   logging, on ``antmaze_hirl/AntReach-v0``, alternating blocks; goal: ratio >= 0.95. Evaluation is
   scaled to the block in the defaults' proportion (50 held-out episodes per 25k steps). A checkpoint
   pickles the whole preallocated 1M-row replay buffer (~0.5 GB), so one per short block overstates
   its share; the ratio is reported both as measured and with the measured save time amortised over
   the default 50k steps between checkpoints.
2. ``eval-low`` figures (200 seeded subgoals up to one cell away) for both shipped policies: the reported set
   (seed 0) and, pooled, ``--sets`` disjoint sets of 200 (seeds 0, 200, 400, ...).
3. The learning curves of the ant's four training stages (``results/low_level/ant_learning_curve*.csv``; the shipped
   stage 5 averages snapshots of stages 3-4's runs and has no curve of its own)
   as a PNG, beside the curves of the runs that chose its settings.

Usage: python -m antmaze_lab.low_level [--steps 6000] [--blocks 4] [--episodes 200] [--sets 4]
Writes results/low_level/low_level.json and results/low_level/ant_learning_curve.png. Files written before it
moved into the lab record ``python scripts/low_level.py`` (earlier ``benchmarks/low_level.py``): the same options.

**Algorithms side by side** (which SB3-compatible algorithm trains the best ant), a separate mode:
``--algorithms td3=FILE,sac=FILE`` trains one ant low level per algorithm from scratch, each with its
hyperparameter file (``train-low --hyperparams``), the same seed and the same step budget, in alternating
chunks (``--chunk``), so machine load and an interrupted session hit every algorithm alike; each run lives in
``--runs-dir/<algo>`` and resumes from its checkpoint, so the comparison can span sessions. At the budget it
scores every final policy beside the shipped one in one pass: eval-low (``--episodes`` free-space subgoals
from seed 0, up to 4 m) and in-maze success (``antmaze_lab.in_maze``'s families, ``--maze-episodes`` each), with 95%
Wilson intervals, plus each algorithm's training steps/s (median over its chunks) and its ratio to the first
algorithm's.

Usage: python -m antmaze_lab.low_level --algorithms td3=TD3.yml,sac=SAC.yml [--budget 500000] [--chunk 25000]
           [--runs-dir runs/algorithms] [--maze-episodes 100] [--families ant4,u,medium,large]
           [--out results/low_level/low_level_algorithms.json]
(for instance td3=scripts/configs/ant_maze.yml,sac=scripts/configs/ant_maze_sac.yml: the maze setting).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import torch

import antmaze_hirl
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experiments.runner import low_level_identity
from antmaze_hirl.experiments.uncertainty import rate_with_interval
from antmaze_hirl.plotting import plot_learning_curves
from antmaze_hirl.sb3_ext import evaluate_reach, load_config, make_model, save_checkpoint, train_low_level
from antmaze_hirl.sb3_ext.checkpoint import POINTER, CheckpointError, latest_checkpoint
from antmaze_hirl.sb3_ext.config import ALGOS
from antmaze_hirl.sb3_ext.loading import load_low_level
from antmaze_lab.commands import recorded_command
from antmaze_lab.in_maze_protocol import parse_families
from antmaze_lab.in_maze_protocol import run as in_maze_run
from antmaze_lab.tables import lab_parser, refuse_below_one

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "low_level"


def ours_seconds(steps: int, seed: int) -> tuple[float, float]:
    """Wall time of a ``train_low_level`` block and of one more checkpoint save of its model."""
    config = load_config("ant").replace(learning_starts=500)
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        model = train_low_level(
            "ant",
            "td3",
            steps,
            out,
            seed=seed,
            config=config,
            checkpoint_freq=steps,
            eval_freq=steps // 2,
            eval_episodes=max(1, round(50 * (steps // 2) / 25_000)),
            progress_bar=False,
        )
        elapsed = time.perf_counter() - start
        save_start = time.perf_counter()
        save_checkpoint(model, Path(out) / "checkpoints", {})
        return elapsed, time.perf_counter() - save_start


def plain_sb3_seconds(steps: int, seed: int) -> float:
    """Wall time of SB3's own ``learn`` on the same model (same env, hyperparameters, policy), no extensions."""
    config = load_config("ant").replace(learning_starts=500)
    start = time.perf_counter()
    make_model("ant", "td3", config, seed=seed, tensorboard_log=tempfile.mkdtemp()).learn(steps)
    return time.perf_counter() - start


def training_ratio(steps: int, blocks: int) -> dict[str, float]:
    """Seconds per ``steps`` training steps, ours against plain SB3, over ``blocks`` alternating blocks."""
    ours, saves, plain = [], [], []
    for block in range(blocks):  # alternate so drifts in machine load hit both sides alike
        elapsed, save = ours_seconds(steps, seed=block)
        ours.append(elapsed)
        saves.append(save)
        plain.append(plain_sb3_seconds(steps, seed=block))
    ours_s, save_s, plain_s = statistics.median(ours), statistics.median(saves), statistics.median(plain)
    amortised_s = ours_s - save_s + save_s * steps / 50_000
    return {
        "steps_per_block": steps,
        "ours_steps_per_s": round(steps / ours_s, 1),
        "plain_sb3_steps_per_s": round(steps / plain_s, 1),
        "checkpoint_save_s": round(save_s, 2),
        "ratio_one_checkpoint_per_block": round(plain_s / ours_s, 3),
        "ratio_checkpoint_every_50k": round(plain_s / amortised_s, 3),
    }


def shipped_figures(episodes: int, sets: int) -> dict[str, dict]:
    """eval-low of each shipped policy: the reported set (seed 0), plus ``sets`` disjoint sets pooled.

    Subgoal ``i`` of a set uses seed ``seed + i``, so disjoint sets start ``episodes`` seeds apart.
    """
    figures = {}
    for body in ("point", "ant"):
        policy, env = load_low_level(body), ReachEnv(body)
        per_set = {
            seed: evaluate_reach(policy, env, episodes=episodes, seed=seed)
            for seed in range(0, sets * episodes, episodes)
        }
        figures[body] = {
            "low_level_id": low_level_identity(body, policy),
            "max_distance_m": env.sample_radius_m,
            **per_set[0],
            "disjoint_sets": {str(seed): result["success_rate"] for seed, result in per_set.items()},
            "pooled_success_rate": round(sum(result["success_rate"] for result in per_set.values()) / sets, 4),
            "pooled_episodes": sets * episodes,
        }
    return figures


# The shipped ant's four stages first (stage 2 warm-starts from stage 1's 500k policy, stage 3 from stage 2's
# 500k and stage 4 from stage 3's 700k, so their steps are plotted after 500k, 1M and 1.7M), then the runs
# that chose the settings (README, "Shipped low-level policies").
# label -> (CSV in results/low_level, steps before the run started)
ANT_CURVES = {
    "stage 1: scale 0.5, gamma 0.98, action_l2 1": ("ant_learning_curve.csv", 0),
    "stage 2: chained subgoals 0.75 (ant_chain.yml)": ("ant_learning_curve_chain.csv", 500_000),
    "stage 2: chained 0.5, lr 3e-4 (ant_chain_finetune.yml)": ("ant_learning_curve_chain_finetune.csv", 500_000),
    # Stage 3's curve scores its own setting (half the subgoals inside random mazes), not free space.
    "stage 3: in mazes (ant_maze.yml; own setting)": ("ant_learning_curve_maze.csv", 1_000_000),
    # Stage 4 scores the same setting as stage 3 (its reward adds the tilt term; success does not change).
    "stage 4: tilt penalty 1 (ant_maze_tilt.yml; own setting)": ("ant_learning_curve_tilt.csv", 1_700_000),
    "scale 0.5, gamma 0.98, no action penalty": ("ant_learning_curve_scale05_gamma098_no_penalty.csv", 0),
    "scale 0.5, gamma 0.95": ("ant_learning_curve_scale05_gamma095.csv", 0),
    "scale 0.5, warm start from the scale-1 run": ("ant_learning_curve_scale05_warm_start.csv", 0),
    "scale 1 (full torque), gamma 0.95": ("ant_learning_curve_scale1.csv", 0),
    "scale 1, absolute goal (no RelativeGoalExtractor)": ("ant_learning_curve_absolute_goal.csv", 0),
}


def read_curve(path: Path, offset: int = 0) -> tuple[list[int], list[float]]:
    """A learning-curve CSV's steps (shifted by ``offset``) and success rates."""
    with path.open() as handle:
        rows = list(csv.DictReader(handle))
    return [offset + int(row["timesteps"]) for row in rows], [float(row["success_rate"]) for row in rows]


def learning_curve_png() -> str:
    """Plots the ant's committed learning curves; returns the PNG's path."""
    curves = {
        label: read_curve(RESULTS / name, offset)
        for label, (name, offset) in ANT_CURVES.items()
        if (RESULTS / name).exists()
    }
    title = "Ant TD3 + HER, held-out subgoals up to 4 m"
    path = plot_learning_curves(curves, RESULTS / "ant_learning_curve.png", title=title)
    return str(Path(path).resolve().relative_to(ROOT))  # repo-relative: JSON is committed


def parse_algorithms(text: str) -> dict[str, Path]:
    """``td3=FILE,sac=FILE`` as ``{algo: hyperparameter file}``, in the order given.

    Raises:
        ValueError: On an entry without ``=``, an unknown or repeated algorithm, a missing file, or fewer than two.
    """
    algorithms: dict[str, Path] = {}
    for entry in filter(None, (part.strip() for part in text.split(","))):
        algo, separator, file = entry.partition("=")
        if not separator or algo not in ALGOS or algo in algorithms:
            raise ValueError(f"--algorithms entry {entry!r} must be ALGO=FILE, ALGO one of {list(ALGOS)}, each once")
        if not Path(file).is_file():
            raise ValueError(f"--algorithms {algo}: no hyperparameter file at {file}")
        algorithms[algo] = Path(file)
    if len(algorithms) < 2:
        raise ValueError(f"--algorithms needs at least two algorithms to compare, got {text!r}")
    return algorithms


def steps_done(run_dir: Path) -> int:
    """Environment steps of a run's latest checkpoint (0 before its first)."""
    if not (run_dir / "checkpoints" / POINTER).exists():
        return 0
    return int(latest_checkpoint(run_dir / "checkpoints")[1]["num_timesteps"])


def latest_model(run_dir: Path) -> Path:
    """The model of a run's latest checkpoint: what is scored.

    So a kill before ``policy.zip`` is written (or a ``policy.zip`` left from an earlier chunk) cannot put another
    step count's policy in the table.
    """
    return latest_checkpoint(run_dir / "checkpoints")[0] / "model.zip"


def train_side_by_side(
    algorithms: dict[str, Path], *, budget: int, chunk: int, runs_dir: Path, seed: int, eval_episodes: int
) -> dict[str, list[dict[str, float]]]:
    """Trains every algorithm to ``budget`` steps, taking turns chunk by chunk; resumes where runs stand.

    Returns each algorithm's timed chunks (``runs_dir/timing.json``, written after every chunk): a chunk is
    timed from one checkpoint to the next, so one cut short by a kill is redone and never timed. A chunk's
    time holds its training steps and also loading the checkpoint, the learning-curve evaluation and the
    saves, so the steps/s figures compare whole runs, not update speed alone.

    Raises:
        ValueError: If ``runs_dir`` holds runs of other settings (another seed, chunk or hyperparameter file).
    """
    settings = {"seed": seed, "chunk": chunk, "hyperparams": {algo: str(file) for algo, file in algorithms.items()}}
    timing_file = runs_dir / "timing.json"
    saved = json.loads(timing_file.read_text()) if timing_file.exists() else {"settings": settings, "chunks": {}}
    mine = {algo: saved["settings"]["hyperparams"].get(algo) for algo in algorithms}
    if {**saved["settings"], "hyperparams": mine} != settings:
        raise ValueError(f"{runs_dir} holds runs of {saved['settings']}, not {settings}; use another --runs-dir")
    saved["settings"]["hyperparams"].update(settings["hyperparams"])
    timing = saved["chunks"]
    for end in range(chunk, budget + chunk, chunk):
        for algo, hyperparams in algorithms.items():
            run_dir, target = runs_dir / algo, min(end, budget)
            before = steps_done(run_dir)
            if before >= target:
                continue
            start = time.perf_counter()
            train_low_level(
                "ant",
                algo,
                target,
                run_dir,
                seed=seed,
                resume=before > 0,
                config=load_config("ant", hyperparams, algo=algo),
                checkpoint_freq=chunk,
                eval_freq=chunk,
                eval_episodes=eval_episodes,
                progress_bar=False,
            )
            seconds = time.perf_counter() - start
            timing.setdefault(algo, []).append(
                {"from": before, "to": steps_done(run_dir), "seconds": round(seconds, 1)}
            )
            atomic_write_json(timing_file, saved)
            print(f"{algo}: {before} -> {target} steps in {seconds:.0f} s", flush=True)
    return {algo: timing.get(algo, []) for algo in algorithms}


def compare_algorithms(args: argparse.Namespace) -> dict[str, Any]:
    """The ``--algorithms`` mode (module docstring): train side by side, then score every final policy."""
    algorithms = parse_algorithms(args.algorithms)
    families = parse_families(args.families)
    if args.budget < args.chunk:
        raise ValueError(f"--budget {args.budget} is below --chunk {args.chunk}: no chunk would be evaluated")
    timing = train_side_by_side(
        algorithms,
        budget=args.budget,
        chunk=args.chunk,
        runs_dir=args.runs_dir,
        seed=args.seed,
        eval_episodes=args.curve_episodes,
    )
    policies = {algo: latest_model(args.runs_dir / algo) for algo in algorithms}
    training: dict[str, Any] = {}
    for algo, chunks in timing.items():
        rates = [(chunk["to"] - chunk["from"]) / chunk["seconds"] for chunk in chunks if chunk["seconds"] > 0]
        training[algo] = {"steps": steps_done(args.runs_dir / algo), "chunks": chunks}
        training[algo]["median_steps_per_s"] = round(statistics.median(rates), 1) if rates else None
    first = training[next(iter(algorithms))]["median_steps_per_s"]  # None before any timed chunk
    for figures in training.values():
        speed = figures["median_steps_per_s"]
        figures["steps_per_s_ratio_to_first"] = round(speed / first, 3) if speed and first else None
    eval_low = {}
    for name, path in {"shipped": None, **policies}.items():
        result = evaluate_reach(load_low_level("ant", path), ReachEnv("ant"), episodes=args.episodes, seed=0)
        eval_low[name] = {**result, **rate_with_interval(result["success_rate"], args.episodes)}
        print(f"eval-low {name}: {eval_low[name]}", flush=True)
    by_path = in_maze_run([None, *policies.values()], families, episodes=args.maze_episodes, seed=HELD_OUT_SEED)
    in_maze = dict(zip(["shipped", *policies], by_path.values(), strict=True))  # keyed as eval_low is
    curves = {algo: read_curve(args.runs_dir / algo / "learning_curve.csv") for algo in algorithms}
    png = plot_learning_curves(curves, args.out.with_suffix(".png"), title="Ant low level by algorithm, same budget")
    with contextlib.suppress(ValueError):  # repo-relative where it lies in the repo: the JSON is committed
        png = Path(png).resolve().relative_to(ROOT)
    return {
        "command": recorded_command("antmaze_lab.low_level", sys.argv[1:]),
        "version": antmaze_hirl.__version__,
        "hyperparams": {algo: str(file) for algo, file in algorithms.items()},
        "budget_steps": args.budget,
        "chunk_steps": args.chunk,
        "seed": args.seed,
        "policies": {algo: str(path) for algo, path in policies.items()},
        "training": training,
        "eval_low": eval_low,
        "in_maze": in_maze,
        "learning_curves_png": str(png),
    }


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``scripts/results_index.py --check`` parses recorded options with it)."""
    parser = lab_parser("antmaze_lab.low_level", __doc__)
    parser.add_argument("--steps", type=int, default=6000, help="training steps per block and side")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=200, help="eval-low subgoals per set")
    parser.add_argument("--sets", type=int, default=4, help="disjoint eval-low sets per shipped policy (seed 0 first)")
    side = parser.add_argument_group("algorithms side by side (module docstring)")
    side.add_argument("--algorithms", default=None, help="ALGO=HYPERPARAMS.yml,ALGO=...: run this mode instead")
    side.add_argument("--budget", type=int, default=500_000, help="environment steps per algorithm")
    side.add_argument("--chunk", type=int, default=25_000, help="steps per turn (and between checkpoints)")
    side.add_argument("--runs-dir", type=Path, default=Path("runs/algorithms"))
    side.add_argument("--seed", type=int, default=0)
    side.add_argument("--curve-episodes", type=int, default=50, help="held-out subgoals per learning-curve point")
    side.add_argument("--maze-episodes", type=int, default=100, help="in-maze episodes per family")
    side.add_argument("--families", default="ant4,u,medium,large")
    side.add_argument("--out", type=Path, default=RESULTS / "low_level_algorithms.json")
    return parser


def main() -> None:
    """The command line: the speed and success figures, or ``--algorithms``' side-by-side training."""
    parser = build_parser()
    args = parser.parse_args()
    torch.set_num_threads(1)
    if args.algorithms is not None:
        refuse_below_one(parser, args, ("budget", "chunk", "episodes", "curve_episodes", "maze_episodes"))
        try:
            result = compare_algorithms(args)
        except (ValueError, CheckpointError) as error:  # a run folder of other settings included
            parser.error(str(error))
        atomic_write_json(args.out, result)
        print(f"training: {json.dumps({a: f['median_steps_per_s'] for a, f in result['training'].items()})}")
        print(f"wrote {args.out}")
        return
    result = {
        "version": antmaze_hirl.__version__,
        "training_throughput": training_ratio(args.steps, args.blocks),
        "eval_low": shipped_figures(args.episodes, args.sets),
        "learning_curve_png": learning_curve_png(),
        "goals": {"ratio_checkpoint_every_50k": ">= 0.95", "ant_success_rate": ">= 0.90 (4 m, 200 episodes)"},
    }
    for section in ("training_throughput", "eval_low"):
        print(f"{section}: {result[section]}")
    atomic_write_json(RESULTS / "low_level.json", result)
    print(f"wrote {RESULTS / 'low_level.json'}")


if __name__ == "__main__":
    main()
