import csv
import dataclasses
import json
import math
import re

import pytest
import torch as th
from conftest import TINY_PROTOCOL1
from scipy.stats import wilcoxon

from antmaze_hirl.cli import main
from antmaze_hirl.experiments import ExperimentConfig, cost_to_reach, run_experiment, summarise

TINY = TINY_PROTOCOL1  # protocol 1 on 3x3 mazes: this file checks the runner, not the protocol


def row(method, seed, episode, cost, eval_success=math.nan, attempts=4):
    return {
        "method": method,
        "seed": seed,
        "episode": episode,
        "success": True,
        "expert_cost": 5,
        "cumulative_expert_cost": cost,
        "attempts": attempts,
        "eval_success": eval_success,
    }


def test_cost_to_reach_uses_the_first_evaluation_at_target():
    trial = [row("a", 0, 0, 5), row("a", 0, 1, 10, 0.5), row("a", 0, 2, 15, 0.6), row("a", 0, 3, 20, 0.9)]
    assert cost_to_reach(trial) == 15
    assert cost_to_reach(trial[:2]) is None


def test_summary_over_seeds():
    rows = [row("a", 0, 0, 5, 0.7), row("a", 1, 0, 8, 0.2), row("a", 2, 0, 6, 0.4), row("b", 0, 0, 3, 0.1, attempts=9)]
    summary = summarise(rows, ["a", "b"])
    final = summary["a"]["final_success"]
    assert (final["median"], final["min"], final["max"]) == (0.4, 0.2, 0.7)
    assert final["pooled"] is None  # no eval_mazes column: no count to put an interval on
    assert summary["a"]["cost_to_60_percent"] == {"median": 5.0, "seeds_reached": 1}
    assert summary["b"]["mean_attempts_per_episode"] == 9
    assert summary["b"]["cost_to_60_percent"]["median"] is None
    assert summarise(rows, ["c"]) == {"c": {"seeds": 0}}


@pytest.mark.integration
def test_experiment_writes_tables_and_resumes_per_trial(tmp_path):
    summary = run_experiment(["dagger", "reward"], 2, TINY, tmp_path, progress_bar=False)
    assert set(summary["methods"]) == {"dagger", "reward"}
    trial = tmp_path / "trials" / "dagger_seed1.csv"
    lines = (tmp_path / "episodes.csv").read_text().splitlines()
    assert lines[0].startswith("method,seed,episode,success,expert_cost,cumulative_expert_cost")
    assert len(lines) == 1 + 2 * 2 * 3
    assert lines[1].startswith("dagger,0,0,")  # counts as the trial CSVs write them, not "0.0"
    assert (
        lines[1].split(",")[:3] == (tmp_path / "trials" / "dagger_seed0.csv").read_text().splitlines()[1].split(",")[:3]
    )
    assert (tmp_path / "panels.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((tmp_path / "summary.json").read_text())["methods"]["dagger"]["seeds"] == 2
    before = trial.stat().st_mtime_ns
    trial.with_suffix(".json").unlink()
    (tmp_path / "trials" / "reward_seed1.csv").unlink()  # as if interrupted during that trial
    run_experiment(["dagger", "reward"], 2, TINY, tmp_path, progress_bar=False)
    assert trial.stat().st_mtime_ns == before, "finished trials are not run again"
    assert (tmp_path / "trials" / "reward_seed1.csv").exists()


@pytest.mark.integration
@pytest.mark.parametrize(
    ("methods", "config"),
    [
        # Fast: two one-episode trials in two worker processes.
        (["reward"], dataclasses.replace(TINY, episodes=1, final_eval_episodes=1)),
        pytest.param(["dagger", "reward"], TINY, marks=pytest.mark.slow),
    ],
)
def test_parallel_trials_give_the_same_numbers_as_one_job(tmp_path, methods, config):
    serial = run_experiment(methods, 2, config, tmp_path / "serial", progress_bar=False)
    parallel = run_experiment(methods, 2, config, tmp_path / "parallel", progress_bar=False, jobs=2)
    assert parallel["methods"] == serial["methods"]
    assert (tmp_path / "parallel" / "episodes.csv").read_text() == (tmp_path / "serial" / "episodes.csv").read_text()
    with pytest.raises(ValueError, match="jobs must be >= 1, got 0"):
        run_experiment(["dagger"], 1, TINY, tmp_path / "other", progress_bar=False, jobs=0)


@pytest.mark.integration
def test_experiment_refuses_mixed_settings_and_unknown_methods(tmp_path):
    run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)
    with pytest.raises(ValueError, match="holds results made with"):
        run_experiment(["dagger"], 1, dataclasses.replace(TINY, episodes=4), tmp_path, progress_bar=False)
    with pytest.raises(ValueError, match="unknown method 'gail'"):
        run_experiment(["gail"], 1, TINY, tmp_path / "other", progress_bar=False)
    with pytest.raises(ValueError, match="subgoal_reach_m must be > 0 metres, got -1"):
        ExperimentConfig(subgoal_reach_m=-1.0)


