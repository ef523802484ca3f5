"""The README's experiment tables come from ``benchmarks/paper_tables.py``: checked on crafted curves."""

import json
import sys
from pathlib import Path

import pytest

from antmaze_hirl.experiments import summarise

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
import paper_tables
from test_experiments import crafted_rows


def test_tables_print_the_summary_figures():
    summary = {"methods": summarise(crafted_rows(), ["dagger", "noise"]), "trial_seconds": {"dagger_seed0": 90}}
    costs = paper_tables.cost_table(summary).splitlines()
    assert costs[2].startswith(
        "| dagger | 75% (70%-80%) | 75.0% [53.1, 88.8] | 5.0 | 4.0 | 275 (250-300) | 1.5-1.5 min |"
    )
    assert "p = 1" in costs[3]  # noise vs DAgger on final success: differences +0.1 and -0.1
    per_label = paper_tables.per_label_table(summary).splitlines()
    # DAgger's median final success, 75%: seed 0 reaches it at 262.5 labels, seed 1 never (its median is none).
    assert per_label[2] == "| dagger | 45% (40%-50%) | 65% (63%-67%) | n/a | 0.40 (0.38-0.41) | n/a (1 of 2) | n/a |"
    assert all(line.count("|") == per_label[0].count("|") for line in per_label)
    effort = paper_tables.effort_table(summary).splitlines()
    # Noise: 300 labels (seeds 200, 400) against DAgger's 275; its 75% median is above DAgger's pooled 53.1%.
    assert effort[3] == "| noise | 300 | 1.09x | 75% | yes (bound 53.1%) |"


def test_tables_refuse_a_summary_from_before_the_per_label_figures(tmp_path, monkeypatch, capsys):
    (tmp_path / "summary.json").write_text(json.dumps({"methods": {"dagger": {"seeds": 5, "final_success": {}}}}))
    monkeypatch.setattr(sys, "argv", ["paper_tables.py", str(tmp_path)])
    with pytest.raises(SystemExit) as stop:
        paper_tables.main()
    assert stop.value.code == 2 and "predates the per-label figures" in capsys.readouterr().err
