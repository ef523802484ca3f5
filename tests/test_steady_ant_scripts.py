"""The steady-ant lab scripts: the distillation run's command line and the side-by-side table."""

import json

import pytest
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (scripts/steady_ant*.py): the integration tier

steady_ant = load_script("scripts/steady_ant.py")
table = load_script("scripts/steady_ant_table.py")


def test_the_garwood_interval_matches_known_values():
    # 0 events: [0, 3.689]; 1 event: [0.0253, 5.572] (per unit exposure).
    assert table.poisson_interval(0, 1.0, per=1.0) == pytest.approx([0.0, 3.6889], abs=1e-4)
    assert table.poisson_interval(1, 1.0, per=1.0) == pytest.approx([0.0253, 5.5716], abs=1e-4)
    assert table.poisson_interval(8, 80_296) == pytest.approx([0.430, 1.963], abs=1e-3)


def report(successes, low_level, flips=0):
    outcomes = [
        {"task_id": k, "seed": k, "success": bool(s), "attempts": 3, "low_level_steps": 100, "flipped": False}
        for k, s in enumerate(successes)
    ]
    return {
        "suite": "large",
        "seed": 0,
        "episodes_per_task": 1,
        "task_ids": "all",
        "policy": "oracle",
        "low_level": low_level,
        "successes": sum(successes),
        "episodes": len(successes),
        "flips": flips,
        "low_level_steps_total": 100 * len(successes),
        "episode_outcomes": outcomes,
    }


def test_benchmark_pairs_count_paired_outcomes(tmp_path):
    first, second = tmp_path / "e.json", tmp_path / "c.json"
    first.write_text(json.dumps(report([1, 1, 0, 1, 0, 1], "ensemble", flips=2)))
    second.write_text(json.dumps(report([1, 0, 1, 1, 1, 1], "candidate")))
    pair = table.benchmark_pair(first, second)
    assert pair["paired"] == {"both_succeed": 3, "only_ensemble": 1, "only_candidate": 2, "mcnemar_exact_p": 1.0}
    assert pair["ensemble"]["flips_per_10k_steps"] == pytest.approx(2 * 10_000 / 600)
    other = report([1, 1, 0, 1, 0, 1], "candidate")
    other["seed"] = 5
    second.write_text(json.dumps(other))
    with pytest.raises(ValueError, match=r"differ in \['seed'\]"):
        table.benchmark_pair(first, second)


def test_the_run_refuses_bad_settings_in_one_line(tmp_path, capsys):
    assert steady_ant.main(["--out", str(tmp_path / "r"), "--maze-sizes", "1"]) == 2
    assert "--maze-sizes must be >= 2" in capsys.readouterr().err
    assert steady_ant.main(["--out", str(tmp_path / "r"), "--iterations", "0"]) == 2
    assert "iterations must be an integer >= 1" in capsys.readouterr().err
    assert steady_ant.main(["--out", str(tmp_path / "r"), "--resume"]) == 2
    assert "no distillation run to resume" in capsys.readouterr().err


def in_maze_file(path, name, episodes, successes=9, flips=1):
    row = {"successes": successes, "episodes": episodes, "flips": flips, "mean_low_level_steps": 200.0}
    data = {
        "command": "x",
        "subgoal_reach_m": 2.0,
        "num_envs": 25,
        "results": {name: {"low_level_id": "sha256:x", "families": {"ant4": {"maze_seed": 1_000_000, **row}}}},
    }
    path.write_text(json.dumps(data))
    return path


def test_in_maze_rows_pair_the_same_episodes(tmp_path):
    ensemble = in_maze_file(tmp_path / "e.json", "shipped", 10)
    candidate = in_maze_file(tmp_path / "c.json", "student.zip", 10, successes=10, flips=0)
    rows = table.in_maze_rows([ensemble, candidate])["families"]["ant4"]
    assert rows["ensemble"]["flips_per_10k_steps"] == pytest.approx(1 * 10_000 / 2_000)
    assert rows["candidate"]["success_rate"] == 1.0
    with pytest.raises(ValueError, match="play 10 episodes from maze seed 1000000 and 20"):
        table.in_maze_rows([ensemble, in_maze_file(tmp_path / "d.json", "student.zip", 20)])
    with pytest.raises(ValueError, match="hold 1 rows"):
        table.in_maze_rows([ensemble])


