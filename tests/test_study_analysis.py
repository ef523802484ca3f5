import json
import re

import pandas as pd
import pytest

from antmaze_hirl.study.analysis import analyze
from antmaze_hirl.study.data import EPISODE_COLUMNS, participant_dir
from antmaze_hirl.study.plan import make_plan, save_plan
from antmaze_hirl.study.questionnaire import ITEM_KEYS

METHODS = ["dagger", "noise", "reward"]
PRACTICE_SECONDS = 999.0  # only practice rows have it: it must never reach a figure


def _episode_rows(participant, trial, episodes):
    rows = []
    for episode in range(episodes):
        evaluated = episode % 2 == 1
        bump = 0.1 * (trial.index + participant)
        rows.append(
            {
                "participant": f"P{participant:02d}",
                "trial": trial.index,
                "method": trial.method,
                "label": trial.label,
                "practice": trial.practice,
                "seed": trial.seed,
                "episode": episode,
                "success": episode % 3 == 0,
                "expert_cost": 2,
                "cumulative_expert_cost": 2 * (episode + 1) + trial.index,
                "attempts": 3 + episode,
                "low_level_steps": 100,
                "beta": 0.5,
                "dataset_size": 2 * (episode + 1),
                "removed": 0,
                "eval_success": min(1.0, bump + 0.1 * episode) if evaluated else None,
                "eval_attempts": 4.0 if evaluated else None,
                "seconds_per_label": PRACTICE_SECONDS if trial.practice else 1.0 + bump + (participant % 2) * 0.5,
                "time_on_task": 30.0,
            }
        )
    return rows


def _answer(participant, trial, rating):
    ratings = {key: 1 + (rating + i) % 5 for i, key in enumerate(ITEM_KEYS)}
    return {
        "participant": participant,
        "trial": trial.index,
        "method": trial.method,
        "label": trial.label,
        "ratings": ratings,
        "comment": "ok",
        "time": 1764000000.0,
    }


def _write_participant(study_dir, plan, number, *, trials=None, last_trial_episodes=None, answer=True):
    participant = plan.participants[number - 1]
    chosen = participant.trials if trials is None else participant.trials[:trials]
    rows, answers = [], []
    for k, trial in enumerate(chosen):
        episodes = trial.episodes if k < len(chosen) - 1 or last_trial_episodes is None else last_trial_episodes
        rows += _episode_rows(number, trial, episodes)
        if answer:
            answers.append(_answer(participant.id, trial, 4 if trial.practice else number + trial.index))
    folder = participant_dir(study_dir, participant.id)
    folder.mkdir(parents=True)
    pd.DataFrame(rows, columns=list(EPISODE_COLUMNS)).to_csv(folder / "episodes.csv", index=False)
    (folder / "answers.jsonl").write_text("".join(json.dumps(a) + "\n" for a in answers))
    (folder / "clicks.jsonl").write_text("")
    return answers


@pytest.fixture
def study(tmp_path):
    plan = make_plan("point", METHODS, participants=4, episodes=4, practice=2, seed=0)
    save_plan(plan, tmp_path)
    answers = [_write_participant(tmp_path, plan, n) for n in (1, 2, 3)]
    # P04 finished their first compared trial and stopped half-way through the second, unanswered.
    _write_participant(tmp_path, plan, 4, trials=3, last_trial_episodes=2, answer=False)
    return tmp_path, plan, answers


@pytest.mark.integration
def test_analyze_writes_the_report(study):
    study_dir, plan, answers = study
    out = analyze(study_dir)
    assert out == study_dir / "report"
    for name in ("panels.png", "likert.png", "seconds_per_label.png", "outcomes.png", "stats.json", "report.md"):
        assert (out / name).stat().st_size > 0, name
    stats = json.loads((out / "stats.json").read_text())
    report = (out / "report.md").read_text()
    for method in METHODS:
        assert f"| {method} | {plan.label_of(method)} |" in report
    assert report.count("- One-way ANOVA (as in the paper): F(2, 6) = ") == 9  # 3 outcomes + 6 TLX items
    assert report.count("- Repeated-measures ANOVA (subject = participant, within = method): F(2, 4) = ") == 9
    assert "Tests over the 3 participants with a value for every method" in report
    assert stats["design"]["distinct_orders"] == 4 and stats["design"]["design_rows"] == 6

    # The TLX means are those of the compared trials' answers: the practice answers (all 4s... shifted) are left out.
    for item in ITEM_KEYS:
        for method in METHODS:
            expected = [a["ratings"][item] for p in answers for a in p if a["method"] == method and a["trial"] > 0]
            summary = stats["measures"][item]["methods"][method]
            assert summary["n"] == 3
            assert summary["mean"] == pytest.approx(sum(expected) / 3)
        assert len(stats["measures"][item]["tests"]["posthoc"]) == 3

    seconds = stats["measures"]["seconds_per_label"]["methods"]
    assert all(s["max"] < PRACTICE_SECONDS for s in seconds.values())
    # P04 finished one compared trial: it counts in that method's table but not in the tests.
    p04_first = plan.participants[3].trials[1].method
    assert seconds[p04_first]["n"] == 4
    assert sum(s["n"] for s in seconds.values()) == 10
    assert stats["measures"]["seconds_per_label"]["tests"]["participants"] == ["P01", "P02", "P03"]
    assert stats["figures"]["panels.png"]["participants"] == 4
    assert stats["figures"]["panels.png"]["per_method"][p04_first] == 4
    assert stats["figures"]["likert.png"]["participants"] == 3
    assert "`panels.png`" in report and "4 participant(s)" in report
    final = stats["measures"]["final_success"]["methods"]
    total = stats["measures"]["total_labels"]["methods"]
    # Last evaluation is episode 3: success min(1, 0.1 (trial + participant) + 0.3); labels 8 + trial index.
    trial_of = {(t.method, p.id): t.index for p in plan.participants[:3] for t in p.trials if not t.practice}
    for method in METHODS:
        indices = [trial_of[(method, f"P{n:02d}")] + n for n in (1, 2, 3)]
        if method != p04_first:
            assert final[method]["mean"] == pytest.approx(sum(min(1.0, 0.1 * i + 0.3) for i in indices) / 3)
            assert total[method]["mean"] == pytest.approx(
                8 + sum(trial_of[(method, f"P{n:02d}")] for n in (1, 2, 3)) / 3
            )


