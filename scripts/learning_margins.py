"""The seed-to-seed spread of the tests' learning checks, so that each bound can sit outside it.

Each check is one function of a seed that computes exactly what its test asserts on; the test loads
this script (``tests/script_helpers.load_script``) and calls the same function, so the measurement and
the test cannot drift apart. This prints, for the seeds asked, each seed's figure and the min, median
and max (on one torch thread, as the tests run):

- ``risk_model``: accuracy of :class:`~antmaze_hirl.dagger.gating.RiskModel` on a synthetic problem
  (``tests/test_gated.py``, unit tier);
- ``bc_nll``: drop of imitation's BC negative log-likelihood on two DAgger episodes' exported labels
  (``tests/test_interop.py``, unit tier; needs the ``imitation`` extra);
- ``bc_nll_random_labels``: the same drop when BC is trained on random subgoals instead (the control);
- ``dagger_ratio``: distance of the learner's subgoals to the oracle's after 8 DAgger episodes over
  the untrained one's (``tests/test_dagger.py``, integration tier);
- ``gated_gain``: success gain of 8 gated episodes on 15 mazes (``tests/test_gated.py``, integration);
- ``dagger_end_to_end``: success gain of 20 DAgger episodes on 30 mazes (``tests/test_dagger.py``, slow);
- ``planner_gain``: grid-level success gain of the planning learner after 200 oracle labels on 30 random 4x4
  point mazes (``scripts/planner_check.py``'s ``learning_gain``; ``tests/test_planning_learner.py``, integration).

``--window K`` also prints the lowest and highest mean of K consecutive seeds, for a test that asserts on
the mean of K seeds.

Usage: python scripts/learning_margins.py CHECK [--seeds 0-9] [--window K]   (``--seeds`` also takes ``0,3,5``)
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import io
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th

from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import DAggerTrainer, GatedQuery, HighLevelPolicy, evaluate_high_level
from antmaze_hirl.dagger.gating import RiskModel
from antmaze_hirl.envs import PointGoToController

HEADING = {"head": "heading", "planning_iterations": 0, "block_walls": False}
"""The heading head without planning: unlike the point's default learner it does not solve 3x3 mazes untrained."""


def point_maze() -> gym.Env:
    """The tests' small maze: a 3x3 point maze, goal at least 2 cells from the start, the scripted go-to."""
    return gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, min_goal_cells=2, low_level=PointGoToController())


def point_trainer(
    seed: int, *, gradient_steps: int, strategy: Any = None, policy_settings: dict | None = None
) -> DAggerTrainer:
    """A DAgger trainer on :func:`point_maze` with the oracle as expert, learner and trainer seeded by ``seed``."""
    env = point_maze()
    rng = np.random.default_rng(seed)
    learner = HighLevelPolicy.for_env(env, rng=rng, **(policy_settings or {}))
    return DAggerTrainer(
        env=env,
        expert=PathOracle.for_env(env),
        learner=learner,
        rng=rng,
        strategy=strategy,
        gradient_steps=gradient_steps,
    )


