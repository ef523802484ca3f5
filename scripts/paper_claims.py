"""The paper's claims, one by one, against the committed results folders (issue 32).

**Protocol 1** (the default, ``python scripts/paper_claims.py [--folders A,B]``): the figures that the
hand-written table of ``docs/paper-claims.md`` quotes, per body and method, from the old folders
(``results/paper_experiment/{point,ant}``, with the flaws of issue 32's audit). It prints final
success (median, min-max over seeds, the paired Wilcoxon p against DAgger), labels per trial, labels to
DAgger's median final success and that ratio, the training episodes and labels at which each trial's
learner first scored >= 60% on a periodic evaluation, and the share of labels that reward-based pruning
removed.

**Protocol 2** (``--protocol2 POINT_FOLDER ANT_FOLDER [--json OUT]``): the claims table with its
verdicts, computed from each folder's ``summary.json`` (and ``episodes.csv`` where the folder has it). It
prints one markdown row per claim: the claim, what was measured on each body, and the verdict.

Verdict rules (protocol 2). A "reading" is one method that stands for the claim on one body:

* **A comparison with DAgger.** The per-seed figures are paired by seed. The test is the two-sided
  Wilcoxon signed-rank test. The interval is the 95% Hodges-Lehmann interval of the paired differences
  (from the Walsh averages; unbounded with 5 pairs or fewer). A body *supports* the claim when the
  median difference points the claimed way and p < the threshold. It *contradicts* the claim when the
  median difference points the other way with p < the threshold, or when the interval excludes the
  claimed effect. The claimed effects are 5 points of final success for "beats" and "worse", and, for
  labels, 10% of DAgger's median labels per trial. Otherwise the body is *undecided*.
* **Thresholds.** p < 0.05, divided by the number of methods that one claim tries (Bonferroni). The two
  reward-based readings, ``reward`` and ``reward_per_step`` (Alg. 4 as written), give 0.025. The five
  active methods of claim 6 give 0.01. With n pairs the exact test cannot go below 2 / 2**n: 0.0625 with
  5 pairs, 0.0039 with 9, 0.0020 with 10.
* **Labels** are the labels at which a seed's curve first reaches DAgger's median final success, on the
  same evaluation set (``labels_to_match_dagger``). A seed that never reaches it counts as more labels
  than any seed that does (1e9 in the test), as in ``summary.json``'s median. Two such seeds tie.
* **Claim 4** has no paired test. A seed passes if its learner's first evaluation at >= 60% comes after
  fewer than 100 training episodes (from ``episodes.csv``). A seed whose untrained learner already scores
  >= 60% passes at 0 episodes. If the median seed's untrained learner does, the claim is *not testable*:
  the curve starts where the claim ends. The one-sided sign test of k passing seeds out of n supports the
  claim when P(X >= k) < the threshold. It contradicts it when P(X <= k) < the threshold. A folder without
  ``episodes.csv`` has no episode counts, only ``summary.json``'s labels. There it can only contradict the
  claim (seeds that never pass within the trial).
* **Claim 6** is supported on a body when some active method reaches DAgger's final success with a median
  ratio of labels <= 0.3x DAgger's, and its labels beat DAgger's in the paired test at 0.01. It is
  contradicted when, for every active method, the 95% interval of the paired differences
  ``labels - 0.3 x DAgger's labels`` lies above 0.
* **Labels (claims 2 and 6)** are read paired by seed where the summary has ``labels_to_match_dagger_per_seed``
  (protocol-2 summaries written since it exists): each seed's target is its own DAgger final success, which
  DAgger always reaches. Older summaries read DAgger's median final success as the target.
* **A claim** holds when every body supports it. It does not hold when some body contradicts it.
  Otherwise it is inconclusive. With several readings, the claim holds when one reading holds, and does
  not hold when every reading does not hold.
* **Claim 5's** ``aggrevate`` uses the oracle's dense cost-to-go, not the paper's sparse reward. DAgger
  beating it is evidence for the claim, since the sparse-reward version can only do worse. The dense
  version beating DAgger decides nothing about the sparse one: that verdict is *not testable here*.
* **Claim 7** is not testable without people.
* **Interim folders.** A folder where some method has fewer than 10 seeds (the issue's count) is
  INTERIM. No verdict on it is final: a row reads "interim: leaning <verdict>". The leaning is the verdict
  where the tests already decide it. Otherwise it is the direction of the data: "holds (direction only)"
  when the median points the claimed way on every body of some reading, "does not hold (direction only)"
  when it points the other way on some body of every reading, else "inconclusive".

Usage:
  python scripts/paper_claims.py                       # protocol 1, the committed folders
  python scripts/paper_claims.py --protocol2 results/protocol2/interim/point \\
      results/protocol2/interim/ant --json claims.json
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import binom

from antmaze_hirl.experiments.results_folder import read_rows, read_summary
from antmaze_hirl.experiments.summary import TARGET_SUCCESS, median_range, trials_by_method
from antmaze_hirl.experiments.uncertainty import paired_comparison

RESULTS = Path(__file__).resolve().parents[1] / "results" / "paper_experiment"
FOLDERS = [RESULTS / "point", RESULTS / "ant"]
BODIES = ("point", "ant")

ALPHA = 0.05
"""The two-sided test level of one claim, before it is split over the methods that claim tries."""
FULL_SEEDS = 10
"""Seeds per method that issue 32 asks for; a folder with fewer in some method is INTERIM."""
SUCCESS_EFFECT = 0.05
"""The smallest difference in final success (a share: 5 points) that "beats" or "worse" claims."""
LABEL_EFFECT = 0.10
"""The smallest saving of labels that "beats in labels" claims, as a share of DAgger's median labels per trial."""
SAVING_RATIO = 0.3
"""Claim 6: an active method's labels to match DAgger, at most this multiple of DAgger's own."""
EPISODE_LIMIT = 100
"""Claim 4: the learner passes 60% after fewer than this many training episodes."""
NEVER = 1e9
"""The labels of a seed that never reaches the target, in the tests: more than any seed that does."""
REWARD_BASED = ("reward", "reward_per_step")
ACTIVE = ("noise", "multi_policy", "reward", "reward_per_step", "gated")
BASELINE = "dagger"

