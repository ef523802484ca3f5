"""``antmaze-hirl benchmark`` and :func:`score_policy`: oracle, random, SB3 zips, DAgger learners, bad input."""

import json
import zipfile

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO

from antmaze_hirl.cli import main
from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments import benchmark
from antmaze_hirl.experiments.benchmark import load_report, score_policy
from antmaze_hirl.experiments.benchmark_policies import resolve_policy

TASKS = [0, 1, 2, 3]


@pytest.fixture(scope="module")
def point_env():
    env = gym.make("antmaze_hirl/PointMaze-5x5-v0")
    yield env
    env.close()


@pytest.fixture(scope="module")
def ppo_zip(tmp_path_factory, point_env):
    # A user's tiny high-level PPO, untrained: only its file format and spaces matter here.
    model = PPO("MultiInputPolicy", point_env, n_steps=8, batch_size=8, policy_kwargs={"net_arch": [8]}, seed=0)
    path = tmp_path_factory.mktemp("sb3") / "ppo_high.zip"
    model.save(path)
    return path


@pytest.fixture(scope="module")
def learner_zip(tmp_path_factory, point_env):
    path = tmp_path_factory.mktemp("dagger") / "learner.zip"
    HighLevelPolicy.for_env(point_env, rng=np.random.default_rng(0)).save(path)
    return path


def test_the_oracle_scores_above_a_random_policy_with_intervals_attempts_and_steps():
    oracle = score_policy("point5", "oracle", task_ids=TASKS)
    random = score_policy("point5", "random", task_ids=TASKS)
    assert oracle["success_rate"] > random["success_rate"]  # the score discriminates
    assert oracle["successes"] == len(TASKS)  # the oracle solves all 100 point tasks (results)
    for report in (oracle, random):
        low, high = report["wilson_95"]
        assert low <= report["success_rate"] <= high
        assert [row["task_id"] for row in report["tasks"]] == TASKS
        assert report["episodes"] == len(TASKS) and report["episodes_per_task"] == 1
        assert report["low_level_steps_total"] == sum(o["low_level_steps"] for o in report["episode_outcomes"])
        assert report["mean_attempts"] >= 1 and report["suite_checksum"] == SUITE_SPECS["point5"].checksum
    assert random["mean_low_level_steps"] > oracle["mean_low_level_steps"]


def test_scores_are_reproducible_and_several_episodes_per_task_get_a_bootstrap_over_tasks():
    first = score_policy("point5", "random", task_ids=[5, 6], episodes_per_task=2, seed=3)
    again = score_policy("point5", "random", task_ids=[5, 6], episodes_per_task=2, seed=3)
    assert first["episode_outcomes"] == again["episode_outcomes"]
    assert [o["seed"] for o in first["episode_outcomes"]] == [13, 14, 15, 16]  # seed + k * K + j
    assert "task_bootstrap_95" in first
    assert "task_bootstrap_95" not in score_policy("point5", "oracle", task_ids=[5])


def test_a_callable_is_scored_like_the_named_policies(point_env):
    from antmaze_hirl.experts import PathOracle

    oracle = PathOracle.for_env(point_env)
    by_callable = score_policy("point5", oracle, task_ids=[7])
    by_name = score_policy("point5", "oracle", task_ids=[7])
    assert by_callable["episode_outcomes"] == by_name["episode_outcomes"]


def test_a_tiny_sb3_zip_and_a_saved_dagger_learner_are_scored(ppo_zip, learner_zip):
    for path, kind in ((ppo_zip, "sb3"), (learner_zip, "dagger learner")):
        report = score_policy("point5", str(path), task_ids=[0, 1])
        assert report["policy"] == f"{kind} {path}"
        assert report["episodes"] == 2 and 0 <= report["successes"] <= 2


def test_the_runner_is_a_one_line_swap_and_gets_num_envs(monkeypatch):
    seen = []

    def recording_runner(make_env, policy, episodes, *, num_envs, progress=False):
        seen.append((list(episodes), num_envs))
        return benchmark.play_serial(make_env, policy, episodes, progress=progress)

    monkeypatch.setattr(benchmark, "EPISODE_RUNNER", recording_runner)
    score_policy("point5", "oracle", task_ids=[2])
    score_policy("point5", "oracle", task_ids=[2], num_envs=1)
    assert seen == [([(2, 2)], benchmark.DEFAULT_NUM_ENVS), ([(2, 2)], 1)]


