"""Protocol 3's preregistered readings of the paper's claims (``docs/preregistration.md``), and their verdicts.

Every number the readings decide by comes from ``docs/preregistration.yaml``; the rules are those of the
page's section 6, in code:

* **A reading** is one method on one body (and one target, for label claims). Its effect ``e`` points the
  claimed way when positive: ``direction x (method - DAgger)`` in final success (:func:`success_reading`),
  ``-log(method's labels / DAgger's)`` to a fixed target (:func:`label_readings`), or the share of seeds past
  60% within 100 episodes (:func:`episodes_reading`).
* **Two one-sided p-values** per reading: ``p_for`` (null ``e <= 0``) and ``p_against`` (null ``e >= delta``).
  For success and labels each is the larger of the two-way (seed x task-class) bootstrap's and the per-seed
  Wilcoxon signed-rank test's, so both tests must agree; for claim 4 they are sign tests.
* **A claim** (:func:`claim_p_values`): ``P_for`` = methods x the smallest over methods of the largest
  ``p_for`` over its bodies and targets; ``P_against`` = the largest over methods of cells x the smallest
  ``p_against`` over its bodies and targets.
* **Holm** over every testable claim's ``P_for`` and ``P_against`` together, at ``alpha_one_sided``;
  :func:`verdict` maps the two rejections to holds / does not hold / inconclusive, the same way for every
  claim. Claims the preregistration marks not testable are so whatever the data.

Usage (from the repository root)::

    python -m antmaze_lab.preregistered read results/protocol2/point results/protocol2/ant --json OUT.json
    python -m antmaze_lab.preregistered table OUT.json
    python -m antmaze_lab.preregistered learner TRIALS_DIR [TRIALS_DIR ...] --candidate next_cell_plan [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.experiments.config import LEARNERS, SELECTION_SEED
from antmaze_hirl.experiments.uncertainty import (
    bootstrap_p,
    holm,
    paired_comparison,
    paired_two_way_bootstrap,
    percentile_interval,
    signed_rank_interval,
    signed_rank_p,
    two_way_bootstrap,
)
from antmaze_lab.claims import sign_test
from antmaze_lab.folders import BodyEvaluations, MethodEvaluations, read_body, symmetry_check
from antmaze_lab.selection_trials import (
    SelectionTrial,
    read_selection_trial,
    selection_task_classes,
    trial_files,
    trial_identity,
)

ROOT = Path(__file__).resolve().parents[1]
PREREGISTRATION = ROOT / "docs" / "preregistration.yaml"
FORMAT = "antmaze_hirl.preregistration/1"
HOLDS, DOES_NOT_HOLD, INCONCLUSIVE, NOT_TESTABLE = "holds", "does not hold", "inconclusive", "not testable"
REACH_TOLERANCE = 1e-9
"""A curve reaches a target when its success is >= target - this (rates are k / n in floating point)."""
DRY_RUN_LABEL = (
    "protocol 2's data read with protocol 3's preregistered rules; these rules were written after protocol 2's "
    "figures were seen, so this is not a preregistered test of protocol 2"
)


def load_preregistration(path: Path = PREREGISTRATION) -> dict[str, Any]:
    """The preregistration's YAML, checked for its format and the keys the readings use.

    Raises:
        ValueError: One line naming the file: not YAML, another format, or a missing key.
    """
    try:
        spec = yaml.safe_load(Path(path).read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"{path} is not YAML: {error}") from None
    if not isinstance(spec, dict) or spec.get("format") != FORMAT:
        raise ValueError(f"{path} is not a preregistration of format {FORMAT!r}")
    for key in ("run", "statistics", "effects", "targets", "costs", "claims", "project_goals"):
        if key not in spec:
            raise ValueError(f"{path} has no {key!r}")
    return spec


# ---------------------------------------------------------------- effects


def first_reach(success: np.ndarray, counts: np.ndarray, target: float) -> np.ndarray:
    """Per seed, the count (labels or episodes) at the first evaluation whose success is >= ``target``.

    Args:
        success: ``(seeds, evaluations)`` success rates, in the order of the evaluations.
        counts: ``(seeds, evaluations)`` or ``(evaluations,)`` the count recorded at each evaluation.
        target: The success to reach.

    Returns:
        ``(seeds,)`` counts; ``inf`` for a seed that never reaches the target (no interpolation between
        evaluations).
    """
    reached = np.asarray(success) >= target - REACH_TOLERANCE
    counts = np.broadcast_to(np.asarray(counts, dtype=float), reached.shape)
    first = reached.argmax(axis=1)
    values = counts[np.arange(len(first)), first]
    return np.where(reached.any(axis=1), values, math.inf)


def log_saving(method: np.ndarray, baseline: np.ndarray) -> np.ndarray:
    """Per seed, ``log(baseline / method)`` of counts to a target: > 0 where the method needs fewer.

    Equal counts give 0 (never against never, or 0 against 0); a never against a count gives -inf; a count
    against a never +inf; 0 labels against some gives +inf, and the mirror -inf.
    """
    method, baseline = np.asarray(method, dtype=float), np.asarray(baseline, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        values = np.log(baseline) - np.log(method)
    return np.where(method == baseline, 0.0, values)


def median_effect(values: np.ndarray) -> float:
    """The median of per-seed effects that may be infinite (-inf and +inf in the middle read 0)."""
    with np.errstate(invalid="ignore"):  # -inf + inf in the middle pair: NaN, read as a tie
        median = float(np.median(values))
    return 0.0 if math.isnan(median) else median


@dataclass(frozen=True)
class Reading:
    """One method, body (and target) tested against DAgger, as section 6 of the preregistration reads it.

    Attributes:
        method: The method that stands for the claim.
        body: The body.
        target: The fixed success target (label readings), else ``None``.
        effect: The statistic on the data (mean paired success difference, or median per-seed ``e``), oriented.
        per_seed: Per-seed ``e`` (oriented), paired by seed with DAgger.
        interval: 95% two-way bootstrap percentile interval of the statistic.
        hodges_lehmann: 95% Hodges-Lehmann interval of the per-seed ``e``.
        p_for: ``max(bootstrap, Wilcoxon)`` one-sided p of the null ``e <= 0``.
        p_against: ``max(bootstrap, Wilcoxon)`` one-sided p of the null ``e >= delta``.
        tests: The four component p-values.
        note: What the reading is (e.g. seeds reaching the target).
    """

    method: str
    body: str
    target: float | None
    effect: float
    per_seed: list[float]
    interval: tuple[float, float]
    hodges_lehmann: tuple[float, float]
    p_for: float
    p_against: float
    tests: dict[str, float | None]
    note: str = ""


def _p(value: float | None) -> float:
    return 1.0 if value is None else value


def _reading(
    method: str,
    body: str,
    target: float | None,
    per_seed: np.ndarray,
    distribution: np.ndarray,
    delta: float,
    note: str,
) -> Reading:
    """A reading from its per-seed effects (Wilcoxon) and the bootstrap distribution of its statistic."""
    tests = {
        "bootstrap_for": bootstrap_p(distribution, 0.0, "greater"),
        "bootstrap_against": bootstrap_p(distribution, delta, "less"),
        "wilcoxon_for": signed_rank_p(per_seed, "greater"),
        "wilcoxon_against": signed_rank_p(per_seed - delta, "less"),
    }
    return Reading(
        method=method,
        body=body,
        target=target,
        effect=float("nan"),  # set by the caller, which knows its statistic
        per_seed=[float(v) for v in per_seed],
        interval=percentile_interval(distribution),
        hodges_lehmann=signed_rank_interval(np.clip(per_seed, -1e6, 1e6)),
        p_for=max(tests["bootstrap_for"], _p(tests["wilcoxon_for"])),
        p_against=max(tests["bootstrap_against"], _p(tests["wilcoxon_against"])),
        tests=tests,
        note=note,
    )


def _paired(body: BodyEvaluations, method: str, baseline: str) -> tuple[MethodEvaluations, MethodEvaluations]:
    mine, theirs = body.methods.get(method), body.methods.get(baseline)
    if mine is None or theirs is None:
        raise ValueError(f"{body.folder}: no trials of {method if mine is None else baseline}")
    if mine.seeds != theirs.seeds:
        raise ValueError(f"{body.folder}: {method} has seeds {mine.seeds}, {baseline} {theirs.seeds}: not paired")
    return mine, theirs


def success_reading(
    body: BodyEvaluations, method: str, direction: int, delta: float, stats: dict[str, Any], baseline: str = "dagger"
) -> Reading:
    """Final success of ``method`` against the baseline's, oriented by ``direction`` (+1: the method higher)."""
    mine, theirs = _paired(body, method, baseline)
    table = direction * (mine.outcomes[:, -1].astype(float) - theirs.outcomes[:, -1].astype(float))

    def mean(rows: np.ndarray, weights: np.ndarray) -> float:
        return float((table[rows] @ weights).sum() / (len(rows) * weights.sum()))

    distribution = two_way_bootstrap(
        mean, table.shape[0], body.task_classes, resamples=stats["resamples"], seed=stats["bootstrap_seed"]
    )
    reading = _reading(method, body.body, None, table.mean(axis=1), distribution, delta, "final success")
    return _with_effect(reading, float(table.mean()))