SUPPORTS, CONTRADICTS, UNDECIDED, UNTESTABLE = "supports", "contradicts", "undecided", "untestable"
HOLDS, DOES_NOT_HOLD, INCONCLUSIVE, NOT_TESTABLE = "holds", "does not hold", "inconclusive", "not testable here"


def first_at(trial: list[dict], target: float = TARGET_SUCCESS) -> tuple[float, float] | None:
    """Training episodes and labels at the trial's first evaluation with success >= ``target``."""
    for row in trial:
        if not math.isnan(row["eval_success"]) and row["eval_success"] >= target:
            return float(row["episode"] + 1), float(row["cumulative_expert_cost"])
    return None


def claims(folder: Path) -> dict:
    """The protocol-1 figures of one results folder."""
    summary = json.loads((folder / "summary.json").read_text())
    rows = read_rows(folder / "episodes.csv")
    methods = [m for m, f in summary["methods"].items() if f.get("seeds")]
    grouped = trials_by_method(rows, methods)
    out = {"folder": str(folder), "config": summary["config"], "methods": {}}
    for method in methods:
        figures = summary["methods"][method]
        trials = grouped[method]
        reached = [first_at(trial) for trial in trials.values()]
        removed = sum(int(row["removed"]) for trial in trials.values() for row in trial)
        labels = sum(int(trial[-1]["cumulative_expert_cost"]) for trial in trials.values())
        match = figures.get("labels_to_match_dagger", {})
        out["methods"][method] = {
            "seeds": figures["seeds"],
            "final_success": {k: figures["final_success"][k] for k in ("median", "min", "max")},
            "final_success_p_vs_dagger": figures.get("vs_dagger", {}).get("final_success", {}).get("wilcoxon_p"),
            "total_labels": figures["total_labels"],
            "labels_to_match_dagger": {k: match.get(k) for k in ("target", "median", "seeds_reached")},
            "labels_ratio_vs_dagger": match.get("ratio_vs_dagger"),
            "episodes_to_60_percent": median_range([r[0] if r else None for r in reached]),
            "labels_to_60_percent": median_range([r[1] if r else None for r in reached]),
            "trials_reaching_60_percent": sum(r is not None for r in reached),
            "labels_removed_by_pruning": removed,
            "labels_spent": labels,
        }
    return out


# ---------------------------------------------------------------- protocol 2: statistics


def smallest_p(pairs: int) -> float:
    """The smallest two-sided p the exact Wilcoxon signed-rank test can give with ``pairs`` pairs: 2 / 2**n."""
    return min(1.0, 2.0 ** (1 - pairs))


def signed_rank_interval(differences: Sequence[float], confidence: float = 0.95) -> tuple[float, float]:
    """The Hodges-Lehmann interval of paired differences: order statistics of their Walsh averages.

    The bounds are the k-th smallest and the k-th largest of the n(n+1)/2 averages ``(d_i + d_j) / 2``
    (i <= j). k is the largest count whose exact signed-rank tail P(T <= k - 1) is <= (1 - confidence) / 2:
    the interval that inverts the Wilcoxon test. Where no k >= 1 qualifies (5 pairs or fewer at 95%), it
    is ``(-inf, inf)``: so few pairs exclude nothing.

    Raises:
        ValueError: If ``confidence`` is not in (0, 1).
    """
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    values = np.asarray(differences, dtype=float)
    n = len(values)
    counts = np.ones(1)  # counts[t]: subsets of the ranks 1..n with rank sum t, the null distribution of T+
    for rank in range(1, n + 1):
        counts = np.append(counts, np.zeros(rank)) + np.append(np.zeros(rank), counts)
    tail = np.cumsum(counts) / 2.0**n
    k = int(np.count_nonzero(tail <= (1 - confidence) / 2))  # tail[k - 1] = P(T <= k - 1)
    if k == 0:
        return -math.inf, math.inf
    walsh = np.sort([(values[i] + values[j]) / 2 for i in range(n) for j in range(i, n)])
    return float(walsh[k - 1]), float(walsh[len(walsh) - k])


