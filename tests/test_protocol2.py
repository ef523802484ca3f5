"""Issue 32, protocol 2: curves read on one set, the untrained learner measured, pooled rates bootstrapped."""

import csv
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import TINY_PROTOCOL2, copy_results

from antmaze_hirl.envs.layouts import canonical_wall_grid
from antmaze_hirl.experiments import ExperimentConfig, run_experiment
from antmaze_hirl.experiments.config import evaluation_schedule, evaluation_sets
from antmaze_hirl.experiments.curves import labels_to_reach, normalised_auc, success_curve
from antmaze_hirl.experiments.old_folders import SETTINGS_BEFORE_PROTOCOL_2
from antmaze_hirl.experiments.results_folder import read_rows
from antmaze_hirl.experiments.summary import summarise
from antmaze_hirl.experiments.uncertainty import cluster_bootstrap

RESULTS = Path(__file__).parents[1] / "results" / "paper_experiment"
TINY2 = TINY_PROTOCOL2


def crafted_trial(method, seed, evaluations_by_episode, labels_per_episode=10, mazes=4):
    """Rows and per-maze outcomes of one trial: ``{episode: successes out of mazes}``, 0 the untrained one."""
    rows, outcomes = [], []
    last = max(evaluations_by_episode)
    for episode in range(1, last + 1):
        labels = episode * labels_per_episode
        successes = evaluations_by_episode.get(episode)
        rows.append(
            {
                "method": method,
                "seed": seed,
                "episode": episode - 1,
                "expert_cost": labels_per_episode,
                "cumulative_expert_cost": labels,
                "attempts": labels_per_episode,
                "eval_success": math.nan if successes is None else successes / mazes,
                "eval_mazes": math.nan if successes is None else mazes,
            }
        )
    for episode, successes in evaluations_by_episode.items():
        for maze in range(mazes):
            outcomes.append(
                {
                    "method": method,
                    "seed": seed,
                    "episode": episode,
                    "labels": episode * labels_per_episode,
                    "maze_seed": 1000 + maze,
                    "success": maze < successes,
                }
            )
    return rows, outcomes


def crafted_trials(curves_by_method, labels_per_episode=None, mazes=4):
    """:func:`crafted_trial` of every ``{method: [curve of seed 0, curve of seed 1, ...]}``, rows and outcomes joined.

    ``labels_per_episode`` maps a method to its labels per episode (default 10).
    """
    rows, evaluations = [], []
    for method, curves in curves_by_method.items():
        per_episode = (labels_per_episode or {}).get(method, 10)
        for seed, curve in enumerate(curves):
            trial_rows, outcomes = crafted_trial(method, seed, curve, labels_per_episode=per_episode, mazes=mazes)
            rows += trial_rows
            evaluations += outcomes
    return rows, evaluations


def test_curve_metrics_on_one_set_start_at_the_untrained_success():
    rows, evaluations = crafted_trials(
        {
            # DAgger: untrained 2/4, 3/4 after 2 episodes, 4/4 after 4: its median final success is 1.0 on the set.
            "dagger": [{0: 2, 2: 3, 4: 4}, {0: 2, 2: 2, 4: 4}],
            # noise: 3/4 and 4/4 untrained (a learner that needs few or no labels), then damaged by training.
            "noise": [{0: 3, 2: 1, 4: 2}, {0: 4, 2: 3, 4: 4}],
        }
    )
    summary = summarise(rows, ["dagger", "noise"], evaluations=evaluations)
    dagger, noise = summary["dagger"], summary["noise"]
    assert dagger["untrained_success"]["per_seed"] == [0.5, 0.5]
    assert noise["untrained_success"]["median"] == 0.875
    assert dagger["final_success"]["median"] == 1.0  # the curve's last point
    assert (
        dagger["final_success"]["pooled"]["rate"] == 1.0 and "cluster_bootstrap_95" in dagger["final_success"]["pooled"]
    )
    # Label horizon 40: dagger seed 0's curve (0, .5) (20, .75) (40, 1) has area (0.625 * 20 + 0.875 * 20) / 40.
    assert dagger["normalised_auc"]["per_seed"][0] == pytest.approx(0.75)
    assert dagger["normalised_auc"]["label_horizon"] == 40
    match = dagger["labels_to_match_dagger"]
    assert match["per_seed"] == [40.0, 40.0] and match["dagger_seeds_reached"] == 2 and match["same_set"]
    # noise seed 1 starts at the target: 0 labels; seed 0 never reaches it.
    assert noise["labels_to_match_dagger"]["per_seed"] == [None, 0.0]
    assert noise["labels_to_match_dagger"]["dagger_seeds_reached"] == 2
    # The same trial read without its untrained point (protocol 1) starts at (0, 0).
    noise_rows = [row for row in rows if row["method"] == "noise" and row["seed"] == 1]
    assert success_curve(noise_rows)[1][0] == 0.0 and success_curve(noise_rows, 1.0)[1][0] == 1.0
    assert labels_to_reach(noise_rows, 1.0) == 40.0 and labels_to_reach(noise_rows, 1.0, 1.0) == 0.0
    assert normalised_auc(noise_rows, 40, 1.0) == pytest.approx((0.875 * 20 + 0.875 * 20) / 40)