def _with_effect(reading: Reading, effect: float) -> Reading:
    return Reading(**{**asdict(reading), "effect": effect})


def answers(method: str, spec: dict[str, Any]) -> float:
    """Expert answers per recorded label of ``method`` (section 8: honest costs)."""
    return float(spec["costs"]["answers_per_label"].get(method, 1))


def label_readings(
    body: BodyEvaluations, method: str, targets: Sequence[float], spec: dict[str, Any], baseline: str = "dagger"
) -> list[Reading]:
    """Labels (honest answers) to each fixed target, ``method`` against the baseline, one reading per target."""
    mine, theirs = _paired(body, method, baseline)
    delta = -math.log(1 - spec["effects"]["label_saving_share"])
    costs = mine.labels * answers(method, spec), theirs.labels * answers(baseline, spec)

    outcomes = [m.outcomes.astype(float) for m in (mine, theirs)]  # converted once, not per resample

    def effects(rows: np.ndarray, weights: np.ndarray) -> np.ndarray:
        curves = [table[rows] @ weights / weights.sum() for table in outcomes]
        return np.array(
            [
                log_saving(first_reach(curves[0], costs[0][rows], t), first_reach(curves[1], costs[1][rows], t))
                for t in targets
            ]
        )

    stats = spec["statistics"]
    observed = effects(np.arange(len(mine.seeds)), np.ones(len(body.mazes)))
    distribution = two_way_bootstrap(
        lambda rows, weights: [median_effect(row) for row in effects(rows, weights)],
        len(mine.seeds),
        body.task_classes,
        resamples=stats["resamples"],
        seed=stats["bootstrap_seed"],
    )
    readings = []
    for index, target in enumerate(targets):
        reached = int(np.isfinite(first_reach(_curve(mine), costs[0], target)).sum())
        note = f"labels to {100 * target:.1f}%: {reached} of {len(mine.seeds)} seeds reach it"
        reading = _reading(method, body.body, target, observed[index], distribution[:, index], delta, note)
        readings.append(_with_effect(reading, median_effect(observed[index])))
    return readings


def _curve(method: MethodEvaluations) -> np.ndarray:
    """``(seeds, evaluations)`` success on the whole set."""
    return method.outcomes.mean(axis=2)