@dataclass(frozen=True)
class Comparison:
    """A paired comparison of one method with DAgger on one body, and what it says of the claim.

    Attributes:
        outcome: ``supports``, ``contradicts`` or ``undecided`` (module docstring).
        toward: +1 if the median difference points the claimed way, -1 the other way, 0 neither.
        pairs: Seeds paired.
        median_difference: Median of method - DAgger (``None`` without pairs).
        p_value: Two-sided Wilcoxon p (``None`` with fewer than 2 pairs).
        interval: 95% Hodges-Lehmann interval of the differences.
    """

    outcome: str
    toward: int
    pairs: int
    median_difference: float | None
    p_value: float | None
    interval: tuple[float, float]


def compare(differences: Sequence[float], direction: int, effect: float, alpha: float) -> Comparison:
    """What paired differences (method - DAgger) say of a claim that they point ``direction``.

    Args:
        differences: Per-seed differences, method - DAgger.
        direction: +1 if the claim is that the method's figure is higher, -1 lower.
        effect: The smallest claimed size of the difference (> 0, in the figure's units).
        alpha: The threshold of the test.

    Raises:
        ValueError: If ``direction`` is not +1 or -1, or ``effect`` is not > 0.
    """
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction}")
    if not effect > 0:
        raise ValueError(f"effect must be > 0, got {effect}")
    test = paired_comparison(list(differences), [0.0] * len(differences))
    interval = signed_rank_interval(differences)
    median, p_value = test["median_difference"], test["wilcoxon_p"]
    toward = 0 if median is None else int(np.sign(direction * median))
    significant = p_value is not None and p_value < alpha
    # The interval excludes the claimed effect: at 95%, the difference falls short of it in the claimed direction.
    excluded = interval[1] < effect if direction > 0 else interval[0] > -effect
    if significant and toward > 0:
        outcome = SUPPORTS
    elif (significant and toward < 0) or excluded:
        outcome = CONTRADICTS
    else:
        outcome = UNDECIDED
    return Comparison(outcome, toward, test["pairs"], median, p_value, interval)


def sign_test(passed: int, seeds: int, alpha: float) -> tuple[str, float, float]:
    """Claim 4's one-sided sign tests of ``passed`` of ``seeds``: the outcome, P(X >= k) and P(X <= k) at 1/2."""
    upper, lower = float(binom.sf(passed - 1, seeds, 0.5)), float(binom.cdf(passed, seeds, 0.5))
    outcome = SUPPORTS if upper < alpha else CONTRADICTS if lower < alpha else UNDECIDED
    return outcome, upper, lower


@dataclass(frozen=True)
class Finding:
    """What one reading on one body says of a claim.

    Attributes:
        outcome: ``supports``, ``contradicts``, ``undecided`` or ``untestable``.
        toward: +1 if the data point the claimed way, -1 the other way, 0 neither (for the interim leaning).
        text: The measurement, in words.
    """

    outcome: str
    toward: int
    text: str


def combine_bodies(findings: Sequence[Finding]) -> tuple[str, int]:
    """One reading's verdict from its bodies and its leaning (+1, -1 or 0) by direction.

    Holds if every body supports it, does not hold if one contradicts it, not testable if one is untestable.
    """
    outcomes = [finding.outcome for finding in findings]
    if UNTESTABLE in outcomes:
        verdict = NOT_TESTABLE
    elif CONTRADICTS in outcomes:
        verdict = DOES_NOT_HOLD
    else:
        verdict = HOLDS if outcomes and all(outcome == SUPPORTS for outcome in outcomes) else INCONCLUSIVE
    towards = [finding.toward for finding in findings]
    lean = 1 if towards and min(towards) > 0 else -1 if any(toward < 0 for toward in towards) else 0
    return verdict, lean


def combine_readings(readings: Sequence[tuple[str, int]]) -> tuple[str, str]:
    """A claim's verdict and its leaning from its readings' ``(verdict, lean)``.

    The claim holds if one reading holds, does not hold if every one does not (the same for not testable).
    """
    verdicts = [verdict for verdict, _ in readings]
    if HOLDS in verdicts:
        verdict = HOLDS
    elif verdicts and all(v == DOES_NOT_HOLD for v in verdicts):
        verdict = DOES_NOT_HOLD
    elif verdicts and all(v == NOT_TESTABLE for v in verdicts):
        verdict = NOT_TESTABLE
    else:
        verdict = INCONCLUSIVE
    if verdict != INCONCLUSIVE:
        return verdict, verdict
    leans = [lean for _, lean in readings]
    if 1 in leans:
        return verdict, f"{HOLDS} (direction only)"
    if leans and all(lean < 0 for lean in leans):
        return verdict, f"{DOES_NOT_HOLD} (direction only)"
    return verdict, INCONCLUSIVE


# ---------------------------------------------------------------- protocol 2: reading the folders


