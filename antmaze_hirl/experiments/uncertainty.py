"""Uncertainty of the reported figures: Wilson intervals, a cluster bootstrap of pooled rates, paired tests.

Per-seed success rates carry Wilson intervals; a rate pooled over seeds that share their mazes carries a
cluster bootstrap interval over seeds and mazes; methods are compared by paired tests over seeds.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
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
def _wilcoxon_p(differences: tuple[float, ...]) -> float:
    """The two-sided Wilcoxon signed-rank p-value of ``differences`` (scipy's), cached.

    With ties scipy falls back to an exact permutation test over all 2**n sign flips (about half a second for
    10 pairs), and the claims and summaries ask for the same differences many times.
    """
    from scipy.stats import wilcoxon  # here, not at import: see the note on imports above

    return float(wilcoxon(np.asarray(differences), alternative="two-sided").pvalue)


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