def episodes_reading(body: BodyEvaluations, method: str, success: float, limit: int) -> dict[str, Any]:
    """Claim 4 on one body: seeds whose learner first scores >= ``success`` after fewer than ``limit`` episodes.

    Returns:
        ``{"method", "body", "passed", "seeds", "episodes" (per seed, None: never), "untrained_median",
        "testable", "p_for", "p_against"}``: the sign tests' P(X >= passed) and P(X <= passed); not testable
        when the median seed's untrained learner already scores >= ``success``.
    """
    evaluations = body.methods[method]
    reached = first_reach(_curve(evaluations), evaluations.episodes, success)
    passed = int((reached < limit).sum())
    _, upper, lower = sign_test(passed, len(reached), 0.05)  # the tails; the level is applied after Holm
    untrained = float(np.median(_curve(evaluations)[:, 0]))
    return {
        "method": method,
        "body": body.body,
        "passed": passed,
        "seeds": len(reached),
        "episodes": [None if math.isinf(v) else float(v) for v in reached],
        "untrained_median": untrained,
        "testable": untrained < success - REACH_TOLERANCE,
        "p_for": upper,
        "p_against": lower,
    }


# ---------------------------------------------------------------- claims and verdicts


def claim_p_values(cells: dict[str, Sequence[tuple[float, float]]]) -> tuple[float, float]:
    """A claim's ``(P_for, P_against)`` from each method's cells' ``(p_for, p_against)`` (bodies x targets).

    The claim holds when some method shows the effect in every cell (intersection over cells: the largest
    ``p_for``; union over methods: Bonferroni, methods x the smallest); it fails when every method fails in
    some cell (union over cells: cells x the smallest ``p_against``; intersection over methods: the largest).

    Raises:
        ValueError: With no method, or a method without cells.
    """
    if not cells or any(len(found) == 0 for found in cells.values()):
        raise ValueError(f"a claim needs methods with cells, got {dict(cells)}")
    p_for = min(1.0, len(cells) * min(max(p for p, _ in found) for found in cells.values()))
    p_against = max(min(1.0, len(found) * min(q for _, q in found)) for found in cells.values())
    return p_for, p_against


def verdict(for_rejected: bool, against_rejected: bool) -> str:
    """A claim's verdict from its two Holm-adjusted rejections (section 6's table, the same for every claim).

    Holds when the claimed direction is shown (even with an effect under ``delta``), does not hold when only
    the claimed effect is ruled out, inconclusive when neither.
    """
    if for_rejected:
        return HOLDS
    return DOES_NOT_HOLD if against_rejected else INCONCLUSIVE


def decide(family: dict[int, tuple[float, float]], alpha: float) -> dict[int, dict[str, Any]]:
    """Holm over every claim's ``P_for`` and ``P_against`` together, then each claim's verdict.

    Args:
        family: ``{claim: (P_for, P_against)}`` of the testable claims.
        alpha: The one-sided level; an adjusted p below it rejects.

    Returns:
        ``{claim: {"p_for", "p_against", "p_for_holm", "p_against_holm", "verdict", "below_delta"}}``;
        ``below_delta`` marks a claim that holds with its effect shown smaller than ``delta``.
    """
    numbers = sorted(family)
    adjusted = holm([p for number in numbers for p in family[number]])
    out = {}
    for index, number in enumerate(numbers):
        p_for, p_against = adjusted[2 * index], adjusted[2 * index + 1]
        found = verdict(p_for < alpha, p_against < alpha)
        out[number] = {
            "p_for": family[number][0],
            "p_against": family[number][1],
            "p_for_holm": p_for,
            "p_against_holm": p_against,
            "verdict": found,
            "below_delta": found == HOLDS and p_against < alpha,
        }
    return out


def _claim_readings(claim: dict[str, Any], bodies: Sequence[BodyEvaluations], spec: dict[str, Any]) -> list[dict]:
    """One claim's readings on every body and method, as dicts (``[]`` for a claim that reads no folder)."""
    methods, baseline = claim["readings"], spec["run"]["baseline"]
    if claim["kind"] == "success":
        share = spec["effects"]["success_share"]
        return [
            asdict(success_reading(b, m, claim["direction"], share, spec["statistics"], baseline))
            for b in bodies
            for m in methods
        ]
    if claim["kind"] == "labels":
        return [asdict(r) for b in bodies for m in methods for r in label_readings(b, m, claim["targets"], spec)]
    if claim["kind"] == "episodes_to_success":
        return [episodes_reading(b, m, claim["success"], claim["episode_limit"]) for b in bodies for m in methods]
    return []


def read_claims(bodies: Sequence[BodyEvaluations], spec: dict[str, Any]) -> dict[str, Any]:
    """Every claim of the preregistration read on one folder per body, with the family's verdicts.

    Returns:
        ``{"claims": [...], "interim": bool}``: per claim its readings, ``P_for``/``P_against`` (raw and
        Holm-adjusted) and verdict; claims marked not testable carry their reason, and claim 5's dense
        variant its own reading outside the family. On an interim folder (a method with fewer than
        ``run.complete_seeds`` seeds) every verdict reads ``interim: no verdict``.
    """
    stats, run = spec["statistics"], spec["run"]
    interim = any(len(m.seeds) < run["complete_seeds"] for body in bodies for m in body.methods.values())
    rows: dict[int, dict[str, Any]] = {}
    family: dict[int, tuple[float, float]] = {}
    for claim in spec["claims"]:
        number, methods = claim["number"], claim["readings"]
        row: dict[str, Any] = {"number": number, "statement": claim["repo_statement"], "quote": claim["quote"]}
        missing = [f"{m} on {b.body}" for b in bodies for m in methods if m not in b.methods]
        row["readings"], cells = [] if missing else _claim_readings(claim, bodies, spec), {}
        if row["readings"]:
            cells = {m: [(r["p_for"], r["p_against"]) for r in row["readings"] if r["method"] == m] for m in methods}
        untestable = [r["body"] for r in row["readings"] if r.get("testable") is False]
        if claim["kind"] == "episodes_to_success" and not missing:  # does it single the claim's methods out?
            baseline = run["baseline"]
            row["for_comparison"] = [
                episodes_reading(b, baseline, claim["success"], claim["episode_limit"]) for b in bodies
            ]
        if claim.get("not_testable"):
            row["verdict"], row["reason"] = NOT_TESTABLE, claim["not_testable"]
            if cells:  # claim 5: the dense variant, read by the same rule, outside the family
                p_for, p_against = claim_p_values(cells)
                row["variant"] = {
                    "what": "the dense-cost-to-go variant, not the paper's claim (outside the family, no Holm)",
                    "p_for": p_for,
                    "p_against": p_against,
                    "verdict": verdict(p_for < stats["alpha_one_sided"], p_against < stats["alpha_one_sided"]),
                }
        elif missing or untestable:
            reason = f"no trials of {', '.join(missing)}" if missing else f"untrained at the target on {untestable}"
            row["verdict"], row["reason"] = NOT_TESTABLE, reason
        else:
            family[number] = claim_p_values(cells)
        rows[number] = row
    for number, decided in decide(family, stats["alpha_one_sided"]).items():
        rows[number].update(decided)
        if interim:
            rows[number]["verdict"] = "interim: no verdict"
    return {"claims": [rows[n] for n in sorted(rows)], "interim": interim, "family_size": 2 * len(family)}


