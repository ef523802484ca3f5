"""Which change to the high-level learner closes a body's gap to its teacher, the oracle: an ablation.

Each variant is a set of :class:`~antmaze_hirl.dagger.HighLevelPolicy` settings. Each trial runs plain
DAgger with the oracle for ``--episodes`` episodes on the body's training mazes of the held-out-layouts
protocol (``ExperimentConfig.held_out_layouts``: the point's 5x5 family, the ant's 4x4 with the shipped low
level and 2 m oracle subgoals), then measures learner-only success (beta = 0, no expert) on the
50 mazes of the selection part (what a choice between variants may read) and on the 100 mazes of the
final evaluation part (what the README quotes), each with its 95% Wilson interval.

Variants:

* ``heading_cnn``: each body's previous default (CNN + MLP, 16 heading bins plus a distance).
* ``next_cell_cnn``: the same CNN classifying the next cell of the path (3x3 around the agent's cell).
* ``next_cell_vin``: the next cell read straight out of a value iteration module's Q at the agent's cell,
  with ``rows + cols + 2`` rounds (16 on the point's 7x7 map, 14 on the ant's 6x6).
* ``next_cell_vin_walls``: the same, with moves into walls (or diagonally between two) ruled out.

Usage: python scripts/learner_ablation.py [--body point|ant] [--variants heading_cnn,next_cell_vin]
           [--seeds 0,1] [--episodes 100] [--trials-dir /tmp/ablation] [--out FILE]
           [--untrained] [--selection-only] [--evaluation-envs 25]

``--untrained`` also scores each trial's learner before its first label on the same selection mazes
(protocol 2's rule: a main-protocol learner scores <= 20% there untrained); ``--selection-only`` leaves
out the final (``"eval"`` part) evaluation, which a choice between variants must not read anyway;
``--evaluation-envs N`` plays the evaluation mazes ``N`` at a time in lockstep (faster; the mazes are the
same, but batched products round differently, so the trial files record it and a summary names it).

``--out`` defaults to ``results/learner_ablation/learner_ablation.json`` for the point and
``learner_ablation_ant.json`` beside it for the ant.

Each trial also measures the learner's agreement with the oracle, the fraction of states where its
subgoal lies in the same cell as the oracle's label (one measure for both heads): on its own training
labels (DAgger's aggregated data) and on 1000 oracle-labelled states of selection mazes it never saw
(agent at a random free cell's centre +-0.35 cells, at rest, labelled with the trial's oracle reach).
High on the first and low on the second is a learner that memorises and does not generalise.

Each evaluation also stores ``outcomes``: 1 or 0 per maze, in seed order from its ``first_seed``, so that two
variants' trials of the same seed can be paired maze by maze (the preregistration's two-way bootstrap).

Finished trials are kept in ``--trials-dir`` (one JSON each) and reused, so an interrupted run resumes;
the summary lists every variant and seed found there for the settings given.
"""

from __future__ import annotations

import argparse
import json
import shlex
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.dagger.evaluation import evaluation_episodes
from antmaze_hirl.experiments.config import (
    LEARNERS,
    SELECTION_SEED,
    ExperimentConfig,
    body_settings,
    evaluation_sets,
    learner_settings,
)
from antmaze_hirl.experiments.config import (
    PLANS as PLANS,  # re-exported: the variants' stand-in for rows + cols + 2 rounds
)
from antmaze_hirl.experiments.provenance import code_provenance
from antmaze_hirl.experiments.runner import make_env, make_trainer
from antmaze_hirl.experiments.uncertainty import pooled_rate, rate_with_interval
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.experts.oracle import sample_labelled_states
from antmaze_hirl.sb3_ext.shipped import make_maze_env

RESULTS = Path(__file__).resolve().parents[1] / "results" / "learner_ablation"

VARIANTS: dict[str, dict[str, Any]] = LEARNERS
"""HighLevelPolicy settings of each variant: the named learners of ``ExperimentConfig.learner``
(:data:`~antmaze_hirl.experiments.config.LEARNERS`). ``next_cell_vin_walls`` is the point's protocol-1
default, the "strong prior" ablation of protocol 2."""

BODY_FILE_PREFIX = {"point": "", "ant": "ant_"}
"""Trial files of the ant start ``ant_``; the point's keep the names they had before the ant joined."""