@dataclass(frozen=True)
class Body:
    """One body's protocol-2 results folder, as the claims read it.

    Attributes:
        name: The body (``point`` or ``ant``).
        folder: Where it was read.
        summary: Its ``summary.json``.
        episodes_to_target: ``{method: {seed: training episodes to 60%, or None}}`` from ``episodes.csv``
            (0 where the untrained learner is at 60% already); ``None`` without that file.
    """

    name: str
    folder: Path
    summary: dict[str, Any]
    episodes_to_target: dict[str, dict[int, float | None]] | None = None

    def method(self, name: str) -> dict[str, Any]:
        """The summary's figures of a method (``{}`` when it has no trials)."""
        figures = self.summary["methods"].get(name, {})
        return figures if figures.get("seeds") else {}

    @property
    def seeds(self) -> tuple[int, int]:
        """Fewest and most seeds over the methods run."""
        counts = [figures["seeds"] for figures in self.summary["methods"].values() if figures.get("seeds")]
        return (min(counts), max(counts)) if counts else (0, 0)

    @property
    def interim(self) -> bool:
        """Some method has fewer than :data:`FULL_SEEDS` seeds (or none ran)."""
        return self.seeds[0] < FULL_SEEDS


def seeds_of(method: dict[str, Any]) -> list[int]:
    """The method's seeds in the order of its per-seed lists (that of ``final_success.per_seed``)."""
    return [entry["seed"] for entry in method["final_success"]["per_seed"]]


def untrained_by_seed(method: dict[str, Any]) -> dict[int, float]:
    """The untrained learner's success per seed (``untrained_success.per_seed`` is in sorted seed order)."""
    per_seed = method.get("untrained_success", {}).get("per_seed", [])
    return dict(zip(sorted(seeds_of(method)), per_seed, strict=False))


def labels_by_seed(method: dict[str, Any]) -> dict[int, float]:
    """Labels to match DAgger per seed, :data:`NEVER` where the seed never reaches DAgger's target."""
    per_seed = method.get("labels_to_match_dagger", {}).get("per_seed", [])
    return {seed: NEVER if labels is None else labels for seed, labels in zip(seeds_of(method), per_seed, strict=False)}


def episodes_to_target(rows: Sequence[dict[str, Any]], summary: dict[str, Any]) -> dict[str, dict[int, float | None]]:
    """Training episodes to the first evaluation at >= 60%, per method and seed (0 if the untrained learner is)."""
    methods = [name for name, figures in summary["methods"].items() if figures.get("seeds")]
    out: dict[str, dict[int, float | None]] = {}
    for name, trials in trials_by_method(rows, methods).items():
        untrained = untrained_by_seed(summary["methods"][name])
        out[name] = {}
        for seed, trial in trials.items():
            reached = first_at(trial)
            out[name][seed] = 0.0 if untrained.get(seed, 0.0) >= TARGET_SUCCESS else reached[0] if reached else None
    return out


def load_body(parser: argparse.ArgumentParser, folder: Path, body: str) -> Body:
    """A protocol-2 folder of ``body``; every bad input is a one-line parser error naming it."""
    path = folder / "summary.json"
    try:
        summary = read_summary(folder)
    except ValueError as error:
        parser.error(str(error))
    config = summary.get("config", {})
    protocol = config.get("protocol", 1)  # summaries from before protocol 2 have no such key
    if protocol != 2:
        parser.error(f"{path} has config.protocol {protocol!r}, not 2: read it without --protocol2")
    if config.get("body") != body:
        parser.error(f"{path} is of body {config.get('body')!r}, but it was passed as the {body} folder")
    if not summary["methods"].get(BASELINE, {}).get("seeds"):
        parser.error(f"{path} has no {BASELINE} trials to compare with")
    episodes = folder / "episodes.csv"
    return Body(body, folder, summary, episodes_to_target(read_rows(episodes), summary) if episodes.is_file() else None)


# ---------------------------------------------------------------- protocol 2: the claims


@dataclass
class Claim:
    """One row of the table.

    Attributes:
        number: The claim's number (1-7).
        claim: The paper's claim, in words.
        measurement: What was measured, per reading and body.
        verdict: ``holds``, ``does not hold``, ``inconclusive`` or ``not testable here``, by the rules.
        leaning: The verdict, or where the tests do not decide it, the direction of the data.
        printed: What the table prints: the verdict, or ``interim: leaning <leaning>`` on an interim folder.
        note: Why a verdict is bounded or untestable ("" if it needs no note).
        outcomes: ``{reading: {body: outcome}}``.
    """

    number: int
    claim: str
    measurement: str
    verdict: str
    leaning: str
    printed: str = ""
    note: str = ""
    outcomes: dict[str, dict[str, str]] = field(default_factory=dict)


def _pct(value: float | None, decimals: int = 0) -> str:
    return "n/a" if value is None else f"{100 * value:.{decimals}f}%"


def _spread(figure: dict[str, Any]) -> str:
    if figure.get("median") is None:
        return "n/a"
    return f"{_pct(figure['median'])} ({100 * figure['min']:.0f}-{100 * figure['max']:.0f}%)"