# ---------------------------------------------------------------- the tables beside the claims


def targets_of(body: BodyEvaluations, spec: dict[str, Any]) -> list[float]:
    """Section 7's targets on a body: the fixed ones, then ``oracle_share`` x the oracle's success there."""
    return [*spec["targets"]["fixed_success"], spec["targets"]["oracle_share"] * body.oracle_success]


def _median(values: Sequence[float]) -> float | None:
    """The median of counts where a never is ``inf``; ``None`` (never) when half or more never get there."""
    median = float(np.median(values)) if len(values) else math.inf
    return None if math.isinf(median) else median


def fixed_targets(body: BodyEvaluations, spec: dict[str, Any]) -> dict[str, Any]:
    """Section 7 on one body: per method and target, seeds reaching it, median labels and episodes.

    Every method but DAgger also gets its paired reading against DAgger: the median ratio of labels, its
    two-way bootstrap interval, and ``p_for``/``p_against`` (a saving, as in section 6).
    """
    targets, baseline = targets_of(body, spec), spec["run"]["baseline"]
    out: dict[str, Any] = {"targets": targets, "methods": {}}
    for name, method in body.methods.items():
        curve, labels = _curve(method), method.labels * answers(name, spec)
        rows = []
        for target in targets:
            by_labels, by_episodes = first_reach(curve, labels, target), first_reach(curve, method.episodes, target)
            rows.append(
                {
                    "target": target,
                    "seeds_reaching": int(np.isfinite(by_labels).sum()),
                    "seeds": len(method.seeds),
                    "median_labels": _median(by_labels),
                    "median_episodes": _median(by_episodes),
                }
            )
        if name != baseline:
            for row, reading in zip(rows, label_readings(body, name, targets, spec), strict=True):
                row["vs_dagger"] = {
                    "median_ratio": math.exp(-reading.effect),
                    "ratio_interval_95": [math.exp(-bound) for bound in reversed(reading.interval)],
                    "p_for": reading.p_for,
                    "p_against": reading.p_against,
                }
        out["methods"][name] = {"answers_per_label": answers(name, spec), "targets": rows}
    return out


def per_label_and_episode(body: BodyEvaluations, spec: dict[str, Any]) -> dict[str, Any]:
    """Each method per episode and per label: answers per episode, and median success at equal episodes."""
    out = {}
    for name, method in body.methods.items():
        curve, labels = _curve(method), method.labels * answers(name, spec)
        out[name] = {
            "answers_per_episode": float(np.median(labels[:, -1] / method.episodes[-1])),
            "success_at_episodes": {
                int(episode): float(np.median(curve[:, index])) for index, episode in enumerate(method.episodes)
            },
        }
    return out


def success_by_path_length(body: BodyEvaluations, spec: dict[str, Any]) -> dict[str, Any]:
    """Final success per shortest-path length (cells): mazes, task classes and each method's pooled rate.

    The interval is the two-way bootstrap's, over seeds and the task classes of that length, as every
    other interval of the readings.
    """
    stats, lengths = spec["statistics"], body.path_lengths
    out = {}
    for length in sorted(set(lengths.tolist())):
        columns = lengths == length
        classes = [c for c, keep in zip(body.task_classes, columns, strict=True) if keep]
        row: dict[str, Any] = {"mazes": int(columns.sum()), "task_classes": len(set(classes))}
        for name, method in body.methods.items():
            table = method.outcomes[:, -1][:, columns].astype(float)

            def mean(rows: np.ndarray, weights: np.ndarray, table: np.ndarray = table) -> float:
                return float((table[rows] @ weights).sum() / (len(rows) * weights.sum()))

            drawn = two_way_bootstrap(
                mean, len(table), classes, resamples=stats["resamples"], seed=stats["bootstrap_seed"]
            )
            row[name] = {"rate": float(table.mean()), "interval_95": list(percentile_interval(drawn))}
        out[str(length)] = row
    return out


def paired_success(body: BodyEvaluations, spec: dict[str, Any]) -> dict[str, Any]:
    """Final success against DAgger: the per-seed Wilcoxon beside the two-way bootstrap (task classes, and mazes)."""
    baseline, stats = spec["run"]["baseline"], spec["statistics"]
    out = {}
    for name in body.methods:
        if name == baseline:
            continue
        mine, theirs = _paired(body, name, baseline)
        table = mine.outcomes[:, -1].astype(float) - theirs.outcomes[:, -1].astype(float)
        per_seed = paired_comparison(table.mean(axis=1).tolist(), [0.0] * len(table))
        kwargs = {"resamples": stats["resamples"], "seed": stats["bootstrap_seed"]}
        out[name] = {
            "mean_difference": float(table.mean()),
            "wilcoxon_p": per_seed["wilcoxon_p"],
            "hodges_lehmann_95": list(signed_rank_interval(per_seed["differences"])),
            "two_way_task_classes": paired_two_way_bootstrap(table, body.task_classes, **kwargs),
            "two_way_mazes": paired_two_way_bootstrap(table, None, **kwargs),
        }
    return out