@pytest.mark.integration
def test_experiment_refuses_results_made_with_another_low_level(tmp_path):
    from antmaze_hirl.envs.controllers import PointGoToController
    from antmaze_hirl.sb3_ext.loading import load_low_level
    from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

    summary = run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)
    shipped = summary["config"]["low_level"]
    assert shipped.startswith("sha256:") and json.loads((tmp_path / "config.json").read_text())["low_level"] == shipped
    # The same weights loaded again are the same low level; other weights or a scripted controller are not.
    run_experiment(["dagger"], 1, TINY, tmp_path, low_level=load_low_level("point"), progress_bar=False)
    retrained = load_low_level("point", shipped_policy_path("point"))
    with th.no_grad():
        next(retrained.policy.parameters()).add_(1e-3)
    for other in (retrained, PointGoToController()):
        with pytest.raises(ValueError, match=f"made with low-level policy {shipped}, not"):
            run_experiment(["dagger"], 1, TINY, tmp_path, low_level=other, progress_bar=False)


@pytest.mark.integration
def test_results_written_before_a_setting_existed_still_resume(tmp_path):
    run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)
    config_file = tmp_path / "config.json"
    saved = json.loads(config_file.read_text())
    del saved["subgoal_reach_m"]  # as written by an older version
    config_file.write_text(json.dumps(saved))
    run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)  # the new setting at its default matches
    with pytest.raises(ValueError, match="holds results made with"):
        run_experiment(["dagger"], 1, dataclasses.replace(TINY, subgoal_reach_m=0.5), tmp_path, progress_bar=False)


def test_trials_written_before_eval_mazes_existed_get_whole_counts_filled():
    from antmaze_hirl.experiments.results_folder import rows_to_csv, with_eval_mazes

    trial = [row("a", 0, 0, 5), row("a", 0, 1, 10, 0.5), row("a", 0, 2, 15, 1.0)]
    filled = with_eval_mazes(trial, TINY)
    assert [r.get("eval_mazes") for r in filled] == [None, TINY.eval_episodes, TINY.final_eval_episodes]
    last_line = rows_to_csv(filled).strip().splitlines()[-1]
    assert last_line.split(",")[-2] == str(TINY.final_eval_episodes)  # "3", not "3.0"


@pytest.mark.integration
def test_subgoal_reach_m_reaches_the_oracle(monkeypatch):
    from antmaze_hirl.experiments import runner

    seen = []
    for_env = runner.PathOracle.for_env

    def recording_for_env(env, **kwargs):
        oracle = for_env(env, **kwargs)
        seen.append(oracle.subgoal_reach_m)
        return oracle

    monkeypatch.setattr(runner.PathOracle, "for_env", recording_for_env)
    runner.run_trial("dagger", 0, dataclasses.replace(TINY, episodes=1, subgoal_reach_m=0.5))
    runner.run_trial("dagger", 0, dataclasses.replace(TINY, episodes=1))
    assert seen == [0.5, 1.0]  # the point's cell is 1 m


