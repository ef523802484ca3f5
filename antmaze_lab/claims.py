"""The paper's claims, and their verdicts computed from paper-experiment results folders.

Protocol 2 (:func:`evaluate_folders`): each claim of :data:`CLAIMS` is judged on one protocol-2 results
folder per body (``summary.json``, and ``episodes.csv`` where the folder has it) and gives a
:class:`ClaimVerdict`. Protocol 1 (:func:`protocol1_figures`): the figures of an older folder, without
verdicts.

Verdict rules. A "reading" is one method that stands for the claim on one body:

* **A comparison with DAgger.** The per-seed figures are paired by seed. The test is the two-sided
  Wilcoxon signed-rank test. The interval is the 95% Hodges-Lehmann interval of the paired differences
  (:func:`~antmaze_hirl.experiments.uncertainty.signed_rank_interval`). A body *supports* the claim when
  the median difference points the claimed way and p < the threshold. It *contradicts* the claim when the
  median difference points the other way with p < the threshold, or when the interval excludes the
  claimed effect (:data:`SUCCESS_EFFECT` of final success for "beats" and "worse"; for labels,
  :data:`LABEL_EFFECT` of DAgger's median labels per trial). Otherwise the body is *undecided*.
* **Thresholds.** :data:`ALPHA`, divided by the number of methods that one claim tries (Bonferroni).
* **Labels** are the labels at which a seed's curve first reaches DAgger's final success. Where the summary
  has ``labels_to_match_dagger_per_seed``, the target is each seed's own DAgger final success (DAgger
  always reaches it) and the seeds are paired by that figure; otherwise the target is DAgger's median final
  success (``labels_to_match_dagger``). A seed that never reaches the target counts as :data:`NEVER`
  labels, more than any seed that does; two such seeds tie.
* **Claim 4** has no paired test. A seed passes if its learner's first evaluation at >= 60% comes after
  fewer than :data:`EPISODE_LIMIT` training episodes (from ``episodes.csv``). A seed whose untrained
  learner already scores >= 60% passes at 0 episodes. If the median seed's untrained learner does, the
  claim is *not testable*: the curve starts where the claim ends. The one-sided sign test of k passing
  seeds out of n supports the claim when P(X >= k) < the threshold, and contradicts it when
  P(X <= k) < the threshold. A folder without ``episodes.csv`` has only ``summary.json``'s labels: there
  it can only contradict the claim (seeds that never pass within the trial).
* **Claim 6** is supported on a body when some active method reaches DAgger's final success with a median
  ratio of labels <= :data:`SAVING_RATIO` x DAgger's, and its labels beat DAgger's in the paired test. It
  is contradicted when, for every active method, the 95% interval of the paired differences
  ``labels - SAVING_RATIO x DAgger's labels`` lies above 0.
* **A claim** holds when every body supports it. It does not hold when some body contradicts it.
  Otherwise it is inconclusive. With several readings, the claim holds when one reading holds, and does
  not hold when every reading does not hold.
* **Claim 5's** ``aggrevate`` uses the oracle's dense cost-to-go, not the paper's sparse reward. DAgger
  beating it is evidence for the claim; the dense version beating DAgger decides nothing about the sparse
  one: that verdict is *not testable here*.
* **Claim 7** is not testable without people.
* **Interim folders.** A folder where some method has fewer than :data:`FULL_SEEDS` seeds is interim. No
  verdict on it is final: its rows print "interim: leaning <leaning>". The leaning is the verdict where the
  tests already decide it. Otherwise it is the direction of the data: "holds (direction only)" when the
  median points the claimed way on every body of some reading, "does not hold (direction only)" when it
  points the other way on some body of every reading, else "inconclusive".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import binom

from antmaze_hirl.experiments.results_folder import read_rows, read_summary
from antmaze_hirl.experiments.summary import TARGET_SUCCESS, median_range, trials_by_method
from antmaze_hirl.experiments.uncertainty import paired_comparison, signed_rank_interval, smallest_signed_rank_p

BODIES = ("point", "ant")
"""The bodies a protocol-2 claims table reads, one results folder each, in this order."""
ALPHA = 0.05
"""The two-sided test level of one claim, before it is split over the methods that claim tries."""
FULL_SEEDS = 10
"""Seeds per method of a complete protocol-2 folder; a folder with fewer in some method is interim."""
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
"""The methods that stand for "reward-based AL" (``reward_per_step`` is the paper's Alg. 4 as written)."""
ACTIVE = ("noise", "multi_policy", "reward", "reward_per_step", "gated")
"""The active-learning methods that claim 6 tries."""
BASELINE = "dagger"
"""The method every other one is compared with."""
PAIRED = "labels_to_match_dagger_per_seed"
"""The summary figure that pairs the labels question by seed (written by ``summary.py``)."""

SUPPORTS, CONTRADICTS, UNDECIDED, UNTESTABLE = "supports", "contradicts", "undecided", "untestable"
HOLDS, DOES_NOT_HOLD, INCONCLUSIVE, NOT_TESTABLE = "holds", "does not hold", "inconclusive", "not testable here"


# ---------------------------------------------------------------- protocol 1


def first_at(trial: Sequence[dict[str, Any]], target: float = TARGET_SUCCESS) -> tuple[float, float] | None:
    """Training episodes and labels at the trial's first evaluation with success >= ``target``.

    Returns:
        ``(episodes, labels)``, or ``None`` if no evaluation of the trial reaches ``target``.
    """
    for row in trial:
        if not math.isnan(row["eval_success"]) and row["eval_success"] >= target:
            return float(row["episode"] + 1), float(row["cumulative_expert_cost"])
    return None


PROTOCOL1_FIGURES = ("final_success", "total_labels")
"""The per-method figures of ``summary.json`` that :func:`protocol1_figures` needs."""


def _episodes_csv(folder: Path) -> Path:
    path = folder / "episodes.csv"
    if not path.is_file():
        raise ValueError(f"no episodes.csv in {folder} (a paper-experiment results folder)")
    return path


def protocol1_figures(folder: Path) -> dict[str, Any]:
    """The figures of one results folder that the protocol-1 claims table quotes, per method.

    Args:
        folder: A paper-experiment results folder with ``summary.json`` and ``episodes.csv``.

    Returns:
        ``{"folder", "config", "methods": {method: figures}}``: per method that ran, its seeds, final success
        (median, min, max) and Wilcoxon p against DAgger, labels per trial, labels to DAgger's median final
        success and that ratio, training episodes and labels to the first evaluation at >= 60%, and the
        labels that reward-based pruning removed out of those spent.

    Raises:
        ValueError: One line naming the folder or file: no ``summary.json`` (or not a summary), a summary
            without the figures of :data:`PROTOCOL1_FIGURES`, no ``episodes.csv``.
    """
    summary = read_summary(folder)
    rows = read_rows(_episodes_csv(folder))
    methods = [m for m, f in summary["methods"].items() if f.get("seeds")]
    for method in methods:
        missing = [key for key in PROTOCOL1_FIGURES if key not in summary["methods"][method]]
        if missing:
            raise ValueError(
                f"{folder / 'summary.json'}: {method!r} has no {missing[0]!r}, a summary older than this reads"
            )
    grouped = trials_by_method(rows, methods)
    out: dict[str, Any] = {"folder": str(folder), "config": summary["config"], "methods": {}}
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


# ---------------------------------------------------------------- protocol 2: the tests


@dataclass(frozen=True)
class Comparison:
    """A paired comparison of one method with DAgger on one body, and what it says of the claim.

    Attributes:
        outcome: ``supports``, ``contradicts`` or ``undecided`` (the module's rules).
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
    """Claim 4's one-sided sign tests of ``passed`` seeds out of ``seeds``, at a pass probability of 1/2.

    Returns:
        The outcome (``supports`` if P(X >= passed) < ``alpha``, ``contradicts`` if P(X <= passed) < ``alpha``,
        else ``undecided``), P(X >= passed) and P(X <= passed).
    """
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
        brief: The measurement in a few words, for the README's table (``""``: none).
    """

    outcome: str
    toward: int
    text: str
    brief: str = ""


def combine_bodies(findings: Sequence[Finding]) -> tuple[str, int]:
    """One reading's verdict from its bodies' findings, and its leaning by direction.

    Returns:
        The verdict (``not testable here`` if one body is untestable, else ``does not hold`` if one
        contradicts, ``holds`` if every one supports, else ``inconclusive``) and the leaning: +1 if every
        body points the claimed way, -1 if one points the other way, else 0.
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
    """A claim's verdict and its leaning from its readings' ``(verdict, lean)`` (:func:`combine_bodies`).

    Returns:
        The verdict (``holds`` if one reading holds, ``does not hold`` or ``not testable here`` if every one
        is, else ``inconclusive``) and the leaning: the verdict itself unless it is ``inconclusive``, then
        ``holds (direction only)`` if some reading leans +1, ``does not hold (direction only)`` if every one
        leans -1, else ``inconclusive``.
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
        """Fewest and most seeds over the methods run (``(0, 0)`` if none ran)."""
        counts = [figures["seeds"] for figures in self.summary["methods"].values() if figures.get("seeds")]
        return (min(counts), max(counts)) if counts else (0, 0)

    @property
    def interim(self) -> bool:
        """Some method has fewer than :data:`FULL_SEEDS` seeds (or none ran)."""
        return self.seeds[0] < FULL_SEEDS


def _seeds_of(method: dict[str, Any]) -> list[int]:
    """The method's seeds in the order of its per-seed lists (that of ``final_success.per_seed``)."""
    return [entry["seed"] for entry in method["final_success"]["per_seed"]]


def _untrained_by_seed(method: dict[str, Any]) -> dict[int, float]:
    """The untrained learner's success per seed (``untrained_success.per_seed`` is in sorted seed order)."""
    per_seed = method.get("untrained_success", {}).get("per_seed", [])
    return dict(zip(sorted(_seeds_of(method)), per_seed, strict=False))


def _labels_by_seed(method: dict[str, Any]) -> dict[int, float]:
    """Labels to match DAgger per seed, :data:`NEVER` where the seed never reaches DAgger's target."""
    per_seed = method.get("labels_to_match_dagger", {}).get("per_seed", [])
    return {
        seed: NEVER if labels is None else labels for seed, labels in zip(_seeds_of(method), per_seed, strict=False)
    }


def episodes_to_target(rows: Sequence[dict[str, Any]], summary: dict[str, Any]) -> dict[str, dict[int, float | None]]:
    """Training episodes to the first evaluation at >= 60%, per method and seed.

    Args:
        rows: The folder's ``episodes.csv`` rows (:func:`~antmaze_hirl.experiments.results_folder.read_rows`).
        summary: The folder's ``summary.json``, for the methods run and their untrained success.

    Returns:
        ``{method: {seed: episodes}}``: 0 where the seed's untrained learner is at 60% already, ``None``
        where the trial never gets there.
    """
    methods = [name for name, figures in summary["methods"].items() if figures.get("seeds")]
    out: dict[str, dict[int, float | None]] = {}
    for name, trials in trials_by_method(rows, methods).items():
        untrained = _untrained_by_seed(summary["methods"][name])
        out[name] = {}
        for seed, trial in trials.items():
            reached = first_at(trial)
            out[name][seed] = 0.0 if untrained.get(seed, 0.0) >= TARGET_SUCCESS else reached[0] if reached else None
    return out


def read_body(folder: Path, body: str) -> Body:
    """The protocol-2 results folder of ``body``, with its episode counts where it has ``episodes.csv``.

    Raises:
        ValueError: One line naming the folder or file: no ``summary.json`` (a missing folder has none), not
            a summary, a summary of another protocol or body, or one without DAgger trials.
    """
    path = folder / "summary.json"
    summary = read_summary(folder)
    config = summary.get("config", {})
    protocol = config.get("protocol")  # read_summary gives a folder from before protocol 2 its protocol, 1
    if protocol != 2:
        raise ValueError(f"{path} has config.protocol {protocol!r}, not 2: read it without --protocol2")
    if config.get("body") != body:
        raise ValueError(f"{path} is of body {config.get('body')!r}, but it was passed as the {body} folder")
    if not summary["methods"].get(BASELINE, {}).get("seeds"):
        raise ValueError(f"{path} has no {BASELINE} trials to compare with")
    episodes = folder / "episodes.csv"
    return Body(body, folder, summary, episodes_to_target(read_rows(episodes), summary) if episodes.is_file() else None)


# ---------------------------------------------------------------- protocol 2: the findings, in words


def _pct(value: float | None, decimals: int = 0) -> str:
    return "n/a" if value is None else f"{100 * value:.{decimals}f}%"


def exact_percent(value: float | None) -> str:
    """A success rate in percent to one decimal where it has one (0.905: "90.5%", not a half-even "90%").

    ``None`` (no figure) reads "n/a". The lab's results tables format their exact figures with it too.
    """
    return "n/a" if value is None else f"{100 * value:.1f}".removesuffix(".0") + "%"


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
        f"floor {smallest_signed_rank_p(comparison.pairs):.3g}), CI [{low}, {high}]: {comparison.outcome}"
    )