def variant_settings(variant: str, config: ExperimentConfig) -> dict[str, Any]:
    """The variant's settings on the trial's map: :data:`PLANS` becomes ``rows + cols + 2`` rounds."""
    return learner_settings(variant, config.maze_size)


SELECTION_MAZES = 50
AGREEMENT_STATES = 1000


def cell_agreement(policy: Any, agent_xy: np.ndarray, predicted: np.ndarray, labels: np.ndarray) -> float:
    """Fraction of states whose predicted subgoal lies in the same cell (relative to the agent's) as the label."""
    steps = policy.cell_steps
    return float(np.mean(np.all(steps(agent_xy, predicted) == steps(agent_xy, labels), axis=1)))


def held_out_agreement(policy: Any, config: ExperimentConfig, seed: int = 0) -> float:
    """:func:`cell_agreement` on oracle-labelled states of selection-part mazes (see the module docstring)."""
    env = make_maze_env(config.body, low_level=lambda *_: None, split="selection", maze_size=config.maze_size)
    reach = config.subgoal_reach_m or env.unwrapped.geometry.scale
    # The body at rest as a reset with the seed leaves it (the point's is zero velocity; the ant's is not all zeros).
    states = sample_labelled_states(
        env, AGREEMENT_STATES, subgoal_reach_m=reach, rng=np.random.default_rng(seed), reset_seed=seed
    )
    env.close()
    batch = policy.encoder.encode(states.walls, states.agents, states.goals, states.bodies)
    agents, labels = np.stack(states.agents), states.labels
    return cell_agreement(policy, agents, agents + policy.subgoal_reach_m * policy.offsets(batch), np.stack(labels))


def run_variant_trial(
    variant: str,
    seed: int,
    config: ExperimentConfig,
    policy_path: Path | None = None,
    *,
    untrained: bool = False,
    final: bool = True,
) -> dict[str, Any]:
    """Trains one learner of ``variant`` from ``seed`` by DAgger with the oracle; its learner-only success.

    With ``policy_path``, the trained policy is saved there (to look at its failures later). With
    ``untrained``, the learner is also scored on the selection mazes before its first label; without
    ``final``, the final (``"eval"`` part) evaluation is left out.
    """
    start = time.perf_counter()
    env = make_env(config, split="train")
    oracle = PathOracle.for_env(env, subgoal_reach_m=config.subgoal_reach_m)
    trainer = make_trainer("dagger", seed, config, env, oracle, policy_settings=variant_settings(variant, config))
    sets = {"selection": ("selection", SELECTION_SEED, SELECTION_MAZES)}
    if final:
        sets["final"] = evaluation_sets(config)["final"]
    evaluations = {}
    if untrained:
        evaluations["untrained_selection"] = evaluate_on(trainer.learner, config, sets["selection"])
    records = [trainer.run_episode() for _ in range(config.episodes)]
    train_seconds = time.perf_counter() - start
    if policy_path is not None:
        trainer.learner.save(policy_path)
    data = trainer.dataset
    own = trainer.learner.predict_batch(data.observations_by_id(data.ids()))
    agreement = {
        "training_labels": cell_agreement(trainer.learner, data.agent_xy(), own, data.subgoals()),
        "held_out_states": held_out_agreement(trainer.learner, config),
    }
    for name, chosen in sets.items():
        evaluations[name] = evaluate_on(trainer.learner, config, chosen)
    env.close()
    return {
        "variant": variant,
        "seed": seed,
        "body": config.body,
        "policy_settings": variant_settings(variant, config),
        "episodes": config.episodes,
        "labels": trainer.total_expert_cost,
        "training_successes": int(sum(record.success for record in records)),
        "gradient_steps": trainer.learner.gradient_steps,
        "oracle_cell_agreement": agreement,
        "train_seconds": round(train_seconds, 1),
        "trial_seconds": round(time.perf_counter() - start, 1),
        "machine": machine(),
        "evaluation_envs": config.evaluation_envs,
        **{f"{name}_success": figures for name, figures in evaluations.items()},
    }