def run_cli(capsys, *argv):
    with pytest.raises(SystemExit) as exit_info:
        main(["benchmark", *argv])
    return exit_info.value.code, capsys.readouterr()


def test_policy_name_names_the_leaderboard_entry_and_is_recorded_in_the_command(tmp_path, capsys):
    from antmaze_hirl.experiments.benchmark import save_report

    out = tmp_path / "new" / "mine.json"
    argv = ["benchmark", "point5", "--policy", "random", "--tasks", "0", "--no-progress", "--json", str(out)]
    assert main([*argv, "--policy-name", "random subgoals, no training"]) == 0
    report = load_report(out)
    assert report["policy"] == "random subgoals, no training"
    assert (
        "--policy random" in report["command"] and "--policy-name 'random subgoals, no training'" in report["command"]
    )
    # save_report writes what load_report reads, and refuses what is no report.
    assert load_report(save_report(report, tmp_path / "copy.json")) == report
    with pytest.raises(ValueError, match=r"not a benchmark report: format None"):
        save_report({"policy": "x"}, tmp_path / "bad.json")


def test_the_command_prints_the_table_and_writes_the_report(tmp_path, capsys):
    out = tmp_path / "report.json"
    assert (
        main(["benchmark", "point5", "--policy", "oracle", "--tasks", "0,1", "--json", str(out), "--no-progress"]) == 0
    )
    printed = capsys.readouterr().out
    assert "2/2" in printed and "task 1" in printed and f"wrote {out}" in printed
    report = load_report(out)
    assert (
        report["command"]
        == "antmaze-hirl benchmark point5 --policy oracle --episodes-per-task 1 --seed 0 --num-envs 8 --tasks 0,1"
    )
    assert report["num_envs"] == 8
    assert report["success_rate"] == 1.0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["pointy", "--policy", "oracle"], r"unknown benchmark suite 'pointy'; choose one of \['point5'"),
        (["point5", "--policy", "missing.zip"], r"no policy file at missing.zip; --policy takes oracle, random"),
        (["point5", "--policy", "random", "--tasks", "0,100"], r"task_id 100 is out of range for suite 'point5'"),
        (["point5", "--policy", "random", "--tasks", "a"], r"--tasks must be comma-separated integers, got 'a'"),
        (["point5", "--policy", "random", "--tasks", "1,2,1"], r"task_ids repeat \[1\]: name each task once"),
        (["point5", "--policy", "random", "--episodes-per-task", "0"], r"--episodes-per-task must be >= 1, got 0"),
        (
            ["point5", "--policy", "random", "--num-envs", "0"],
            r"--num-envs must be >= 1 \(mazes played at once; 1: one after another\), got 0",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, argv, message):
    code, captured = run_cli(capsys, *argv)
    assert code == 2
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("antmaze-hirl benchmark: error: ")
    assert pytest.importorskip("re").search(message, lines[0]), lines[0]


def test_a_policy_of_the_wrong_body_is_one_line_and_exit_2(capsys, ppo_zip, learner_zip):
    # Scored on the ant's U maze, the point's policies are refused before any episode is played.
    code, captured = run_cli(capsys, "u", "--policy", str(ppo_zip))
    assert code == 2 and "a policy of another body or maze size" in captured.err
    assert len(captured.err.strip().splitlines()) == 1
    code, captured = run_cli(capsys, "u", "--policy", str(learner_zip))
    assert code == 2 and "is a learner for the point body (1 m cells); suite 'u' is ant" in captured.err


def test_a_file_that_is_no_policy_is_refused_naming_it(tmp_path):
    text = tmp_path / "notes.zip"
    text.write_text("not a zip")
    with pytest.raises(ValueError, match=r"notes.zip is not a zip"):
        score_policy("point5", str(text), task_ids=[0])
    other = tmp_path / "other.zip"
    with zipfile.ZipFile(other, "w") as archive:
        archive.writestr("readme.txt", "hello")
    with pytest.raises(ValueError, match=r"other.zip is neither an SB3 model zip"):
        score_policy("point5", str(other), task_ids=[0])