def test_cluster_bootstrap_matches_the_known_standard_errors():
    # Only the mazes vary (every seed identical): half the 100 mazes fail for everyone. The mean over a
    # maze resample has standard error sqrt(0.25 / 100) = 0.05; a pooled Wilson interval of the 1,000
    # outcomes would claim about 0.016.
    mazes = np.tile(np.arange(100) < 50, (10, 1))
    result = cluster_bootstrap(mazes, resamples=4000)
    assert result["rate"] == 0.5 and result["bootstrap_se"] == pytest.approx(0.05, rel=0.1)
    low, high = result["cluster_bootstrap_95"]
    assert low == pytest.approx(0.5 - 1.96 * 0.05, abs=0.015) and high == pytest.approx(0.5 + 1.96 * 0.05, abs=0.015)
    # Only the seeds vary: 5 of 10 seeds solve every maze. Standard error sqrt(0.25 / 10) = 0.158.
    seeds = np.repeat((np.arange(10) < 5)[:, None], 100, axis=1)
    assert cluster_bootstrap(seeds, resamples=4000)["bootstrap_se"] == pytest.approx(0.5 / np.sqrt(10), rel=0.1)
    # No variation at all: a degenerate interval.
    assert cluster_bootstrap(np.ones((3, 20)))["cluster_bootstrap_95"] == [1.0, 1.0]
    with pytest.raises(ValueError, match=r"non-empty \(seeds, mazes\) table, got shape \(5,\)"):
        cluster_bootstrap(np.ones(5))
    with pytest.raises(ValueError, match="resamples must be >= 100, got 10"):
        cluster_bootstrap(np.ones((2, 2)), resamples=10)


def test_protocol_settings_are_checked_and_the_schedule_includes_the_untrained_learner():
    assert evaluation_schedule(TINY2) == [0, 2, 3]
    assert evaluation_schedule(ExperimentConfig(episodes=25, eval_every=10)) == [0, 10, 20, 25]  # the default
    assert evaluation_schedule(ExperimentConfig(episodes=25, eval_every=10, **SETTINGS_BEFORE_PROTOCOL_2)) == [
        10,
        20,
        25,
    ]
    sets = evaluation_sets(TINY2)
    assert sets["periodic"] == sets["final"] and sets["final"][0] == "eval" and sets["final"][2] == 4
    with pytest.raises(ValueError, match="protocol 2 needs held_out_layouts=True"):
        ExperimentConfig(held_out_layouts=False)
    with pytest.raises(ValueError, match=r"protocol must be one of \[1, 2\], got 3"):
        ExperimentConfig(protocol=3, held_out_layouts=True)


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_a_protocol_2_run_writes_per_maze_outcomes_on_one_held_out_set(finished_protocol2):
    tmp_path, _ = finished_protocol2  # TINY2, 2 seeds, run once per session (read only)
    summary = json.loads((tmp_path / "summary.json").read_text())
    untrained = summary["methods"]["dagger"]["untrained_success"]
    assert len(untrained["per_seed"]) == 2 and "cluster_bootstrap_95" in untrained["pooled"]
    with (tmp_path / "evaluations.csv").open() as handle:
        evaluations = list(csv.DictReader(handle))
    rows = read_rows(tmp_path / "episodes.csv")
    for seed in (0, 1):
        mine = [row for row in evaluations if int(row["seed"]) == seed]
        by_episode = {}
        for row in mine:
            by_episode.setdefault(int(row["episode"]), []).append(row)
        assert sorted(by_episode) == [0, 2, 3]
        mazes = [[row["maze_seed"] for row in outcomes] for outcomes in by_episode.values()]
        assert all(m == mazes[0] for m in mazes) and len(mazes[0]) == 4  # one set, every time
        last = [row for row in rows if row["seed"] == seed][-1]
        assert last["eval_success"] == np.mean([row["success"] == "True" for row in by_episode[3]])
        assert int(by_episode[3][0]["labels"]) == last["cumulative_expert_cost"]

    # Held out up to symmetry: no evaluation wall grid is a rotation or mirror of a training one.
    def grid_class(layout):
        grid = layout.replace("S", "0").replace("G", "0")
        return canonical_wall_grid(np.array([[c == "1" for c in row] for row in grid.split("/")]))

    training = {grid_class(row["layout"]) for row in rows}
    assert training.isdisjoint({grid_class(row["layout"]) for row in evaluations})


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_lockstep_evaluation_gives_the_serial_per_maze_outcomes_on_the_point(finished_protocol2, tmp_path):
    # The point's low level and learner are exact in lockstep (benchmarks/lockstep_agreement.py: 100/100):
    # evaluation_envs changes how the mazes are played, not which mazes or what happens in them. The serial
    # run is seed 0 of the session's TINY2 folder (each trial is seeded by its own rng, whatever the seed count).
    serial_folder, _ = finished_protocol2
    runs = {}
    with (serial_folder / "evaluations.csv").open() as handle:
        runs[1] = [dict(row) for row in csv.DictReader(handle) if row["seed"] == "0"]
    out = tmp_path / "envs3"
    run_experiment(["dagger"], 1, replace(TINY2, evaluation_envs=3), out, progress_bar=False, tensorboard=False)
    with (out / "evaluations.csv").open() as handle:
        runs[3] = [dict(row) for row in csv.DictReader(handle)]
    assert len(runs[1]) == 3 * TINY2.final_eval_episodes
    assert runs[1] == runs[3]