def _p_text(comparison: Comparison) -> str:
    """The paired p in a few words, saying so when the median points against the claim (p alone reads as support)."""
    if comparison.p_value is None:
        return "no test"
    return f"p = {comparison.p_value:.2g}" + (", the other way" if comparison.toward < 0 else "")


def _points(value: float) -> str:
    return f"{100 * value:+.1f} pts"


def _labels(value: float) -> str:
    return f"{value:+.0f} labels"


def _success_finding(body: Body, name: str, direction: int, alpha: float) -> Finding:
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
    ours, theirs = (exact_percent(m["final_success"].get("median")) for m in (method, dagger))
    return Finding(comparison.outcome, comparison.toward, text, f"`{name}` {ours} vs {theirs}, {_p_text(comparison)}")


def _higher_success(body: Body, name: str, alpha: float) -> Finding:
    return _success_finding(body, name, 1, alpha)


def _lower_success(body: Body, name: str, alpha: float) -> Finding:
    return _success_finding(body, name, -1, alpha)


def label_differences(body: Body, name: str, scale: float = 1.0) -> list[float]:
    """Per-seed ``labels - scale x DAgger's labels`` to DAgger's target, over the seeds both ran.

    With :data:`PAIRED` in the summary the target is each seed's own DAgger final success, which DAgger always
    reaches; otherwise DAgger's median final success, which about half of DAgger's seeds never reach. A seed
    that never reaches the target counts as :data:`NEVER` labels.
    """
    paired = body.method(name).get(PAIRED)
    if paired is not None:
        return [
            NEVER if seed["labels"] is None else seed["labels"] - scale * seed["baseline_labels"]
            for seed in paired["per_seed"]
        ]
    mine, theirs = _labels_by_seed(body.method(name)), _labels_by_seed(body.method(BASELINE))
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


