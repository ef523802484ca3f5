"""Per-method figures of an experiment: learning per label, final success with intervals, comparisons.

For each method, over its seeds (median, min and max):

* ``final_success``: learner-only success at the final evaluation, per seed and pooled over seeds, each
  with its 95% Wilson interval (:mod:`~antmaze_hirl.experiments.uncertainty`);
* ``success_at_labels``: success at 100, 200 and 400 labels, interpolated on each trial's
  success-vs-labels curve (:mod:`~antmaze_hirl.experiments.curves`); ``None`` for a seed whose labels
  end before the budget. An interpolation between two evaluations is no count of successes, so these
  carry the spread over seeds, not a Wilson interval;
* ``normalised_auc``: the area under that curve over ``[0, L]`` labels divided by ``L``, where ``L``
  (``label_horizon``) is the smallest final label count over every trial summarised together (all
  methods and seeds of one experiment, so of one body), so that every trial's curve covers it and all
  methods are compared over the same labels;
* ``vs_<baseline>``: each figure paired by seed against plain DAgger
  (:func:`~antmaze_hirl.experiments.uncertainty.paired_comparison`, a Wilcoxon signed-rank test);
* ``total_labels``: the expert's labels over the whole trial;
* ``labels_to_match_<baseline>``: labels at which the curve first reaches plain DAgger's median final
  success (:func:`~antmaze_hirl.experiments.curves.labels_to_reach`), and the ratio of its median to
  DAgger's own: the expert-cost figure of "equal success with fewer labels". A seed that never reaches it
  counts as infinitely many labels in the median (``None`` if that is the median); 0 labels (a learner at
  the target untrained, protocol 2) is a count like any: ratio 0.0 against DAgger's 40, 1.0 when both are 0,
  ``None`` when DAgger needs 0 and the method more;
* ``labels_to_match_<baseline>_per_seed`` (protocol 2 only): the same question paired by seed, which stays
  defined where under half of DAgger's seeds reach DAgger's median: for each seed, the target is that seed's
  DAgger final success (the seeds of one experiment share their evaluation mazes and initial weights), DAgger's
  cost is the labels where its own curve first reaches it (always: at the latest its last point), and the
  method's the labels where its curve first reaches it; the per-seed ratio of the two, and its median over seeds
  (a seed whose method never reaches the target ranks above every ratio; ``None`` if that is the median);
  ``skipped_seeds`` names the seeds left out: run by only one of the two, or with DAgger ending at 0%;
* ``labels_to_match_<baseline>_per_seed_smoothed`` (protocol 2 only): the same, with each seed's target the
  mean of DAgger's last ``SMOOTHED_TARGET_EVALUATIONS`` evaluations on that seed, so that no single
  evaluation sets the bar; DAgger's curve still always reaches it. ``target_evaluations`` records the count;
* secondary: mean expert cost and attempts per episode, and labels to first reach 60% success
  (``cost_to_60_percent``; in protocol 2 the untrained evaluation counts, at 0 labels).

With protocol 2's per-maze outcomes (``evaluations``, ``evaluations.csv``) every curve starts at the
trial's measured untrained success (``untrained_success``, per seed and pooled), the final evaluation is
the same set as every other, and each pooled rate (``final_success.pooled``, ``untrained_success.pooled``)
carries a two-way cluster bootstrap interval over seeds and mazes
(:func:`~antmaze_hirl.experiments.uncertainty.cluster_bootstrap`) instead of a Wilson interval that
counts the shared mazes as independent; per-seed rates keep their Wilson intervals. Without them
(protocol 1, the committed results folders) the figures are as they always were.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from antmaze_hirl.experiments.curves import (
    LABEL_BUDGETS,
    final_labels,
    labels_to_reach,
    normalised_auc,
    success_at_labels,
    success_curve,
)
from antmaze_hirl.experiments.uncertainty import cluster_bootstrap, paired_comparison, pooled_rate, rate_with_interval

TARGET_SUCCESS = 0.6
BASELINE = "dagger"
# The smoothed paired target averages the baseline's last evaluations: one evaluation of 100 mazes moves by
# several points from one checkpoint to the next, and a lucky (or unlucky) last one would set the bar alone.
SMOOTHED_TARGET_EVALUATIONS = 3

Trial = list[dict[str, Any]]


def median_range(values: Sequence[float | None]) -> dict[str, float | None]:
    """``{"median", "min", "max"}`` of the values that are not ``None`` (all three ``None`` when none is)."""
    present = [value for value in values if value is not None]
    if not present:
        return {"median": None, "min": None, "max": None}
    return {"median": float(np.median(present)), "min": float(np.min(present)), "max": float(np.max(present))}


def cost_to_reach(
    rows: Sequence[dict[str, Any]], target: float = TARGET_SUCCESS, start: float | None = None
) -> float | None:
    """Cumulative expert cost at the first learner-only evaluation with success >= ``target`` (one trial).

    ``start`` is the untrained learner's success (protocol 2's evaluation at episode 0): at or above
    ``target`` the trial costs 0 labels. ``None`` (protocol 1, no untrained evaluation) skips it.
    """
    if start is not None and start >= target:
        return 0.0
    for row in rows:
        if not math.isnan(row["eval_success"]) and row["eval_success"] >= target:
            return float(row["cumulative_expert_cost"])
    return None


def trials_by_method(rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> dict[str, dict[int, Trial]]:
    """Rows grouped as ``{method: {seed: rows in episode order}}`` (methods without rows map to ``{}``)."""
    grouped: dict[str, dict[int, Trial]] = {method: {} for method in methods}
    for row in rows:
        if row["method"] in grouped:
            grouped[row["method"]].setdefault(int(row["seed"]), []).append(row)
    return grouped


def maze_table(evaluations: Sequence[dict[str, Any]], seeds: Sequence[int], episode: int | None) -> np.ndarray:
    """``(seeds, mazes)`` successes of a method's evaluations after ``episode`` episodes (``None``: each trial's last).

    Raises:
        ValueError: If the seeds did not play the same mazes (then they are no shared clusters).
    """
    by_seed: dict[int, dict[int, bool]] = {}
    for seed in seeds:
        rows = [row for row in evaluations if int(row["seed"]) == seed]
        at = max(int(row["episode"]) for row in rows) if episode is None else episode
        by_seed[seed] = {int(row["maze_seed"]): bool(row["success"]) for row in rows if int(row["episode"]) == at}
    mazes = [sorted(outcomes) for outcomes in by_seed.values()]
    if any(m != mazes[0] for m in mazes):
        raise ValueError(f"seeds {list(seeds)} played different evaluation mazes; a pooled rate needs shared ones")
    return np.array([[by_seed[seed][maze] for maze in mazes[0]] for seed in seeds], dtype=np.float64)


def untrained_success(evaluations: Sequence[dict[str, Any]], seeds: Sequence[int]) -> dict[str, Any]:
    """The untrained learner's success (evaluation at episode 0): per seed and pooled with its cluster bootstrap."""
    table = maze_table(evaluations, seeds, 0)
    per_seed = [float(rate) for rate in table.mean(axis=1)]
    return {**median_range(per_seed), "per_seed": per_seed, "pooled": cluster_bootstrap(table)}


