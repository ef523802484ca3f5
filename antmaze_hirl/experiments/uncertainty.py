"""Uncertainty of the reported figures: Wilson intervals, a cluster bootstrap of pooled rates, paired tests.

Per-seed success rates carry Wilson intervals; a rate pooled over seeds that share their mazes carries a
cluster bootstrap interval over seeds and mazes; methods are compared by paired tests over seeds, and by a
two-way bootstrap of paired differences that counts the mazes (and the tasks equal up to symmetry) as draws
too (:func:`two_way_bootstrap`, :func:`paired_two_way_bootstrap`); a family of tests is corrected by
:func:`holm`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

CONFIDENCE = 0.95
# Importing scipy.stats takes seconds, and the docs' generated tables import this module: so scipy.stats is
# imported inside the functions that use it, not here.
# Paired differences are compared to this many decimals (far finer than any rate or AUC reported).
DIFFERENCE_DECIMALS = 9


def wilson_interval(successes: int, trials: int) -> tuple[float, float]:
    """The 95% Wilson score interval of ``successes`` out of ``trials``: scipy's.

    ``scipy.stats.binomtest(successes, trials).proportion_ci(method="wilson")``; it equals the closed form
    (Wilson 1927) that this function computed before to 4e-16 (a test checks it on every count up to 300 trials)
    and statsmodels' ``proportion_confint(method="wilson")`` (checked where the study extra is installed).

    Raises:
        ValueError: If ``trials < 1`` or ``successes`` is outside ``[0, trials]``.
    """
    if trials < 1:
        raise ValueError(f"trials must be >= 1, got {trials}")
    if not 0 <= successes <= trials:
        raise ValueError(f"successes must lie in [0, {trials}], got {successes}")
    from scipy.stats import binomtest  # here, not at import: see the note on imports above

    interval = binomtest(int(successes), int(trials)).proportion_ci(confidence_level=CONFIDENCE, method="wilson")
    return float(interval.low), float(interval.high)


def rate_with_interval(rate: float, trials: int) -> dict[str, Any]:
    """A success rate measured on ``trials`` episodes, with its count and 95% Wilson interval.

    Raises:
        ValueError: If ``rate * trials`` is not a whole count (to 1e-6) or ``trials < 1``.
    """
    successes = round(rate * trials)
    if abs(successes - rate * trials) > 1e-6:
        raise ValueError(f"success rate {rate} is no whole count of {trials} episodes")
    return pooled_rate(successes, trials)


def pooled_rate(successes: int, trials: int) -> dict[str, Any]:
    """``{"rate", "successes", "episodes", "wilson_95"}`` of ``successes`` out of ``trials``."""
    return {
        "rate": successes / trials,
        "successes": successes,
        "episodes": trials,
        "wilson_95": list(wilson_interval(successes, trials)),
    }


@functools.lru_cache(maxsize=4096)
def _wilcoxon_p(differences: tuple[float, ...], alternative: str = "two-sided") -> float:
    """The Wilcoxon signed-rank p-value of ``differences`` (scipy's), cached.

    With ties scipy falls back to an exact permutation test over all 2**n sign flips (about half a second for
    10 pairs), and the claims and summaries ask for the same differences many times.
    """
    from scipy.stats import wilcoxon  # here, not at import: see the note on imports above

    return float(wilcoxon(np.asarray(differences), alternative=alternative).pvalue)


ALTERNATIVES = ("two-sided", "greater", "less")


def signed_rank_p(differences: Sequence[float], alternative: str = "two-sided") -> float | None:
    """The Wilcoxon signed-rank p of paired ``differences`` against 0, two-sided or one-sided (scipy's).

    Infinite differences (a seed that never reaches a target against one that does) are ranked above every
    finite one, as the test's ranks allow; differences are rounded to :data:`DIFFERENCE_DECIMALS` first (see
    :func:`paired_comparison`).

    Returns:
        The p-value; ``None`` with fewer than 2 differences; 1.0 when every difference is 0 (no evidence
        either way).

    Raises:
        ValueError: If ``alternative`` is not one of :data:`ALTERNATIVES`, or a difference is NaN.
    """
    if alternative not in ALTERNATIVES:
        raise ValueError(f"alternative must be one of {ALTERNATIVES}, got {alternative!r}")
    values = np.asarray(differences, dtype=float)
    if np.isnan(values).any():
        raise ValueError(f"differences hold NaN: {values.tolist()}")
    finite = values[np.isfinite(values)]
    # Above every finite difference, and far enough that rounding never ties it with one.
    big = 1e6 * (1.0 + (np.abs(finite).max() if finite.size else 0.0))
    values = np.round(np.clip(values, -big, big), DIFFERENCE_DECIMALS)
    if len(values) < 2:
        return None
    if not values.any():
        return 1.0
    if len(values) <= EXACT_SIGN_FLIP_PAIRS:
        return _sign_flip_p(values, alternative)
    return _wilcoxon_p(tuple(values.tolist()), alternative)


EXACT_SIGN_FLIP_PAIRS = 16
"""Up to this many pairs :func:`signed_rank_p` enumerates all 2**n sign flips itself (65,536 at most)."""


def _sign_flip_p(values: np.ndarray, alternative: str) -> float:
    """The exact signed-rank p over every sign flip of the non-zero differences' mid-ranks.

    What scipy's ``wilcoxon`` computes (zeros dropped, its default ``zero_method="wilcox"``): its exact
    table without ties, and with ties the same enumeration through ``permutation_test``, which takes about
    0.75 s per call for 10 pairs; the readings ask for hundreds. A test checks the two agree, ties included.
    """
    from scipy.stats import rankdata  # here, not at import: see Z_95

    nonzero = values[values != 0]
    ranks = rankdata(np.abs(nonzero))
    observed = ranks[nonzero > 0].sum()
    flips = (np.arange(2 ** len(nonzero))[:, None] >> np.arange(len(nonzero))) & 1
    totals = flips @ ranks  # the positive-rank sum under every sign assignment, each equally likely under H0
    tolerance = 1e-9 * (1 + ranks.sum())  # mid-ranks are halves; sums are exact, but compare safely
    greater = float(np.mean(totals >= observed - tolerance))
    less = float(np.mean(totals <= observed + tolerance))
    return {"greater": greater, "less": less}.get(alternative, min(1.0, 2 * min(greater, less)))


def paired_comparison(values: Sequence[float], baseline: Sequence[float]) -> dict[str, Any]:
    """Paired comparison of a method with the baseline over seeds (pair i = seed i of each).

    The test is scipy's two-sided Wilcoxon signed-rank test (exact for few seeds, no normality
    assumption). With 5 seeds its smallest possible p-value is 2/32 = 0.0625, so 5 seeds cannot show a
    difference at the 5% level whatever the data; the per-seed differences are given to read directly.

    Returns:
        ``{"pairs", "differences" (value - baseline, to 9 decimals), "median_difference", "wilcoxon_p"}``;
        the p-value is ``None`` with fewer than 2 pairs and 1.0 when every difference is 0.

    Raises:
        ValueError: If the two sequences differ in length.
    """
    if len(values) != len(baseline):
        raise ValueError(f"paired values need equal lengths, got {len(values)} and {len(baseline)}")
    # Rates are k / n in floating point, so 0.94 - 0.92 and 0.88 - 0.86 differ in the 17th digit; unrounded,
    # such equal differences get distinct ranks and a tie the test must see is broken by rounding noise.
    differences = np.round(np.asarray(values, dtype=float) - np.asarray(baseline, dtype=float), DIFFERENCE_DECIMALS)
    if len(differences) < 2:
        p_value = None
    elif not differences.any():
        p_value = 1.0  # scipy divides by a zero variance here; no difference is no evidence of one
    else:
        p_value = _wilcoxon_p(tuple(differences.tolist()))
    return {
        "pairs": len(differences),
        "differences": [float(d) for d in differences],
        "median_difference": float(np.median(differences)) if len(differences) else None,
        "wilcoxon_p": p_value,
    }


def smallest_signed_rank_p(pairs: int) -> float:
    """The smallest two-sided p the exact Wilcoxon signed-rank test can give with ``pairs`` pairs: 2 / 2**n."""
    return min(1.0, 2.0 ** (1 - pairs))


def signed_rank_interval(differences: Sequence[float], confidence: float = CONFIDENCE) -> tuple[float, float]:
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


BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0


def cluster_bootstrap(
    outcomes: np.ndarray, *, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = BOOTSTRAP_SEED
) -> dict[str, Any]:
    """The pooled success rate of a ``(seeds, mazes)`` table with a two-way cluster bootstrap interval.

    Every seed of an experiment plays the same mazes, so its ``seeds x mazes`` outcomes are not
    independent draws: a hard maze fails for every seed, a lucky seed succeeds on many mazes. A Wilson
    interval of the pooled count treats them as independent and is too narrow. Here each resample draws
    seeds (rows) and mazes (columns) with replacement, independently (the "pigeonhole" bootstrap of
    Owen, 2007), and the interval is the 2.5 and 97.5 percentiles of the resampled means. With one seed
    it is the bootstrap over mazes alone. Seeded, so the same table gives the same interval.

    Args:
        outcomes: ``(seeds, mazes)`` successes (bool or 0/1).
        resamples: Bootstrap resamples.
        seed: Seed of the resampling.

    Returns:
        ``{"rate", "seeds", "mazes", "cluster_bootstrap_95", "bootstrap_se", "resamples"}``.

    Raises:
        ValueError: For a table that is not 2-D or is empty, or ``resamples < 100``.
    """
    table = np.asarray(outcomes, dtype=np.float64)
    if table.ndim != 2 or table.size == 0:
        raise ValueError(f"outcomes must be a non-empty (seeds, mazes) table, got shape {table.shape}")
    if resamples < 100:
        raise ValueError(f"resamples must be >= 100, got {resamples}")
    rng = np.random.default_rng(seed)
    n_seeds, n_mazes = table.shape
    means = np.empty(resamples)
    for index in range(resamples):
        rows, columns = rng.integers(n_seeds, size=n_seeds), rng.integers(n_mazes, size=n_mazes)
        means[index] = table[np.ix_(rows, columns)].mean()
    low, high = np.percentile(means, [100 * (1 - CONFIDENCE) / 2, 100 * (1 + CONFIDENCE) / 2])
    return {
        "rate": float(table.mean()),
        "seeds": n_seeds,
        "mazes": n_mazes,
        "cluster_bootstrap_95": [float(low), float(high)],
        "bootstrap_se": float(means.std(ddof=1)),
        "resamples": resamples,
    }


def two_way_bootstrap(
    statistic: Callable[[np.ndarray, np.ndarray], np.ndarray | float],
    seeds: int,
    maze_clusters: Sequence[Any],
    *,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> np.ndarray:
    """The bootstrap distribution of a statistic of a ``seeds x mazes`` experiment, both ways resampled.

    Each resample draws ``seeds`` seed indices with replacement and, independently, as many maze clusters as
    there are with replacement (the two-way "pigeonhole" bootstrap of :func:`cluster_bootstrap`, with mazes
    grouped: mazes that are one task up to the square's symmetries are one cluster, so a duplicate does not
    count as new evidence). A maze's weight is the number of times its cluster was drawn. The statistic sees
    the resampled seed indices and the maze weights, so one function serves a mean, a median over seeds of
    per-seed readings, or a vector of them (one per target).

    Args:
        statistic: ``statistic(seed_indices, maze_weights)``: ``seed_indices`` an ``(seeds,)`` int array,
            ``maze_weights`` an ``(mazes,)`` float array of non-negative counts; returns a float or a 1-D
            array of fixed length.
        seeds: Seeds (rows) of the experiment.
        maze_clusters: One label per maze (column); equal labels are one cluster. ``range(mazes)`` resamples
            mazes one by one.
        resamples: Bootstrap resamples.
        seed: Seed of the resampling.

    Returns:
        ``(resamples,)`` or ``(resamples, k)`` values of the statistic.

    Raises:
        ValueError: With no seed or maze, or ``resamples < 100``.
    """
    if seeds < 1 or len(maze_clusters) == 0:
        raise ValueError(f"a two-way bootstrap needs seeds and mazes, got {seeds} seeds and {len(maze_clusters)} mazes")
    if resamples < 100:
        raise ValueError(f"resamples must be >= 100, got {resamples}")
    _, cluster_of = np.unique(np.asarray([str(label) for label in maze_clusters]), return_inverse=True)
    clusters = int(cluster_of.max()) + 1
    rng = np.random.default_rng(seed)
    values = []
    for _ in range(resamples):
        rows = rng.integers(seeds, size=seeds)
        drawn = np.bincount(rng.integers(clusters, size=clusters), minlength=clusters)
        values.append(np.asarray(statistic(rows, drawn[cluster_of].astype(float)), dtype=float))
    return np.asarray(values)


def bootstrap_p(distribution: Sequence[float], null: float, side: str) -> float:
    """The one-sided bootstrap p of a null bound: how often the resampled statistic falls on the null's side.

    ``side="greater"`` tests the null "statistic <= null" against "above it": ``(1 + #{T* <= null}) / (1 + B)``;
    ``side="less"`` the mirror, ``(1 + #{T* >= null}) / (1 + B)``. Resamples exactly at the bound count for the
    null, and the +1 keeps p above 0 (it inverts the percentile interval: p < a/2 when the two-sided ``1 - a``
    interval excludes ``null``, up to that +1).

    Raises:
        ValueError: If ``side`` is neither ``"greater"`` nor ``"less"``, or the distribution is empty or NaN.
    """
    values = np.asarray(distribution, dtype=float)
    if side not in ("greater", "less"):
        raise ValueError(f"side must be 'greater' or 'less', got {side!r}")
    if values.size == 0 or np.isnan(values).any():
        raise ValueError(f"a bootstrap distribution of {values.size} values, some NaN or none")
    hits = np.count_nonzero(values <= null) if side == "greater" else np.count_nonzero(values >= null)
    return float((1 + hits) / (1 + values.size))


def percentile_interval(distribution: Sequence[float], confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The two-sided percentile interval of a bootstrap distribution (infinite values allowed, lower method).

    Uses numpy's ``inverted_cdf`` quantiles, which pick resampled values rather than interpolating between
    them, so an interval over infinite readings (a seed that never reaches a target) stays defined.
    """
    values = np.asarray(distribution, dtype=float)
    tail = (1 - confidence) / 2
    low, high = np.quantile(values, [tail, 1 - tail], method="inverted_cdf")
    return float(low), float(high)


def paired_two_way_bootstrap(
    differences: np.ndarray,
    maze_clusters: Sequence[Any] | None = None,
    *,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
    confidence: float = CONFIDENCE,
) -> dict[str, Any]:
    """The mean of a ``(seeds, mazes)`` table of paired differences, with a two-way bootstrap interval and p.

    Row ``i`` is seed ``i`` of one method minus seed ``i`` of the baseline, maze by maze (e.g. success 1/0
    minus success 1/0). Seeds and maze clusters are resampled as :func:`two_way_bootstrap` does, so the
    interval counts both the seeds and the mazes as draws; a per-seed test (Wilcoxon over the seeds' mean
    differences) treats the mazes as fixed and is narrower when mazes differ.

    Args:
        differences: ``(seeds, mazes)`` paired differences.
        maze_clusters: One label per maze; ``None``: each maze its own cluster.
        resamples: Bootstrap resamples.
        seed: Seed of the resampling.
        confidence: The interval's coverage (``interval_95`` keeps its name whatever it is; 0.95 by default).

    Returns:
        ``{"mean", "seeds", "mazes", "clusters", "interval_95", "p_greater", "p_less", "p_two_sided",
        "resamples"}``: ``p_greater`` tests "mean <= 0" against "above 0" (:func:`bootstrap_p`), ``p_less``
        the mirror, ``p_two_sided`` twice the smaller, capped at 1.

    Raises:
        ValueError: For a table that is not 2-D or is empty, or a cluster list of another length.
    """
    table = np.asarray(differences, dtype=float)
    if table.ndim != 2 or table.size == 0:
        raise ValueError(f"differences must be a non-empty (seeds, mazes) table, got shape {table.shape}")
    clusters = list(range(table.shape[1])) if maze_clusters is None else list(maze_clusters)
    if len(clusters) != table.shape[1]:
        raise ValueError(f"{len(clusters)} maze clusters for a table of {table.shape[1]} mazes")

    def mean(rows: np.ndarray, weights: np.ndarray) -> float:
        return float((table[rows] @ weights).sum() / (len(rows) * weights.sum()))

    distribution = two_way_bootstrap(mean, table.shape[0], clusters, resamples=resamples, seed=seed)
    greater, less = bootstrap_p(distribution, 0.0, "greater"), bootstrap_p(distribution, 0.0, "less")
    return {
        "mean": float(table.mean()),
        "seeds": table.shape[0],
        "mazes": table.shape[1],
        "clusters": len(set(map(str, clusters))),
        "interval_95": list(percentile_interval(distribution, confidence)),
        "p_greater": greater,
        "p_less": less,
        "p_two_sided": min(1.0, 2 * min(greater, less)),
        "resamples": resamples,
    }


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (Holm 1979), in the order given.

    Written here, in a few lines, because scipy has no Holm correction (``scipy.stats.false_discovery_control``
    is Benjamini-Hochberg's) and statsmodels, which has it (``multipletests(method="holm")``), is only in the
    ``study`` extra; a test checks the two agree where statsmodels is installed. The caller compares the
    adjusted p-values with its level.

    Raises:
        ValueError: If a p-value lies outside [0, 1].
    """
    values = np.asarray(p_values, dtype=float)
    if ((values < 0) | (values > 1) | np.isnan(values)).any():
        raise ValueError(f"p-values must lie in [0, 1], got {values.tolist()}")
    order = np.argsort(values, kind="stable")
    steps = (len(values) - np.arange(len(values))) * values[order]
    adjusted = np.empty_like(values)
    adjusted[order] = np.minimum(1.0, np.maximum.accumulate(steps))
    return [float(p) for p in adjusted]
