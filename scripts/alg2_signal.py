"""Does a start-selection score carry a signal, as protocol 2 asks? Its ranking of unseen states above trained ones.

For each seed, a learner is trained by a few episodes of one trainer on the ``"train"`` part of the
held-out layouts; each score is then taken at every state of its dataset (states it was trained on) and
at the oracle's states on five ``"eval"``-part mazes (states it has not seen, walls held out up to
symmetry). Printed and written per seed and score: the medians and the AUC, the probability that an
unseen state scores above a trained one (0.5: no signal).

Trainers (``--methods``): ``dagger`` (corner starts: no score chose the trained states, the fair ground
for comparing scores), ``noise_old`` (starts by the old noise score, as in the audit that found it had none),
``noise`` (starts by the new one) and ``multi_policy``. A trainer whose starts a score picks trains on
the states that score ranked highest, which biases that score's AUC downwards; ``dagger`` has no such bias.

Scores, old and new side by side:

- ``noise_old``: protocol 2's first noise score, before the symmetric views: the variance of the class
  distribution under body noise (``NoiseQuery(symmetries=False, measure="variance")``).
- ``noise``: the ``noise`` method's score now (``NoiseQuery()``), the Jensen-Shannon divergence of the
  class distributions of each state's body-noisy copies seen in the 8 symmetries of the square.
- ``ensemble_old``: ``multi_policy``'s score, the members' variance of their class distributions
  (``multi_policy`` trainer only).
- ``ensemble_js``: the members' Jensen-Shannon divergence instead.

Each is read two ways: ``at_state``, the state as it was (agent where it stood, its body moving), and
``as_candidate``, the agent at its cell's centre with the body at rest, which is how ``choose_start``
sees a candidate. ``untrained`` rows take the same scores from a fresh learner of the same settings
(a fresh ensemble for the ensemble scores): how far the two state sets differ without any training.

``--fitted`` measures instead the unit test's setting (:func:`fitted_aucs`) over ``--seeds`` seeds.

Usage: python scripts/alg2_signal.py [--body point] [--seeds 8] [--episodes 5] [--methods LIST] [--out FILE]
       python scripts/alg2_signal.py --fitted --seeds 10
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger import HighLevelPolicy
from antmaze_hirl.dagger.strategies import NoiseQuery, StartQuery, class_probabilities, information_radius, spread
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env, make_trainer
from antmaze_hirl.experts.oracle import PathOracle
from antmaze_hirl.rollout import play_episode

RESULTS = Path(__file__).resolve().parents[1] / "results" / "alg2_signal"
GENERIC = {"head": "next_cell", "planning_iterations": 0, "block_walls": False}
VIEWS = ("at_state", "as_candidate")
METHODS = ("dagger", "noise_old", "noise", "multi_policy")
SCORES = {"noise_old": NoiseQuery(symmetries=False, measure="variance"), "noise": NoiseQuery()}
"""The noise scores compared (their settings; each call gets its own rng)."""


def oracle_states(env, oracle, episodes: int, seed: int) -> list[dict]:
    """Every observation of the oracle's episodes on ``env`` from seeds ``seed, seed + 1, ...``.

    The states the oracle is asked about: each episode's observations but its last (the one after the end).
    """
    states = []

    def recorded_oracle(observation: dict) -> np.ndarray:
        states.append(observation)
        return oracle(observation)

    for episode in range(episodes):
        play_episode(env, recorded_oracle, seed=seed + episode)
    return states


def state_parts(policy, observation: dict, view: str, rest_body: np.ndarray) -> tuple:
    """Walls, agent xy, goal xy and body of a state, the agent at its cell's centre at rest for ``as_candidate``."""
    state = observation["state"]
    agent = np.asarray(STATE_LAYOUT.agent_xy(state), dtype=np.float64)
    body = np.asarray(STATE_LAYOUT.body_observation(state), dtype=np.float64)
    if view == "as_candidate":
        agent, body = policy.geometry.cell_to_xy(policy.geometry.xy_to_cell(agent)), rest_body
    return (
        policy.encoder.renderer.walls_from_image(observation["image"]),
        agent,
        np.asarray(STATE_LAYOUT.goal_xy(state)),
        body,
    )


def noise_scores(strategy: NoiseQuery, policy, states, view: str, rest_body, rng: np.random.Generator) -> np.ndarray:
    """``strategy``'s score at each state itself (one candidate: the state's own agent position)."""
    scores = []
    for observation in states:
        walls, agent, goal, body = state_parts(policy, observation, view, rest_body)
        query = StartQuery(walls, goal, agent[None], body, policy)
        scores.append(strategy.scores(query, np.random.default_rng(rng.integers(2**63)))[0])
    return np.array(scores)