def test_the_flip_rate_test_is_the_conditional_binomial_of_two_poisson_counts():
    def row(flips, steps):
        return {"flips": flips, "low_level_steps": steps}

    assert table.flip_rate_p(row(10, 1000), row(0, 1000)) == pytest.approx(2 * 0.5**10)
    assert table.flip_rate_p(row(5, 1000), row(5, 1000)) == pytest.approx(1.0)
    assert table.flip_rate_p(row(0, 1000), row(0, 5000)) == 1.0
    # Twice the steps, twice the flips: the same rate.
    assert table.flip_rate_p(row(4, 1000), row(8, 2000)) == pytest.approx(1.0)
    assert table.flip_rate_p(row(9, 80_000), row(1, 80_000)) < 0.05


def test_a_pair_whose_candidate_played_fewer_tasks_is_read_on_the_shared_tasks(tmp_path):
    first, second = tmp_path / "e.json", tmp_path / "c.json"
    ensemble = report([1, 1, 0, 1, 0, 1], "ensemble")
    ensemble["episode_outcomes"][2]["flipped"] = True
    ensemble["episode_outcomes"][4]["flipped"] = True
    ensemble["flips"] = 2
    first.write_text(json.dumps(ensemble))
    candidate = report([1, 0, 1], "candidate")  # tasks 0, 1, 2 only (--tasks 0,1,2)
    candidate["task_ids"] = "0,1,2"
    second.write_text(json.dumps(candidate))
    pair = table.benchmark_pair(first, second)
    assert pair["tasks"] == [0, 1, 2]
    assert (pair["ensemble"]["episodes"], pair["ensemble"]["successes"], pair["ensemble"]["flips"]) == (3, 2, 1)
    assert pair["ensemble"]["low_level_steps"] == 300 and pair["ensemble"]["task_bootstrap_95"] is None
    assert pair["paired"] == {"both_succeed": 1, "only_ensemble": 1, "only_candidate": 1, "mcnemar_exact_p": 1.0}
    assert "benchmark large (K=1, tasks 0,1,2)" in table.table({"benchmark": [pair]})
    assert table.benchmark_pair(first, first)["tasks"] == "all"
    disjoint = report([1], "candidate")
    disjoint["episode_outcomes"][0]["task_id"] = 9
    second.write_text(json.dumps(disjoint))
    with pytest.raises(ValueError, match="share no task"):
        table.benchmark_pair(first, second)


def test_eval_low_sets_pool_disjoint_sets_and_refuse_overlaps(tmp_path, capsys):
    def write(name, rate, episodes=200):
        path = tmp_path / name
        path.write_text(json.dumps({"success_rate": rate, "episodes": episodes, "low_level_id": name}))
        return str(path)

    sets = [("0", write("e0", 0.91), write("c0", 0.95)), ("200", write("e2", 0.93), write("c2", 0.92))]
    summary = table.eval_low_sets(sets)
    assert [row["candidate"]["successes"] for row in summary["sets"]] == [190, 184]
    assert summary["sets"][0]["ensemble"]["num_envs"] == 1  # a file without the field played one at a time
    assert summary["pooled"]["ensemble"]["successes"] == 182 + 186
    assert summary["pooled"]["candidate"]["episodes"] == 400
    low, high = summary["pooled"]["candidate"]["success_ci95"]
    assert low < 374 / 400 < high
    with pytest.raises(ValueError, match=r"seeds \[0, 100\] overlap"):
        table.eval_low_sets([sets[0], ("100", *sets[1][1:])])
    with pytest.raises(ValueError, match="tried 200 and 100 subgoals"):
        table.eval_low_sets([("0", write("e", 0.9), write("c", 0.9, episodes=100))])
    out = tmp_path / "s.json"
    assert table.main(["--eval-low", "x", sets[0][1], sets[0][2], "--out", str(out)]) == 2
    assert "seed 'x' is not an integer" in capsys.readouterr().err
    assert table.main(["--eval-low", "0", sets[0][1], sets[0][2], "--out", str(out)]) == 0
    assert "| eval-low pooled | candidate | 190/200 [" in json.loads(out.read_text())["table_markdown"]
    # Files made before eval-low recorded its seed: the typed seed is taken, and the script says so.
    assert f"{sets[0][1]} records no seed: seed 0 is taken from the command line" in capsys.readouterr().err