@pytest.mark.integration
def test_experiment_cli(tmp_path, capsys):
    args = ["experiment", "--methods", "noise", "--seeds", "1", "--episodes", "2", "--eval-every", "1"]
    args += ["--eval-episodes", "1", "--final-eval-episodes", "2", "--maze-size", "3", "--gradient-steps", "3"]
    assert main([*args, "--out", str(tmp_path), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("noise: final success median") and "summary.json" in out
    assert "None" not in out and not re.search(r"\d\.\d{4,}", out), out  # rounded, and a missing figure named


# --- issue 12: held-out layouts, learning per label, uncertainty, provenance, bad input ---

HELD_OUT = dataclasses.replace(TINY, held_out_layouts=True, maze_size=4)  # the 3x3 family has no selection part


def grid_of(layout):
    """The layout's wall grid up to symmetry (what the learner, trained on all 8 images, cannot tell apart)."""
    import numpy as np

    from antmaze_hirl.envs.layouts import canonical_wall_grid

    grid = layout.replace("S", "0").replace("G", "0")
    return canonical_wall_grid(np.array([[cell == "1" for cell in row] for row in grid.split("/")]))


@pytest.mark.integration
def test_held_out_runs_rerun_byte_for_byte_and_share_no_wall_grid(tmp_path):
    from antmaze_hirl.experiments.runner import read_rows

    for folder in ("first", "second"):
        run_experiment(["dagger"], 1, HELD_OUT, tmp_path / folder, progress_bar=False)
    for name in ("trials/dagger_seed0.csv", "episodes.csv", "eval_layouts.csv"):
        assert (tmp_path / "first" / name).read_bytes() == (tmp_path / "second" / name).read_bytes(), name
    training = {grid_of(row["layout"]) for row in read_rows(tmp_path / "first" / "episodes.csv")}
    with (tmp_path / "first" / "eval_layouts.csv").open() as handle:
        evaluation = list(csv.DictReader(handle))
    assert len(training) >= 1 and len(evaluation) == HELD_OUT.eval_episodes + HELD_OUT.final_eval_episodes
    periodic = {grid_of(row["layout"]) for row in evaluation if row["set"] == "periodic"}
    final = {grid_of(row["layout"]) for row in evaluation if row["set"] == "final"}
    assert training.isdisjoint(periodic | final) and periodic.isdisjoint(final)
    assert all(layout_split_of(grid) == "train" for grid in training)
    assert all(layout_split_of(grid) == "eval" for grid in final)


def layout_split_of(grid):
    import numpy as np

    from antmaze_hirl.envs.layout_splits import wall_grid_split

    return wall_grid_split(np.array([[cell == "1" for cell in row] for row in grid.split("/")]))


@pytest.mark.parametrize(
    ("methods", "seeds", "message"),
    [
        (["dagger"], 0, "seeds must be an int >= 1 .*got 0"),
        (["dagger"], -2, "seeds must be an int >= 1 .*got -2"),
        ([], 1, r"methods must be a non-empty list .*got \[\]"),
        ("dagger", 1, "methods must be a non-empty list .*got 'dagger'"),
        (["dagger", "spider"], 1, "unknown method 'spider'"),
        (["dagger", "dagger"], 1, r"methods name \['dagger'\] more than once"),
    ],
)
def test_experiment_rejects_bad_seeds_and_methods_before_writing(tmp_path, methods, seeds, message):
    with pytest.raises(ValueError, match=message):
        run_experiment(methods, seeds, TINY, tmp_path / "out", progress_bar=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("flag", "value", "message"),
    [
        ("--seeds", "0", "--seeds must be >= 1 (trials per method), got 0"),
        ("--seeds", "-1", "--seeds must be >= 1 (trials per method), got -1"),
        ("--methods", ",", "--methods names no method, got ','"),
        ("--methods", "", "--methods names no method, got ''"),
        ("--methods", "dagger,spider", "unknown method 'spider'"),
        ("--methods", "gated,gated+spider", "unknown method 'gated+spider'"),
    ],
)
def test_experiment_cli_bad_seeds_and_methods_exit_2_with_one_line(tmp_path, capsys, flag, value, message):
    with pytest.raises(SystemExit) as exit_info:
        main(["experiment", "--out", str(tmp_path / "out"), "--no-progress", f"{flag}={value}"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def crafted_rows():
    """Two methods x two seeds; evaluations at (labels, success of 10 mazes), the last one final."""
    curves = {
        ("dagger", 0): [(50, 0.2), (150, 0.6), (300, 0.8)],
        ("dagger", 1): [(100, 0.5), (250, 0.7)],
        ("noise", 0): [(40, 0.3), (200, 0.9)],
        ("noise", 1): [(80, 0.4), (400, 0.6)],
    }
    rows = []
    for (method, seed), points in curves.items():
        for episode, (labels, success) in enumerate(points):
            # A row without evaluation between evaluations, as every M-th episode is evaluated.
            rows.append(row(method, seed, 2 * episode, labels - 1))
            rows.append({**row(method, seed, 2 * episode + 1, labels, success), "eval_mazes": 10})
    return rows


def test_learning_per_label_metrics_on_a_crafted_episodes_csv(tmp_path):
    from antmaze_hirl.experiments.results_folder import read_rows, rows_to_csv

    path = tmp_path / "episodes.csv"
    path.write_text(rows_to_csv(crafted_rows()))
    summary = summarise(read_rows(path), ["dagger", "noise"])
    dagger, noise = summary["dagger"], summary["noise"]
    # Curves start at (0 labels, 0 success) and are linear between evaluations.
    assert dagger["success_at_labels"]["100"]["per_seed"] == pytest.approx([0.4, 0.5])
    assert dagger["success_at_labels"]["200"]["per_seed"] == pytest.approx([0.6 + 0.2 / 3, 0.5 + 0.2 * 2 / 3])
    assert dagger["success_at_labels"]["400"] == {
        "median": None, "min": None, "max": None, "per_seed": [None, None], "seeds_reached": 0
    }  # fmt: skip
    assert noise["success_at_labels"]["100"]["per_seed"] == pytest.approx([0.525, 0.4125])
    assert noise["success_at_labels"]["400"]["median"] == pytest.approx(0.6)
    assert noise["success_at_labels"]["400"]["seeds_reached"] == 1
    # L = 200, the smallest final label count (noise seed 0); trapezoids by hand.
    assert noise["normalised_auc"]["label_horizon"] == 200
    assert dagger["normalised_auc"]["per_seed"] == pytest.approx([76.66667 / 200, 81.66667 / 200], abs=1e-6)
    assert noise["normalised_auc"]["per_seed"] == pytest.approx([0.51, 0.3425])
    assert dagger["normalised_auc"]["median"] == pytest.approx((0.383333 + 0.408333) / 2, abs=1e-6)
    # Final success: 8/10 and 7/10, pooled 15/20, each with its Wilson interval.
    final = dagger["final_success"]
    assert (final["median"], final["min"], final["max"]) == pytest.approx((0.75, 0.7, 0.8))
    assert final["per_seed"][0]["wilson_95"] == pytest.approx([0.4902, 0.9433], abs=1e-4)
    assert final["pooled"]["successes"] == 15 and final["pooled"]["episodes"] == 20
    assert final["pooled"]["wilson_95"] == pytest.approx([0.5313, 0.8881], abs=1e-4)
    # Paired by seed against plain DAgger.
    versus = noise["vs_dagger"]
    assert versus["final_success"]["differences"] == pytest.approx([0.1, -0.1])
    assert versus["normalised_auc"]["differences"] == pytest.approx([0.51 - 0.383333, 0.3425 - 0.408333], abs=1e-6)
    assert versus["success_at_400_labels"]["pairs"] == 0 and versus["success_at_400_labels"]["wilcoxon_p"] is None
    assert "vs_dagger" not in dagger
    # Secondary: labels to first reach 60%.
    assert dagger["cost_to_60_percent"] == {"median": 200.0, "seeds_reached": 2}


def test_labels_to_match_dagger_on_crafted_curves():
    curves = {
        ("dagger", 0): [(100, 0.3), (200, 0.6)],  # never reaches DAgger's median final success, 0.7
        ("dagger", 1): [(100, 0.5), (300, 0.8)],  # 0.7 at 100 + 200 * 2/3 labels
        ("dagger", 2): [(200, 0.7)],  # from (0, 0): at its last evaluation
        ("gated", 0): [(50, 0.7)],
        ("gated", 1): [(40, 0.35), (80, 0.7)],
        ("gated", 2): [(100, 0.5)],
    }
    rows = [
        row(m, s, e, labels, success) for (m, s), points in curves.items() for e, (labels, success) in enumerate(points)
    ]
    summary = summarise(rows, ["dagger", "gated"])
    dagger, gated = summary["dagger"]["labels_to_match_dagger"], summary["gated"]["labels_to_match_dagger"]
    assert dagger["target"] == gated["target"] == pytest.approx(0.7)
    assert dagger["per_seed"] == pytest.approx([None, 100 + 200 * 2 / 3, 200])
    # The seed that never reaches it sorts last: the median is the middle of (200, 233.3, inf).
    assert dagger["median"] == pytest.approx(233.3333, abs=1e-4) and dagger["seeds_reached"] == 2
    assert gated["per_seed"] == pytest.approx([50, 80, None]) and gated["median"] == 80
    assert gated["ratio_vs_dagger"] == pytest.approx(80 / (100 + 200 * 2 / 3))
    assert summary["gated"]["total_labels"] == {"median": 80.0, "min": 50.0, "max": 100.0}
    # Half the seeds short of the target: the median is no label count.
    assert summarise(rows, ["dagger", "gated"])["dagger"]["labels_to_match_dagger"]["ratio_vs_dagger"] == 1.0
    two_seeds = [r for r in rows if r["seed"] != 2]
    assert summarise(two_seeds, ["dagger"])["dagger"]["labels_to_match_dagger"]["median"] is None
    from antmaze_hirl.experiments.curves import labels_to_reach

    with pytest.raises(ValueError, match=r"target success must lie in \(0, 1\], got 1.5"):
        labels_to_reach(curves_trial := rows[:2], 1.5)
    assert labels_to_reach(curves_trial, 0.3) == 100


def test_curve_figures_reject_a_non_positive_label_count():
    from antmaze_hirl.experiments import normalised_auc, success_at_labels

    trial = [row("a", 0, 0, 50, 0.5)]
    assert success_at_labels(trial, 50) == 0.5 and success_at_labels(trial, 51) is None
    with pytest.raises(ValueError, match="label budget must be > 0, got 0"):
        success_at_labels(trial, 0)
    with pytest.raises(ValueError, match="label horizon must be > 0, got -5"):
        normalised_auc(trial, -5)


def test_wilson_intervals_and_paired_test_against_known_values():
    from antmaze_hirl.experiments import paired_comparison, wilson_interval

    assert wilson_interval(8, 10) == pytest.approx((0.4902, 0.9433), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson_interval(85, 100) == pytest.approx((0.7672, 0.9069), abs=1e-4)
    with pytest.raises(ValueError, match=r"successes must lie in \[0, 10\], got 11"):
        wilson_interval(11, 10)
    # Five seeds all better: the exact two-sided signed-rank p is 2/32, its floor with 5 pairs.
    better = paired_comparison([0.9, 0.8, 0.7, 0.95, 0.85], [0.8, 0.6, 0.67, 0.9, 0.5])
    assert better["wilcoxon_p"] == pytest.approx(0.0625)
    assert paired_comparison([0.5, 0.6], [0.5, 0.6])["wilcoxon_p"] == 1.0
    # 0.94 - 0.92 and 0.86 - 0.88 are not opposites in floating point; their ranks must tie all the same, as
    # for the integer differences (2, -2, 2, 1) points: unrounded, scipy gives 0.875 here instead of 0.625.
    tied = paired_comparison([0.94, 0.86, 0.30, 0.61], [0.92, 0.88, 0.28, 0.60])
    assert tied["wilcoxon_p"] == pytest.approx(float(wilcoxon([2, -2, 2, 1]).pvalue))
    assert tied["differences"] == [0.02, -0.02, 0.02, 0.01]
    with pytest.raises(ValueError, match="equal lengths, got 2 and 1"):
        paired_comparison([0.5, 0.6], [0.5])


@pytest.mark.integration
def test_experiment_records_provenance_and_refuses_other_code(tmp_path):
    one = dataclasses.replace(TINY, episodes=1)
    summary = run_experiment(["dagger"], 1, one, tmp_path, progress_bar=False)
    provenance = json.loads((tmp_path / "provenance.json").read_text())
    assert summary["provenance"] == provenance and provenance["earlier"] == []
    assert set(provenance["packages"]) >= {"torch", "numpy", "gymnasium", "gymnasium-robotics", "mujoco"}
    assert provenance["torch_threads"] == th.get_num_threads() and provenance["cpu_model"] is not None
    run_experiment(["dagger"], 1, one, tmp_path, progress_bar=False)  # same code: resumes
    other = {**provenance, "git_commit": "0" * 40, "source_sha256": "1" * 64}
    (tmp_path / "provenance.json").write_text(json.dumps(other))
    current = provenance["git_commit"]
    with pytest.raises(ValueError, match=f"other code \\(commit {'0' * 40}\\), this is commit {current}"):
        run_experiment(["dagger"], 1, one, tmp_path, progress_bar=False)
    run_experiment(["dagger"], 1, one, tmp_path, progress_bar=False, allow_code_change=True)
    resumed = json.loads((tmp_path / "provenance.json").read_text())
    assert resumed["source_sha256"] == provenance["source_sha256"]
    assert [writer["git_commit"] for writer in resumed["earlier"]] == ["0" * 40]
    (tmp_path / "provenance.json").unlink()  # as a folder written before provenance was recorded
    with pytest.raises(ValueError, match="recorded no provenance"):
        run_experiment(["dagger"], 1, one, tmp_path, progress_bar=False)


def test_body_settings_pick_the_held_out_family_and_keep_given_values():
    from antmaze_hirl.experiments.config import body_settings

    assert body_settings("ant") == {"maze_size": 3, "subgoal_reach_m": 2.0}
    assert body_settings("ant", held_out_layouts=True) == {"maze_size": 4, "subgoal_reach_m": 2.0}
    assert body_settings("ant", held_out_layouts=True, maze_size=5, subgoal_reach_m=3.0) == {
        "maze_size": 5,
        "subgoal_reach_m": 3.0,
    }
    assert body_settings("point", held_out_layouts=True) == {"maze_size": 5, "subgoal_reach_m": None}
    with pytest.raises(ValueError, match="unknown body 'cat'"):
        body_settings("cat")