def _match_figure(method: dict[str, Any], unit: str) -> tuple[bool, str, Any, Any]:
    """Labels to DAgger's final success: paired, the figure in words, seeds reaching it, seeds.

    The figure is the median paired ratio where the summary has it, else the median labels followed by ``unit``.
    """
    paired = method.get(PAIRED)
    if paired is not None:
        ratio = "never" if paired["median_ratio"] is None else f"{paired['median_ratio']:.2f}x DAgger's"
        return True, ratio, paired["seeds_reached"], paired["seeds"]
    match = method.get("labels_to_match_dagger", {})
    median = "never" if match.get("median") is None else f"{match['median']:.0f}{unit}"
    return False, median, match.get("seeds_reached"), method["seeds"]


def _labels_to_match_brief(method: dict[str, Any]) -> str:
    """Labels to DAgger's final success in a few words: the paired ratio where the summary has it, else labels."""
    _, figure, reached, seeds = _match_figure(method, " labels")
    return f"{figure} ({reached} of {seeds} seeds)"


def _labels_to_match(method: dict[str, Any]) -> str:
    paired, figure, reached, seeds = _match_figure(method, "")
    if paired:
        return f"paired by seed: median {figure} ({reached} of {seeds} seeds reach it)"
    return f"{figure} ({reached} of {seeds} reach it)"


