"""The README's experiment tables come from ``antmaze_lab.paper_tables``: checked on crafted curves."""

import copy
import json
import sys

import pytest
from test_experiments import crafted_rows

from antmaze_hirl.experiments import summarise
from antmaze_lab import paper_tables

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.paper_tables): the integration tier


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
    table = [line for line in per_label if line.startswith("|")]
    assert all(line.count("|") == per_label[0].count("|") for line in table)
    # The AUC's label horizon (summary.json's label_horizon) and the target's set are printed.
    horizon = summary["methods"]["dagger"]["normalised_auc"]["label_horizon"]
    assert f"| normalised AUC over 0-{horizon:.0f} labels |" in per_label[0]
    assert per_label[len(table) :] == [
        "",
        "Labels to match DAgger: same_set false: DAgger's target is read on the final set and the curves' "
        "earlier points on the periodic set (protocol 1).",
    ]
    effort = paper_tables.effort_table(summary).splitlines()
    # Noise: 300 labels (seeds 200, 400) against DAgger's 275; its 75% median is above DAgger's pooled 53.1%.
    assert effort[3] == "| noise | 300 | 1.09x | 75% | yes (bound 53.1%) |"


def test_tables_refuse_a_summary_from_before_the_per_label_figures(tmp_path, monkeypatch, capsys):
    (tmp_path / "summary.json").write_text(json.dumps({"methods": {"dagger": {"seeds": 5, "final_success": {}}}}))
    monkeypatch.setattr(sys, "argv", ["paper_tables.py", str(tmp_path)])
    with pytest.raises(SystemExit) as stop:
        paper_tables.main()
    assert stop.value.code == 2 and "predates the per-label figures" in capsys.readouterr().err


def test_beside_table_pairs_final_success_by_seed_and_pools_every_method():
    summary = {"methods": summarise(crafted_rows(), ["dagger", "noise"]), "config": {"low_level": "new", "seeds": 2}}
    summary["oracle_success"] = {"success_rate": 0.97, "episodes": 100}
    other = copy.deepcopy(summary)
    other["config"]["low_level"] = "old"
    other["oracle_success"]["success_rate"] = 0.93
    for method in other["methods"].values():  # the other run: 10 points lower on the first seed only
        method["final_success"]["per_seed"][0]["rate"] -= 0.1
        method["final_success"]["per_seed"].reverse()  # pairs are matched by seed, not by position
    other["methods"]["noise"]["final_success"]["per_seed"].insert(0, {"seed": 99, "rate": 0.0})  # unpaired
    other["methods"]["gated"] = {"seeds": 1, "final_success": {"per_seed": [{"seed": 0, "rate": 0.5}]}}
    lines = paper_tables.beside_table(summary, other, ("new", "old")).splitlines()
    assert lines[0].startswith("| method | new, median (min-max) | old, median (min-max) |")
    # DAgger's crafted seeds score 80% and 70%; the other run 70% and 70%: one up, one tie.
    assert lines[2] == "| dagger | 75% (70%-80%) | 70% (70%-70%) | +5 (1 up, 0 down of 2) | 1 |"
    # Noise's seeds score 90% and 60%, the other run's 80% and 60%; its seed 99 (0%) is in no figure.
    assert lines[3] == "| noise | 75% (60%-90%) | 70% (60%-80%) | +5 (1 up, 0 down of 2) | 1 |"
    assert lines[4] == "| every method pooled | | | +5 (2 up, 0 down of 4) | 0.5 |"
    assert lines[5] == "| oracle success | 97% of 100 | 93% of 100 | | |"
    assert lines[7:] == [
        "Methods in one run only (not compared): gated.",
        "The configs differ in: low_level ('new' vs 'old').",
    ]
    with pytest.raises(ValueError, match="share no method"):
        paper_tables.beside_table(summary, {"methods": {}}, ("new", "old"))
    for method in other["methods"].values():  # trials, but no per-seed rates: nothing pairs
        method["final_success"]["per_seed"] = []
    with pytest.raises(ValueError, match="share no method with per-seed final success"):
        paper_tables.beside_table(summary, other, ("new", "old"))
    elsewhere = {**summary, "config": {**summary["config"], "maze_size": 5}}
    with pytest.raises(ValueError, match=r"final mazes differ \(maze_size 5 vs None\)"):
        paper_tables.beside_table(elsewhere, summary, ("new", "old"))