def project_goals(bodies: Sequence[BodyEvaluations], targets: dict[str, Any], spec: dict[str, Any]) -> dict[str, Any]:
    """Section 9, apart from the claims: 0.3x labels at the goal's target, the best method near the oracle."""
    goals = spec["project_goals"]
    level = spec["statistics"]["alpha_one_sided"] / len(goals["saving_methods"])
    saving = {}
    for name in goals["saving_methods"]:
        per_body = {}
        for body in bodies:
            rows = targets[body.body]["methods"].get(name, {}).get("targets", [])
            row = next((r for r in rows if abs(r["target"] - goals["saving_target"]) < REACH_TOLERANCE), None)
            per_body[body.body] = None if row is None else row["vs_dagger"]
        met = all(
            r is not None and r["median_ratio"] <= goals["saving_ratio"] and r["p_for"] < level
            for r in per_body.values()
        )
        saving[name] = {"per_body": per_body, "met": met}
    near = {}
    for body in bodies:
        finals = {name: float(np.median(_curve(m)[:, -1])) for name, m in body.methods.items()}
        best = max(finals, key=finals.get)
        gap = body.oracle_success - finals[best]
        near[body.body] = {"best": best, "final": finals[best], "oracle": body.oracle_success, "gap": gap}
    return {
        "saving": {"methods": saving, "level": level, "met": any(v["met"] for v in saving.values())},
        "near_the_teacher": {
            "bodies": near,
            "met": all(v["gap"] <= goals["oracle_gap_share"] + REACH_TOLERANCE for v in near.values()),
        },
    }


def read_folders(folders: Sequence[Path], spec: dict[str, Any]) -> dict[str, Any]:
    """Everything the preregistration reads, on one results folder per body (in ``run.bodies``' order).

    Raises:
        ValueError: One line naming a folder that is not of its body, or a file it lacks.
    """
    for folder, name in zip(folders, spec["run"]["bodies"], strict=True):  # before the long read
        summary = Path(folder) / "summary.json"
        found = json.loads(summary.read_text())["config"]["body"] if summary.is_file() else None
        if found != name:
            raise ValueError(f"{folder} is of body {found!r}, but it was passed as the {name} folder")
    bodies = [read_body(Path(folder)) for folder in folders]
    protocol = {json.loads((b.folder / "config.json").read_text()).get("protocol") for b in bodies}
    targets = {b.body: fixed_targets(b, spec) for b in bodies}
    return {
        "label": DRY_RUN_LABEL if protocol == {2} else f"protocol {sorted(protocol)} read with its preregistered rules",
        "folders": [str(b.folder) for b in bodies],
        "statistics": spec["statistics"],
        "symmetry": {b.body: symmetry_check(b.folder) for b in bodies},
        **read_claims(bodies, spec),
        "fixed_targets": targets,
        "per_label_and_episode": {b.body: per_label_and_episode(b, spec) for b in bodies},
        "success_by_path_length": {b.body: success_by_path_length(b, spec) for b in bodies},
        "paired_success": {b.body: paired_success(b, spec) for b in bodies},
        "project_goals": project_goals(bodies, targets, spec),
    }


# ---------------------------------------------------------------- the learner-selection check

BEATS, DOES_NOT_BEAT, TOO_FEW_SEEDS, MISSING_BODY = "beats", "does not beat", "too few seeds", "missing body"
NOT_DECIDED = "not decided"


def _selection_body(
    candidate: Sequence[SelectionTrial],
    baseline: Sequence[SelectionTrial],
    spec: dict[str, Any],
    task_classes: Callable[[str, tuple[int, ...]], tuple[str, ...]],
) -> dict[str, Any]:
    """One body's reading of ``learner.beats``: the paired difference's two-way bootstrap interval, or why none.

    Raises:
        ValueError: One line naming the trial files when paired seeds were evaluated on different mazes.
    """
    check, stats = spec["learner"]["selection_check"], spec["statistics"]
    mine, theirs = {t.seed: t for t in candidate}, {t.seed: t for t in baseline}
    seeds = sorted(mine.keys() & theirs.keys())
    out: dict[str, Any] = {
        "seeds": seeds,
        "unpaired_seeds": {
            "candidate": sorted(mine.keys() - theirs.keys()),
            "baseline": sorted(theirs.keys() - mine.keys()),
        },
    }
    if not mine or not theirs:
        return {**out, "verdict": MISSING_BODY, "missing": "candidate" if not mine else "baseline"}
    if len(seeds) < check["min_seeds"]:
        return {**out, "verdict": TOO_FEW_SEEDS}
    first = mine[seeds[0]]
    for trial in [mine[s] for s in seeds] + [theirs[s] for s in seeds]:
        if trial.split != check["split"]:
            raise ValueError(f"{trial.path} was evaluated on the {trial.split!r} part, not {check['split']!r}")
        if trial.maze_seeds[0] != SELECTION_SEED:
            raise ValueError(f"{trial.path}: its mazes start at seed {trial.maze_seeds[0]}, not {SELECTION_SEED}")
        if trial.maze_seeds != first.maze_seeds:
            raise ValueError(f"{trial.path} was evaluated on other selection mazes than {first.path}")
    table = np.array([mine[s].success for s in seeds], dtype=float) - np.array([theirs[s].success for s in seeds])
    if stats["maze_clusters"] == "canonical_task":
        clusters: Sequence[Any] = task_classes(first.body, first.maze_seeds)
    elif stats["maze_clusters"] == "maze":
        clusters = first.maze_seeds
    else:
        raise ValueError(f"statistics.maze_clusters must be canonical_task or maze, got {stats['maze_clusters']!r}")
    drawn = paired_two_way_bootstrap(
        table, clusters, resamples=stats["resamples"], seed=stats["bootstrap_seed"], confidence=stats["confidence"]
    )
    beats = drawn["interval_95"][0] > check["lower_bound_above"]
    return {
        **out,
        "verdict": BEATS if beats else DOES_NOT_BEAT,
        "candidate_success": float(np.mean([mine[s].success.mean() for s in seeds])),
        "baseline_success": float(np.mean([theirs[s].success.mean() for s in seeds])),
        "per_seed_difference": [float(v) for v in table.mean(axis=1)],
        "evaluation_envs": {
            "candidate": sorted({str(mine[s].evaluation_envs) for s in seeds}),
            "baseline": sorted({str(theirs[s].evaluation_envs) for s in seeds}),
        },
        "bootstrap": drawn,
    }