def _fewer_labels(body: Body, name: str, alpha: float) -> Finding:
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
    # Paired by seed, DAgger's own figure is 1x on every seed: only the method's is worth a word.
    theirs = "" if PAIRED in method else f" vs DAgger {_labels_to_match_brief(dagger)}"
    brief = f"`{name}` {_labels_to_match_brief(method)}{theirs}, {_p_text(comparison)}"
    return Finding(comparison.outcome, comparison.toward, text, brief)


def _sixty_finding(body: Body, name: str, alpha: float) -> Finding:
    """Claim 4 on one body: the seeds whose learner passes 60% after fewer than EPISODE_LIMIT episodes."""
    method = body.method(name)
    if not method:
        return Finding(UNDECIDED, 0, f"{body.name} `{name}`: no trials")
    seeds, untrained = method["seeds"], method.get("untrained_success", {})
    start = untrained.get("pooled", {}).get("rate")
    prefix = f"{body.name} `{name}`: untrained {_pct(start, 1)} pooled ({_spread(untrained)} per seed)"
    if untrained.get("median") is not None and untrained["median"] >= TARGET_SUCCESS:
        return Finding(UNTESTABLE, 0, f"{prefix}: at 60% before its first label", f"`{name}` at 60% untrained")
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
            f"`{name}` {within} of {seeds} seeds within the trial (no episode counts)",
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
        f"`{name}` {passed} of {len(episodes)} seeds, median {after} episodes",
    )