def test_evaluation_envs_is_checked():
    with pytest.raises(ValueError, match="evaluation_envs must be >= 1, got 0"):
        replace(TINY2, evaluation_envs=0)


def to_12_digits(value):
    # Numbers to 12 significant digits, at any depth: scipy's Wilson interval, which the summaries use since
    # the committed ones were written, differs from the closed form they hold by at most 4e-16.
    if isinstance(value, float):
        return float(f"{value:.12g}")
    if isinstance(value, dict):
        return {key: to_12_digits(item) for key, item in value.items()}
    if isinstance(value, list):
        return [to_12_digits(item) for item in value]
    return value


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize("body", ["point", "ant"])
def test_committed_protocol_1_folders_still_summarise_as_committed(body):
    folder = RESULTS / body
    committed = json.loads((folder / "summary.json").read_text())["methods"]
    summary = summarise(read_rows(folder / "episodes.csv"), list(committed))
    for method, figures in committed.items():
        assert to_12_digits(summary[method]["final_success"]) == to_12_digits(figures["final_success"]), method
        assert summary[method]["normalised_auc"] == figures["normalised_auc"], method
        assert "untrained_success" not in summary[method]


def test_protocol_2_trains_the_generic_learner_and_protocol_1_the_body_default():
    from antmaze_hirl.experiments.config import LEARNERS, PROTOCOL_LEARNER, STRONG_PRIOR, learner_settings
    from antmaze_hirl.experiments.runner import make_env, make_trainer
    from antmaze_hirl.experts import PathOracle

    def policy_config(config):
        env = make_env(config, split="train")
        trainer = make_trainer("dagger", 0, config, env, PathOracle.for_env(env))
        env.close()
        return trainer.learner.config()

    generic = policy_config(TINY2)
    assert PROTOCOL_LEARNER == "next_cell_cnn" and generic["head"] == "next_cell"
    assert generic["planning_iterations"] == 0 and not generic["block_walls"]
    old = policy_config(ExperimentConfig(body="point", maze_size=4, held_out_layouts=True, protocol=1))
    assert old["planning_iterations"] == 14 and old["block_walls"]  # the point's body default: the strong prior
    prior = policy_config(ExperimentConfig(**{**TINY2.__dict__, "learner": STRONG_PRIOR}))
    assert prior["planning_iterations"] == 14 and prior["block_walls"]
    assert learner_settings(STRONG_PRIOR, 5)["planning_iterations"] == 16 and STRONG_PRIOR in LEARNERS
    with pytest.raises(ValueError, match="unknown learner 'mlp'; choose from"):
        ExperimentConfig(learner="mlp")


