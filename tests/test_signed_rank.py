"""The signed-rank interval and smallest p of ``experiments.uncertainty``, on known answers."""

import math

import pytest

from antmaze_hirl.experiments.uncertainty import signed_rank_interval, smallest_signed_rank_p


def test_the_interval_inverts_the_signed_rank_test():
    assert signed_rank_interval([1, 2, 3, 4, 5]) == (-math.inf, math.inf)
    assert signed_rank_interval([3, 1, 4, 1, 5, 9]) == (1.0, 9.0)  # 6 pairs: the extreme Walsh averages
    differences = [0.5, -1.0, 2.0, 3.0, 1.5, 4.0, -0.5, 2.5, 6.0, 1.0]
    walsh = sorted((a + b) / 2 for i, a in enumerate(differences) for b in differences[i:])
    # 10 pairs: the two-sided 5% critical value of T is 8, so the bounds are the 9th Walsh average from each end.
    assert signed_rank_interval(differences) == (walsh[8], walsh[-9])
    assert [smallest_signed_rank_p(n) for n in (3, 5, 10)] == [0.25, 0.0625, 2 / 1024]
    with pytest.raises(ValueError, match="confidence must lie in"):
        signed_rank_interval([1.0, 2.0], confidence=1.5)
