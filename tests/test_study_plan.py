import itertools
import json
import re
from collections import Counter

import pytest

from antmaze_hirl.dagger.strategies import STRATEGIES
from antmaze_hirl.study.plan import (
    MAX_METHODS,
    StudyPlan,
    load_plan,
    make_plan,
    save_plan,
    williams_design,
)


def _adjacent_pairs(rows):
    return Counter((row[i], row[i + 1]) for row in rows for i in range(len(row) - 1))


@pytest.mark.parametrize("n", [2, 4, 6, 3, 5])
def test_williams_design_balances_position_and_carryover(n):
    rows = williams_design(n)
    copies = 1 if n % 2 == 0 else 2
    assert len(rows) == n * copies
    assert all(sorted(row) == list(range(n)) for row in rows)
    for position in range(n):
        assert Counter(row[position] for row in rows) == {m: copies for m in range(n)}
    pairs = _adjacent_pairs(rows)
    assert pairs == {pair: copies for pair in itertools.permutations(range(n), 2)}


def test_williams_design_single_method_and_bad_input():
    assert williams_design(1) == [[0]]
    for bad in (0, -2, 2.0, True):
        with pytest.raises(ValueError, match="n_methods"):
            williams_design(bad)


def test_plan_structure_and_labels():
    methods = ("dagger", "noise", "multi_policy", "reward")
    plan = make_plan("point", methods, participants=9, episodes=20, practice=5, seed=3)
    assert [p.id for p in plan.participants] == [f"P{i:02d}" for i in range(1, 10)]
    assert sorted(label for _, label in plan.labels) == ["Method A", "Method B", "Method C", "Method D"]
    assert sorted(method for method, _ in plan.labels) == sorted(methods)
    rows = {p.order for p in plan.participants}
    assert len(rows) == 4  # 9 participants cycle through the 4 rows of the design
    assert plan.participants[0].order == plan.participants[4].order == plan.participants[8].order
    order_indices = [[methods.index(m) for m in order] for order in rows]
    assert _adjacent_pairs(order_indices) == {pair: 1 for pair in itertools.permutations(range(4), 2)}
    for participant in plan.participants:
        practice, *compared = participant.trials
        assert (practice.index, practice.method, practice.label, practice.episodes, practice.practice) == (
            0,
            "dagger",
            "Practice",
            5,
            True,
        )
        assert [t.index for t in compared] == [1, 2, 3, 4]
        for trial in compared:
            assert not trial.practice and trial.episodes == 20
            assert trial.label == plan.label_of(trial.method)
            assert trial.method not in trial.label
    seeds = [t.seed for p in plan.participants for t in p.trials]
    assert len(set(seeds)) == len(seeds) == 45


def test_plan_is_seeded():
    a = make_plan("ant", ["noise", "reward", "dagger"], participants=6, seed=1)
    assert a == make_plan("ant", ["noise", "reward", "dagger"], participants=6, seed=1)
    others = [make_plan("ant", ["noise", "reward", "dagger"], participants=6, seed=s) for s in range(2, 8)]
    assert any(o.labels != a.labels for o in others)
    assert any([p.order for p in o.participants] != [p.order for p in a.participants] for o in others)


def test_no_practice_trial():
    plan = make_plan("point", ["noise", "reward"], participants=2, practice=0)
    assert all(len(p.trials) == 2 and not any(t.practice for t in p.trials) for p in plan.participants)
    assert [t.index for t in plan.participants[0].trials] == [1, 2]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"methods": ["noise", "bogus"]}, "unknown method 'bogus'"),
        ({"methods": ["noise", "noise"]}, "method 'noise' is listed 2 times"),
        ({"methods": []}, "methods is empty"),
        ({"methods": "noise"}, "string 'noise'"),
        ({"episodes": 0}, r"episodes must be an int in \[1, 100000\], got 0"),
        ({"episodes": -3}, r"episodes must be an int in \[1, 100000\], got -3"),
        ({"participants": 0}, r"participants must be an int in \[1, 10000\], got 0"),
        ({"participants": 10**20}, r"participants must be an int in \[1, 10000\], got 100000000000000000000"),
        ({"practice": -1}, r"practice must be an int in \[0, 100000\], got -1"),
        ({"seed": -1}, r"seed must be an int in \[0, 4294967295\], got -1"),
        ({"seed": 2**32}, r"seed must be an int in \[0, 4294967295\], got 4294967296"),
        ({"body": "horse"}, "unknown body 'horse'"),
    ],
)
def test_make_plan_rejects_bad_input(kwargs, message):
    args = {"body": "point", "methods": ["noise", "reward"], "participants": 2, **kwargs}
    with pytest.raises(ValueError, match=message):
        make_plan(**args)


