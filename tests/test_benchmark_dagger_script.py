"""scripts/benchmark_dagger.py: its arguments, its report names, and a tiny run writing scored reports."""

import json

import pytest
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (scripts/benchmark_dagger.py): the integration tier

script = load_script("scripts/benchmark_dagger.py")


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--body", "car"], "'car'"),
        (["--learner", "vin"], "'vin'"),
        (["--method", "bc"], "'bc'"),
        (["--labels", "100,x"], "'100,x'"),
        (["--labels", "0,100"], "'0,100'"),
        (["--num-envs", "0"], "--num-envs must be >= 1, got 0"),
        (["--tasks", "0"], "--tasks must be >= 1, got 0"),
        (["--max-episodes", "0"], "--max-episodes must be >= 1, got 0"),
    ],
)
def test_a_bad_argument_exits_with_one_line_naming_it(capsys, argv, named):
    with pytest.raises(SystemExit) as exited:
        script.parse_args(argv)
    assert exited.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error:" in error
    assert named in error


def test_the_ant_protocol_learner_scores_on_ant4_with_lockstep_by_default():
    args = script.parse_args(["--body", "ant", "--learner", "protocol"])
    assert (args.body, args.learner, args.targets, args.num_envs) == ("ant", "protocol", [100, 300, 1000], 8)
    config, settings = script.learner_setup("ant", "protocol")
    assert (config.body, config.maze_size, config.held_out_layouts) == ("ant", 4, True)
    assert config.learner == "next_cell_cnn" and settings == {}
    assert config.subgoal_reach_m == 2.0  # the ant oracle's 2 m subgoals, as the ant experiment


def test_the_generic_learner_keeps_the_heading_head_of_the_committed_point_rows():
    config, settings = script.learner_setup("point", "generic")
    assert (config.body, config.maze_size, config.learner) == ("point", 5, None)
    assert settings == {"head": "heading", "planning_iterations": 0, "block_walls": False}
    assert script.learner_setup("point", "default")[1] == {}


def test_report_names_are_distinct_per_body_learner_seed_and_labels():
    assert script.report_name("point", "generic", 0, 300) == "point5_dagger_generic_s0_300.json"
    assert script.report_name("ant", "protocol", 0, 300) == "ant4_dagger_protocol_s0_300.json"
    names = {
        script.report_name(body, learner, seed, labels)
        for body in ("point", "ant")
        for learner in script.LEARNERS
        for seed in (0, 1)
        for labels in (0, 100)
    }
    assert len(names) == 2 * len(script.LEARNERS) * 2 * 2
    active = {script.report_name("point", "protocol", 0, 100, method) for method in script.METHODS}
    assert len(active) == len(script.METHODS) and "point5_dagger_protocol_s0_100.json" in active
    assert script.report_name("ant", "protocol", 1, 0, "gated+noise") == "ant4_gated_noise_protocol_s1_0.json"


def test_an_active_methods_rows_name_it_and_plain_dagger_keeps_its_committed_name():
    assert script.parse_args([]).method == "dagger"
    assert script.policy_name("dagger", "protocol", 2, 1001) == "DAgger (plain), protocol learner, seed 2, 1001 labels"
    assert script.policy_name("noise", "protocol", 0, 103).startswith("DAgger with `noise` (active), protocol learner")


@pytest.mark.parametrize(
    ("body", "learner", "method", "named"),
    [("car", "generic", "dagger", "'car'"), ("ant", "vin", "dagger", "'vin'"), ("ant", "protocol", "bc", "'bc'")],
)
def test_report_name_refuses_an_unknown_body_learner_or_method_naming_it(body, learner, method, named):
    with pytest.raises(ValueError, match=named):
        script.report_name(body, learner, 0, 0, method)


@pytest.mark.integration  # ~5-15 s: 200 gradient steps and the suite env's start
def test_a_tiny_run_scores_the_untrained_and_the_trained_learner(tmp_path):
    argv = ["--labels", "1", "--learner", "protocol", "--tasks", "2", "--num-envs", "2"]
    assert script.main([*argv, "--out", str(tmp_path / "learners"), "--results", str(tmp_path)]) == 0
    untrained = json.loads((tmp_path / "point5_dagger_protocol_s0_0.json").read_text())
    trained = json.loads((tmp_path / "point5_dagger_protocol_s0_1.json").read_text())
    assert untrained["training"]["labels"] == 0 and untrained["training"]["episodes"] == 0
    assert trained["training"]["labels"] >= 1 and trained["training"]["episodes"] >= 1
    for report in (untrained, trained):
        assert report["suite"] == "point5" and report["episodes"] == 2 and report["num_envs"] == 2
        assert report["training"]["learner_settings"]["head"] == "next_cell"
    assert (tmp_path / "learners" / "point5_dagger_protocol_s0_1.zip").is_file()
    assert trained["training"]["label_target"] == 1 and not trained["training"]["stopped_short_at_max_episodes"]


@pytest.mark.integration  # ~5-15 s, as above
def test_a_target_out_of_reach_in_max_episodes_is_scored_short_and_ends_the_run(tmp_path):
    # One episode asks about 8 labels: 1,000 are out of reach, so the run stops after it, scored and flagged.
    argv = ["--labels", "1000,2000", "--learner", "protocol", "--tasks", "2", "--num-envs", "2", "--max-episodes", "1"]
    assert script.main([*argv, "--out", str(tmp_path / "learners"), "--results", str(tmp_path)]) == 0
    short = json.loads((tmp_path / "point5_dagger_protocol_s0_1000.json").read_text())["training"]
    assert short["episodes"] == 1 and 0 < short["labels"] < 1000 and short["stopped_short_at_max_episodes"]
    assert not (tmp_path / "point5_dagger_protocol_s0_2000.json").exists()