def _bound(value: float, unit: Callable[[float], str]) -> str:
    return ("-inf" if value < 0 else "+inf") if abs(value) >= NEVER / 4 else unit(value)


def _test_text(comparison: Comparison, unit: Callable[[float], str]) -> str:
    if comparison.pairs < 2 or comparison.median_difference is None:
        return f"{comparison.pairs} pairs, no test: {comparison.outcome}"
    low, high = (_bound(bound, unit) for bound in comparison.interval)
    return (
        f"{_bound(comparison.median_difference, unit)}, p = {comparison.p_value:.3g} (n = {comparison.pairs}, "
        f"floor {smallest_p(comparison.pairs):.3g}), CI [{low}, {high}]: {comparison.outcome}"
    )


def _points(value: float) -> str:
    return f"{100 * value:+.1f} pts"


def _labels(value: float) -> str:
    return f"{value:+.0f} labels"


def success_finding(body: Body, name: str, direction: int, alpha: float) -> Finding:
    """Final success of ``name`` against DAgger's on one body."""
    method, dagger = body.method(name), body.method(BASELINE)
    if not method:
        return Finding(UNDECIDED, 0, f"{body.name} `{name}`: no trials")
    test = method.get(f"vs_{BASELINE}", {}).get("final_success", {})
    comparison = compare(test.get("differences", []), direction, SUCCESS_EFFECT, alpha)
    text = (
        f"{body.name} `{name}`: {_spread(method['final_success'])} vs DAgger {_spread(dagger['final_success'])}; "
        + _test_text(comparison, _points)
    )
    return Finding(comparison.outcome, comparison.toward, text)


PAIRED = "labels_to_match_dagger_per_seed"
"""The summary figure that pairs the labels question by seed (``summary.py``; protocol-2 summaries written since)."""


def label_differences(body: Body, name: str, scale: float = 1.0) -> list[float]:
    """Per-seed ``labels - scale x DAgger's labels`` to DAgger's target, over the seeds both ran.

    With :data:`PAIRED` in the summary the target is each seed's own DAgger final success, which DAgger always
    reaches; otherwise DAgger's median final success, which about half of DAgger's seeds never reach.
    """
    paired = body.method(name).get(PAIRED)
    if paired is not None:
        return [
            NEVER if seed["labels"] is None else seed["labels"] - scale * seed["baseline_labels"]
            for seed in paired["per_seed"]
        ]
    mine, theirs = labels_by_seed(body.method(name)), labels_by_seed(body.method(BASELINE))
    differences = []
    for seed in sorted(mine.keys() & theirs.keys()):
        never = mine[seed] >= NEVER, theirs[seed] >= NEVER
        # Never against never ties; never against a count is the largest difference there is.
        if all(never):
            differences.append(0.0)
        elif any(never):
            differences.append(NEVER if never[0] else -NEVER)
        else:
            differences.append(mine[seed] - scale * theirs[seed])
    return differences


def _labels_to_match(method: dict[str, Any]) -> str:
    paired = method.get(PAIRED)
    if paired is not None:
        ratio = "never" if paired["median_ratio"] is None else f"{paired['median_ratio']:.2f}x DAgger's"
        return f"paired by seed: median {ratio} ({paired['seeds_reached']} of {paired['seeds']} seeds reach it)"
    match = method.get("labels_to_match_dagger", {})
    median = "never" if match.get("median") is None else f"{match['median']:.0f}"
    return f"{median} ({match.get('seeds_reached')} of {method['seeds']} reach it)"


def labels_finding(body: Body, name: str, alpha: float) -> Finding:
    """Labels to DAgger's final success of ``name`` against DAgger's own labels to it, on one body."""
    method, dagger = body.method(name), body.method(BASELINE)
    if "labels_to_match_dagger" not in method:
        return Finding(UNDECIDED, 0, f"{body.name} `{name}`: no labels to match DAgger")
    effect = LABEL_EFFECT * dagger["total_labels"]["median"]
    comparison = compare(label_differences(body, name), -1, effect, alpha)
    target = "each seed's DAgger final" if PAIRED in method else _pct(method["labels_to_match_dagger"]["target"])
    text = (
        f"{body.name} `{name}`: labels to DAgger's {target} {_labels_to_match(method)} vs DAgger "
        f"{_labels_to_match(dagger)}; " + _test_text(comparison, _labels)
    )
    return Finding(comparison.outcome, comparison.toward, text)


def _row(
    number: int,
    claim: str,
    bodies: Sequence[Body],
    readings: Sequence[str],
    judge: Callable[[Body, str, float], Finding],
) -> Claim:
    """A claim tried on every reading and body, each reading at ALPHA / len(readings)."""
    alpha = ALPHA / len(readings)
    findings = {reading: [judge(body, reading, alpha) for body in bodies] for reading in readings}
    verdict, leaning = combine_readings([combine_bodies(found) for found in findings.values()])
    text = "<br>".join(finding.text for found in findings.values() for finding in found)
    outcomes = {
        reading: {body.name: finding.outcome for body, finding in zip(bodies, found, strict=True)}
        for reading, found in findings.items()
    }
    return Claim(number, claim, f"threshold p < {alpha:.3g}<br>{text}", verdict, leaning, outcomes=outcomes)


