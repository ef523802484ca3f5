"""``antmaze-hirl submit``: a leaderboard submission is checked, and its row names what it is."""

import json
from pathlib import Path

import pytest

from antmaze_hirl.cli import main
from antmaze_hirl.experiments.submission import SubmissionError, check_submission

# Copies of two committed leaderboard reports (point5's oracle and PPO seed 1): the unit tier reads no results/.
LEADERBOARD = Path(__file__).resolve().parent / "data" / "reports"


def reference(name="point5_oracle.json", **changes):
    return {**json.loads((LEADERBOARD / name).read_text()), **changes}


def submit(tmp_path, capsys, report, *options):
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(report))
    try:
        status = main(["submit", str(path), *options])
    except SystemExit as stop:
        status = stop.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_a_good_report_is_checked_and_its_row_filled_from_the_options(tmp_path, capsys):
    out = tmp_path / "results" / "point5_mine_s3.json"
    status, printed, _ = submit(
        tmp_path,
        capsys,
        reference(policy="my planner"),
        "--budget",
        "50k steps",
        "--training-seed",
        "3",
        "--out",
        str(out),
    )
    assert status == 0
    assert printed.splitlines()[0] == "ok: point5 | my planner | 50k steps | seed 3 | 100 of 100 episodes"
    written = json.loads(out.read_text())
    assert written["submission"] == {"budget": "50k steps", "seed": 3}
    assert written["episode_outcomes"] == reference()["episode_outcomes"]


def test_the_budget_and_seed_come_from_the_report_when_it_has_them():
    scored = reference(policy="my planner", submission={"budget": "2 hours of labels", "seed": 1})
    assert check_submission(scored)["submission"] == {"budget": "2 hours of labels", "seed": 1}
    ppo = reference("point5_ppo_rl_s1.json")  # the training script's own block
    assert check_submission(ppo)["submission"] == {"budget": "200,704 high-level steps (subgoals)", "seed": 1}


def test_a_bad_checksum_is_refused_in_one_line_with_exit_2(tmp_path, capsys):
    report = reference(policy="my planner", suite_checksum="ab" * 32)
    status, printed, error = submit(tmp_path, capsys, report, "--budget", "1k", "--training-seed", "0")
    assert status == 2 and printed == ""
    assert error.count("\n") == 1 and "Traceback" not in error
    assert "suite checksum 'abababababababab' is not suite 'point5''s (63de7a5432976684...)" in error


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"format": "mine/1"}, "format 'mine/1' is not a benchmark report"),
        ({"suite": "point9"}, "suite 'point9' is not a suite"),
        ({"env_id": "antmaze_hirl/PointMaze-v0"}, "env_id 'antmaze_hirl/PointMaze-v0' is not suite 'point5''s"),
        ({"successes": 99}, "successes 99 disagree with its 100 episode_outcomes (100 successes)"),
        ({"policy": "oracle"}, "policy 'oracle' is no entry's name"),
        ({"submission": {"seed": 0}}, "no training budget: pass --budget"),
        ({"submission": {"budget": "1k", "seed": "zero"}}, "training seed 'zero' is not an integer"),
    ],
)
def test_a_report_that_cannot_be_a_row_is_refused_naming_the_field(change, message):
    report = {**reference(policy="my planner", submission={"budget": "1k", "seed": 0}), **change}
    with pytest.raises(SubmissionError, match=r"^the report: ") as refused:
        check_submission(report)
    assert message in str(refused.value)


def test_fewer_episodes_than_the_protocol_are_refused():
    report = reference(policy="my planner", submission={"budget": "1k", "seed": 0})
    report["episode_outcomes"] = report["episode_outcomes"][:40]
    with pytest.raises(SubmissionError, match=r"40 episodes, the protocol plays 100 \(1 on each of 100 tasks"):
        check_submission(report)


def test_a_file_that_is_no_json_is_one_line(tmp_path, capsys):
    path = tmp_path / "broken.json"
    path.write_text("{ not json")
    with pytest.raises(SystemExit) as stop:
        main(["submit", str(path)])
    error = capsys.readouterr().err
    assert stop.value.code == 2 and error.count("\n") == 1 and "not JSON" in error