def test_eval_low_sets_read_the_seed_and_radius_the_files_record(tmp_path, capsys):
    def write(name, seed, radius=4.0, identity=None, **fields):
        path = tmp_path / name
        data = {"success_rate": 0.9, "episodes": 200, "low_level_id": identity or name, "seed": seed}
        path.write_text(json.dumps({**data, "sample_radius_m": radius, **fields}))
        return str(path)

    pair = ("200", write("e200", 200), write("c200", 200))
    summary = table.eval_low_sets([pair])
    assert [summary["sets"][0][role]["seed_from"] for role in ("ensemble", "candidate")] == ["file", "file"]
    # A file of another set typed as this one: refused, though the typed seeds alone would not overlap.
    with pytest.raises(ValueError, match=r"c0 records seed 0, not the typed 200: another set of subgoals$"):
        table.eval_low_sets([("200", write("e0", 200), write("c0", 0))])
    with pytest.raises(ValueError, match=r"drew subgoals up to 4.0 and 8.0 m: not the same set$"):
        table.eval_low_sets([("200", write("e", 200), write("c", 200, radius=8.0))])
    with pytest.raises(ValueError, match=r"both hold low level sha256:ab: not two low levels$"):
        table.eval_low_sets([("200", write("e", 200, identity="sha256:ab"), write("c", 200, identity="sha256:ab"))])
    (tmp_path / "partial.json").write_text(json.dumps({"success_rate": 0.9}))
    with pytest.raises(ValueError, match=r"partial.json has no 'episodes': not an antmaze-hirl eval-low file$"):
        table.eval_low_sets([("200", pair[1], str(tmp_path / "partial.json"))])
    out = tmp_path / "s.json"
    assert table.main(["--eval-low", "0", *pair[1:], "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("steady_ant_table.py: error: ") and "not the typed 0" in err
    assert table.main(["--eval-low", "200", *pair[1:], "--out", str(out)]) == 0
    assert "note" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"episodes": 0}, "episodes must be an integer >= 1, got 0"),
        ({"episodes": 200.0}, "episodes must be an integer >= 1, got 200.0"),
        ({"success_rate": "0.9"}, "success_rate must be a number in [0, 1], got '0.9'"),
        ({"success_rate": 1.5}, "success_rate must be a number in [0, 1], got 1.5"),
        ({"seed": "0"}, "seed must be an integer, got '0'"),
    ],
)
def test_an_eval_low_file_with_a_field_of_the_wrong_type_is_refused_naming_it(tmp_path, capsys, fields, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"success_rate": 0.9, "episodes": 200, "seed": 0, **fields}))
    with pytest.raises(ValueError) as refused:
        table.eval_low_file(path)
    assert str(refused.value) == f"{path}: {message}"


def test_every_distill_setting_but_beta0_is_an_option_and_a_missing_one_fails_loudly(tmp_path, monkeypatch):
    import argparse

    got = []
    monkeypatch.setattr(steady_ant, "distill", lambda teacher, out, sources, settings, **_: got.append(settings))
    assert steady_ant.main(["--out", str(tmp_path / "r"), "--batch-size", "7", "--init-head", "-1"]) == 0
    assert got == [steady_ant.DistillSettings(batch_size=7, init_head=None)]
    options = {name: 1 for name in ("iterations", "seed")}
    with pytest.raises(KeyError, match="batch_size"):
        steady_ant.distill_settings(argparse.Namespace(**options, init_head=0))


def test_each_larger_maze_episode_gets_its_own_paths_budget_not_the_largest_so_far():
    from antmaze_hirl.envs.suites import scaled_step_limit
    from antmaze_hirl.sb3_ext.distill import RecordingController

    (source,) = steady_ant.maze_sources(RecordingController(), [6], reach=False, subgoal_reach_m=2.0)
    inner = source.env.unwrapped
    fixed_budget = inner.max_steps
    budgets = []
    for seed in range(8):
        source.env.reset(seed=seed)
        budget = source.step_limit(inner)
        inner.max_steps = budget  # what playing the episode sets, as HighLevelEpisodes.play does after its reset
        assert budget == max(fixed_budget, scaled_step_limit(inner.layout, inner.geometry.scale))
        budgets.append(budget)
    # Some episode's path is shorter than an earlier one's: its budget must come out smaller, not carried over.
    assert any(later < earlier for i, earlier in enumerate(budgets) for later in budgets[i + 1 :]), budgets
    source.close()