def claim_success(bodies: Sequence[Body]) -> Claim:
    """(1) Reward-based AL beats DAgger in final success."""

    def judge(body: Body, name: str, alpha: float) -> Finding:
        return success_finding(body, name, 1, alpha)

    return _row(1, "Reward-based AL beats DAgger in **success**", bodies, REWARD_BASED, judge)


def claim_labels(bodies: Sequence[Body]) -> Claim:
    """(2) Reward-based AL beats DAgger in labels (to DAgger's final success)."""
    return _row(2, "Reward-based AL beats DAgger in **labels**", bodies, REWARD_BASED, labels_finding)


def claim_multi_policy(bodies: Sequence[Body]) -> Claim:
    """(3) Multi-policy AL does worse than DAgger (final success)."""

    def judge(body: Body, name: str, alpha: float) -> Finding:
        return success_finding(body, name, -1, alpha)

    return _row(3, "Multi-policy AL does **worse** than DAgger", bodies, ("multi_policy",), judge)


def sixty_finding(body: Body, name: str, alpha: float) -> Finding:
    """(4) on one body: the seeds whose learner passes 60% after fewer than 100 training episodes."""
    method = body.method(name)
    if not method:
        return Finding(UNDECIDED, 0, f"{body.name} `{name}`: no trials")
    seeds, untrained = method["seeds"], method.get("untrained_success", {})
    start = untrained.get("pooled", {}).get("rate")
    prefix = f"{body.name} `{name}`: untrained {_pct(start, 1)} pooled ({_spread(untrained)} per seed)"
    if untrained.get("median") is not None and untrained["median"] >= TARGET_SUCCESS:
        return Finding(UNTESTABLE, 0, f"{prefix}: at 60% before its first label")
    reached = method["cost_to_60_percent"]
    labels = "never" if reached["median"] is None else f"{reached['median']:.0f} labels"
    if body.episodes_to_target is None:
        # summary.json counts labels, not episodes: passing within the trial is all it shows.
        within, per_episode = reached["seeds_reached"], method["mean_expert_cost_per_episode"]
        estimate = None if reached["median"] is None else reached["median"] / per_episode
        outcome = CONTRADICTS if sign_test(within, seeds, alpha)[0] == CONTRADICTS else UNDECIDED
        if 2 * within > seeds and estimate is not None and estimate < EPISODE_LIMIT:
            toward = 1
        else:
            toward = -1 if 2 * within < seeds else 0
        about = "" if estimate is None else f", about {estimate:.0f} episodes at {per_episode:.1f} labels per episode"
        return Finding(
            outcome,
            toward,
            f"{prefix}; {within} of {seeds} seeds pass 60% within the {body.summary['config']['episodes']}-episode "
            f"trial, median {labels}{about}; no episodes.csv, so no episode counts: {outcome}",
        )
    episodes = body.episodes_to_target.get(name, {})
    passed = sum(count is not None and count < EPISODE_LIMIT for count in episodes.values())
    outcome, upper, lower = sign_test(passed, len(episodes), alpha)
    spread = median_range(list(episodes.values()))
    after = "never" if spread["median"] is None else f"{spread['median']:.0f} ({spread['min']:.0f}-{spread['max']:.0f})"
    toward = int(np.sign(2 * passed - len(episodes)))
    return Finding(
        outcome,
        toward,
        f"{prefix}; first >= 60% after {after} episodes, median {labels}; {passed} of {len(episodes)} seeds "
        f"under {EPISODE_LIMIT} episodes, sign test P(X >= {passed}) = {upper:.3g}, "
        f"P(X <= {passed}) = {lower:.3g}: {outcome}",
    )


def claim_sixty(bodies: Sequence[Body]) -> Claim:
    """(4) Reward-based AL passes 60% success in under 100 episodes, from the measured untrained success."""
    row = _row(4, "Reward-based AL passes **60% in under 100 episodes**", bodies, REWARD_BASED, sixty_finding)
    dagger = "<br>".join(sixty_finding(body, BASELINE, ALPHA / len(REWARD_BASED)).text for body in bodies)
    row.measurement += f"<br>for comparison, not in the verdict:<br>{dagger}"
    return row


def claim_aggrevate(bodies: Sequence[Body]) -> Claim:
    """(5) DAgger beats AggreVaTeD under sparse reward; bounded, since ``aggrevate`` has a dense oracle Q."""

    def judge(body: Body, name: str, alpha: float) -> Finding:
        return success_finding(body, name, -1, alpha)

    row = _row(5, "DAgger beats **AggreVaTeD under sparse reward**", bodies, ("aggrevate",), judge)
    row.note = (
        "bounded: `aggrevate` scores with the oracle's dense cost-to-go, not a sparse reward; DAgger beating it "
        "supports the claim, it beating DAgger says nothing of the sparse-reward one"
    )
    # The dense Q favours aggrevate, so its win over DAgger cannot refute a claim about a sparse one.
    row.verdict = NOT_TESTABLE if row.verdict == DOES_NOT_HOLD else row.verdict
    row.leaning = NOT_TESTABLE if row.leaning.startswith(DOES_NOT_HOLD) else row.leaning
    return row


