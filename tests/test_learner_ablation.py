"""``scripts/learner_ablation.py``: variant settings per map, machine records and which trials a summary reads."""

import json
import sys

import numpy as np
import pytest
from script_helpers import load_script

from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env
from antmaze_hirl.experts import PathOracle

pytestmark = pytest.mark.integration  # a lab check (scripts/learner_ablation.py): the integration tier

learner_ablation = load_script("scripts/learner_ablation.py")


def test_planning_variants_get_rows_plus_cols_plus_two_rounds_on_each_bodys_map():
    point = ExperimentConfig(body="point", held_out_layouts=True)
    ant = ExperimentConfig(body="ant", held_out_layouts=True, **body_settings("ant", held_out_layouts=True))
    assert learner_ablation.variant_settings("next_cell_vin_walls", point)["planning_iterations"] == 16  # 7x7 map
    assert learner_ablation.variant_settings("next_cell_vin", ant)["planning_iterations"] == 14  # 6x6 map
    assert learner_ablation.variant_settings("next_cell_cnn", ant)["planning_iterations"] == 0
    assert learner_ablation.VARIANTS["next_cell_vin"]["planning_iterations"] == learner_ablation.PLANS  # untouched


def test_machines_lists_each_distinct_machine_once_and_skips_trials_without_one():
    here = {"cpu_model": "A", "packages": {"torch": "2.13.0"}}
    there = {"cpu_model": "B", "packages": {"torch": "2.11.0"}}
    trials = [{"machine": here}, {"machine": dict(here)}, {"machine": there}, {}]
    assert learner_ablation.machines(trials) == [here, there]


def trial(variant, seed, body=None, final=0.5):
    figures = {"rate": final, "wilson_95": [0.4, 0.6]}
    record = {
        "variant": variant,
        "seed": seed,
        "final_success": figures,
        "selection_success": figures,
        "oracle_cell_agreement": {"training_labels": 1.0, "held_out_states": 0.7},
        "labels": 100,
        "trial_seconds": 60.0,
    }
    return record if body is None else {**record, "body": body}


def test_a_summary_reads_its_own_bodys_trials_and_a_rerun_keeps_the_note(tmp_path, monkeypatch):
    trials = tmp_path / "trials"
    trials.mkdir()
    # A trial that names no body is the point's (written before the ant joined).
    (trials / "heading_cnn_e100_seed0.json").write_text(json.dumps(trial("heading_cnn", 0, final=0.9)))
    (trials / "ant_heading_cnn_e100_seed0.json").write_text(json.dumps(trial("heading_cnn", 0, "ant", final=0.3)))
    out = tmp_path / "ant.json"
    argv = ["learner_ablation.py", "--body", "ant", "--variants", "heading_cnn", "--seeds", "0"]
    argv += ["--trials-dir", str(trials), "--out", str(out)]
    monkeypatch.setattr(sys, "argv", [*argv, "--note", "ran elsewhere"])
    learner_ablation.main()
    monkeypatch.setattr(sys, "argv", argv)
    learner_ablation.main()
    summary = json.loads(out.read_text())
    assert summary["variants"]["heading_cnn"]["final_success_median"] == 0.3  # the ant's trial, not the point's
    assert summary["protocol"]["body"] == "ant" and summary["protocol"]["maze_size"] == 4
    assert summary["note"] == "ran elsewhere" and len(summary["commands"]) == 2


def test_the_untrained_rule_pools_the_seeds_and_a_selection_only_summary_has_no_final():
    config = ExperimentConfig(body="point", held_out_layouts=True)
    low = {"rate": 0.1, "successes": 5, "episodes": 50, "wilson_95": [0.04, 0.21]}
    high = {"rate": 0.4, "successes": 20, "episodes": 50, "wilson_95": [0.28, 0.54]}
    passing = [{**trial("next_cell_cnn", s), "untrained_selection_success": low} for s in (0, 1)]
    failing = [{**trial("next_cell_vin", 0), "untrained_selection_success": low}]
    failing.append({**trial("next_cell_vin", 1), "untrained_selection_success": high})
    for record in passing:
        del record["final_success"]  # --selection-only
    summary = learner_ablation.summarise([*passing, *failing], config)
    assert summary["next_cell_cnn"]["final_success_median"] is None
    assert summary["next_cell_vin"]["final_success_median"] == 0.5
    cnn, vin = (summary[name]["untrained_selection_successes"] for name in ("next_cell_cnn", "next_cell_vin"))
    assert cnn["successes"] == 10 and cnn["meets_rule"]
    assert vin["rate"] == 0.25 and not vin["meets_rule"]
    assert learner_ablation.untrained_total([trial("heading_cnn", 0)]) is None  # not measured


@pytest.mark.integration
def test_an_evaluation_stores_one_outcome_per_maze_in_seed_order_and_its_rate_is_their_mean():
    config = ExperimentConfig(body="point", held_out_layouts=True)
    env = make_env(config, split="selection")
    oracle = PathOracle.for_env(env, subgoal_reach_m=config.subgoal_reach_m)
    env.close()
    scored = learner_ablation.evaluate_on(oracle, config, ("selection", 3_000_000, 4))
    random = learner_ablation.evaluate_on(lambda observation: np.zeros(2), config, ("selection", 3_000_000, 4))
    assert scored["outcomes"] == [1, 1, 1, 1] and scored["successes"] == 4
    assert len(random["outcomes"]) == 4 and set(random["outcomes"]) <= {0, 1}
    assert random["successes"] == sum(random["outcomes"]) and random["first_seed"] == 3_000_000