def evaluate_on(policy: Any, config: ExperimentConfig, chosen: tuple[str, int, int]) -> dict[str, Any]:
    """``policy``'s learner-only success on the mazes ``(split, first seed, count)``, with its interval."""
    split, first_seed, mazes = chosen
    eval_env = make_env(config, split=split)
    played = evaluation_episodes(policy, eval_env, episodes=mazes, seed=first_seed, num_envs=config.evaluation_envs)
    eval_env.close()
    outcomes = [int(bool(info["is_success"])) for info in played]
    return {
        **rate_with_interval(float(np.mean(outcomes)), mazes),
        "mean_attempts": float(np.mean([info["attempts"] for info in played])),
        "split": split,
        "first_seed": first_seed,
        # Per maze, in seed order from first_seed: what a paired (seed x maze) bootstrap between learners reads.
        "outcomes": outcomes,
    }


def median_rate(trials: list[dict[str, Any]], key: str) -> float | None:
    """The median of ``trials[i][key]["rate"]`` over the trials that have it (``None``: none has)."""
    rates = [t[key]["rate"] for t in trials if key in t]
    return statistics.median(rates) if rates else None


def machine() -> dict[str, Any]:
    """Where a trial ran: trials of one summary may come from different machines, so each says which."""
    provenance = code_provenance()
    return {key: provenance[key] for key in ("git_commit", "git_dirty", "packages", "python", "cpu_model")}