def saving_finding(body: Body, name: str, alpha: float) -> Finding:
    """(6) on one method and body: DAgger's final success at <= 0.3x DAgger's labels."""
    method, dagger = body.method(name), body.method(BASELINE)
    if "labels_to_match_dagger" not in method:
        return Finding(UNDECIDED, 0, f"`{name}` no labels to match DAgger")
    match, theirs = method["labels_to_match_dagger"], dagger["labels_to_match_dagger"]["median"]
    ratio = match.get("ratio_vs_dagger")
    if PAIRED in method:  # paired by seed: DAgger reaches its own target on every seed, so a ratio is read
        ratio, theirs = method[PAIRED]["median_ratio"], 1.0
    test = compare(label_differences(body, name), -1, LABEL_EFFECT * dagger["total_labels"]["median"], alpha)
    scaled = signed_rank_interval(label_differences(body, name, SAVING_RATIO))
    if ratio is not None and ratio <= SAVING_RATIO and test.outcome == SUPPORTS:
        outcome = SUPPORTS
    elif scaled[0] > 0:
        outcome = CONTRADICTS
    else:
        outcome = UNDECIDED
    # Direction: the median ratio against 0.3; none when DAgger's own median is never (no ratio to read).
    toward = 0 if theirs is None else -1 if ratio is None else int(np.sign(SAVING_RATIO - ratio) or 1)
    shown = "n/a" if ratio is None else f"{ratio:.2f}x"
    p_value = "n/a" if test.p_value is None else f"{test.p_value:.3g}"
    return Finding(outcome, toward, f"`{name}` {_labels_to_match(method)}, {shown}, p = {p_value}: {outcome}")


def claim_saving(bodies: Sequence[Body]) -> Claim:
    """(6) Active learning saves expert cost: some active method at <= 0.3x DAgger's labels, on every body."""
    alpha = ALPHA / len(ACTIVE)
    per_body, texts = [], []
    outcomes: dict[str, dict[str, str]] = {name: {} for name in ACTIVE}
    for body in bodies:
        found = {name: saving_finding(body, name, alpha) for name in ACTIVE}
        kinds = [finding.outcome for finding in found.values()]
        outcome = SUPPORTS if SUPPORTS in kinds else CONTRADICTS if all(k == CONTRADICTS for k in kinds) else UNDECIDED
        towards = [finding.toward for finding in found.values()]
        toward = 1 if 1 in towards else -1 if all(t < 0 for t in towards) else 0
        per_body.append(Finding(outcome, toward, ""))
        for name, finding in found.items():
            outcomes[name][body.name] = finding.outcome
        dagger = body.method(BASELINE)
        texts.append(
            f"{body.name}: labels to DAgger's {_pct(dagger.get('labels_to_match_dagger', {}).get('target'))}, DAgger "
            f"{_labels_to_match(dagger)}; " + "; ".join(f.text for f in found.values()) + f"; body: {outcome}"
        )
    verdict, leaning = combine_readings([combine_bodies(per_body)])
    claim = f"Active learning **saves expert cost** (DAgger's final success at <= {SAVING_RATIO}x its labels)"
    measurement = f"threshold p < {alpha:.3g}; median labels (seeds reaching), ratio to DAgger's, paired p<br>"
    return Claim(6, claim, measurement + "<br>".join(texts), verdict, leaning, outcomes=outcomes)


STUDY_MEASURES = (
    "No people took part in these runs. The study kit (`antmaze_hirl/study`) measures, per participant and "
    "method: the six NASA-TLX items (mental, physical and temporal demand, performance, effort, frustration) "
    "on the paper's 5-point scale after each trial, seconds per label, time on task and labels. It compares "
    "methods by a repeated-measures ANOVA and paired tests (`antmaze_hirl/study/stats.py`)."
)


def claim_subjective(bodies: Sequence[Body]) -> Claim:
    """(7) The methods differ in perceived workload: it needs participants, so no results folder tests it."""
    del bodies  # oracle runs hold no person's answers
    claim = "**Subjective measures**: the methods differ in perceived workload and frustration"
    return Claim(7, claim, STUDY_MEASURES, NOT_TESTABLE, NOT_TESTABLE, note="it needs participants")


CLAIMS = (claim_success, claim_labels, claim_multi_policy, claim_sixty, claim_aggrevate, claim_saving, claim_subjective)


def protocol2_claims(bodies: Sequence[Body]) -> list[Claim]:
    """Every claim's row; on an interim folder each prints ``interim: leaning ...``, never a verdict."""
    interim = any(body.interim for body in bodies)
    rows = [make(bodies) for make in CLAIMS]
    for row in rows:
        # Claim 7 needs people, not seeds: no rerun changes it.
        word = f"interim: leaning {row.leaning}" if interim and row.number != 7 else row.verdict
        row.printed = f"{word} ({row.note})" if row.note else word
    return rows


