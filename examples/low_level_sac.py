"""Bring your own SB3 algorithm: SAC + HER on the point reach env, then plug it into the maze.

Run: .venv/bin/python examples/low_level_sac.py [--timesteps 20000]
"""

import argparse

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
args = parser.parse_args()
torch.set_num_threads(1)  # small networks: one thread is faster than two fighting the simulator

model = SAC(
    "MultiInputPolicy",
    gym.make("antmaze_hirl/PointReach-v0"),
    replay_buffer_class=HerReplayBuffer,
    learning_starts=200,
    seed=0,
)
model.learn(args.timesteps, progress_bar=True)
print("reach:", evaluate_reach(model, ReachEnv("point"), episodes=100, seed=0))

maze = gym.make("antmaze_hirl/PointMaze-v0", low_level=model)  # the SAC policy walks to the oracle's subgoals
print("oracle + SAC low level:", evaluate_high_level(PathOracle.for_env(maze), maze, episodes=50))
