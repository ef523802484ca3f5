"""Learning per label: one trial's learner-only success as a function of cumulative expert labels.

A trial's curve joins its evaluations ``(cumulative_expert_cost, eval_success)`` by straight lines. It
starts at ``(0, start_success)``: in protocol 2 the untrained learner's measured success on the same
mazes (``ExperimentConfig.protocol``); in protocol 1, where the untrained learner was not evaluated,
at ``(0, 0)``, which hides a learner that solves the mazes before its first label. Read off it are the
success at a fixed label budget and the normalised area under the curve, figures that, unlike "labels
to first reach 60%", do not reward a method for short episodes alone: a method that spends fewer labels
per episode but learns no more per label has the same curve.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

LABEL_BUDGETS = (100, 200, 400)
"""Label budgets at which ``summary.json`` reports success."""


def success_curve(trial: Sequence[dict[str, Any]], start_success: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The curve's points: labels (from 0) and success, one point per evaluation plus ``(0, start_success)``.

    Args:
        trial: One trial's rows in episode order (``cumulative_expert_cost``, ``eval_success``; NaN
            where the episode was not evaluated).
        start_success: The untrained learner's success (protocol 2's evaluation before the first
            episode); 0 where it was not measured (protocol 1).
    """
    evaluated = [row for row in trial if not math.isnan(row["eval_success"])]
    labels = np.array([0.0] + [float(row["cumulative_expert_cost"]) for row in evaluated])
    success = np.array([float(start_success)] + [float(row["eval_success"]) for row in evaluated])
    return labels, success


def final_labels(trial: Sequence[dict[str, Any]]) -> float:
    """Labels at the trial's last evaluation: how far its curve reaches."""
    return float(success_curve(trial)[0][-1])


def success_at_labels(trial: Sequence[dict[str, Any]], budget: float, start_success: float = 0.0) -> float | None:
    """Success at ``budget`` labels, linearly interpolated; ``None`` if the trial's curve ends before it.

    Raises:
        ValueError: If ``budget`` is not > 0.
    """
    curve = _curve_reaching(trial, budget, "label budget", start_success)
    return None if curve is None else float(np.interp(budget, *curve))


def labels_to_reach(trial: Sequence[dict[str, Any]], target: float, start_success: float = 0.0) -> float | None:
    """Labels where the curve first reaches ``target`` success, linearly interpolated; ``None`` if it never does.

    Interpolated like :func:`success_at_labels`, so a method is not charged for the labels between its
    last evaluation below ``target`` and its first at or above it. 0 if the untrained learner
    (``start_success``) already reaches it.

    Raises:
        ValueError: If ``target`` is not in ``(0, 1]``.
    """
    if not 0 < target <= 1:
        raise ValueError(f"target success must lie in (0, 1], got {target}")
    labels, success = success_curve(trial, start_success)
    reached = np.flatnonzero(success >= target)
    if not len(reached):
        return None
    after = int(reached[0])
    if after == 0:
        return 0.0
    before = after - 1
    fraction = (target - success[before]) / (success[after] - success[before])
    return float(labels[before] + fraction * (labels[after] - labels[before]))


def normalised_auc(trial: Sequence[dict[str, Any]], horizon: float, start_success: float = 0.0) -> float | None:
    """Area under the curve over ``[0, horizon]`` labels divided by ``horizon`` (in ``[0, 1]``).

    1 means success 100% from the first label on. ``None`` if the curve ends before ``horizon``.

    Raises:
        ValueError: If ``horizon`` is not > 0.
    """
    curve = _curve_reaching(trial, horizon, "label horizon", start_success)
    if curve is None:
        return None
    labels, success = curve
    inside = labels < horizon
    x = np.append(labels[inside], horizon)
    y = np.append(success[inside], np.interp(horizon, labels, success))
    return float(np.trapezoid(y, x) / horizon)


def _curve_reaching(
    trial: Sequence[dict[str, Any]], labels: float, what: str, start_success: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """The trial's curve if it reaches ``labels`` (validated as ``what``), else ``None``."""
    if not labels > 0:
        raise ValueError(f"{what} must be > 0, got {labels}")
    curve = success_curve(trial, start_success)
    return curve if labels <= curve[0][-1] else None