def final_success(trials: dict[int, Trial], evaluations: Sequence[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Final learner-only success: spread over seeds, each seed's rate and the pooled rate with Wilson intervals.

    The number of mazes comes from each final row's ``eval_mazes``; where that is missing (results
    written before it was recorded) the intervals are ``None``.
    """
    finals = {seed: trial[-1] for seed, trial in trials.items()}
    mazes = {seed: row.get("eval_mazes", math.nan) for seed, row in finals.items()}
    counted = all(not math.isnan(n) for n in mazes.values())
    per_seed = [
        {
            "seed": seed,
            **(
                rate_with_interval(row["eval_success"], int(mazes[seed]))
                if counted
                else {"rate": float(row["eval_success"])}
            ),
        }
        for seed, row in finals.items()
    ]
    pooled = None
    if evaluations:  # protocol 2: the seeds share the mazes, so the interval resamples both
        pooled = cluster_bootstrap(maze_table(evaluations, sorted(trials), None))
    elif counted:
        pooled = pooled_rate(sum(seed["successes"] for seed in per_seed), sum(int(n) for n in mazes.values()))
    return {**median_range([seed["rate"] for seed in per_seed]), "per_seed": per_seed, "pooled": pooled}


def _per_seed_figures(trial: Trial, horizon: float, start: float) -> dict[str, float | None]:
    figures = {f"success_at_{budget}_labels": success_at_labels(trial, budget, start) for budget in LABEL_BUDGETS}
    return {
        "final_success": float(trial[-1]["eval_success"]),
        **figures,
        "normalised_auc": normalised_auc(trial, horizon, start),
    }


def summarise(
    rows: Sequence[dict[str, Any]],
    methods: Sequence[str],
    *,
    baseline: str = BASELINE,
    evaluations: Sequence[dict[str, Any]] | None = None,
) -> dict[str, dict[str, Any]]:
    """Summary per method over seeds (see the module docstring for each figure).

    Args:
        rows: Every episode row of one experiment (the columns of ``episodes.csv``).
        methods: Methods to summarise, in order; one without rows gets ``{"seeds": 0}``.
        baseline: The method the others are compared with, when it has rows.
        evaluations: Protocol 2's per-maze outcomes (the rows of ``evaluations.csv``); ``None`` for protocol 1.
    """
    grouped = trials_by_method(rows, methods)
    by_method = {m: [row for row in evaluations or () if row["method"] == m] for m in grouped}
    starts = {
        method: {seed: _untrained(by_method[method], seed) for seed in trials} for method, trials in grouped.items()
    }
    every_trial = [trial for trials in grouped.values() for trial in trials.values()]
    horizon = min((final_labels(trial) for trial in every_trial), default=0.0)
    figures = {
        method: {seed: _per_seed_figures(trial, horizon, starts[method][seed]) for seed, trial in trials.items()}
        if horizon > 0
        else {}
        for method, trials in grouped.items()
    }
    summary: dict[str, dict[str, Any]] = {}
    for method, trials in grouped.items():
        if not trials:
            summary[method] = {"seeds": 0}
            continue
        per_seed = figures[method]
        # Protocol 2: the untrained evaluation counts (a learner at 60% untrained costs 0 labels).
        costs = [
            cost
            for seed, trial in trials.items()
            if (cost := cost_to_reach(trial, start=starts[method][seed] if evaluations else None)) is not None
        ]
        method_rows = [row for trial in trials.values() for row in trial]
        summary[method] = {
            "seeds": len(trials),
            "final_success": final_success(trials, by_method[method]),
            "success_at_labels": {str(budget): _budget_figure(per_seed, budget) for budget in LABEL_BUDGETS},
            "normalised_auc": {
                **median_range([seed["normalised_auc"] for seed in per_seed.values()]),
                "per_seed": [seed["normalised_auc"] for seed in per_seed.values()],
                "label_horizon": horizon,
            },
            "mean_expert_cost_per_episode": float(np.mean([row["expert_cost"] for row in method_rows])),
            "mean_attempts_per_episode": float(np.mean([row["attempts"] for row in method_rows])),
            "cost_to_60_percent": {"median": float(np.median(costs)) if costs else None, "seeds_reached": len(costs)},
            "total_labels": median_range([float(trial[-1]["cumulative_expert_cost"]) for trial in trials.values()]),
        }
        if by_method[method]:
            summary[method]["untrained_success"] = untrained_success(by_method[method], sorted(trials))
        if method != baseline and figures.get(baseline):
            summary[method][f"vs_{baseline}"] = _compare(per_seed, figures[baseline])
    target = summary.get(baseline, {}).get("final_success", {}).get("median")
    if target:  # None without baseline trials; 0 success is no target to match
        matches = {
            method: _labels_to_match(trials, target, starts[method]) for method, trials in grouped.items() if trials
        }
        for method, match in matches.items():
            ratio = _ratio(match["median"], matches[baseline]["median"])
            summary[method][f"labels_to_match_{baseline}"] = {
                **match,
                f"ratio_vs_{baseline}": ratio,
                # How often DAgger itself reaches its own median: below half its seeds, the ratio means little.
                f"{baseline}_seeds_reached": matches[baseline]["seeds_reached"] if baseline in matches else None,
                # Protocol 2: the target and every curve are read on one set; protocol 1: the target is the
                # final set's and the curves' earlier points the periodic set's.
                "same_set": bool(evaluations),
            }
    if evaluations and grouped.get(baseline):
        for method, trials in grouped.items():
            if trials and method != baseline:
                for suffix, count in (("", 1), ("_smoothed", SMOOTHED_TARGET_EVALUATIONS)):
                    summary[method][f"labels_to_match_{baseline}_per_seed{suffix}"] = _paired_labels_to_match(
                        trials, grouped[baseline], starts[method], starts[baseline], target_evaluations=count
                    )
    return summary


def _paired_labels_to_match(
    trials: dict[int, Trial],
    baseline: dict[int, Trial],
    starts: dict[int, float],
    baseline_starts: dict[int, float],
    *,
    target_evaluations: int = 1,
) -> dict[str, Any]:
    """Per seed: labels to the baseline's success on that seed, the method's over the baseline's.

    The target on a seed is the mean of the baseline's last ``target_evaluations`` evaluations there (all of
    them if it has fewer), at most the best of them, so the baseline's curve always reaches it; 1 is its final
    success.
    """
    per_seed, skipped = [], sorted(set(trials) ^ set(baseline))  # a seed only one of the two ran
    for seed in sorted(set(trials) & set(baseline)):
        last = success_curve(baseline[seed])[1][1:][-target_evaluations:]  # [0] is the curve's start, not an evaluation
        # Capped at the best of them: the mean of a plateau (0.72 three times) rounds above it, out of reach.
        target = min(float(np.mean(last)), float(last.max())) if len(last) else 0.0
        if target <= 0:  # a baseline at 0% sets no success to match
            skipped.append(seed)
            continue
        labels = labels_to_reach(trials[seed], target, starts[seed])
        baseline_labels = labels_to_reach(baseline[seed], target, baseline_starts[seed])
        per_seed.append(
            {
                "seed": seed,
                "target": target,
                "labels": labels,
                "baseline_labels": baseline_labels,
                "ratio": _ratio(labels, baseline_labels),
            }
        )
    return {
        # A seed that never reaches its target, or has no finite ratio, ranks above every ratio.
        "median_ratio": _median_never_last([seed["ratio"] for seed in per_seed]),
        "seeds": len(per_seed),
        "seeds_reached": sum(seed["labels"] is not None for seed in per_seed),
        "per_seed": per_seed,
        "skipped_seeds": sorted(skipped),
        "target_evaluations": target_evaluations,
    }


def _median_never_last(values: Sequence[float | None]) -> float | None:
    """The median of ``values``, each ``None`` (never reached) ranked above every number.

    ``None`` if that is the median, or there are no values.
    """
    ranked = np.array([math.inf if value is None else value for value in values])
    median = float(np.median(ranked)) if len(ranked) else math.inf
    return median if math.isfinite(median) else None


def _ratio(labels: float | None, baseline: float | None) -> float | None:
    """``labels / baseline``: 0 labels is a count like any (0 vs DAgger's 40 is 0.0, 0 vs 0 is 1.0).

    ``None`` where either never reaches the target (``None``), or the baseline needs 0 labels and this method more
    (no finite ratio).
    """
    if labels is None or baseline is None:
        return None
    if baseline == 0:
        return 1.0 if labels == 0 else None
    return labels / baseline


def _untrained(evaluations: Sequence[dict[str, Any]], seed: int) -> float:
    """The trial's untrained success (its evaluation at episode 0), 0 where none was made (protocol 1)."""
    at_start = [bool(row["success"]) for row in evaluations if int(row["seed"]) == seed and int(row["episode"]) == 0]
    return float(np.mean(at_start)) if at_start else 0.0


def _labels_to_match(trials: dict[int, Trial], target: float, starts: dict[int, float]) -> dict[str, Any]:
    per_seed = [labels_to_reach(trial, target, starts[seed]) for seed, trial in trials.items()]
    return {
        "target": target,
        # A seed that never reaches the target has spent more labels than any that did: it sorts last.
        "median": _median_never_last(per_seed),
        "per_seed": per_seed,
        "seeds_reached": sum(labels is not None for labels in per_seed),
    }


def _budget_figure(per_seed: dict[int, dict[str, float | None]], budget: int) -> dict[str, Any]:
    values = [seed[f"success_at_{budget}_labels"] for seed in per_seed.values()]
    return {**median_range(values), "per_seed": values, "seeds_reached": sum(value is not None for value in values)}


def _compare(per_seed: dict[int, dict[str, float | None]], baseline: dict[int, dict[str, float | None]]) -> dict:
    comparisons = {}
    for figure in next(iter(per_seed.values())):
        # Pairs: the seeds both methods ran and both reached (a budget beyond a trial's labels is no value).
        seeds = [
            seed
            for seed in sorted(per_seed)
            if seed in baseline and per_seed[seed][figure] is not None and baseline[seed][figure] is not None
        ]
        comparisons[figure] = {
            "seeds": seeds,
            **paired_comparison([per_seed[s][figure] for s in seeds], [baseline[s][figure] for s in seeds]),
        }
    return comparisons
