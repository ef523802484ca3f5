"""The preregistration's learner-selection check (``learner.beats``) on crafted learner-ablation trial files."""

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from antmaze_hirl.envs.layouts import canonical_task
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.experiments.config import ExperimentConfig, body_settings
from antmaze_hirl.experiments.runner import make_env
from antmaze_lab import preregistered as pre
from antmaze_lab.selection_trials import read_selection_trial, selection_task_classes

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.selection_trials): the integration tier

ROOT = Path(__file__).resolve().parents[1]
CANDIDATE, OLD = "next_cell_plan", "next_cell_cnn"
MAZES = 50
FIRST_MAZE = 3_000_000


@pytest.fixture(scope="module")
def spec():
    loaded = pre.load_preregistration()
    loaded["statistics"]["resamples"] = 400  # the YAML's 10,000 in the check of record; enough for clear-cut tables
    return loaded


def write_trial(folder, body, variant, seed, success, episodes=100, outcomes=True, first_seed=FIRST_MAZE):
    """A trial file as ``scripts/learner_ablation.py`` writes it, with the per-maze outcomes the check needs."""
    success = [int(bool(v)) for v in success]
    figures = {"rate": float(np.mean(success)), "successes": sum(success), "episodes": len(success)}
    trial = {
        "variant": variant,
        "seed": seed,
        "body": body,
        "episodes": episodes,
        "evaluation_envs": 25,
        "selection_success": {**figures, "first_seed": first_seed, **({"outcomes": success} if outcomes else {})},
    }
    path = Path(folder) / f"{body}_{variant}_e{episodes}_seed{seed}.json"
    path.write_text(json.dumps(trial))
    return path


def one_task_per_maze(body, maze_seeds):
    """Crafted mazes: every maze its own task up to symmetry (the default draws the real mazes again)."""
    return tuple(f"{body} task {seed}" for seed in maze_seeds)


def write_body(folder, body, candidate_rate, old_rate, seeds=range(5), old_seeds=None, same=False, mazes=MAZES):
    """Trials of both learners on one body: each maze a success with the learner's rate (a fixed draw per seed)."""
    for seed in seeds:
        write_trial(folder, body, CANDIDATE, seed, np.random.default_rng(seed).random(mazes) < candidate_rate)
    for seed in seeds if old_seeds is None else old_seeds:
        rate = candidate_rate if same else old_rate
        write_trial(folder, body, OLD, seed, np.random.default_rng(seed if same else 100 + seed).random(mazes) < rate)


def check(folder, spec, task_classes=one_task_per_maze):
    return pre.learner_beats(pre.read_selection_trials([folder], (CANDIDATE, OLD))[0], CANDIDATE, spec, task_classes)


def test_a_candidate_clearly_better_on_both_bodies_beats(tmp_path, spec):
    for body in ("point", "ant"):
        write_body(tmp_path, body, 0.9, 0.5)
    found = check(tmp_path, spec)
    assert found["verdict"] == pre.BEATS and found["baseline"] == OLD
    for row in found["bodies"].values():
        assert row["verdict"] == pre.BEATS and row["seeds"] == [0, 1, 2, 3, 4]
        assert row["bootstrap"]["interval_95"][0] > 0 and row["bootstrap"]["mazes"] == MAZES


def test_a_candidate_that_plays_as_the_old_learner_does_not_beat_it(tmp_path, spec):
    for body in ("point", "ant"):
        write_body(tmp_path, body, 0.8, None, same=True)
    found = check(tmp_path, spec)
    assert found["verdict"] == pre.DOES_NOT_BEAT
    assert all(row["bootstrap"]["interval_95"] == [0.0, 0.0] for row in found["bodies"].values())


def test_one_body_that_does_not_beat_decides_the_check(tmp_path, spec):
    write_body(tmp_path, "point", 0.9, 0.5)
    write_body(tmp_path, "ant", 0.5, 0.9)
    found = check(tmp_path, spec)
    assert found["bodies"]["point"]["verdict"] == pre.BEATS
    assert found["verdict"] == pre.DOES_NOT_BEAT and found["reason"].endswith("on ant")


def test_a_gain_on_one_maze_for_every_seed_does_not_beat_when_the_mazes_count(tmp_path, spec):
    # Every seed gains the same 2 points (one maze of 50): a per-seed test sees 5 positive pairs out of 5, but
    # the bootstrap over mazes leaves that maze out in about (49/50)^50 = 36% of resamples.
    base = np.random.default_rng(0).random(MAZES) < 0.5
    base[0] = False
    gained = base.copy()
    gained[0] = True
    for body in ("point", "ant"):
        for seed in range(5):
            write_trial(tmp_path, body, CANDIDATE, seed, gained)
            write_trial(tmp_path, body, OLD, seed, base)
    found = check(tmp_path, spec)
    assert found["bodies"]["point"]["per_seed_difference"] == [pytest.approx(0.02)] * 5
    assert found["bodies"]["point"]["bootstrap"]["interval_95"][0] == 0.0
    assert found["verdict"] == pre.DOES_NOT_BEAT


