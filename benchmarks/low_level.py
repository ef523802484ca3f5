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
3. The learning curves of the shipped ant's two training stages (``benchmarks/results/ant_learning_curve*.csv``)
   as a PNG, beside the curves of the runs that chose its settings.

Usage: python benchmarks/low_level.py [--steps 6000] [--blocks 4] [--episodes 200] [--sets 4]
Writes benchmarks/results/low_level.json and benchmarks/results/ant_learning_curve.png.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import tempfile
import time
from pathlib import Path

import torch

import antmaze_hirl
from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.plotting import plot_learning_curves
from antmaze_hirl.sb3_ext import evaluate_reach, load_config, make_model, save_checkpoint, train_low_level
from antmaze_hirl.sb3_ext.loading import load_low_level

RESULTS = Path(__file__).parent / "results"


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
            "max_distance_m": env.goal_radius,
            **per_set[0],
            "disjoint_sets": {str(seed): result["success_rate"] for seed, result in per_set.items()},
            "pooled_success_rate": round(sum(result["success_rate"] for result in per_set.values()) / sets, 4),
            "pooled_episodes": sets * episodes,
        }
    return figures


# The shipped ant's two stages first (stage 2 warm-starts from stage 1's 500k policy, so its steps are
# plotted after 500k), then the runs that chose the settings (README, "Shipped low-level policies").
# label -> (CSV in benchmarks/results, steps before the run started)
ANT_CURVES = {
    "stage 1: scale 0.5, gamma 0.98, action_l2 1": ("ant_learning_curve.csv", 0),
    "stage 2: chained subgoals 0.75 (ant_chain.yml)": ("ant_learning_curve_chain.csv", 500_000),
    "stage 2: chained 0.5, lr 3e-4 (ant_chain_finetune.yml)": ("ant_learning_curve_chain_finetune.csv", 500_000),
    "scale 0.5, gamma 0.98, no action penalty": ("ant_learning_curve_scale05_gamma098_no_penalty.csv", 0),
    "scale 0.5, gamma 0.95": ("ant_learning_curve_scale05_gamma095.csv", 0),
    "scale 0.5, warm start from the scale-1 run": ("ant_learning_curve_scale05_warm_start.csv", 0),
    "scale 1 (full torque), gamma 0.95": ("ant_learning_curve_scale1.csv", 0),
    "scale 1, absolute goal (no RelativeGoalExtractor)": ("ant_learning_curve_absolute_goal.csv", 0),
}


def read_curve(path: Path, offset: int = 0) -> tuple[list[int], list[float]]:
    with path.open() as handle:
        rows = list(csv.DictReader(handle))
    return [offset + int(row["timesteps"]) for row in rows], [float(row["success_rate"]) for row in rows]


def learning_curve_png() -> str:
    curves = {
        label: read_curve(RESULTS / name, offset)
        for label, (name, offset) in ANT_CURVES.items()
        if (RESULTS / name).exists()
    }
    title = "Ant TD3 + HER, held-out subgoals up to 4 m"
    path = plot_learning_curves(curves, RESULTS / "ant_learning_curve.png", title=title)
    return str(Path(path).resolve().relative_to(RESULTS.resolve().parent.parent))  # repo-relative: JSON is committed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=6000, help="training steps per block and side")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=200, help="eval-low subgoals per set")
    parser.add_argument("--sets", type=int, default=4, help="disjoint eval-low sets per shipped policy (seed 0 first)")
    args = parser.parse_args()
    torch.set_num_threads(1)
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
