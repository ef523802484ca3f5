"""``scripts/next_cell_labels.py``: the carried rule turns the ant's "stay" labels into moves along the path."""

import json
import sys

import pytest
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (scripts/next_cell_labels.py): the integration tier

next_cell_labels = load_script("scripts/next_cell_labels.py")


def test_carrying_labels_at_the_reach_cuts_stay_and_follows_the_path(tmp_path, monkeypatch):
    out = tmp_path / "labels.json"
    argv = ["next_cell_labels.py", "--mazes", "30", "--states", "10", "--out", str(out)]
    monkeypatch.setattr(sys, "argv", argv)
    next_cell_labels.main()
    result = json.loads(out.read_text())
    old, new = result["rules"].values()
    assert result["states"] > 200 and result["reach_m"] == 2.0 and result["cell_m"] == 4.0
    assert old["stay"] > 0.4 and new["stay"] < old["stay"] - 0.25
    assert new["matches_grid_path"] > old["matches_grid_path"] + 0.2
    assert new["goal_within_reach_moved"] < 0.01 and new["own_centre_moved"] < 0.01