def test_fewer_paired_seeds_than_the_preregistered_minimum_is_not_decided(tmp_path, spec):
    write_body(tmp_path, "point", 0.9, 0.5, seeds=range(4))
    write_body(tmp_path, "ant", 0.9, 0.5, seeds=range(5), old_seeds=[0, 1, 2, 3, 9])  # 4 paired seeds
    found = check(tmp_path, spec)
    assert {row["verdict"] for row in found["bodies"].values()} == {pre.TOO_FEW_SEEDS}
    assert found["bodies"]["ant"]["unpaired_seeds"] == {"candidate": [4], "baseline": [9]}
    assert found["verdict"] == pre.NOT_DECIDED
    assert found["reason"] == "point: too few seeds; ant: too few seeds"


def test_the_minimum_of_seeds_is_read_from_the_preregistration(tmp_path, spec):
    for body in ("point", "ant"):
        write_body(tmp_path, body, 0.9, 0.5)
    stricter = copy.deepcopy(spec)
    stricter["learner"]["selection_check"]["min_seeds"] = 6
    assert check(tmp_path, spec)["verdict"] == pre.BEATS
    assert check(tmp_path, stricter)["verdict"] == pre.NOT_DECIDED


def test_a_body_short_of_seeds_leaves_the_check_undecided_even_where_the_other_does_not_beat(tmp_path, spec):
    write_body(tmp_path, "point", 0.5, 0.9)
    write_body(tmp_path, "ant", 0.5, 0.9, seeds=range(4))
    found = check(tmp_path, spec)
    assert found["bodies"]["point"]["verdict"] == pre.DOES_NOT_BEAT
    assert found["verdict"] == pre.NOT_DECIDED and found["reason"] == "ant: too few seeds"


def test_a_body_without_trials_of_a_learner_is_missing_and_the_check_not_decided(tmp_path, spec):
    write_body(tmp_path, "point", 0.9, 0.5)
    for seed in range(5):  # the ant's candidate only
        write_trial(tmp_path, "ant", CANDIDATE, seed, np.ones(MAZES))
    found = check(tmp_path, spec)
    assert found["bodies"]["point"]["verdict"] == pre.BEATS
    assert found["bodies"]["ant"]["verdict"] == pre.MISSING_BODY and found["bodies"]["ant"]["missing"] == "baseline"
    assert found["verdict"] == pre.NOT_DECIDED and found["reason"] == "ant: missing body"


def test_other_learners_and_other_episode_counts_are_left_out(tmp_path, spec):
    for body in ("point", "ant"):
        write_body(tmp_path, body, 0.9, 0.5)
        write_trial(tmp_path, body, OLD, 0, np.zeros(MAZES), episodes=20)  # another trial length
        write_trial(tmp_path, body, "next_cell_vin_floor", 0, np.zeros(MAZES), outcomes=False)  # not read
    found = check(tmp_path, spec)
    assert found["verdict"] == pre.BEATS and found["left_out"] == 2