def test_make_plan_rejects_too_many_methods():
    names = [f"m{i}" for i in range(MAX_METHODS + 1)]
    assert make_plan("point", names[:MAX_METHODS], participants=1, known_methods=names).methods == tuple(names[:-1])
    with pytest.raises(ValueError, match=f"at most {MAX_METHODS}"):
        make_plan("point", names, participants=1, known_methods=names)


def test_known_methods_default_to_the_strategies():
    plan = make_plan("point", list(STRATEGIES), participants=1)
    assert plan.methods == tuple(STRATEGIES)


def test_save_and_load_round_trip(tmp_path):
    plan = make_plan("point", ["noise", "reward", "multi_policy"], participants=7, episodes=10, practice=2, seed=5)
    path = save_plan(plan, tmp_path)
    assert path == tmp_path / "plan.json"
    loaded = load_plan(tmp_path)
    assert isinstance(loaded, StudyPlan) and loaded == plan
    save_plan(plan, tmp_path)  # the same plan again is fine
    other = make_plan("point", ["noise", "reward", "multi_policy"], participants=7, episodes=10, practice=2, seed=6)
    with pytest.raises(ValueError, match="already holds a different plan"):
        save_plan(other, tmp_path)
    assert load_plan(tmp_path) == plan
    (tmp_path / "plan.json").write_text("{broken")
    with pytest.raises(ValueError, match="already holds a different plan"):
        save_plan(plan, tmp_path)


def test_save_plan_with_custom_method_names(tmp_path):
    names = ["m0", "m1"]
    plan = make_plan("point", names, participants=2, known_methods=names)
    save_plan(plan, tmp_path)
    save_plan(plan, tmp_path)
    assert load_plan(tmp_path, known_methods=names) == plan
    with pytest.raises(ValueError, match="unknown method 'm0'"):
        load_plan(tmp_path)


def test_load_plan_errors_name_the_file(tmp_path):
    with pytest.raises(ValueError, match=re.escape(f"no study plan at {tmp_path / 'plan.json'}")):
        load_plan(tmp_path)
    (tmp_path / "plan.json").write_text("{not json")
    with pytest.raises(ValueError, match=r"plan\.json is not a readable JSON plan"):
        load_plan(tmp_path)


def _edited(tmp_path, edit):
    plan = make_plan("point", ["noise", "reward"], participants=2, episodes=4, practice=1)
    save_plan(plan, tmp_path)
    data = json.loads((tmp_path / "plan.json").read_text())
    edit(data)
    (tmp_path / "plan.json").write_text(json.dumps(data))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("seed"), "exactly the keys"),
        (lambda d: d.update(methods=["noise", "bogus"]), "unknown method 'bogus'"),
        (lambda d: d.update(episodes="4"), "episodes must be an int"),
        (lambda d: d["participants"][0]["trials"][1].update(label="noise"), "P01's trials do not match"),
        (lambda d: d["participants"][1]["trials"][2].update(episodes=3), "P02's trials do not match"),
        (lambda d: d["participants"][1]["trials"][2].update(seed=d["participants"][0]["trials"][0]["seed"]), "share"),
        (lambda d: d["participants"][1].update(id="P01"), "ids repeat"),
        (lambda d: d["participants"][0]["trials"][0].update(practice=1), "practice flag must be a bool"),
        (lambda d: d.update(labels=[["noise", "Method A"], ["reward", "Method A"]]), "its own label"),
        (lambda d: d.update(participants=[]), "non-empty list"),
    ],
)
def test_load_plan_rejects_edited_files(tmp_path, edit, message):
    _edited(tmp_path, edit)
    with pytest.raises(ValueError, match=message) as error:
        load_plan(tmp_path)
    assert "plan.json is not a valid study plan" in str(error.value)
    assert "\n" not in str(error.value)


def test_new_studies_hold_layouts_out_and_old_settings_files_read_as_they_ran(tmp_path):
    from antmaze_hirl.study.settings import SETTINGS_FILE, StudySettings, load_settings, save_settings

    ant = StudySettings.for_body("ant")
    assert ant.held_out_layouts and ant.maze_size == 4 and ant.experiment_config(3).held_out_layouts
    assert StudySettings.for_body("ant", held_out_layouts=False).maze_size == 3
    save_settings(StudySettings.for_body("point"), tmp_path)
    written = json.loads((tmp_path / SETTINGS_FILE).read_text())
    assert written["held_out_layouts"] is True
    del written["held_out_layouts"]  # a settings.json from before the setting existed
    (tmp_path / SETTINGS_FILE).write_text(json.dumps(written))
    assert load_settings(tmp_path).held_out_layouts is False