def ensemble_scores(members, policy, states, view: str, rest_body, measure: Callable) -> np.ndarray:
    """``measure`` (variance or JS) across ``members``' class distributions at each state."""
    parts = [state_parts(policy, observation, view, rest_body) for observation in states]
    batch = policy.encoder.encode(*map(list, zip(*parts, strict=True)))
    distributions = np.stack([class_probabilities(member, batch) for member in members], axis=1)
    return np.array([measure(block) for block in distributions])


def auc(unseen: np.ndarray, trained: np.ndarray) -> float:
    """P(unseen score > trained score), ties counting half."""
    return float((unseen[:, None] > trained[None, :]).mean() + 0.5 * (unseen[:, None] == trained[None, :]).mean())


def score_row(name: str, view: str, trained_state: str, s_trained: np.ndarray, s_unseen: np.ndarray) -> dict:
    """One score's figures on one seed's two state sets."""
    return {
        "score": name,
        "view": view,
        "learner": trained_state,
        "median_trained": float(np.median(s_trained)),
        "median_unseen": float(np.median(s_unseen)),
        "smallest_score": float(min(s_trained.min(), s_unseen.min())),
        "auc_unseen_above_trained": auc(s_unseen, s_trained),
    }


def seed_scores(method: str, trainer, trained, unseen, seed: int) -> list[dict]:
    """Every score of ``method``'s trainer (and of untrained stand-ins) on the two state sets, both views."""
    policy, rest = trainer.learner, trainer._rest_body
    fresh = policy.spawn(np.random.default_rng(10_000 + seed))
    rows = []
    for view in VIEWS:
        for name, strategy in SCORES.items():
            for learner, who in ((policy, "trained"), (fresh, "untrained")):
                rng = np.random.default_rng(seed)
                s_trained, s_unseen = (noise_scores(strategy, learner, s, view, rest, rng) for s in (trained, unseen))
                rows.append(score_row(name, view, who, s_trained, s_unseen))
        if method == "multi_policy":
            members = trainer.strategy.members
            stand_ins = [policy.spawn(np.random.default_rng(20_000 + seed + i)) for i in range(len(members))]
            for name, measure in (("ensemble_old", spread), ("ensemble_js", information_radius)):
                for group, who in ((members, "trained"), (stand_ins, "untrained")):
                    s_trained, s_unseen = (
                        ensemble_scores(group, policy, s, view, rest, measure) for s in (trained, unseen)
                    )
                    rows.append(score_row(name, view, who, s_trained, s_unseen))
    return rows


def fitted_aucs(env, seed: int, steps: int = 400) -> tuple[float, float]:
    """AUCs of ``NoiseQuery()``, unseen above trained, for a learner fitted on two mazes and for an untrained one.

    The generic learner (batch 16) is fitted ``steps`` Adam steps to the oracle's states on the mazes of
    reset seeds ``100 * seed`` and ``+ 1``; the score is read at those states and at the oracle's states
    on the mazes of ``100 * seed + 50`` to ``+ 53``, and again from the same learner untrained (how far
    the two state sets differ without training). ``tests/test_alg2_signal.py`` asserts on it.
    """
    oracle = PathOracle.for_env(env)
    trained, unseen = oracle_states(env, oracle, 2, 100 * seed), oracle_states(env, oracle, 4, 100 * seed + 50)
    aucs = []
    for fit in (True, False):
        policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(seed), batch_size=16, **GENERIC)
        if fit:
            policy.fit(policy.encoder.encode_observations(trained), np.stack([oracle(o) for o in trained]), steps)
        unseen_scores, trained_scores = (
            noise_scores(NoiseQuery(), policy, states, "at_state", None, np.random.default_rng(seed))
            for states in (unseen, trained)
        )
        aucs.append(auc(unseen_scores, trained_scores))
    return aucs[0], aucs[1]