def learner_beats(
    trials: Sequence[SelectionTrial],
    candidate: str,
    spec: dict[str, Any],
    task_classes: Callable[[str, tuple[int, ...]], tuple[str, ...]] = selection_task_classes,
) -> dict[str, Any]:
    """The preregistration's ``learner.beats`` rule: does ``candidate`` beat protocol 2's learner (selection mazes)?

    On each body of ``run.bodies``: the trials of ``candidate`` and of ``learner.protocol2_learner`` with
    ``learner.selection_check.episodes`` training episodes, paired by seed (the seeds both have); the table of
    per-maze paired differences of final learner-only success, ``seeds x selection mazes``; its two-way bootstrap
    (seeds and maze clusters resampled, ``statistics``' resamples, seed, confidence and clusters: tasks up to
    symmetry come from ``task_classes(body, maze_seeds)``, the mazes drawn again by default). A body reads
    **beats** when the interval's lower bound is above ``lower_bound_above`` (0), **does not beat** otherwise,
    **too few seeds** with fewer than ``min_seeds`` paired seeds, **missing body** without trials of one learner.

    The check is read only with every body complete: while some body has too few seeds or misses a learner, it is
    **not decided** (and says why), whatever the other bodies read. Then the candidate **beats** protocol 2's
    learner when it beats it on every body, and **does not beat** it otherwise.

    Returns:
        ``{"candidate", "baseline", "episodes", "min_seeds", "verdict", "reason", "bodies": {body: {...}},
        "left_out"}``; ``left_out`` counts the trials of the two learners with another number of episodes.
    """
    check, baseline = spec["learner"]["selection_check"], spec["learner"]["protocol2_learner"]
    if candidate == baseline:
        raise ValueError(f"the candidate must differ from protocol 2's learner, got {candidate!r} for both")
    learners = (candidate, baseline)
    chosen = [t for t in trials if t.variant in learners and t.episodes == check["episodes"]]
    seen: dict[tuple[str, str, int], Path] = {}
    for trial in chosen:
        key = (trial.body, trial.variant, trial.seed)
        if key in seen:
            raise ValueError(f"{trial.path} and {seen[key]} are both {trial.body} {trial.variant} seed {trial.seed}")
        seen[key] = trial.path
    bodies = {}
    for body in spec["run"]["bodies"]:
        of = {name: [t for t in chosen if t.body == body and t.variant == name] for name in learners}
        bodies[body] = _selection_body(of[candidate], of[baseline], spec, task_classes)
    verdicts = {body: found["verdict"] for body, found in bodies.items()}
    short = [f"{b}: {v}" for b, v in verdicts.items() if v in (TOO_FEW_SEEDS, MISSING_BODY)]
    if short:  # read on every body complete, never on part of the trials (no optional stopping)
        overall, reason = NOT_DECIDED, "; ".join(short)
    elif all(v == BEATS for v in verdicts.values()):
        overall, reason = BEATS, "the lower bound is above 0 on every body"
    else:
        overall = DOES_NOT_BEAT
        reason = "the lower bound is not above 0 on " + ", ".join(b for b, v in verdicts.items() if v == DOES_NOT_BEAT)
    return {
        "candidate": candidate,
        "baseline": baseline,
        "episodes": check["episodes"],
        "min_seeds": check["min_seeds"],
        "verdict": overall,
        "reason": reason,
        "bodies": bodies,
        "left_out": sum(t.variant in learners and t.episodes != check["episodes"] for t in trials),
    }


def read_selection_trials(
    paths: Sequence[Path], learners: Sequence[str], *, episodes: int | None = None
) -> tuple[list[SelectionTrial], int]:
    """The trial files of ``learners`` among ``paths`` (folders of ``*.json``, or files), read per maze.

    Files of other learners, and (with ``episodes``) files of ``learners`` trained for another number of episodes,
    are skipped unread past their identity, so they need no per-maze outcomes.

    Returns:
        The trials read, and how many files of ``learners`` were skipped for their episodes.

    Raises:
        ValueError: One line naming the file (see :func:`~antmaze_lab.selection_trials.read_selection_trial`).
    """
    read, skipped = [], 0
    for path in trial_files(paths):
        _, variant, _, trained = trial_identity(path)
        if variant not in learners:
            continue
        if episodes is not None and trained != episodes:
            skipped += 1
            continue
        read.append(read_selection_trial(path))
    return read, skipped