def test_the_success_curves_start_at_the_untrained_success():
    from antmaze_hirl.experiments.results_folder import untrained_by_seed
    from antmaze_hirl.plotting import success_points

    rows, evaluations = crafted_trials({"dagger": [{0: 1, 2: 3, 4: 4}, {0: 3, 2: 2, 4: 4}]})
    untrained = untrained_by_seed(evaluations)
    assert untrained == {"dagger": {0: 0.25, 1: 0.75}}
    episodes, labels, success = success_points(rows, "dagger", untrained["dagger"])
    assert episodes.tolist() == [0.0, 2.0, 4.0] and labels.tolist() == [0.0, 20.0, 40.0]
    assert success.tolist() == [[0.25, 0.75, 1.0], [0.75, 0.5, 1.0]]
    # Protocol 1: no untrained point, the curve starts at the first evaluation after training.
    episodes, labels, success = success_points(rows, "dagger")
    assert episodes.tolist() == [2.0, 4.0] and labels.tolist() == [20.0, 40.0] and success.shape == (2, 2)


@pytest.mark.integration  # runs a protocol-2 experiment (the finished_protocol2 fixture)
def test_the_panels_of_a_protocol_2_run_start_at_the_untrained_success(finished_protocol2, tmp_path, monkeypatch):
    import antmaze_hirl.plotting as plotting
    from antmaze_hirl.experiments.results_folder import read_evaluations, write_reports

    copy_results(finished_protocol2[0], tmp_path)  # TINY2, 2 seeds; the reports are rewritten here
    drawn = []
    real = plotting.draw_band
    monkeypatch.setattr(
        plotting, "draw_band", lambda ax, x, values, label: drawn.append((x, values)) or real(ax, x, values, label)
    )
    write_reports(tmp_path, ["dagger"], 2, TINY2)
    untrained = {}
    for row in read_evaluations(tmp_path / "evaluations.csv"):
        if row["episode"] == 0:
            untrained.setdefault(row["seed"], []).append(row["success"])
    start = [np.mean(untrained[seed]) for seed in (0, 1)]
    (episodes, by_episode), (labels, by_labels) = drawn[0], drawn[1]  # success vs episode, success vs labels
    assert episodes[0] == 0 and labels[0] == 0
    assert by_episode[:, 0].tolist() == start and by_labels[:, 0].tolist() == start
    assert episodes.tolist() == [0.0, 2.0, 3.0]


def test_cost_to_60_percent_counts_the_untrained_evaluation_in_protocol_2():
    from antmaze_hirl.experiments.summary import cost_to_reach

    # Seed 0 is at 3/4 untrained, then 2/4 and 3/4: 0 labels. Seed 1 starts at 1/4 and reaches 3/4 after 4 episodes.
    rows, evaluations = crafted_trials({"dagger": [{0: 3, 2: 2, 4: 3}, {0: 1, 2: 2, 4: 3}]})
    figure = summarise(rows, ["dagger"], evaluations=evaluations)["dagger"]["cost_to_60_percent"]
    assert figure == {"median": 20.0, "seeds_reached": 2}  # median of 0 and 40 labels
    seed0 = [row for row in rows if row["seed"] == 0]
    assert cost_to_reach(seed0, start=0.75) == 0.0 and cost_to_reach(seed0) == 40.0
    # Protocol 1 (no per-maze outcomes) reads the rows only: seed 0 costs 40 labels there.
    assert summarise(rows, ["dagger"])["dagger"]["cost_to_60_percent"] == {"median": 40.0, "seeds_reached": 2}


def dagger_and_gated(dagger, gated, mazes=4):
    """Rows and per-maze outcomes of DAgger (10 labels per episode) and gated (5), one crafted curve per seed."""
    return crafted_trials({"dagger": dagger, "gated": gated}, {"gated": 5}, mazes)