def machines(trials: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each distinct machine the trials ran on (trials recorded before machines were recorded say nothing)."""
    seen: dict[str, dict[str, Any]] = {}
    for trial in trials:
        if "machine" in trial:
            seen.setdefault(json.dumps(trial["machine"], sort_keys=True), trial["machine"])
    return list(seen.values())


def summarise(trials: list[dict[str, Any]], config: ExperimentConfig) -> dict[str, Any]:
    """Per variant: each seed's figures and the medians of final and selection success."""
    summary: dict[str, Any] = {}
    for variant in VARIANTS:
        mine = sorted((t for t in trials if t["variant"] == variant), key=lambda t: t["seed"])
        if not mine:
            continue
        summary[variant] = {
            "policy_settings": variant_settings(variant, config),
            "seeds": [t["seed"] for t in mine],
            "final_success_median": median_rate(mine, "final_success"),
            "untrained_selection_success_median": median_rate(mine, "untrained_selection_success"),
            "untrained_selection_successes": untrained_total(mine),
            "selection_success_median": statistics.median(t["selection_success"]["rate"] for t in mine),
            "selection_success_mean": round(statistics.mean(t["selection_success"]["rate"] for t in mine), 4),
            "held_out_agreement_median": statistics.median(t["oracle_cell_agreement"]["held_out_states"] for t in mine),
            "labels_median": statistics.median(t["labels"] for t in mine),
            "trial_seconds_median": statistics.median(t["trial_seconds"] for t in mine),
            "trials": mine,
        }
    return summary


UNTRAINED_LIMIT = 0.2
"""Protocol 2's rule, a learner that must learn: a main-protocol learner scores at most this untrained on the
selection mazes."""


def untrained_total(trials: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The untrained learners' selection successes pooled over seeds, their rate's Wilson interval, the rule's verdict.

    Pooled over initialisations of one variant on the same mazes: the interval treats the mazes as
    independent draws, which the seeds' shared mazes are not, so it is a rough bound (``None``: not measured).
    """
    measured = [t["untrained_selection_success"] for t in trials if "untrained_selection_success" in t]
    if not measured:
        return None
    successes, mazes = sum(m["successes"] for m in measured), sum(m["episodes"] for m in measured)
    return {**pooled_rate(successes, mazes), "meets_rule": successes / mazes <= UNTRAINED_LIMIT}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--body", choices=sorted(BODY_FILE_PREFIX), default="point")
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--seeds", default="0,1", help="comma-separated trial seeds")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--trials-dir", type=Path, default=Path("/tmp/learner_ablation"))
    parser.add_argument("--out", type=Path, default=None, help="default: see the module docstring")
    parser.add_argument("--note", default=None, help="a line stored in the summary (where and how the trials ran)")
    parser.add_argument("--untrained", action="store_true", help="also score each learner before its first label")
    parser.add_argument("--selection-only", action="store_true", help="leave out the final ('eval' part) evaluation")
    parser.add_argument("--evaluation-envs", type=int, default=1, help="mazes evaluated at once, in lockstep")
    args = parser.parse_args()
    prefix = BODY_FILE_PREFIX[args.body]
    args.out = args.out or RESULTS / ("learner_ablation.json" if args.body == "point" else "learner_ablation_ant.json")
    torch.set_num_threads(1)  # one core per trial, as paper_experiment's --cpus-per-trial 1
    variants = [name.strip() for name in args.variants.split(",") if name.strip()]
    unknown = sorted(set(variants) - set(VARIANTS))
    if unknown:
        parser.error(f"unknown variants {unknown}; choose from {sorted(VARIANTS)}")
    seeds = [int(seed) for seed in args.seeds.split(",")]
    if args.evaluation_envs < 1:
        parser.error(f"--evaluation-envs must be >= 1, got {args.evaluation_envs}")
    config = ExperimentConfig(
        body=args.body,
        episodes=args.episodes,
        held_out_layouts=True,
        protocol=1,  # the periodic and final sets of protocol 1's held-out layouts, as the committed files ran
        eval_episodes=50,
        evaluation_envs=args.evaluation_envs,
        **body_settings(args.body, held_out_layouts=True),
    )
    args.trials_dir.mkdir(parents=True, exist_ok=True)
    for seed in seeds:  # seed-major: every variant of a seed before the next seed
        for variant in variants:
            path = args.trials_dir / f"{prefix}{variant}_e{args.episodes}_seed{seed}.json"
            if not path.exists():
                trial = run_variant_trial(
                    variant,
                    seed,
                    config,
                    path.with_suffix(".zip"),
                    untrained=args.untrained,
                    final=not args.selection_only,
                )
                atomic_write_json(path, trial)
            trial = json.loads(path.read_text())
            parts = [f"{variant} seed {seed}:"]
            if "final_success" in trial:
                parts.append(f"final {trial['final_success']['rate']:.2f} {trial['final_success']['wilson_95']},")
            if "untrained_selection_success" in trial:
                parts.append(f"untrained selection {trial['untrained_selection_success']['rate']:.2f},")
            parts.append(
                f"selection {trial['selection_success']['rate']:.2f}, {trial['labels']} labels, "
                f"agreement {trial['oracle_cell_agreement']}, {trial['trial_seconds']:.0f} s"
            )
            print(" ".join(parts), flush=True)
    trials = [json.loads(path.read_text()) for path in sorted(args.trials_dir.glob(f"*_e{args.episodes}_seed*.json"))]
    trials = [t for t in trials if t.get("body", "point") == args.body and t["variant"] in VARIANTS]
    # The summary covers every trial in the folder, which earlier invocations may have run: say which ran.
    command = shlex.join(["python", "scripts/learner_ablation.py", *sys.argv[1:]])
    previous = json.loads(args.out.read_text()) if args.out.exists() else {}
    earlier = previous.get("commands") or ([previous["command"]] if "command" in previous else [])
    summary = summarise(trials, config)
    note = args.note or previous.get("note")  # a rerun that only re-summarises keeps the note
    atomic_write_json(
        args.out,
        {
            "command": command,
            "commands": [*[c for c in earlier if c != command], command],
            "protocol": {
                "body": args.body,
                "maze_size": config.maze_size,
                "method": "dagger",
                "expert": "PathOracle",
                "subgoal_reach_m": config.subgoal_reach_m,
                "episodes": config.episodes,
                "gradient_steps_per_update": config.gradient_steps,
                "held_out_layouts": True,
                "selection_mazes": SELECTION_MAZES,
                "final_mazes": config.final_eval_episodes,
                "interval": "95% Wilson",
                "torch_threads": 1,
                "evaluation_envs": args.evaluation_envs,
                "untrained_limit": UNTRAINED_LIMIT,
                "agreement_states": AGREEMENT_STATES,
                "note": "trials recorded before block_walls existed list no block_walls: it was False",
            },
            "machines": machines(trials),
            **({"note": note} if note else {}),
            "variants": summary,
        },
    )

    def cell(value: float | None, width: int) -> str:
        return f"{value:>{width}.2f}" if value is not None else f"{'-':>{width}}"

    print(
        f"\n{'variant':<21}{'untrained sel.':>15}{'final (median)':>16}{'selection (median)':>20}"
        f"{'labels':>8}{'trial s':>9}"
    )
    for name, figures in summary.items():
        print(
            f"{name:<21}{cell(figures['untrained_selection_success_median'], 15)}"
            f"{cell(figures['final_success_median'], 16)}{figures['selection_success_median']:>20.2f}"
            f"{figures['labels_median']:>8.0f}{figures['trial_seconds_median']:>9.0f}"
        )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