def format_selection(found: dict[str, Any]) -> str:
    """The learner-selection check as a few Markdown lines."""
    lines = [
        f"`{found['candidate']}` against protocol 2's `{found['baseline']}` on the selection mazes, "
        f"{found['episodes']} episodes, >= {found['min_seeds']} paired seeds per body: **{found['verdict']}** "
        f"({found['reason']})."
    ]
    for body, row in found["bodies"].items():
        text = f"- {body}: {row['verdict']}; paired seeds {row['seeds']}"
        if "bootstrap" in row:
            low, high = row["bootstrap"]["interval_95"]
            text += (
                f"; {100 * row['candidate_success']:.1f}% against {100 * row['baseline_success']:.1f}%, "
                f"{_pts(row['bootstrap']['mean'])} pts [{_pts(low)}, {_pts(high)}] over "
                f"{row['bootstrap']['seeds']} seeds and {row['bootstrap']['mazes']} mazes "
                f"({row['bootstrap']['clusters']} clusters)"
            )
        lines.append(text)
    return "\n".join(lines)


# ---------------------------------------------------------------- the report


def _git_commit(path: Path) -> str:
    """The last commit that changed ``path`` (``not recorded`` outside a git checkout)."""
    import subprocess

    try:
        found = subprocess.run(
            ["git", "log", "-1", "--format=%h", "--", str(path)], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        found = ""
    return found or "not recorded"


def _pts(value: float) -> str:
    return f"{100 * value:+.1f}"


def _pv(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2g}"


def _ratio(value: float) -> str:
    return "never" if math.isinf(value) or value > 1e6 else f"{value:.2f}x"


def _reading_text(reading: dict[str, Any]) -> str:
    head = f"{reading['body']} `{reading['method']}`"
    tests = f"p {_pv(reading['p_for'])} / {_pv(reading['p_against'])}"
    if "passed" in reading:
        return f"{head}: {reading['passed']} of {reading['seeds']} seeds, {tests}"
    low, high = reading["interval"]
    if reading["target"] is None:
        return f"{head}: {_pts(reading['effect'])} pts [{_pts(low)}, {_pts(high)}], {tests}"
    ratio = math.exp(-reading["effect"])
    bounds = f"[{_ratio(math.exp(-high))}, {_ratio(math.exp(-low))}]"
    return f"{head} to {100 * reading['target']:.0f}%: {_ratio(ratio)} DAgger's labels {bounds}, {tests}"


def _claims_table(report: dict[str, Any]) -> list[str]:
    lines = [
        "| # | the claim (the repository's words; the paper's: the preregistration, section 1) | readings: effect, + "
        "the claimed way [two-way 95% interval], p_for / p_against | P_for, P_against after Holm | verdict |",
        "|---|---|---|---|---|",
    ]
    for claim in report["claims"]:
        readings = "<br>".join(_reading_text(r) for r in claim["readings"]) or "none"
        if claim.get("for_comparison"):
            readings += "<br>for comparison, not in the verdict: " + "; ".join(
                _reading_text(r) for r in claim["for_comparison"]
            )
        if "p_for_holm" in claim:
            holm_text = f"{_pv(claim['p_for_holm'])}, {_pv(claim['p_against_holm'])}"
        else:
            holm_text = "not in the family"
        word = claim["verdict"]
        if claim.get("below_delta"):
            word += " (effect below delta)"
        if "reason" in claim:
            word += f" ({claim['reason']})"
        if "variant" in claim:
            word += f"; {claim['variant']['what']}: {claim['variant']['verdict']}"
        lines.append(f"| {claim['number']} | {claim['statement']} | {readings} | {holm_text} | **{word}** |")
    return lines


def _targets_table(report: dict[str, Any], body: str) -> list[str]:
    found = report["fixed_targets"][body]
    names = [f"{100 * t:.0f}%" for t in found["targets"][:-1]] + [
        f"95% of the oracle ({100 * found['targets'][-1]:.1f}%)"
    ]
    lines = [
        f"| {body}: method (answers per label); seeds reaching, median labels and episodes, median paired ratio "
        "of labels to DAgger's | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(names),
    ]
    dagger = found["methods"]["dagger"]["targets"]
    for name, method in sorted(found["methods"].items()):
        cells = []
        for row in method["targets"]:
            text = f"{row['seeds_reaching']}/{row['seeds']}"
            if row["median_labels"] is None:
                text += "; never"
            else:
                text += f"; {row['median_labels']:.0f} labels, {row['median_episodes']:.0f} ep."
            if "vs_dagger" in row and None not in (row["median_labels"], dagger[len(cells)]["median_labels"]):
                text += f"; {_ratio(row['vs_dagger']['median_ratio'])}"
            cells.append(text)
        lines.append(f"| `{name}` ({method['answers_per_label']:g}) | " + " | ".join(cells) + " |")
    return lines


def _paired_table(report: dict[str, Any]) -> list[str]:
    lines = [
        "| body | method | mean difference, pts | per-seed Wilcoxon p (two-sided) | Hodges-Lehmann 95% | "
        "two-way bootstrap 95%, task classes (p) | two-way bootstrap 95%, mazes (p) |",
        "|---|---|---|---|---|---|---|",
    ]
    for body, methods in report["paired_success"].items():
        for name, row in sorted(methods.items()):
            hl = "[" + ", ".join(_pts(v) for v in row["hodges_lehmann_95"]) + "]"
            ways = [
                f"[{_pts(w['interval_95'][0])}, {_pts(w['interval_95'][1])}] ({_pv(w['p_two_sided'])})"
                for w in (row["two_way_task_classes"], row["two_way_mazes"])
            ]
            lines.append(
                f"| {body} | `{name}` | {_pts(row['mean_difference'])} | {_pv(row['wilcoxon_p'])} | {hl} | "
                f"{ways[0]} | {ways[1]} |"
            )
    return lines


def _path_table(report: dict[str, Any], body: str) -> list[str]:
    rows = report["success_by_path_length"][body]
    methods = sorted(k for k in next(iter(rows.values())) if k not in ("mazes", "task_classes"))
    lines = [
        f"| {body}: path (cells) | mazes (task classes) | " + " | ".join(f"`{m}`" for m in methods) + " |",
        "|---|---|" + "---|" * len(methods),
    ]
    for length, row in rows.items():
        cells = " | ".join(f"{100 * row[m]['rate']:.0f}%" for m in methods)
        lines.append(f"| {length} | {row['mazes']} ({row['task_classes']}) | {cells} |")
    return lines


def format_report(report: dict[str, Any]) -> str:
    """The report's Markdown: its label, the symmetry re-check, the claims, fixed targets, paired success, paths."""
    lines = [f"**{report['label'][0].upper()}{report['label'][1:]}.**", ""]
    lines.append(
        f"Rules: `docs/preregistration.yaml` at commit `{report['preregistration']['commit']}`; two-way bootstrap of "
        f"{report['statistics']['resamples']:,} resamples over seeds and task classes; one-sided level "
        f"{report['statistics']['alpha_one_sided']}, Holm over {report['family_size']} hypotheses."
    )
    lines.append("")
    for body, check in report["symmetry"].items():
        lines.append(
            f"- {body}: {check['training_mazes']} training mazes, {check['evaluation_mazes']} evaluation mazes = "
            f"{check['evaluation_tasks_up_to_symmetry']} tasks and {check['evaluation_wall_grids_up_to_symmetry']} "
            f"wall grids up to symmetry; shared with training: {check['shared_wall_grids']} wall grids, "
            f"{check['shared_tasks']} tasks; grids outside their part: "
            f"{check['training_grids_outside_train'] + check['evaluation_grids_outside_eval']}: "
            + ("**disjoint**" if check["disjoint"] else "**NOT disjoint**")
        )
    lines += ["", *_claims_table(report), ""]
    for body in report["fixed_targets"]:
        lines += [*_targets_table(report, body), ""]
    lines += [*_paired_table(report), ""]
    for body in report["success_by_path_length"]:
        lines += [*_path_table(report, body), ""]
    goals = report["project_goals"]
    near = "; ".join(
        f"{body} `{v['best']}` {100 * v['final']:.1f}% vs the oracle's {100 * v['oracle']:.1f}%"
        for body, v in goals["near_the_teacher"]["bodies"].items()
    )
    lines.append(
        "The project's goals (not the paper's claims): 0.3x DAgger's labels to 90% at p < "
        f"{goals['saving']['level']:.3g}: **{'met' if goals['saving']['met'] else 'missed'}**; the best method within "
        f"2 points of the oracle ({near}): **{'met' if goals['near_the_teacher']['met'] else 'missed'}**."
    )
    return "\n".join(lines)


def _spec(args: argparse.Namespace) -> dict[str, Any]:
    """The preregistration a command reads, with ``--resamples`` applied.

    Raises:
        ValueError: From :func:`load_preregistration`, or ``--resamples`` below 100.
    """
    spec = load_preregistration(args.preregistration)
    if args.resamples is not None:
        if args.resamples < 100:
            raise ValueError(f"--resamples must be >= 100, got {args.resamples}")
        spec["statistics"]["resamples"] = args.resamples
    return spec


def _shown(path: Path) -> str:
    """``path`` relative to the repository root where it lies inside it (no machine's path in a committed file)."""
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


def _learner_command(args: argparse.Namespace) -> int:
    """``learner``: print the learner-selection check (and write it with ``--json``); 2 on bad input."""
    try:
        spec = _spec(args)
        if args.candidate not in LEARNERS:
            raise ValueError(f"unknown learner {args.candidate!r}; choose from {sorted(LEARNERS)}")
        learners = (args.candidate, spec["learner"]["protocol2_learner"])
        episodes = spec["learner"]["selection_check"]["episodes"]
        trials, skipped = read_selection_trials(args.trials, learners, episodes=episodes)
        found = learner_beats(trials, args.candidate, spec)
        found["left_out"] += skipped
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if args.json is not None:
        found["preregistration"] = {"path": _shown(args.preregistration), "commit": _git_commit(args.preregistration)}
        atomic_write_json(args.json, found)
    print(format_selection(found))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``read`` folders into a JSON report (and print its table), or print the ``table`` of a report."""
    parser = argparse.ArgumentParser(prog="python -m antmaze_lab.preregistered", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    read = commands.add_parser("read", help="read one results folder per body (point, ant) and write the report")
    read.add_argument("folders", nargs=2, type=Path, metavar="FOLDER")
    read.add_argument("--json", type=Path, required=True, help="the report to write")
    read.add_argument("--preregistration", type=Path, default=PREREGISTRATION)
    read.add_argument("--resamples", type=int, default=None, help="bootstrap resamples (default: the YAML's)")
    table = commands.add_parser("table", help="print the Markdown table of a report")
    table.add_argument("report", type=Path)
    learner = commands.add_parser(
        "learner", help="the learner-selection check (learner.beats) on learner-ablation trial files"
    )
    learner.add_argument("trials", nargs="+", type=Path, metavar="TRIALS", help="trial files or folders (required)")
    learner.add_argument("--candidate", required=True, help="the candidate learner's variant name (required)")
    learner.add_argument("--json", type=Path, default=None, help="write the check here (default: print only)")
    learner.add_argument("--preregistration", type=Path, default=PREREGISTRATION, help="(default: the committed one)")
    learner.add_argument("--resamples", type=int, default=None, help="bootstrap resamples (default: the YAML's)")
    args = parser.parse_args(argv)
    if args.command == "learner":
        return _learner_command(args)
    try:
        if args.command == "table":
            if not args.report.is_file():
                raise ValueError(f"no report at {args.report}")
            print(format_report(json.loads(args.report.read_text())))
            return 0
        spec = _spec(args)
        report = read_folders(args.folders, spec)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    path = args.preregistration.resolve()
    shown = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    report["preregistration"] = {"path": str(shown), "commit": _git_commit(path)}
    report["code_commit"] = _git_commit(Path(__file__))  # the last commit of this module
    report["command"] = "python -m antmaze_lab.preregistered " + " ".join(argv if argv is not None else sys.argv[1:])
    atomic_write_json(args.json, report)
    print(format_report(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
