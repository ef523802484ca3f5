"""The generic statistics of protocol 3's readings: the two-way bootstrap, its p-values, Holm, one-sided Wilcoxon."""

import itertools
import math

import numpy as np
import pytest

from antmaze_hirl.experiments.uncertainty import (
    bootstrap_p,
    holm,
    paired_comparison,
    paired_two_way_bootstrap,
    percentile_interval,
    signed_rank_p,
    two_way_bootstrap,
)


def mean_of(table):
    return lambda rows, weights: float((table[rows] @ weights).sum() / (len(rows) * weights.sum()))


def test_the_bootstrap_distribution_of_a_small_table_matches_its_exact_enumeration():
    # 2 seeds x 3 mazes: 2**2 row draws x 3**3 column draws, all equally likely, give the exact distribution.
    table = np.array([[1.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    exact = [
        table[np.ix_(rows, cols)].mean()
        for rows in itertools.product(range(2), repeat=2)
        for cols in itertools.product(range(3), repeat=3)
    ]
    resamples = 20000
    drawn = two_way_bootstrap(mean_of(table), 2, range(3), resamples=resamples, seed=1)
    for cut in (0.0, 1 / 3, 0.5, 2 / 3, 5 / 6):
        probability = np.mean(np.asarray(exact) <= cut + 1e-12)
        tolerance = 4 * math.sqrt(probability * (1 - probability) / resamples) + 1e-9
        assert abs(np.mean(drawn <= cut + 1e-12) - probability) <= tolerance, cut


def test_an_additive_table_has_the_known_bootstrap_variance():
    # d[s, m] = a_s + b_m: a resample's mean is mean(a drawn) + mean(b drawn), of variance var(a)/S + var(b)/M.
    rng = np.random.default_rng(0)
    a, b = rng.normal(0, 2, size=10), rng.normal(0, 5, size=100)
    table = a[:, None] + b[None, :]
    expected = math.sqrt(a.var() / 10 + b.var() / 100)
    drawn = two_way_bootstrap(mean_of(table), 10, range(100), resamples=8000, seed=2)
    assert drawn.std() == pytest.approx(expected, rel=0.05)
    assert drawn.mean() == pytest.approx(table.mean(), abs=4 * expected / math.sqrt(8000))


def test_mazes_that_are_one_task_up_to_symmetry_are_resampled_as_one_cluster():
    # 50 tasks, each played twice (a task and its mirror image): the mazes add no information beyond the tasks,
    # so the bootstrap's spread is that of 50 clusters, sqrt(2) wider than treating 100 mazes as independent.
    rng = np.random.default_rng(3)
    tasks = rng.normal(0, 1, size=50)
    table = np.tile(np.repeat(tasks, 2), (10, 1))  # no seed effect
    clusters = np.repeat(np.arange(50), 2)
    as_clusters = two_way_bootstrap(mean_of(table), 10, clusters, resamples=6000, seed=4)
    as_mazes = two_way_bootstrap(mean_of(table), 10, range(100), resamples=6000, seed=4)
    assert as_clusters.std() == pytest.approx(tasks.std() / math.sqrt(50), rel=0.06)
    assert as_mazes.std() == pytest.approx(tasks.std() / math.sqrt(100), rel=0.06)


def test_a_constant_difference_has_a_point_interval_and_the_smallest_p():
    result = paired_two_way_bootstrap(np.full((10, 20), 0.25), resamples=500)
    assert result["interval_95"] == [0.25, 0.25]
    assert result["p_greater"] == pytest.approx(1 / 501) and result["p_less"] == 1.0
    assert result["mean"] == 0.25 and result["clusters"] == 20


def test_counting_the_mazes_widens_what_the_per_seed_test_calls_certain():
    # Every seed gains the same +2 points on average, but the gain comes from a few mazes: the per-seed test sees
    # ten equal positive differences (its smallest p), the two-way bootstrap an interval that reaches below 0.
    maze_effect = np.zeros(100)
    maze_effect[:2] = 1.0  # two mazes flip from failure to success for every seed
    table = np.tile(maze_effect, (10, 1))
    per_seed = paired_comparison(table.mean(axis=1).tolist(), [0.0] * 10)
    two_way = paired_two_way_bootstrap(table, resamples=4000)
    assert per_seed["wilcoxon_p"] == pytest.approx(0.001953125)
    assert two_way["interval_95"][0] == 0.0 and two_way["p_greater"] > 0.05


def test_the_paired_interval_has_the_coverage_asked_for():
    table = np.random.default_rng(0).normal(0.1, 1.0, (8, 40))
    wide, narrow = (paired_two_way_bootstrap(table, resamples=2000, confidence=c)["interval_95"] for c in (0.95, 0.5))
    assert wide[0] < narrow[0] < table.mean() < narrow[1] < wide[1]
    assert wide == paired_two_way_bootstrap(table, resamples=2000)["interval_95"]  # 0.95 by default


def test_bootstrap_p_counts_the_bound_for_the_null_and_refuses_bad_input():
    values = np.array([-1.0, 0.0, 1.0, 2.0])
    assert bootstrap_p(values, 0.0, "greater") == pytest.approx(3 / 5)  # -1 and 0 are on the null's side
    assert bootstrap_p(values, 2.0, "less") == pytest.approx(2 / 5)
    with pytest.raises(ValueError, match="side"):
        bootstrap_p(values, 0.0, "two-sided")
    with pytest.raises(ValueError, match="NaN"):
        bootstrap_p([math.nan], 0.0, "less")


def test_the_percentile_interval_picks_resampled_values_even_infinite_ones():
    values = np.array([-math.inf, *range(98), math.inf])
    assert percentile_interval(values, 0.5) == (23.0, 73.0)  # the 25th and 75th of 100 sorted values
    assert percentile_interval(np.array([1.0, math.inf]), 0.5) == (1.0, math.inf)


def test_two_way_bootstrap_refuses_an_empty_experiment_and_few_resamples():
    with pytest.raises(ValueError, match="needs seeds and mazes"):
        two_way_bootstrap(lambda r, w: 0.0, 0, range(3))
    with pytest.raises(ValueError, match="resamples"):
        two_way_bootstrap(lambda r, w: 0.0, 2, range(3), resamples=10)
    with pytest.raises(ValueError, match="maze clusters"):
        paired_two_way_bootstrap(np.zeros((2, 3)), ["a", "b"])


def test_holm_by_hand_and_against_statsmodels():
    # Sorted 0.005, 0.01, 0.03, 0.04: 4 x 0.005, 3 x 0.01, max(2 x 0.03, ...), max(1 x 0.04, 0.06).
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert holm([]) == []
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        holm([0.5, 1.5])
    multitest = pytest.importorskip("statsmodels.stats.multitest")
    p_values = np.random.default_rng(5).uniform(0, 0.2, size=12)
    assert holm(p_values) == pytest.approx(multitest.multipletests(p_values, method="holm")[1].tolist())


def test_the_one_sided_signed_rank_test_ranks_never_above_every_count():
    assert signed_rank_p(range(1, 11), "greater") == pytest.approx(1 / 1024)  # the floor with 10 pairs
    assert signed_rank_p([math.inf] * 10, "greater") == pytest.approx(1 / 1024)
    assert signed_rank_p([math.inf] * 10, "less") == 1.0
    # -inf is the largest loss: one seed that never gets there outweighs nine small gains' ranks.
    mixed = [0.1] * 9 + [-math.inf]
    assert signed_rank_p(mixed, "greater") > signed_rank_p([0.1] * 9 + [-0.05], "greater")
    assert signed_rank_p([0.0, 0.0], "greater") == 1.0 and signed_rank_p([1.0], "greater") is None
    with pytest.raises(ValueError, match="alternative"):
        signed_rank_p([1.0, 2.0], "bigger")


@pytest.mark.parametrize(
    "differences",
    [
        [0.1, 0.1, 0.2, -0.1, 0.3, 0.3, 0.0, 0.05, 0.1, -0.2],  # ties and a zero: scipy's permutation path
        [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, -10.0],  # no ties: scipy's exact table
        [0.02, -0.01, 0.02, 0.02, -0.03, 0.01],
    ],
)
def test_the_enumerated_signed_rank_p_equals_scipys(differences):
    from scipy.stats import wilcoxon

    for alternative in ("greater", "less", "two-sided"):
        expected = wilcoxon(differences, alternative=alternative).pvalue
        assert signed_rank_p(differences, alternative) == pytest.approx(expected, rel=1e-9), alternative