def test_a_learner_for_another_maze_shape_is_refused(tmp_path):
    env = gym.make("antmaze_hirl/AntMaze-4x4-v0", low_level=lambda obs: np.zeros(8))
    path = tmp_path / "ant4_learner.zip"
    HighLevelPolicy.for_env(env, rng=np.random.default_rng(0)).save(path)
    env.close()
    with pytest.raises(ValueError, match=r"is a CNN learner for 6x6 maps; suite 'large' has 9x12 maps \(only a plan"):
        score_policy("large", str(path), task_ids=[0], low_level=lambda obs: np.zeros(8))


def test_a_planning_learner_plays_another_map_zero_shot_and_the_report_says_so(tmp_path):
    from antmaze_hirl.experiments.config import learner_settings

    env = gym.make("antmaze_hirl/PointMaze-5x5-v0", low_level=lambda obs: np.zeros(2))
    path = tmp_path / "point5_planner.zip"
    HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **learner_settings("next_cell_plan", 5)).save(path)
    env.close()
    report = score_policy(
        "point-u", str(path), task_ids=[0], episodes_per_task=1, low_level=lambda obs: np.zeros(2), num_envs=1
    )
    assert report["policy"].endswith("(zero-shot: trained on 7x7 maps)")
    assert report["episodes"] == 1


def test_a_report_of_another_format_is_refused(tmp_path):
    path = tmp_path / "r.json"
    path.write_text(json.dumps({"format": "x"}))
    with pytest.raises(ValueError, match=r"has format 'x', expected 'antmaze_hirl.benchmark_result/1'"):
        load_report(path)


@pytest.mark.integration  # reads the committed results
def test_the_leaderboard_page_is_generated_from_the_committed_reports_of_the_current_suites():
    from script_helpers import load_script

    from antmaze_lab import leaderboard

    generate_docs = load_script("scripts/generate_docs.py")
    for name, section in leaderboard.SECTIONS.items():
        # Each section is one generated block of its page (generate_docs --check compares it; this names the stale one).
        page = leaderboard.page_of(name)
        blocks = {block.command: block.text for block in generate_docs.find_blocks(page, page.read_text())}
        command = f"python -m antmaze_lab.leaderboard --section {name}"
        assert blocks[command] == section(), f"stale: run python scripts/generate_docs.py {page}"
    reports = sorted(leaderboard.RESULTS.glob("*.json"))
    assert reports
    rows = leaderboard.ROWS_PAGE.read_text()
    for path in reports:
        report = load_report(path)
        assert report["suite_checksum"] == SUITE_SPECS[report["suite"]].checksum, path.name
        assert f"`{path.name}` |" in rows


