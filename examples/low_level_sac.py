"""Bring your own SB3 algorithm: SAC + HER on the point reach env, then plug it into the maze.

Run: .venv/bin/python examples/low_level_sac.py [--timesteps 20000] [--reach-episodes 100] [--maze-episodes 50]
About 9 minutes on 2 cores. A progress bar on a terminal; otherwise (a log file, CI) SB3 prints a table of
its progress every 20 episodes. A smoke run (what the tests do): --timesteps 300 --reach-episodes 2 --maze-episodes 1
"""

import argparse
import sys

import gymnasium as gym
import torch
from stable_baselines3 import SAC, HerReplayBuffer

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import evaluate_high_level
from antmaze_hirl.envs import ReachEnv
from antmaze_hirl.sb3_ext import evaluate_reach

parser = argparse.ArgumentParser()
parser.add_argument("--timesteps", type=int, default=20_000)
parser.add_argument("--reach-episodes", type=int, default=100, help="reach episodes of the evaluation")
parser.add_argument("--maze-episodes", type=int, default=50, help="maze episodes of the oracle + SAC evaluation")
args = parser.parse_args()
torch.set_num_threads(1)  # small networks: one thread is faster than two fighting the simulator
# A progress bar redraws one line, which a log file never shows; a log gets SB3's periodic tables instead.
interactive = sys.stdout.isatty()

model = SAC(
    "MultiInputPolicy",
    gym.make("antmaze_hirl/PointReach-v0"),
    replay_buffer_class=HerReplayBuffer,
    learning_starts=200,
    seed=0,
    verbose=0 if interactive else 1,
)
model.learn(args.timesteps, progress_bar=interactive, log_interval=20)
print("reach:", evaluate_reach(model, ReachEnv("point"), episodes=args.reach_episodes, seed=0))

maze = gym.make("antmaze_hirl/PointMaze-v0", low_level=model)  # the SAC policy walks to the oracle's subgoals
print("oracle + SAC low level:", evaluate_high_level(PathOracle.for_env(maze), maze, episodes=args.maze_episodes))