def _saving_finding(body: Body, name: str, alpha: float) -> Finding:
    """Claim 6 on one method and body: DAgger's final success at <= SAVING_RATIO x DAgger's labels."""
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
    # Direction: the median ratio against the saving ratio; none when DAgger's own median is never (no ratio).
    toward = 0 if theirs is None else -1 if ratio is None else int(np.sign(SAVING_RATIO - ratio) or 1)
    shown = "n/a" if ratio is None else f"{ratio:.2f}x"
    p_value = "n/a" if test.p_value is None else f"{test.p_value:.3g}"
    text = f"`{name}` {_labels_to_match(method)}, {shown}, p = {p_value}: {outcome}"
    return Finding(outcome, toward, text, f"`{name}` {_labels_to_match_brief(method)}")


# ---------------------------------------------------------------- protocol 2: the claims


@dataclass(frozen=True)
class ClaimVerdict:
    """One claim judged on the bodies' folders: one row of the claims table.

    Attributes:
        number: The claim's number (1-7).
        claim: The paper's claim, in words (markdown).
        measurement: What was measured, per reading and body (markdown, ``<br>`` between lines).
        verdict: ``holds``, ``does not hold``, ``inconclusive`` or ``not testable here``, by the rules.
        leaning: The verdict, or where the tests do not decide it, the direction of the data.
        printed: What the table prints: the verdict, or ``interim: leaning <leaning>`` on an interim folder,
            followed by `` (<note>)`` when there is a note; ``""`` until :func:`judge_claims` sets it.
        note: Why a verdict is bounded or untestable (``""`` if it needs no note).
        outcomes: ``{reading: {body: outcome}}``.
        brief: The measurement in a few words per body (markdown, ``<br>`` between bodies), for the README.
    """

    number: int
    claim: str
    measurement: str
    verdict: str
    leaning: str
    printed: str = ""
    note: str = ""
    outcomes: dict[str, dict[str, str]] = field(default_factory=dict)
    brief: str = ""


Judge = Callable[[Body, str, float], Finding]
"""A reading's finding on one body: ``judge(body, method, alpha)``."""


@dataclass(frozen=True)
class PaperClaim:
    """One of the paper's claims and how the folders test it.

    Attributes:
        number: The claim's number (1-7).
        statement: The claim, in words (markdown, as the table prints it).
        readings: The methods that each stand for the claim; each is tried at ``ALPHA / len(readings)``.
        rule: The claim's verdict on the bodies' folders, ``rule(claim, bodies)``.
    """

    number: int
    statement: str
    readings: tuple[str, ...]
    rule: Callable[[PaperClaim, Sequence[Body]], ClaimVerdict]

    @property
    def alpha(self) -> float:
        """The threshold of each reading's test: :data:`ALPHA` split over the readings (Bonferroni)."""
        return ALPHA / max(1, len(self.readings))

    def judge(self, bodies: Sequence[Body]) -> ClaimVerdict:
        """This claim's verdict on ``bodies`` (one per body of :data:`BODIES`), before the interim rule."""
        return self.rule(self, bodies)


def _brief_by_body(bodies: Sequence[Body], findings: Sequence[Sequence[Finding]]) -> str:
    """One line per body: its findings' briefs, ``findings[i]`` being body ``i``'s."""
    return "<br>".join(
        f"{body.name}: " + "; ".join(finding.brief for finding in found)
        for body, found in zip(bodies, findings, strict=True)
    )