@pytest.mark.integration  # a lab check (antmaze_lab.leaderboard)
def test_the_leaderboard_prints_the_one_section_asked_for(capsys):

    from antmaze_lab import leaderboard

    assert leaderboard.main(["--section", "suites"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("| suite | id | tasks |") and "| policy | budget |" not in printed
    with pytest.raises(SystemExit):
        leaderboard.main(["--section", "board"])
    assert "invalid choice: 'board'" in capsys.readouterr().err


def test_subgoal_reach_m_shortens_the_oracles_subgoals_and_is_recorded(point_env):
    spec = SUITE_SPECS["point5"]
    obs, _ = point_env.reset(seed=0, options={"task_id": 0})
    agent = obs["state"][:2]
    default, _ = resolve_policy(spec, "oracle", point_env, seed=0)
    short, _ = resolve_policy(spec, "oracle", point_env, seed=0, subgoal_reach_m=0.5)
    assert np.linalg.norm(default(obs) - agent) > 0.6  # one cell (1 m) by default
    assert np.linalg.norm(short(obs) - agent) == pytest.approx(0.5)
    report = score_policy("point5", "oracle", task_ids=[0], subgoal_reach_m=0.5)
    assert report["oracle_subgoal_reach_m"] == 0.5 and report["successes"] == 1
    assert report["mean_attempts"] > score_policy("point5", "oracle", task_ids=[0])["mean_attempts"]
    assert "oracle_subgoal_reach_m" not in score_policy("point5", "random", task_ids=[0])


def test_clearance_m_moves_the_oracles_subgoals_off_the_walls_and_is_recorded(point_env):
    spec = SUITE_SPECS["point5"]
    default, _ = resolve_policy(spec, "oracle", point_env, seed=0)
    wide, _ = resolve_policy(spec, "oracle", point_env, seed=0, clearance_m=0.45)
    obs, _ = point_env.reset(seed=0, options={"task_id": 0})
    moved, done = 0, False
    while not done:  # one episode of the default oracle; the wide one labels the same observations
        moved += not np.allclose(wide(obs), default(obs))
        obs, _, terminated, truncated, _ = point_env.step(default(obs))
        done = terminated or truncated
    assert moved > 0
    report = score_policy("point5", "oracle", task_ids=[0], clearance_m=0.45)
    assert report["oracle_clearance_m"] == 0.45 and report["oracle_subgoal_reach_m"] == 1.0
    assert score_policy("point5", "oracle", task_ids=[0])["oracle_clearance_m"] == pytest.approx(0.2)  # 0.2 cell


@pytest.mark.parametrize("name", ["subgoal_reach_m", "clearance_m"])
@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), True])
def test_a_bad_oracle_setting_is_refused_naming_it_and_the_value(name, bad):
    with pytest.raises(ValueError, match=rf"{name} must be a finite number of metres > 0, got {bad!r}"):
        score_policy("point5", "oracle", task_ids=[0], **{name: bad})


def test_subgoal_reach_m_for_another_policy_is_refused(point_env, capsys):
    with pytest.raises(ValueError, match=r"subgoal_reach_m is the oracle's setting; policy 'random' takes none"):
        score_policy("point5", "random", task_ids=[0], subgoal_reach_m=1.0)
    with pytest.raises(ValueError, match=r"subgoal_reach_m is the oracle's setting; a function policy takes none"):
        score_policy("point5", lambda obs: obs["state"][:2], task_ids=[0], subgoal_reach_m=1.0)
    for argv, message in (
        (["--policy", "random", "--subgoal-reach-m", "1"], "is the oracle's setting; --policy random"),
        (["--policy", "oracle", "--subgoal-reach-m", "0"], "--subgoal-reach-m must be a finite number > 0"),
        (["--policy", "random", "--clearance-m", "1"], "--clearance-m is the oracle's setting; --policy random"),
        (["--policy", "oracle", "--clearance-m", "nan"], "--clearance-m must be a finite number > 0"),
    ):
        code, captured = run_cli(capsys, "point5", *argv, "--tasks", "0")
        lines = captured.err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and message in lines[0], lines


@pytest.mark.integration  # reads the committed results
def test_the_spread_section_sets_each_dagger_seed_side_by_side(tmp_path, monkeypatch):
    import shutil

    from antmaze_lab import leaderboard

    source = leaderboard.RESULTS
    for seed in (0, 1):
        for target in (0, 1000):
            name = f"ant4_dagger_protocol_s{seed}_{target}.json"
            shutil.copy(source / name, tmp_path / name)
    monkeypatch.setattr(leaderboard, "RESULTS", tmp_path)
    rows = leaderboard.spread_table().splitlines()[2:]
    expected = {
        target: [load_report(source / f"ant4_dagger_protocol_s{seed}_{target}.json") for seed in (0, 1)]
        for target in (0, 1000)
    }
    assert len(rows) == 2
    for row, target in zip(rows, (0, 1000), strict=True):
        rates = [100 * report["success_rate"] for report in expected[target]]
        assert row.startswith(f"| `ant4` | `dagger` | protocol | {target} | 0, 1 |")
        assert f"| {sum(rates) / 2:.1f} | {min(rates):.0f}-{max(rates):.0f} |" in row
    # An active method's rows (scripts/benchmark_dagger.py --method) make their own rows, after plain DAgger's.
    shutil.copy(source / "ant4_dagger_protocol_s0_1000.json", tmp_path / "ant4_reward_per_step_protocol_s0_1000.json")
    rows = leaderboard.spread_table().splitlines()[2:]
    assert len(rows) == 3 and rows[2].startswith("| `ant4` | `reward_per_step` | protocol | 1000 | 0 |")
    (tmp_path / "ant4_dagger_protocol_seed2.json").write_text("{}")
    with pytest.raises(SystemExit, match=r"ant4_dagger_protocol_seed2\.json: a DAgger row.s name must be"):
        leaderboard.spread_table()