def risk_problem(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """400 six-dimensional normal features and their labels: failed where the first feature is above 0.5."""
    features = np.random.default_rng(seed).normal(size=(400, 6)).astype(np.float32)
    return features, features[:, 0] > 0.5


def risk_model_accuracy(seed: int) -> float:
    """Training accuracy of a :class:`RiskModel` (seeded ``seed + 1``) after 300 steps on :func:`risk_problem`."""
    features, failed = risk_problem(seed)
    model = RiskModel(rng=np.random.default_rng(seed + 1))
    model.fit(features, failed, steps=300)
    return float(np.mean((model.predict(features) > 0.5) == failed))


def exported_labels(seed: int) -> DAggerTrainer:
    """A trainer seeded ``seed`` after two DAgger episodes (2 gradient steps each): ~6 labels to export."""
    trainer = point_trainer(seed, gradient_steps=2)
    trainer.train(2)
    return trainer


def bc_negative_log_likelihoods(
    trainer: DAggerTrainer, seed: int, *, random_labels: bool = False
) -> tuple[float, float]:
    """Mean negative log-likelihood of ``trainer``'s labels under imitation's BC before and after 60 batches.

    BC's policy is built from torch's global RNG, seeded ``seed`` here; its minibatches from ``seed`` too.
    ``random_labels`` trains it instead on uniform random subgoals at the same states (the control: a fit
    to anything but the exported labels), still scoring the exported labels.
    """
    from imitation.algorithms import bc

    from antmaze_hirl.dagger.interop import to_transitions

    transitions = to_transitions(trainer.dataset)
    env = trainer.env
    demonstrations = transitions
    if random_labels:
        space = env.action_space
        uniform = np.random.default_rng(seed).uniform(space.low, space.high, size=transitions.acts.shape)
        demonstrations = dataclasses.replace(transitions, acts=uniform.astype(np.float32))
    th.manual_seed(seed)
    with contextlib.redirect_stdout(io.StringIO()):  # BC's logger prints a table per batch
        cloner = bc.BC(
            observation_space=env.observation_space,
            action_space=env.action_space,
            rng=np.random.default_rng(seed),
            demonstrations=demonstrations,
            batch_size=4,  # two short point episodes give ~6 labels
        )

    def negative_log_likelihood() -> float:
        observations = {key: transitions.obs.get(key) for key in ("image", "state")}
        obs_tensor, _ = cloner.policy.obs_to_tensor(observations)
        with th.no_grad():
            _, log_prob, _ = cloner.policy.evaluate_actions(obs_tensor, th.as_tensor(transitions.acts))
        return float(-log_prob.mean())

    before = negative_log_likelihood()
    with contextlib.redirect_stdout(io.StringIO()):
        cloner.train(n_batches=60, progress_bar=False)
    return before, negative_log_likelihood()


def bc_nll_drop(seed: int, *, random_labels: bool = False) -> float:
    """:func:`bc_negative_log_likelihoods` of :func:`exported_labels`: before minus after."""
    before, after = bc_negative_log_likelihoods(exported_labels(seed), seed, random_labels=random_labels)
    return before - after


def dagger_distance_ratio(seed: int) -> float:
    """Mean distance of the learner's subgoals to the oracle's on 30 held-out mazes, after 8 episodes over before.

    The default learner, 100 gradient steps per update; the mazes are reset seeds 1000-1029 (held out by
    seed: the 3x3 family has few layouts).
    """
    eval_env = point_maze()
    oracle = PathOracle.for_env(eval_env)
    observations = [eval_env.reset(seed=1000 + maze)[0] for maze in range(30)]
    trainer = point_trainer(seed, gradient_steps=100)

    def distance_to_the_experts_labels() -> float:
        policy = trainer.learner
        return float(np.mean([np.linalg.norm(policy.predict(obs) - oracle.label(obs)) for obs in observations]))

    untrained = distance_to_the_experts_labels()
    trainer.train(8)
    return distance_to_the_experts_labels() / untrained


def success_gain(trainer: DAggerTrainer, episodes: int, mazes: int) -> tuple[float, list]:
    """Held-out success of ``trainer``'s learner after ``episodes`` episodes minus before (``mazes`` mazes), records."""
    eval_env = point_maze()
    untrained = evaluate_high_level(trainer.learner, eval_env, episodes=mazes)
    records = trainer.train(episodes)
    trained = evaluate_high_level(trainer.learner, eval_env, episodes=mazes)
    return trained["success_rate"] - untrained["success_rate"], records


def gated_run(seed: int) -> dict[str, float]:
    """Gated DAgger, heading head, 8 episodes of 100 gradient steps: labels, attempts and gain on 15 mazes."""
    trainer = point_trainer(seed, gradient_steps=100, strategy=GatedQuery(), policy_settings=HEADING)
    gain, records = success_gain(trainer, 8, 15)
    labels, attempts = sum(r.expert_cost for r in records), sum(r.attempts for r in records)
    return {"labels": labels, "attempts": attempts, "gain": gain}


def dagger_end_to_end_gain(seed: int) -> float:
    """Plain DAgger, heading head, 20 episodes of 300 gradient steps: success gain on 30 held-out mazes."""
    return success_gain(point_trainer(seed, gradient_steps=300, policy_settings=HEADING), 20, 30)[0]


def planner_gain(seed: int) -> dict[str, float]:
    """``scripts/planner_check.py``'s ``learning_gain`` (loaded by path: scripts are not a package)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent / "planner_check.py"
    spec = importlib.util.spec_from_file_location("planner_check", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.learning_gain(seed)


CHECKS: dict[str, tuple[Callable[[int], Any], str]] = {
    "risk_model": (risk_model_accuracy, "accuracy"),
    "bc_nll": (bc_nll_drop, "NLL drop"),
    "bc_nll_random_labels": (functools.partial(bc_nll_drop, random_labels=True), "NLL drop"),
    "dagger_ratio": (dagger_distance_ratio, "distance ratio"),
    "gated_gain": (gated_run, "gain"),
    "dagger_end_to_end": (dagger_end_to_end_gain, "gain"),
    "planner_gain": (planner_gain, "gain"),
}
"""Each check's function of a seed and the name of its figure (a key of its dict, where it returns one)."""


def parse_seeds(text: str) -> list[int]:
    """``"0-9"`` or ``"0,3,5"`` as a list of seeds.

    Raises:
        ValueError: If ``text`` is neither form of non-negative integers.
    """
    try:
        if "-" in text:
            first, last = (int(part) for part in text.split("-"))
            seeds = list(range(first, last + 1))
        else:
            seeds = [int(part) for part in text.split(",")]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0:
        raise ValueError(f"--seeds must be like 0-9 or 0,3,5 (non-negative), got {text!r}")
    return seeds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("check", choices=sorted(CHECKS))
    parser.add_argument("--seeds", default="0-9", help="a range 0-9 or a list 0,3,5 (default 0-9)")
    parser.add_argument("--window", type=int, default=None, help="also the extreme means of K consecutive seeds")
    args = parser.parse_args()
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError as error:
        parser.error(str(error))
    if args.window is not None and not 1 <= args.window <= len(seeds):
        parser.error(f"--window must be between 1 and the number of seeds ({len(seeds)}), got {args.window}")
    th.set_num_threads(1)  # as the tests run: the same figures on every machine
    measure, figure = CHECKS[args.check]
    values = []
    for seed in seeds:
        start = time.perf_counter()
        result = measure(seed)
        value = result[figure] if isinstance(result, dict) else result
        values.append(value)
        shown = result if isinstance(result, dict) else round(value, 4)
        print(f"seed {seed}: {shown} ({time.perf_counter() - start:.0f} s)", flush=True)
    sd = np.std(values, ddof=1) if len(values) > 1 else 0.0
    print(
        f"{args.check} {figure} over seeds {args.seeds}: min {np.min(values):.4f}, median {np.median(values):.4f}, "
        f"max {np.max(values):.4f}, mean {np.mean(values):.4f}, sd {sd:.4f}"
    )
    if args.window is not None:
        means = np.convolve(values, np.ones(args.window) / args.window, mode="valid")
        print(f"means of {args.window} consecutive seeds: min {np.min(means):.4f}, max {np.max(means):.4f}")


if __name__ == "__main__":
    main()