def _by_readings(judge: Judge) -> Callable[[PaperClaim, Sequence[Body]], ClaimVerdict]:
    """The rule that tries ``judge`` on every reading and body and combines them (the module's rules)."""

    def rule(claim: PaperClaim, bodies: Sequence[Body]) -> ClaimVerdict:
        findings = {reading: [judge(body, reading, claim.alpha) for body in bodies] for reading in claim.readings}
        verdict, leaning = combine_readings([combine_bodies(found) for found in findings.values()])
        text = "<br>".join(finding.text for found in findings.values() for finding in found)
        outcomes = {
            reading: {body.name: finding.outcome for body, finding in zip(bodies, found, strict=True)}
            for reading, found in findings.items()
        }
        measurement = f"threshold p < {claim.alpha:.3g}<br>{text}"
        by_body = _brief_by_body(bodies, [[found[i] for found in findings.values()] for i in range(len(bodies))])
        brief = f"threshold p < {claim.alpha:.3g}<br>{by_body}"
        return ClaimVerdict(
            claim.number, claim.statement, measurement, verdict, leaning, outcomes=outcomes, brief=brief
        )

    return rule


def _sixty(claim: PaperClaim, bodies: Sequence[Body]) -> ClaimVerdict:
    """Claim 4, with DAgger's own episodes to 60% shown beside it."""
    row = _by_readings(_sixty_finding)(claim, bodies)
    dagger = "<br>".join(_sixty_finding(body, BASELINE, claim.alpha).text for body in bodies)
    return dataclasses.replace(row, measurement=f"{row.measurement}<br>for comparison, not in the verdict:<br>{dagger}")


def _bounded_by_dense_q(claim: PaperClaim, bodies: Sequence[Body]) -> ClaimVerdict:
    """Claim 5: ``aggrevate`` beating DAgger is not testable here, since its oracle Q is dense."""
    row = _by_readings(_lower_success)(claim, bodies)
    # The dense Q favours aggrevate, so its win over DAgger cannot refute a claim about a sparse one.
    return dataclasses.replace(
        row,
        verdict=NOT_TESTABLE if row.verdict == DOES_NOT_HOLD else row.verdict,
        leaning=NOT_TESTABLE if row.leaning.startswith(DOES_NOT_HOLD) else row.leaning,
        note=(
            "bounded: `aggrevate` scores with the oracle's dense cost-to-go, not a sparse reward; DAgger beating "
            "it supports the claim, it beating DAgger says nothing of the sparse-reward one"
        ),
    )


def _saving(claim: PaperClaim, bodies: Sequence[Body]) -> ClaimVerdict:
    """Claim 6: a body supports it when some active method does, contradicts it when every one does."""
    per_body, texts, briefs = [], [], []
    outcomes: dict[str, dict[str, str]] = {name: {} for name in claim.readings}
    for body in bodies:
        found = {name: _saving_finding(body, name, claim.alpha) for name in claim.readings}
        kinds = [finding.outcome for finding in found.values()]
        outcome = SUPPORTS if SUPPORTS in kinds else CONTRADICTS if all(k == CONTRADICTS for k in kinds) else UNDECIDED
        towards = [finding.toward for finding in found.values()]
        toward = 1 if 1 in towards else -1 if all(t < 0 for t in towards) else 0
        per_body.append(Finding(outcome, toward, ""))
        briefs.append(list(found.values()))
        for name, finding in found.items():
            outcomes[name][body.name] = finding.outcome
        dagger = body.method(BASELINE)
        texts.append(
            f"{body.name}: labels to DAgger's {_pct(dagger.get('labels_to_match_dagger', {}).get('target'))}, DAgger "
            f"{_labels_to_match(dagger)}; " + "; ".join(f.text for f in found.values()) + f"; body: {outcome}"
        )
    verdict, leaning = combine_readings([combine_bodies(per_body)])
    measurement = f"threshold p < {claim.alpha:.3g}; median labels (seeds reaching), ratio to DAgger's, paired p<br>"
    brief = (
        f"threshold p < {claim.alpha:.3g}; labels to DAgger's final success, median (seeds reaching it):<br>"
        + _brief_by_body(bodies, briefs)
    )
    return ClaimVerdict(
        claim.number,
        claim.statement,
        measurement + "<br>".join(texts),
        verdict,
        leaning,
        outcomes=outcomes,
        brief=brief,
    )