def _folder_line(body: Body) -> str:
    low, high = body.seeds
    seeds = f"{low}" if low == high else f"{low}-{high}"
    state = f"INTERIM: fewer than {FULL_SEEDS} seeds, no verdict is final" if body.interim else "complete"
    return f"- {body.name}: `{body.folder}`, {seeds} seeds per method ({state})"


FOOTNOTE = (
    "Verdict rules (the docstring of `scripts/paper_claims.py`). Each method is paired by seed against "
    f"DAgger: two-sided Wilcoxon signed-rank test at p < {ALPHA}, split over the methods a claim tries "
    "(two reward-based: 0.025; five active: 0.01). CI is the 95% Hodges-Lehmann interval of the paired "
    "differences, unbounded with 5 pairs or fewer. With n pairs, p cannot go below 2/2^n (the floor). A body "
    "supports a claim when the median difference points the claimed way with p under the threshold. It "
    "contradicts it when the other way is significant, or when the CI excludes the claimed effect "
    f"({100 * SUCCESS_EFFECT:.0f} points of success; {100 * LABEL_EFFECT:.0f}% of DAgger's median labels). A "
    "claim holds when every body supports it, does not hold when one contradicts it, and is inconclusive "
    "otherwise. With two readings, one that holds is enough. Labels: to DAgger's median final success on the "
    "same set; a seed that never gets there ranks above every count. Claim 4: a sign test of the seeds passing "
    f"60% in under {EPISODE_LIMIT} episodes, counted from the measured untrained success (`episodes.csv`). "
    f"Claim 6: some active method at a median <= {SAVING_RATIO}x DAgger's labels whose paired test passes; "
    f"contradicted when every method's CI of labels - {SAVING_RATIO}x DAgger's is above 0. A folder with "
    f"fewer than {FULL_SEEDS} seeds in some method is INTERIM. Its rows lean, they do not decide: the "
    "verdict where the tests decide it, else the direction of the medians (direction only)."
)


def markdown(bodies: Sequence[Body], rows: Sequence[Claim]) -> str:
    """The claims table, with its folders (INTERIM marked) above and the verdict rules below."""
    interim = any(body.interim for body in bodies)
    title = "Protocol 2 claims" + (" (INTERIM: not a result)" if interim else "")
    lines = [f"{title}:", "", *(_folder_line(body) for body in bodies), ""]
    lines += ["| # | the paper's claim | this project's measurement (protocol 2) | verdict |", "|---|---|---|---|"]
    lines += [f"| {row.number} | {row.claim} | {row.measurement} | **{row.printed}** |" for row in rows]
    return "\n".join([*lines, "", FOOTNOTE])


def protocol2_json(bodies: Sequence[Body], rows: Sequence[Claim]) -> dict[str, Any]:
    """The table as data: the folders (seeds, interim), the rules' constants and every row."""
    return {
        "folders": {
            body.name: {"folder": str(body.folder), "seeds": list(body.seeds), "interim": body.interim}
            for body in bodies
        },
        "interim": any(body.interim for body in bodies),
        "rules": {
            "alpha": ALPHA,
            "full_seeds": FULL_SEEDS,
            "success_effect": SUCCESS_EFFECT,
            "label_effect": LABEL_EFFECT,
            "saving_ratio": SAVING_RATIO,
            "episode_limit": EPISODE_LIMIT,
        },
        "claims": [asdict(row) for row in rows],
    }


def _plain(value: Any) -> Any:
    return None if isinstance(value, float) and np.isnan(value) else value


def main(argv: Sequence[str] | None = None) -> None:
    """The command line (the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--folders", default=None, help="protocol 1: comma-separated folders (default: the committed)")
    parser.add_argument(
        "--protocol2", nargs=2, type=Path, metavar=("POINT_FOLDER", "ANT_FOLDER"), help="protocol 2: the claims table"
    )
    parser.add_argument("--json", type=Path, default=None, help="also write what is printed, as JSON, to this file")
    args = parser.parse_args(argv)
    if args.protocol2 is not None:
        if args.folders is not None:
            parser.error("--folders names protocol-1 folders; --protocol2 takes its two folders itself")
        bodies = [load_body(parser, folder, body) for folder, body in zip(args.protocol2, BODIES, strict=True)]
        rows = protocol2_claims(bodies)
        print(markdown(bodies, rows))
        output: Any = protocol2_json(bodies, rows)
    else:
        folders = FOLDERS if args.folders is None else [Path(f) for f in args.folders.split(",")]
        output = []
        for folder in folders:
            result = claims(folder)
            output.append(result)
            print(f"== {folder.name} (body {result['config']['body']}, protocol 1)")
            for method, figures in result["methods"].items():
                print(method, json.dumps(figures, default=_plain))
    if args.json is not None:
        args.json.write_text(json.dumps(output, indent=1, default=_plain) + "\n")


if __name__ == "__main__":
    main()