@pytest.mark.integration  # reads the committed results
def test_the_paired_section_sets_a_method_against_plain_dagger_seed_by_seed(tmp_path, monkeypatch):
    from scipy.stats import binomtest

    from antmaze_lab import leaderboard

    report = json.loads((leaderboard.RESULTS / "ant4_dagger_protocol_s0_1000.json").read_text())

    def write(method, seed, target, successes):
        row = {**report, "successes": successes, "success_rate": successes / 100}
        (tmp_path / f"ant4_{method}_protocol_s{seed}_{target}.json").write_text(json.dumps(row))

    # At 100 labels gated is ahead on eight seeds, at 300 on six; at 1,000 on three, behind on one, tied on
    # one; the untrained rows and a seed only one method ran are left out. Holm over the three rows multiplies
    # the smallest p (2 / 2**8) by 3 and the 6-seed sweep's 2 / 2**6 by 2, which lifts it past 0.05.
    for seed in range(8):
        write("dagger", seed, 0, 1), write("gated", seed, 0, 1)
        write("dagger", seed, 100, 40), write("gated", seed, 100, 50)
    for seed in range(6):
        write("dagger", seed, 300, 60), write("gated", seed, 300, 70 + seed)
    for seed, gated in enumerate((90, 91, 92, 80, 85)):
        write("dagger", seed, 1000, 85), write("gated", seed, 1000, gated)
    write("gated", 7, 1000, 99)
    monkeypatch.setattr(leaderboard, "RESULTS", tmp_path)
    rows = leaderboard.paired_table().splitlines()[2:]
    assert rows == [
        "| `ant4` | `gated` | protocol | 100 | 0, 1, 2, 3, 4, 5, 6, 7 | +10, +10, +10, +10, +10, +10, +10, +10 | "
        "8 / 0 / 0 | 0.00781 | 0.0234 | ahead beyond chance (Holm-adjusted p < 0.05) |",
        "| `ant4` | `gated` | protocol | 300 | 0, 1, 2, 3, 4, 5 | +10, +11, +12, +13, +14, +15 | 6 / 0 / 0 | "
        "0.0312 | 0.0625 | ahead on every seed: a direction, not shown at 5% |",
        "| `ant4` | `gated` | protocol | 1000 | 0, 1, 2, 3, 4 | +5, +6, +7, -5, +0 | 3 / 1 / 1 | 0.625 | 0.625 | "
        "mixed, not shown at 5% |",
    ]
    for ahead, behind in ((4, 0), (5, 0), (3, 1), (6, 2), (0, 3)):
        assert leaderboard.sign_test_p(ahead, behind) == pytest.approx(binomtest(ahead, ahead + behind).pvalue)
    assert leaderboard.sign_test_p(0, 0) == 1.0


