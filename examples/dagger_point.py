"""DAgger with noise-based active learning on random point-mass mazes, top to bottom in one file.

Run: .venv/bin/python examples/dagger_point.py [--episodes 30] [--seed 0] [--eval-episodes 50] [--out runs/examples]
Trains the high-level policy from the scripted oracle, evaluates it alone on 50 held-out mazes,
saves it, and draws one evaluation episode to runs/examples/dagger_point.png.
A smoke run (what the tests do): --episodes 2 --eval-episodes 2 --out /tmp/smoke
"""

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy, NoiseQuery, evaluate_high_level
from antmaze_hirl.plotting import plot_played_episode
from antmaze_hirl.rollout import play_episode

parser = argparse.ArgumentParser()
parser.add_argument("--episodes", type=int, default=30)
parser.add_argument("--seed", type=int, default=0)
parser.add_argument("--eval-episodes", type=int, default=50, help="held-out mazes the learner plays alone")
parser.add_argument("--out", type=Path, default=Path("runs/examples"), help="folder of the policy and the picture")
args = parser.parse_args()
torch.set_num_threads(1)

# 1. The high-level env: random 5x5 mazes, the shipped point policy walks to each subgoal.
env = gym.make("antmaze_hirl/PointMaze-v0")
rng = np.random.default_rng(args.seed)

# 2. Learner, expert, and the trainer with an active-learning strategy. The learner is protocol 2's CNN
#    next-cell head: the point's default reads its head out of value iteration, which solves most mazes untrained.
policy = HighLevelPolicy.for_env(env, rng=rng, planning_iterations=0, block_walls=False)
trainer = DAggerTrainer(env=env, expert=PathOracle.for_env(env), learner=policy, rng=rng, strategy=NoiseQuery())
records = trainer.train(args.episodes, progress_bar=True)
print(f"expert labels: {trainer.total_expert_cost} over {len(records)} episodes")

# 3. The learner alone on held-out mazes.
eval_env = gym.make("antmaze_hirl/PointMaze-v0")
print("learner-only:", evaluate_high_level(policy, eval_env, episodes=args.eval_episodes))
print("policy:", policy.save(args.out / "high_level_point.zip"))

# 4. One episode, drawn.
episode = play_episode(eval_env, policy, seed=7)
picture = plot_played_episode(
    eval_env, episode, args.out / "dagger_point.png", title=f"learner alone: success={episode.success}"
)
print("picture:", picture)