def test_main_prints_the_beside_table_after_the_three_tables(tmp_path, monkeypatch, capsys):
    summary = {"methods": summarise(crafted_rows(), ["dagger", "noise"])}
    for name in ("new", "old"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(json.dumps(summary))
    argv = ["paper_tables.py", str(tmp_path / "new"), "--beside", str(tmp_path / "old"), "--names", "A, B"]
    monkeypatch.setattr(sys, "argv", argv)
    paper_tables.main()
    out = capsys.readouterr().out
    assert out.index("| method | A, median (min-max) | B, median (min-max) |") > out.index(
        "| labels per trial, median |"
    )
    assert "| dagger | 75% (70%-80%) | 75% (70%-80%) | +0 (0 up, 0 down of 2) | 1 |" in out  # a run beside itself


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--names", "only one"], "--names takes two comma-separated names, got 'only one'"),
        (["--names", "a,"], "--names takes two comma-separated names, got 'a,'"),
        (["--beside", "nowhere"], "no summary.json in nowhere"),
        (["--names", "a,b"], "--names 'a,b' names the --beside columns: pass --beside too"),
        (["--beside", "{bad}"], "summary.json is not JSON: Expecting value"),
        (["--beside", "{listed}"], "summary.json has no 'methods' object: not a paper-experiment summary"),
    ],
)
def test_bad_beside_arguments_get_one_line_errors(tmp_path, monkeypatch, capsys, extra, message):
    summary = {"methods": summarise(crafted_rows(), ["dagger"])}
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    for name, text in (("bad", "not json"), ("listed", "[1, 2]")):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(text)
    extra = [part.format(bad=tmp_path / "bad", listed=tmp_path / "listed") for part in extra]
    monkeypatch.setattr(sys, "argv", ["paper_tables.py", str(tmp_path), *extra])
    with pytest.raises(SystemExit) as stop:
        paper_tables.main()
    assert stop.value.code == 2 and message in capsys.readouterr().err


def test_labels_to_match_dagger_at_0_labels_has_a_ratio_and_protocol_2_notes_the_same_set():
    from test_protocol2 import crafted_trials

    # DAgger reaches its median final success (4/4) after 4 episodes (40 labels); noise starts there untrained.
    rows, evaluations = crafted_trials({"dagger": [{0: 1, 2: 3, 4: 4}] * 2, "noise": [{0: 4, 2: 4, 4: 4}] * 2})
    summary = {"methods": summarise(rows, ["dagger", "noise"], evaluations=evaluations)}
    noise = summary["methods"]["noise"]["labels_to_match_dagger"]
    assert noise["median"] == 0.0 and noise["ratio_vs_dagger"] == 0.0  # not None: 0 labels is a count
    per_label = paper_tables.per_label_table(summary).splitlines()
    assert "| normalised AUC over 0-40 labels |" in per_label[0]
    # The last two: paired by seed, on DAgger's final success and on the mean of its last 3 evaluations.
    assert "| paired, target the mean of DAgger's last 3 evaluations |" in per_label[0]
    # Both seeds 40 labels below DAgger's: the paired test's p with 2 pairs is 0.5, its floor.
    assert per_label[3].endswith("| 0 (2 of 2) | 0.00x | 0.00x (2 of 2, p = 0.5) | 0.00x (2 of 2, p = 0.5) |")
    assert per_label[2].endswith("| 40 (2 of 2) | 1.00x | 1.00x | 1.00x |")
    # The header states the count the summary recorded, not today's default.
    older = copy.deepcopy(summary)
    older["methods"]["noise"]["labels_to_match_dagger_per_seed_smoothed"]["target_evaluations"] = 5
    assert "| paired, target the mean of DAgger's last 5 evaluations |" in paper_tables.per_label_table(older)
    assert per_label[-1].startswith("Labels to match DAgger: same_set true: DAgger's target and every curve")
    # DAgger itself at 0 labels: 0 against 0 is a ratio of 1; a method needing more has no finite ratio.
    both = {"methods": summarise(rows, ["noise"], baseline="noise", evaluations=evaluations)}
    assert both["methods"]["noise"]["labels_to_match_noise"]["ratio_vs_noise"] == 1.0
    dagger_vs_noise = summarise(rows, ["dagger", "noise"], baseline="noise", evaluations=evaluations)
    assert dagger_vs_noise["dagger"]["labels_to_match_noise"]["ratio_vs_noise"] is None