def fitted_margin(seeds: int, out: Path) -> None:
    """Writes :func:`fitted_aucs` on 4x4 point mazes for seeds ``0 .. seeds - 1``: the test's margins."""
    import gymnasium as gym

    from antmaze_hirl.envs import PointGoToController

    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=4, low_level=PointGoToController())
    rows = []
    for seed in range(seeds):
        fitted, untrained = fitted_aucs(env, seed)
        rows.append({"seed": seed, "fitted_auc": fitted, "untrained_auc": untrained, "difference": fitted - untrained})
        print(rows[-1], flush=True)
    env.close()
    windows = [rows[i : i + 2] for i in range(len(rows) - 1)]
    result = {
        "command": shlex.join(["python", "scripts/alg2_signal.py", *sys.argv[1:]]),
        "what": "fitted_aucs: NoiseQuery() AUC unseen above trained, fitted and untrained (the unit test setting)",
        "rows": rows,
        "fitted_auc_min": min(r["fitted_auc"] for r in rows),
        "difference_min": min(r["difference"] for r in rows),
        "two_seed_mean_fitted_auc_min": min(np.mean([r["fitted_auc"] for r in w]) for w in windows)
        if windows
        else None,
        "two_seed_mean_difference_min": min(np.mean([r["difference"] for r in w]) for w in windows)
        if windows
        else None,
    }
    atomic_write_json(out, result)
    print({k: v for k, v in result.items() if k != "rows"})
    print("wrote", out)


def summary(rows: list[dict]) -> list[dict]:
    """Per (method, score, view, learner): the per-seed AUCs, their mean and smallest."""
    groups: dict[tuple, list[float]] = {}
    for row in rows:
        key = (row["method"], row["score"], row["view"], row["learner"])
        groups.setdefault(key, []).append(row["auc_unseen_above_trained"])
    return [
        {
            "method": method,
            "score": score,
            "view": view,
            "learner": learner,
            "aucs": [round(value, 3) for value in aucs],
            "mean_auc": round(float(np.mean(aucs)), 3),
            "min_auc": round(float(np.min(aucs)), 3),
        }
        for (method, score, view, learner), aucs in groups.items()
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--body", choices=["point", "ant"], default="point")
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--methods", default=",".join(METHODS), help=f"comma-separated trainers: {', '.join(METHODS)}")
    parser.add_argument("--out", type=Path, default=None, help="default: results/alg2_signal[_ant|_fitted].json")
    parser.add_argument(
        "--fitted", action="store_true", help="instead: the unit test's setting (fitted_aucs) over --seeds seeds"
    )
    args = parser.parse_args()
    if args.seeds < 1 or args.episodes < 1:
        parser.error(f"--seeds and --episodes must be >= 1, got {args.seeds} and {args.episodes}")
    methods = args.methods.split(",")
    if not methods or not set(methods) <= set(METHODS):
        parser.error(f"--methods must name some of {', '.join(METHODS)}, got {args.methods!r}")
    torch.set_num_threads(1)
    if args.fitted:
        fitted_margin(args.seeds, args.out or RESULTS / "alg2_signal_fitted.json")
        return
    out = args.out or RESULTS / ("alg2_signal.json" if args.body == "point" else f"alg2_signal_{args.body}.json")
    # protocol 1: the learner is GENERIC's, passed over the body's default, as the committed files ran
    settings = body_settings(args.body, held_out_layouts=True)
    config = ExperimentConfig(body=args.body, held_out_layouts=True, protocol=1, **settings)
    rows = []
    for method in methods:
        for seed in range(args.seeds):
            start = time.perf_counter()
            env = make_env(config, split="train")
            oracle = PathOracle.for_env(env, subgoal_reach_m=config.subgoal_reach_m)
            trainer = make_trainer(method.removesuffix("_old"), seed, config, env, oracle, policy_settings=GENERIC)
            if method == "noise_old":
                trainer.strategy = SCORES["noise_old"]
            for _ in range(args.episodes):
                trainer.run_episode()
            trained = trainer.dataset.observations_by_id(trainer.dataset.ids())
            held_out = make_env(config, split="eval")
            unseen = oracle_states(
                held_out, PathOracle.for_env(held_out, subgoal_reach_m=config.subgoal_reach_m), 5, 1000 + seed
            )
            for row in seed_scores(method, trainer, trained, unseen, seed):
                row = {
                    "method": method,
                    "seed": seed,
                    "trained_states": len(trained),
                    "unseen_states": len(unseen),
                    **row,
                }
                rows.append(row)
            print(
                {"method": method, "seed": seed, "seconds": round(time.perf_counter() - start, 1)},
                {
                    f"{r['score']}/{r['view']}/{r['learner']}": round(r["auc_unseen_above_trained"], 3)
                    for r in rows
                    if r["method"] == method and r["seed"] == seed
                },
                flush=True,
            )
            env.close()
            held_out.close()
    result = {
        "command": shlex.join(["python", "scripts/alg2_signal.py", *sys.argv[1:]]),
        "body": args.body,
        "learner": GENERIC,
        "episodes": args.episodes,
        "summary": summary(rows),
        "rows": rows,
    }
    atomic_write_json(out, result)
    for line in result["summary"]:
        print(line)
    print("wrote", out)


if __name__ == "__main__":
    main()