@pytest.mark.integration  # reads the committed results
def test_the_summary_pools_an_entrys_seeds_over_shared_tasks_and_leaves_checkpoints_out(tmp_path, monkeypatch):
    import shutil

    from antmaze_hirl.experiments.uncertainty import cluster_bootstrap
    from antmaze_lab import leaderboard

    source = leaderboard.RESULTS
    names = [f"ant4_dagger_protocol_s{seed}_1000.json" for seed in (0, 2, 4)]
    names += ["ant4_oracle.json", "ant4_ppo_rl_s0.json", "ant4_ppo_rl_s0_untrained.json"]
    names += ["ant4_ppo_rl_s0_at_10240.json", "ant4_gated_protocol_s0_0.json"]
    for name in names:
        shutil.copy(source / name, tmp_path / name)
    monkeypatch.setattr(leaderboard, "RESULTS", tmp_path)
    rows = leaderboard.summary_table().splitlines()[2:]
    # An active method's untrained row is plain DAgger's learner again: no entry of its own.
    assert [row.split(" | ")[1] for row in rows] == [
        "oracle (goal >= 95%: met by the rate; interval reaches below 95%)",
        "DAgger (plain), protocol learner",
        "SB3 PPO on the high level",
        "SB3 PPO on the high level",
    ]
    seeds = [load_report(source / name) for name in names[:3]]
    pooled = cluster_bootstrap(leaderboard.outcome_table(seeds))
    low, high = pooled["cluster_bootstrap_95"]
    assert pooled["rate"] == pytest.approx(sum(report["success_rate"] for report in seeds) / 3)
    labels = sorted(report["training"]["labels"] for report in seeds)
    assert rows[1].startswith(
        f"| `ant4` | DAgger (plain), protocol learner | 1,000 labels ({labels[0]:,}-{labels[-1]:,}) | 0, 2, 4 | "
        f"{', '.join(str(report['successes']) for report in seeds)} (of 100) | {100 * pooled['rate']:.1f}% "
        f"[{100 * low:.1f}%, {100 * high:.1f}%] | cluster bootstrap, 3 seeds x 100 tasks |"
    )
    # The untrained model first, then the final row at its steps; the checkpoint (_at_10240) is the curve's.
    assert "| untrained (0 steps) |" in rows[2] and "| 24,576 high-level steps | 0 |" in rows[3]
    assert all("10,240" not in row for row in rows)
    # Two seeds are too few for a bootstrap over seeds: they carry the envelope of their Wilson intervals.
    (tmp_path / names[2]).unlink()
    rows = leaderboard.summary_table().splitlines()[2:]
    low, high = min(report["wilson_95"][0] for report in seeds[:2]), max(report["wilson_95"][1] for report in seeds[:2])
    assert f"[{100 * low:.1f}%, {100 * high:.1f}%] | envelope of its 2 seeds' Wilson intervals" in rows[1]
    # A submitted row (any other name) is its own entry, named by its policy, its budget and seed from the
    # report (antmaze-hirl submit); seeds of an RL baseline that reached other steps are other budgets, never pooled.
    submitted = {**load_report(source / "ant4_oracle.json"), "policy": "my HRL agent"}
    submitted["submission"] = {"budget": "1M steps", "seed": 7}
    (tmp_path / "ant4_my_agent.json").write_text(json.dumps(submitted))
    capped = json.loads((source / "ant4_ppo_rl_s0.json").read_text())
    capped["training"] = {**capped["training"], "steps_reached": 20480, "seed": 1}
    (tmp_path / "ant4_ppo_rl_s1.json").write_text(json.dumps(capped))
    rows = leaderboard.summary_table().splitlines()[2:]
    assert [row.split(" | ")[2] for row in rows[2:]] == [
        "untrained (0 steps)",
        "20,480 high-level steps",
        "24,576 high-level steps",
        "1M steps",
    ]
    assert rows[-1].startswith("| `ant4` | my HRL agent | 1M steps | 7 | 99 (of 100) |")
    # One that fails the check stops the tables, naming the file, rather than listing a row it cannot vouch for.
    (tmp_path / "ant4_my_agent.json").write_text(json.dumps({**submitted, "suite_checksum": "0" * 64}))
    with pytest.raises(SystemExit, match=r"ant4_my_agent\.json: suite checksum '0{16}' is not suite 'ant4'"):
        leaderboard.summary_table()
    (tmp_path / "ant4_my_agent.json").unlink()
    # Seeds that played other tasks cannot be pooled: an error naming the row, not a silent mean.
    report = json.loads((tmp_path / names[1]).read_text())
    outcomes = report["episode_outcomes"]
    report["episode_outcomes"] = [{**episode, "task_id": episode["task_id"] + 1} for episode in outcomes]
    (tmp_path / names[1]).write_text(json.dumps(report))
    with pytest.raises(SystemExit, match="its tasks differ from its group's"):
        leaderboard.summary_table()