def test_analyze_with_one_participant_gives_tables_without_tests(tmp_path):
    plan = make_plan("ant", ["noise", "reward"], participants=1, episodes=2, practice=0, seed=4)
    save_plan(plan, tmp_path)
    _write_participant(tmp_path, plan, 1)
    report = (analyze(tmp_path) / "report.md").read_text()
    assert "Tests not run: 1 participant(s) with a value for every method; the tests need 2." in report
    assert "One-way ANOVA" not in report
    assert "| Method A (" in report and "| Method B (" in report


def test_analyze_without_any_data(tmp_path):
    plan = make_plan("point", METHODS, participants=2, episodes=3, seed=1)
    save_plan(plan, tmp_path)
    stats = json.loads((analyze(tmp_path) / "stats.json").read_text())
    assert stats["figures"]["panels.png"]["participants"] == 0
    assert stats["measures"]["effort"]["tests"]["run"] is False


def test_analyze_rejects_data_that_contradict_the_plan(study):
    study_dir, plan, _ = study
    path = participant_dir(study_dir, "P02") / "episodes.csv"
    frame = pd.read_csv(path)
    trial = plan.participants[1].trials[1]
    wrong = next(m for m in METHODS if m != trial.method)
    frame.loc[frame["trial"] == trial.index, "method"] = wrong
    frame.to_csv(path, index=False)
    with pytest.raises(ValueError, match=f"episodes.csv: trial {trial.index} is '{wrong}'"):
        analyze(study_dir)


def test_analyze_rejects_a_bad_answer_line(study):
    study_dir, _, _ = study
    path = participant_dir(study_dir, "P01") / "answers.jsonl"
    lines = path.read_text().splitlines()
    entry = json.loads(lines[1])
    entry["ratings"]["effort"] = 7
    path.write_text("\n".join([lines[0], json.dumps(entry), *lines[2:]]) + "\n")
    with pytest.raises(ValueError, match=r"answers\.jsonl:2: rating of 'effort' must be from 1 to 5, got 7"):
        analyze(study_dir)


def test_episode_columns_are_the_documented_server_format():
    documented = (
        "participant trial method label practice seed episode success expert_cost cumulative_expert_cost attempts "
        "low_level_steps beta dataset_size removed eval_success eval_attempts eval_mazes layout seconds_per_label "
        "time_on_task learner_updates"
    )
    assert EPISODE_COLUMNS == tuple(documented.split())
    import antmaze_hirl.study.analysis as analysis

    assert ", ".join(EPISODE_COLUMNS) in " ".join(analysis.__doc__.split()).replace("``", "")


@pytest.mark.parametrize(
    ("column", "value", "message"),
    [
        ("episode", 1.5, "episode must be a whole number, got 1.5"),
        ("episode", 7, "has episode 7 of 4"),
        ("episode", 0, "has episode 0 more than once"),
        ("success", "yes", "success must be True or False, got 'yes'"),
        ("attempts", "", "attempts must be a number, got ''"),
        ("attempts", "many", "attempts must be a number, got 'many'"),
    ],
)
def test_analyze_rejects_bad_episode_rows(study, column, value, message):
    study_dir, _, _ = study
    path = participant_dir(study_dir, "P03") / "episodes.csv"
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    frame.loc[5, column] = str(value)
    frame.to_csv(path, index=False)
    with pytest.raises(ValueError, match=re.escape("P03/episodes.csv: ") + ".*" + re.escape(message)):
        analyze(study_dir)