def test_labels_to_match_paired_by_seed_stays_defined_where_dagger_misses_its_own_median():
    # DAgger's three seeds end at 2/4, 3/4 and 4/4: its median final success (0.75) is first reached by only
    # seeds 1 and 2, so the median-target figure's ratio is read on 2 of 3 seeds.
    dagger = [{0: 0, 2: 1, 4: 2}, {0: 0, 2: 3, 4: 3}, {0: 0, 2: 2, 4: 4}]
    # gated: half the labels per episode; reaches each seed's DAgger final by episode 2 on seeds 0 and 2 only.
    # Its seed 3 has no DAgger trial to pair with: skipped, and named.
    gated = [{0: 0, 2: 2, 4: 2}, {0: 0, 2: 1, 4: 2}, {0: 0, 2: 4, 4: 4}, {0: 0, 2: 4, 4: 4}]
    rows, evaluations = dagger_and_gated(dagger, gated)
    summary = summarise(rows, ["dagger", "gated"], evaluations=evaluations)
    paired = summary["gated"]["labels_to_match_dagger_per_seed"]
    assert [seed["target"] for seed in paired["per_seed"]] == [0.5, 0.75, 1.0]
    # DAgger's own cost per seed: seed 0 reaches 2/4 at 40 labels (1/4 at 20), seed 1 3/4 at 20, seed 2 4/4 at 40.
    assert [seed["baseline_labels"] for seed in paired["per_seed"]] == [40.0, 20.0, 40.0]
    # gated reaches 2/4 at 10 labels (seed 0), never 3/4 (seed 1), 4/4 at 10 labels (seed 2).
    assert [seed["labels"] for seed in paired["per_seed"]] == [10.0, None, 10.0]
    assert [seed["ratio"] for seed in paired["per_seed"]] == [0.25, None, 0.25]
    assert paired["median_ratio"] == 0.25 and paired["seeds_reached"] == 2 and paired["seeds"] == 3
    assert paired["skipped_seeds"] == [3]
    assert "labels_to_match_dagger_per_seed" not in summary["dagger"]
    # Protocol 1 (no per-maze outcomes) has no such figure: its final point is read on another set.
    assert "labels_to_match_dagger_per_seed" not in summarise(rows, ["dagger", "gated"])["gated"]


def test_smoothed_paired_target_is_the_mean_of_daggers_last_evaluations():
    # DAgger's last evaluation on seed 0 is a lucky 4/4 after 2/4 and 2/4: the plain paired target is 1.0, which
    # gated never reaches; the smoothed target, the mean of the last 3 evaluations (2/3), gated reaches.
    dagger = [{0: 0, 2: 1, 4: 2, 6: 2, 8: 4}]
    gated = [{0: 0, 2: 1, 4: 3, 6: 3, 8: 3}]
    rows, evaluations = dagger_and_gated(dagger, gated)
    summary = summarise(rows, ["dagger", "gated"], evaluations=evaluations)["gated"]
    plain, smoothed = summary["labels_to_match_dagger_per_seed"], summary["labels_to_match_dagger_per_seed_smoothed"]
    assert plain["target_evaluations"] == 1 and smoothed["target_evaluations"] == 3
    assert plain["per_seed"][0]["target"] == 1.0 and plain["per_seed"][0]["labels"] is None
    assert plain["median_ratio"] is None
    target = smoothed["per_seed"][0]["target"]
    assert math.isclose(target, 2 / 3)
    # gated: 1/4 at 10 labels, 3/4 at 20: 2/3 is reached at 10 + (2/3 - 1/4) / (1/2) * 10 labels.
    assert math.isclose(smoothed["per_seed"][0]["labels"], 10 + (target - 0.25) / 0.5 * 10)
    # DAgger: 2/4 up to 60 labels, 4/4 at 80: 2/3 at 60 + (2/3 - 1/2) / (1/2) * 20 labels.
    assert math.isclose(smoothed["per_seed"][0]["baseline_labels"], 60 + (target - 0.5) / 0.5 * 20)
    assert smoothed["median_ratio"] is not None and smoothed["median_ratio"] < 1


def test_smoothed_paired_target_on_a_plateau_is_reached_by_daggers_own_curve():
    # DAgger ends on a plateau at 72/100: the mean of 0.72 three times is 0.7200000000000001 in floating point,
    # which no evaluation reaches; the target must be the plateau itself, reached by DAgger at 40 labels.
    dagger = [{0: 0, 2: 50, 4: 72, 6: 72, 8: 72}]
    gated = [{0: 0, 2: 72, 4: 72, 6: 72, 8: 72}]
    rows, evaluations = dagger_and_gated(dagger, gated, mazes=100)
    smoothed = summarise(rows, ["dagger", "gated"], evaluations=evaluations)["gated"][
        "labels_to_match_dagger_per_seed_smoothed"
    ]
    assert smoothed["per_seed"][0]["target"] == 0.72
    assert smoothed["per_seed"][0]["baseline_labels"] == 40.0 and smoothed["per_seed"][0]["labels"] == 10.0
    assert smoothed["median_ratio"] == 0.25