STUDY_MEASURES = (
    "No people took part in these runs. The study kit (`antmaze_hirl/study`) measures, per participant and "
    "method: the six NASA-TLX items (mental, physical and temporal demand, performance, effort, frustration) "
    "on the paper's 5-point scale after each trial, seconds per label, time on task and labels. It compares "
    "methods by a repeated-measures ANOVA and paired tests (`antmaze_hirl/study/stats.py`)."
)
"""Claim 7's measurement: what the study kit would measure, since oracle runs hold no person's answers."""


def _needs_people(claim: PaperClaim, bodies: Sequence[Body]) -> ClaimVerdict:
    """Claim 7: it needs participants, so no results folder tests it."""
    del bodies  # oracle runs hold no person's answers
    return ClaimVerdict(
        claim.number,
        claim.statement,
        STUDY_MEASURES,
        NOT_TESTABLE,
        NOT_TESTABLE,
        note="it needs participants",
        brief="no people took part; the study kit measures NASA-TLX workload, seconds per label and labels",
    )


CLAIMS = (
    PaperClaim(1, "Reward-based AL beats DAgger in **success**", REWARD_BASED, _by_readings(_higher_success)),
    PaperClaim(2, "Reward-based AL beats DAgger in **labels**", REWARD_BASED, _by_readings(_fewer_labels)),
    PaperClaim(3, "Multi-policy AL does **worse** than DAgger", ("multi_policy",), _by_readings(_lower_success)),
    PaperClaim(4, "Reward-based AL passes **60% in under 100 episodes**", REWARD_BASED, _sixty),
    PaperClaim(5, "DAgger beats **AggreVaTeD under sparse reward**", ("aggrevate",), _bounded_by_dense_q),
    PaperClaim(
        6,
        f"Active learning **saves expert cost** (DAgger's final success at <= {SAVING_RATIO}x its labels)",
        ACTIVE,
        _saving,
    ),
    PaperClaim(
        7, "**Subjective measures**: the methods differ in perceived workload and frustration", (), _needs_people
    ),
)
"""The paper's seven claims, in its order."""


def judge_claims(bodies: Sequence[Body]) -> list[ClaimVerdict]:
    """Every claim of :data:`CLAIMS` judged on ``bodies``, with what the table prints.

    On an interim folder (some body's :attr:`Body.interim`) every row but claim 7's prints
    ``interim: leaning <leaning>``, never a verdict: claim 7 needs people, not seeds, so no rerun changes it.
    """
    interim = any(body.interim for body in bodies)
    verdicts = []
    for claim in CLAIMS:
        row = claim.judge(bodies)
        word = f"interim: leaning {row.leaning}" if interim and claim.number != 7 else row.verdict
        verdicts.append(dataclasses.replace(row, printed=f"{word} ({row.note})" if row.note else word))
    return verdicts


@dataclass(frozen=True)
class ClaimsReport:
    """The claims judged on one protocol-2 folder per body.

    Attributes:
        bodies: The folders read, in the order of :data:`BODIES`.
        verdicts: One per claim of :data:`CLAIMS`, in its order.
    """

    bodies: tuple[Body, ...]
    verdicts: tuple[ClaimVerdict, ...]

    @property
    def interim(self) -> bool:
        """Some folder is interim, so no verdict is final."""
        return any(body.interim for body in self.bodies)


def evaluate_folders(point_folder: Path, ant_folder: Path) -> ClaimsReport:
    """The paper's claims judged on a protocol-2 results folder of each body.

    Args:
        point_folder: The point body's results folder (``summary.json``, optionally ``episodes.csv``).
        ant_folder: The ant body's.

    Raises:
        ValueError: One line naming the folder or file that is not a protocol-2 folder of its body
            (:func:`read_body`).
    """
    bodies = tuple(
        read_body(Path(folder), name) for folder, name in zip((point_folder, ant_folder), BODIES, strict=True)
    )
    return ClaimsReport(bodies, tuple(judge_claims(bodies)))
