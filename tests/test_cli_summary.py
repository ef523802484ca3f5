"""The experiment command's terminal summary: figures rounded, a missing one named (not ``None``)."""

import pytest

from antmaze_hirl.cli import _rounded


@pytest.mark.parametrize(
    ("value", "digits", "shown"),
    [(0.8750000001, 3, "0.875"), (12.0, 0, "12"), (None, 3, "n/a"), (float("nan"), 3, "n/a")],
)
def test_a_summary_figure_is_rounded_or_named_missing(value, digits, shown):
    assert _rounded(value, digits) == shown


def test_a_target_never_reached_says_so():
    assert _rounded(None, 0, "not reached") == "not reached"