def test_a_trial_without_per_maze_outcomes_is_refused_naming_the_file_and_the_field(tmp_path, capsys):
    path = write_trial(tmp_path, "point", OLD, 0, np.ones(MAZES), outcomes=False)
    assert pre.main(["learner", str(tmp_path), "--candidate", CANDIDATE]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and str(path) in error and "'outcomes'" in error


def test_seeds_evaluated_on_other_mazes_are_refused(tmp_path, spec):
    write_body(tmp_path, "point", 0.9, 0.5)
    write_trial(tmp_path, "point", OLD, 4, np.ones(MAZES + 1))  # one maze more: other mazes
    with pytest.raises(
        ValueError, match=r"point_next_cell_cnn_e100_seed4\.json was evaluated on other selection mazes"
    ):
        check(tmp_path, spec)


def test_trials_on_mazes_that_are_not_the_selection_mazes_are_refused(tmp_path, spec):
    write_body(tmp_path, "point", 0.9, 0.5)
    write_trial(tmp_path, "point", OLD, 4, np.ones(MAZES), first_seed=FIRST_MAZE + 1)
    with pytest.raises(ValueError, match=r"seed4\.json: its mazes start at seed 3000001, not 3000000$"):
        check(tmp_path, spec)
    path = write_trial(tmp_path, "point", OLD, 4, np.ones(MAZES))
    trial = json.loads(path.read_text())
    trial["selection_success"]["split"] = "eval"
    path.write_text(json.dumps(trial))
    with pytest.raises(ValueError, match=r"seed4\.json was evaluated on the 'eval' part, not 'selection'$"):
        check(tmp_path, spec)


def test_an_unknown_candidate_is_one_line_and_exit_2(tmp_path, capsys):
    write_body(tmp_path, "point", 0.9, 0.5)
    assert pre.main(["learner", str(tmp_path), "--candidate", "nosuch"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: unknown learner 'nosuch'; choose from [") and error.count("\n") == 1


def test_trials_of_another_length_are_left_out_even_without_per_maze_outcomes(tmp_path, capsys):
    # 4 mazes: the command draws each maze again (the default task_classes, its one run in the unit tier), and
    # a drawing costs a MuJoCo compile; the count of mazes plays no part in what is left out.
    write_body(tmp_path, "point", 0.9, 0.5, mazes=4)
    write_trial(tmp_path, "point", OLD, 7, np.ones(4), episodes=30, outcomes=False)
    out = tmp_path / "check" / "found.json"
    assert pre.main(["learner", str(tmp_path), "--candidate", CANDIDATE, "--resamples", "200", "--json", str(out)]) == 0
    assert "not decided" in capsys.readouterr().out  # the ant has no trials: read on complete bodies only
    assert json.loads(out.read_text())["left_out"] == 1


def test_two_files_of_one_trial_are_refused(tmp_path, spec):
    write_body(tmp_path, "point", 0.9, 0.5)
    copy_of = tmp_path / "again.json"
    copy_of.write_text((tmp_path / "point_next_cell_cnn_e100_seed0.json").read_text())
    with pytest.raises(ValueError, match="are both point next_cell_cnn seed 0"):
        check(tmp_path, spec)


def test_mazes_that_are_one_task_up_to_symmetry_are_resampled_as_one_cluster(tmp_path, spec):
    for body in ("point", "ant"):
        write_body(tmp_path, body, 0.9, 0.5)
    as_mazes = check(tmp_path, spec)["bodies"]["point"]["bootstrap"]
    as_pairs = check(tmp_path, spec, lambda body, seeds: tuple(f"task {s // 2}" for s in seeds))["bodies"]["point"]
    assert (as_mazes["clusters"], as_pairs["bootstrap"]["clusters"]) == (MAZES, MAZES // 2)
    assert as_pairs["bootstrap"]["mean"] == as_mazes["mean"]
    assert as_pairs["bootstrap"]["interval_95"] != as_mazes["interval_95"]


@pytest.mark.integration
def test_the_selection_mazes_are_drawn_again_as_the_evaluation_drew_them():
    seeds = (FIRST_MAZE, FIRST_MAZE + 1, FIRST_MAZE + 2)
    classes = selection_task_classes("ant", seeds)
    config = ExperimentConfig(body="ant", held_out_layouts=True, **body_settings("ant", held_out_layouts=True))
    env = make_env(config, split="selection")  # the evaluation's env, with its low level
    drawn = []
    for seed in seeds:
        env.reset(seed=seed)
        drawn.append(canonical_task(maze_env(env).layout))
    env.close()
    assert classes == tuple(drawn) and len(set(classes)) > 1


def test_per_maze_outcomes_that_disagree_with_the_recorded_counts_are_refused(tmp_path):
    path = write_trial(tmp_path, "point", OLD, 0, np.ones(MAZES))
    trial = json.loads(path.read_text())
    trial["selection_success"]["successes"] = 3
    path.write_text(json.dumps(trial))
    with pytest.raises(ValueError, match=r"50 per-maze successes, but selection_success\.successes = 3"):
        read_selection_trial(path)
    trial["selection_success"]["outcomes"] = [2] * MAZES
    path.write_text(json.dumps(trial))
    with pytest.raises(ValueError, match="holds values other than 0 and 1"):
        read_selection_trial(path)


def test_the_command_prints_the_verdict_and_writes_the_check(tmp_path, capsys):
    folder = tmp_path / "trials"
    folder.mkdir()
    for body in ("point", "ant"):  # few mazes: the command draws them again to group them by task
        write_body(folder, body, 1.0, 0.0, mazes=6)
    out = tmp_path / "check.json"
    argv = ["learner", str(folder), "--candidate", CANDIDATE, "--json", str(out), "--resamples", "200"]
    assert pre.main(argv) == 0
    assert f"`{CANDIDATE}` against protocol 2's `{OLD}`" in capsys.readouterr().out
    written = json.loads(out.read_text())
    assert written["verdict"] == pre.BEATS and written["bodies"]["ant"]["bootstrap"]["resamples"] == 200


def test_the_yaml_states_the_pages_selection_rule():
    spec, page = pre.load_preregistration(), (ROOT / "docs" / "preregistration.md").read_text()
    assert spec["learner"]["selection_check"] == {
        "min_seeds": 5,
        "episodes": 100,
        "split": "selection",
        "lower_bound_above": 0.0,
    }
    assert "100 episodes, the same 5 or more seeds for both learners" in " ".join(page.split())
    assert "is above 0 **on both bodies**" in " ".join(page.split())
