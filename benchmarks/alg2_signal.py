"""Does a start-selection score carry a signal? Its ranking of unseen states above trained ones (issue 32).

For each seed, a learner is trained by a few DAgger (``noise`` score) or multi-policy (ensemble score)
episodes on the ``"train"`` part of the held-out layouts; the score is then taken at every state of its
dataset (states it was trained on) and at the oracle's states on five ``"eval"``-part mazes (states it
has not seen, walls held out up to symmetry). Printed and written per seed: the medians and the AUC,
the probability that an unseen state scores above a trained one (0.5: no signal). ``noise`` is Alg. 2's
spread of the class distribution under body noise (:data:`~antmaze_hirl.dagger.strategies.SIGNALS`),
``multi_policy`` the ensemble members' spread of theirs.

Usage: python benchmarks/alg2_signal.py [--body point] [--seeds 4] [--episodes 5] [--out FILE]
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.strategies import NoiseQuery, StartQuery, spread
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env, make_trainer
from antmaze_hirl.experts.oracle import PathOracle

RESULTS = Path(__file__).parent / "results"
GENERIC = {"head": "next_cell", "planning_iterations": 0, "block_walls": False}


def oracle_states(env, oracle, episodes: int, seed: int) -> list[dict]:
    """Every observation of the oracle's episodes on ``env`` from seeds ``seed, seed + 1, ...``."""
    states = []
    for episode in range(episodes):
        observation, _ = env.reset(seed=seed + episode)
        done = False
        while not done:
            states.append(observation)
            observation, _, terminated, truncated, _ = env.step(oracle(observation))
            done = terminated or truncated
    return states


def noise_scores(policy, states: list[dict], rng: np.random.Generator) -> np.ndarray:
    """NoiseQuery's score at each state itself (its walls, agent, goal; one shared noise buffer)."""
    strategy = NoiseQuery()
    scores = []
    for observation in states:
        state = observation["state"]
        walls = policy.encoder.renderer.walls_from_image(observation["image"])
        body = np.asarray(STATE_LAYOUT.body_observation(state), dtype=np.float64)
        query = StartQuery(
            walls, np.asarray(STATE_LAYOUT.goal_xy(state)), np.asarray(STATE_LAYOUT.agent_xy(state))[None], body, policy
        )
        scores.append(strategy.scores(query, np.random.default_rng(rng.integers(2**63)))[0])
    return np.array(scores)


def ensemble_scores(strategy, policy, states: list[dict]) -> np.ndarray:
    """The ensemble's spread of class distributions at each state."""
    return np.array([spread(p) for p in strategy.member_probabilities(policy.encoder.encode_observations(states))])


def auc(unseen: np.ndarray, trained: np.ndarray) -> float:
    """P(unseen score > trained score), ties counting half."""
    return float((unseen[:, None] > trained[None, :]).mean() + 0.5 * (unseen[:, None] == trained[None, :]).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--body", choices=["point", "ant"], default="point")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--out", type=Path, default=RESULTS / "alg2_signal.json")
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = ExperimentConfig(body=args.body, held_out_layouts=True, **body_settings(args.body, held_out_layouts=True))
    rows = []
    for method in ("noise", "multi_policy"):
        for seed in range(args.seeds):
            start = time.perf_counter()
            env = make_env(config, split="train")
            oracle = PathOracle.for_env(env, max_distance=config.expert_max_distance)
            trainer = make_trainer(method, seed, config, env, oracle, policy_settings=GENERIC)
            for _ in range(args.episodes):
                trainer.run_episode()
            trained = trainer.dataset.observations_by_id(trainer.dataset.ids())
            held_out = make_env(config, split="eval")
            unseen = oracle_states(
                held_out, PathOracle.for_env(held_out, max_distance=config.expert_max_distance), 5, 1000 + seed
            )
            if method == "noise":
                rng = np.random.default_rng(seed)
                s_trained, s_unseen = (
                    noise_scores(trainer.policy, trained, rng),
                    noise_scores(trainer.policy, unseen, rng),
                )
            else:
                s_trained = ensemble_scores(trainer.strategy, trainer.policy, trained)
                s_unseen = ensemble_scores(trainer.strategy, trainer.policy, unseen)
            row = {
                "method": method,
                "seed": seed,
                "trained_states": len(s_trained),
                "unseen_states": len(s_unseen),
                "median_trained": float(np.median(s_trained)),
                "median_unseen": float(np.median(s_unseen)),
                "smallest_score": float(min(s_trained.min(), s_unseen.min())),
                "auc_unseen_above_trained": auc(s_unseen, s_trained),
                "seconds": round(time.perf_counter() - start, 1),
            }
            rows.append(row)
            print(row, flush=True)
            env.close()
            held_out.close()
    result = {
        "command": shlex.join(["python", "benchmarks/alg2_signal.py", *sys.argv[1:]]),
        "body": args.body,
        "learner": GENERIC,
        "episodes": args.episodes,
        "rows": rows,
    }
    atomic_write_json(args.out, result)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
