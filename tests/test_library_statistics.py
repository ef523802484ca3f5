"""The intervals that scipy now computes (``scipy.stats.binomtest``'s Wilson interval, ``scipy.stats.bootstrap``)
against the outputs of the hand-written code they replaced, kept here as it was: the committed results files'
intervals came from it."""

import math

import numpy as np
import pytest

from antmaze_hirl.experiments.benchmark import BOOTSTRAP_RESAMPLES, task_bootstrap_interval
from antmaze_hirl.experiments.uncertainty import wilson_interval


def closed_form_wilson(successes, trials):
    # uncertainty.wilson_interval (and benchmark._wilson, which called it) before scipy.
    z = 1.959963984540054  # scipy.stats.norm.ppf(0.975), as it was written out
    rate = successes / trials
    denominator = 1 + z * z / trials
    centre = (rate + z * z / (2 * trials)) / denominator
    half_width = z * math.sqrt(rate * (1 - rate) / trials + z * z / (4 * trials * trials)) / denominator
    return max(0.0, centre - half_width), min(1.0, centre + half_width)


def hand_written_task_bootstrap(task_rates, seed):
    # benchmark.task_bootstrap_interval before scipy.
    rates = np.asarray(task_rates, dtype=float)
    draws = np.random.default_rng(seed).integers(len(rates), size=(BOOTSTRAP_RESAMPLES, len(rates)))
    means = rates[draws].mean(axis=1)
    return [float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))]


def test_scipys_wilson_interval_gives_the_old_closed_forms_outputs():
    # Every count up to 30 trials, and the edges and a spread of counts of the sample sizes the results use.
    cases = [(k, n) for n in range(1, 31) for k in range(n + 1)]
    cases += [(k, n) for n in (50, 100, 200, 500, 1000, 2000) for k in (0, 1, 2, n // 10, n // 3, n // 2, n - 1, n)]
    for successes, trials in cases:
        assert wilson_interval(successes, trials) == pytest.approx(closed_form_wilson(successes, trials), abs=1e-15)
    assert wilson_interval(0, 10)[0] == 0.0 and wilson_interval(10, 10)[1] == 1.0  # never past the unit interval


@pytest.mark.parametrize("tasks", [2, 5, 100])
def test_scipys_bootstrap_gives_the_hand_written_task_bootstrap_outputs(tasks):
    rng = np.random.default_rng(tasks)
    # Success rates of K = 1, 5 and 20 episodes per task, as the suites score them.
    for episodes in (1, 5, 20):
        rates = rng.integers(0, episodes + 1, size=tasks) / episodes
        for seed in (0, 7):
            assert task_bootstrap_interval(rates, seed) == pytest.approx(
                hand_written_task_bootstrap(rates, seed), abs=1e-15
            )
    assert task_bootstrap_interval([0.4], 0) == hand_written_task_bootstrap([0.4], 0) == [0.4, 0.4]
