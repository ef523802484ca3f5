"""Bad input to the planning-learner commands: ``scripts/planner_check.py`` and ``python -m
antmaze_lab.planning_tables`` refuse it in one line naming the value, exit status 2, before any work."""

import json
from pathlib import Path

import pytest
from script_helpers import load_script

from antmaze_lab import planning_tables

pytestmark = pytest.mark.integration  # a lab check (scripts/planner_check.py): the integration tier

planner_check = load_script("scripts/planner_check.py")


def refused(capsys, argv):
    """The message of the one error line ``planner_check`` prints for ``argv``, after checking it exits 2."""
    with pytest.raises(SystemExit) as stopped:
        planner_check.main(argv)
    assert stopped.value.code == 2
    prog, message = capsys.readouterr().err.strip().splitlines()[-1].split(": error: ")
    assert prog  # argparse's usage line, then "PROG: error: MESSAGE"
    return message


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--selection-sizes", "x"], "--selection-sizes: 'x' is not a whole number"),
        (["--selection-sizes", "6,0"], "--selection-sizes: 0 is below 1"),
        (["--seeds", "0,a"], "--seeds: 'a' is not a whole number"),
        (["--maps", "medium,nosuch"], "--maps: unknown name 'nosuch'; choose from giant, large, medium, open, "),
        (["--variants", "next_cell_plan,nosuch"], "--variants: unknown name 'nosuch'; choose from heading_cnn, "),
        (["--tasks", "-1"], "argument --tasks: must be >= 1, got -1"),
        (["--labels", "0"], "argument --labels: must be >= 1, got 0"),
        (["--learner-zip", "x.zip"], "--learner-zip x.zip is read with --shipped-failures only"),
        (["--variants", ","], "nothing to screen: --variants ',' --seeds '0'"),
        (["--shipped-failures", "--learner-zip", "/nowhere/x.zip"], "--learner-zip: no high-level policy at "),
        (["--out", "/proc/nope/x.json"], "--out /proc/nope/x.json: cannot write there ("),
    ],
)
def test_planner_check_refuses_bad_input_in_one_line(capsys, argv, message):
    assert refused(capsys, argv).startswith(message)


def test_planner_check_refuses_another_bodys_learner_and_a_size_with_no_selection_part(capsys):
    point = str(Path(__file__).parents[1] / "antmaze_hirl" / "learners" / "point_plan.zip")
    line = refused(capsys, ["--shipped-failures", "--body", "ant", "--learner-zip", point])
    assert line.endswith(f"--learner-zip {point}: its cells are 1.0 m, the ant's are 4.0 m (another body's learner)")
    line = refused(capsys, ["--body", "point", "--selection-sizes", "3"])
    assert line.startswith("--selection-sizes 3: no layout in split 'selection'")


def test_every_planner_check_option_states_its_default(capsys):
    with pytest.raises(SystemExit):
        planner_check.main(["--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    for option in ("--body", "--variants", "--seeds", "--labels", "--steps", "--tasks", "--maps", "--out"):
        assert f"{option} " in help_text
    assert help_text.count("(default: ") == 12  # every option but --help


ENDS = {
    "command": "python scripts/planner_check.py --body ant --shipped-failures --maps u --tasks 2",
    "body": "ant",
    "tasks": 2,
    "rows": {
        "selection": {"tasks": 2, "ends": {"success": 2}, "ends_on_paths_of_7_cells_or_more": {"success": 0}},
        "u": {
            "tasks": 2,
            "ends": {"success": 1},
            "ends_on_paths_of_7_cells_or_more": {},
            "suite_task_ends": ["success"],
        },
    },
}


def report(**fields):
    """A benchmark report of the shipped ant learner on ``u`` (one task, two episodes), then ``fields``."""
    episodes = [{"task_id": 0, "seed": 0, "success": True, "flipped": False}] * 2
    base = {
        "format": "antmaze_hirl.benchmark_result/1",
        "suite": "u",
        "body": "ant",
        "seed": 0,
        "episodes_per_task": 2,
        "tasks": [{"task_id": 0}],
        "episode_outcomes": episodes,
        "command": "antmaze-hirl benchmark u --policy planner --episodes-per-task 2 --seed 0",
    }
    return base | fields


def tables(tmp_path, capsys, table, *files):
    """``planning_tables``' exit status and its output (stdout, or the error line), ``files`` written to tmp."""
    paths = []
    for index, data in enumerate(files):
        path = tmp_path / f"f{index}.json"
        path.write_text(json.dumps(data) if not isinstance(data, str) else data)
        paths.append(str(path))
    status = planning_tables.main([table, *paths])
    out, err = capsys.readouterr()
    return status, (out if status == 0 else err.strip()), paths


def test_the_tasks_table_pairs_an_ends_file_with_the_reports_of_its_run(tmp_path, capsys):
    status, out, _ = tables(tmp_path, capsys, "tasks", ENDS, report())
    assert status == 0 and out.splitlines()[-1] == "| `u` | 0 | success | 2/2 | 0 |"


@pytest.mark.parametrize(
    ("other", "message"),
    [
        (report(body="point"), "{1} is a point report, {0} holds ant rollouts"),
        (report(suite="medium"), "{1} scores suite 'medium', {0} rolled out u"),
        (report(tasks=[{}, {}]), "{1} has 2 tasks of 'u', {0} rolled out 1"),
        (report(command="antmaze-hirl benchmark u --policy mine.zip"), "{1} scored --policy mine.zip, {0} rolled out "),
        (report(seed=1), "{2} has seed 1, {1} 0 (one run's reports)"),
        (report(episodes_per_task=5), "{2} has episodes_per_task 5, {1} 2 (one run's reports)"),
        (report(), "{1} and {2} both score suite 'u' (one report a suite)"),
    ],
)
def test_the_tasks_table_refuses_files_that_do_not_belong_together(tmp_path, capsys, other, message):
    files = [ENDS, other] if "{2}" not in message else [ENDS, report(), other]
    status, err, paths = tables(tmp_path, capsys, "tasks", *files)
    assert status == 2 and err.startswith("error: " + message.format(*paths)), err


def test_the_tasks_table_reads_the_learner_an_ends_file_scored(tmp_path, capsys):
    zipped = ENDS | {"command": ENDS["command"] + " --learner-zip runs/gate.zip"}
    status, err, paths = tables(tmp_path, capsys, "tasks", zipped, report())
    assert (status, err) == (
        2,
        f"error: {paths[1]} scored --policy planner, {paths[0]} rolled out the runs/gate.zip learner",
    )
    mine = report(command="antmaze-hirl benchmark u --policy runs/gate.zip")
    assert tables(tmp_path, capsys, "tasks", zipped, mine)[0] == 0
    recorded = ENDS | {"learner": "runs/gate.zip"}  # planner_check records it since the lab split
    assert tables(tmp_path, capsys, "tasks", recorded, mine)[0] == 0


def trial(**fields):
    """A DAgger trial file of ``scripts/learner_ablation.py`` (point, CNN, seed 0), then ``fields``."""
    rate = {"rate": 0.5, "wilson_95": [0.3, 0.7]}
    base = {"variant": "next_cell_cnn", "seed": 0, "body": "point", "labels": 800, "trial_seconds": 600}
    return base | {"untrained_selection_success": rate, "selection_success": rate} | fields


def test_the_trials_table_refuses_two_bodies_and_two_files_of_one_trial(tmp_path, capsys):
    status, out, _ = tables(tmp_path, capsys, "trials", trial(), trial(seed=1), trial(variant="next_cell_gate"))
    assert status == 0 and len(out.splitlines()) == 5  # header, rule, three trials
    # The table has no body column: a point and an ant trial would print rows that differ in nothing.
    status, err, paths = tables(tmp_path, capsys, "trials", trial(), trial(body="ant"))
    assert (status, err) == (2, f"error: {paths[1]} is the ant's trial, {paths[0]} the point's (one body a table)")
    status, err, paths = tables(tmp_path, capsys, "trials", trial(), trial(seed=1), trial(labels=900))
    assert (status, err) == (
        2,
        f"error: {paths[0]} and {paths[2]} are both variant next_cell_cnn seed 0 (one file a trial)",
    )


def test_the_screen_table_gives_one_seeds_rates_with_their_interval_and_several_seeds_their_range(tmp_path, capsys):
    def row(variant, seed, selection):
        parts = {"untrained_selection": 0.0, "selection": selection, "selection_6x6": selection - 0.1}
        return {"variant": variant, "seed": seed, "labels": 300} | {
            name: {"success": success, "tasks": 100} for name, success in parts.items()
        }

    screen = {"command": "python scripts/planner_check.py", "rows": [row("a", 0, 0.9), row("b", 0, 0.5)]}
    screen["rows"].append(row("b", 1, 0.7))
    status, out, _ = tables(tmp_path, capsys, "screen", screen)
    assert status == 0
    a, b, blank, note = out.splitlines()[2:]
    # One seed: a range of one value says nothing; 90 of 100 tasks has a Wilson interval of 83-94%.
    assert a == "| `a` | 0 | 300 | 0/100 (0%) [0, 4] | 90/100 (90%) [83, 94] | 80/100 (80%) [71, 87] |"
    assert b == "| `b` | 0,1 | 300 | 0% (0-0) | 60% (50-70) | 50% (40-60) |"
    # Both kinds in one column: the table says which statistic each kind of row shows.
    assert blank == "" and note.startswith("One-seed rows give that seed's tasks solved with a Wilson 95% interval")
    screen["rows"].remove(row("a", 0, 0.9))
    status, out, _ = tables(tmp_path, capsys, "screen", screen)
    assert status == 0 and len(out.splitlines()) == 3  # one kind of row: no note


def test_a_planning_table_refuses_a_file_it_does_not_read_in_one_line(tmp_path, capsys):
    screen = {"command": "python scripts/planner_check.py", "rows": [{"variant": "next_cell_plan", "seed": 0}]}
    status, err, paths = tables(tmp_path, capsys, "ends", screen)
    assert (status, err) == (2, f"error: {paths[0]} is of kind 'screen'; ends reads 'ends' files here")
    status, err, paths = tables(tmp_path, capsys, "screen", ENDS)
    assert (status, err) == (2, f"error: {paths[0]} is of kind 'ends'; screen reads 'screen' files here")
    status, err, paths = tables(tmp_path, capsys, "ends", ENDS, ENDS)
    assert (status, err) == (2, f"error: ends reads one ends file, got 2: {paths[0]} {paths[1]}")
    status, err, paths = tables(tmp_path, capsys, "tasks", ENDS)
    assert (status, err) == (2, f"error: tasks reads an ends file and at least one benchmark report, got {paths[0]}")
    status, err, paths = tables(tmp_path, capsys, "ends", "{not json")
    assert status == 2 and err.startswith(f"error: {paths[0]} is not JSON: ")
    assert planning_tables.main(["ends", str(tmp_path / "missing.json")]) == 2
    assert capsys.readouterr().err == f"error: {tmp_path / 'missing.json'}: no such file\n"
    assert planning_tables.main(["ends", str(tmp_path)]) == 2  # a folder: named, no traceback
    assert capsys.readouterr().err == f"error: {tmp_path}: Is a directory\n"
    (tmp_path / "binary.json").write_bytes(b"\xc2\x00\xff")
    assert planning_tables.main(["ends", str(tmp_path / "binary.json")]) == 2
    assert capsys.readouterr().err == f"error: {tmp_path / 'binary.json'} is not a text (JSON) file\n"
    broken = {"rows": {"u": {"ends": {"success": 1}}}}  # an ends file without its other fields
    status, err, paths = tables(tmp_path, capsys, "ends", broken)
    assert status == 2 and err.startswith(f"error: {paths[0]}: a field is missing or malformed (KeyError(")


def test_the_planning_tables_positionals_say_they_are_required(capsys):
    with pytest.raises(SystemExit):
        planning_tables.main(["--help"])
    assert " ".join(capsys.readouterr().out.split()).count("(required)") == 2


def scored(suite, policy, successes, budget=None):
    """A benchmark report of ``policy`` on ``suite``: ``successes`` of 100 episodes, a submission at ``budget``."""
    fields = {"suite": suite, "policy": policy, "successes": successes, "episodes": 100}
    fields["success_rate"] = successes / 100
    if budget is not None:
        fields["submission"] = {"budget": budget, "seed": 0}
    return report(**fields)


def test_the_labels_table_sets_each_budget_beside_the_suites_oracle(tmp_path, capsys):
    files = [
        scored("u", "oracle", 80),
        scored("u", "learner.zip (zero-shot: trained on 6x6 maps)", 60, "1000 oracle labels (DAgger)"),
        scored("u", "learner.zip (zero-shot: trained on 6x6 maps)", 40, "100 oracle labels (DAgger)"),
        scored("ant4", "oracle", 100),
        scored("ant4", "learner.zip", 50, "100 oracle labels (DAgger)"),
    ]
    status, out, _ = tables(tmp_path, capsys, "labels", *files)
    assert status == 0
    header, _, u_row, ant4_row = out.splitlines()
    assert header == "| suite | oracle | 100 labels | 1,000 labels |"
    assert u_row.startswith("| `u` | 80/100 (80%) [71, 87] | 40/100 (40%) [31, 50]: 0.50x zero-shot | 60/100 (60%)")
    assert u_row.endswith(": 0.75x zero-shot |")
    assert ant4_row.endswith("50/100 (50%) [40, 60]: 0.50x |  |")  # no zero-shot on its own family; no 1,000 row


@pytest.mark.parametrize(
    ("files", "message"),
    [
        ([scored("u", "learner.zip", 60, "100 oracle labels (DAgger)")], "no oracle report of suite(s) u"),
        ([scored("u", "oracle", 80), scored("u", "oracle", 81)], "two oracle reports of suite 'u'"),
        ([scored("u", "oracle", 80), scored("u", "a.zip", 1, "200k steps")], "u: a.zip has no label budget"),
        (
            [scored("u", "oracle", 80)] + [scored("u", "a.zip", 1, "100 oracle labels (DAgger)")] * 2,
            "two reports of suite 'u' at 100 labels",
        ),
    ],
)
def test_the_labels_table_refuses_reports_it_cannot_set_side_by_side(tmp_path, capsys, files, message):
    status, err, _ = tables(tmp_path, capsys, "labels", *files)
    assert status == 2 and err.startswith("error: " + message), err


def seed_ends(*per_place, body="ant", tasks=10):
    """An ends file of ``planner_check.py --shipped-failures``: per place (selection, then ``selection_8x8``),
    its (success, into_wall, stay, past_corner, timeout) counts of ``tasks``."""
    rows = {}
    for place, counts in zip(("selection", "selection_8x8"), per_place, strict=False):
        ends = dict(zip(("success", "into_wall", "stay", "past_corner", "timeout"), counts, strict=True))
        rows[place] = {"tasks": tasks, "ends": ends, "ends_on_paths_of_7_cells_or_more": {}}
    return {"command": "python scripts/planner_check.py --shipped-failures", "body": body, "tasks": tasks, "rows": rows}


def seed_tables(tmp_path, capsys, *labelled):
    """``planning_tables ends-seeds``' exit status, output (or error line) and files, from (label, file) pairs.

    A file given as an int ``k`` is the ``k``-th pair's file again, spelt another way (``sub/../``)."""
    arguments, paths = [], []
    (tmp_path / "sub").mkdir(exist_ok=True)
    for index, (label, data) in enumerate(labelled):
        path = (
            tmp_path / "sub" / ".." / Path(paths[data]).name if isinstance(data, int) else tmp_path / f"s{index}.json"
        )
        if not isinstance(data, int):
            path.write_text(json.dumps(data))
        arguments.append(f"{label}={path}")
        paths.append(str(path))
    status = planning_tables.main(["ends-seeds", *arguments])
    out, err = capsys.readouterr()
    return status, (out if status == 0 else err.strip()), paths


def test_the_ends_seeds_table_gives_each_seeds_ends_and_each_learners_medians(tmp_path, capsys):
    files = [
        ("switch:0 (ninth look)", seed_ends((9, 1, 0, 10, 0), (6, 3, 0, 1, 10), tasks=20)),
        ("switch:1", seed_ends((3, 0, 1, 2, 14), (8, 1, 0, 0, 11), tasks=20)),
        ("switch:2", seed_ends((7, 5, 0, 0, 8), (2, 8, 0, 0, 10), tasks=20)),
        ("plan:0", seed_ends((5, 5, 0, 0, 10), (4, 6, 0, 0, 10), tasks=20)),
        ("plan:1", seed_ends((6, 3, 0, 1, 10), (1, 9, 0, 0, 10), tasks=20)),
    ]
    status, out, _ = seed_tables(tmp_path, capsys, *files)
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == "| learner | seed | selection part, 20 tasks | `selection_8x8` (zero-shot), 20 tasks |"
    assert (
        lines[2] == "| `switch` | 0 (ninth look) | 9 / 1 (0, 10, 0) | 6 / 3 (0, 1, 10) |"
    )  # stay, past corner, timeout
    assert lines[3] == "| `switch` | 1 | 3 / 0 (1, 2, 14) | 8 / 1 (0, 0, 11) |"
    # Medians, neither means nor one seed's row: success 7 of (9, 3, 7) and 6 of (6, 8, 2), into a wall 1 of
    # (1, 0, 5) and 3 of (3, 1, 8); the means would be 6.3, 5.3, 2 and 4.
    assert lines[5] == "| `switch` | **median** | **7 / 1** | **6 / 3** |"
    # Two seeds: the median is half-way, and a learner's median reads its own seeds only.
    assert lines[6:9] == [
        "| `plan` | 0 | 5 / 5 (0, 0, 10) | 4 / 6 (0, 0, 10) |",
        "| `plan` | 1 | 6 / 3 (0, 1, 10) | 1 / 9 (0, 0, 10) |",
        "| `plan` | **median** | **5.5 / 4** | **2.5 / 7.5** |",
    ]
    assert lines[9] == "" and lines[10].startswith("Each cell: success / into a wall (stay, past a corner, timeout)")
    assert len(lines) == 11


ONE = seed_ends((1, 0, 0, 0, 0))


@pytest.mark.parametrize(
    ("labelled", "message"),
    [
        ([("switch", ONE)], "ends-seeds reads LEARNER:SEED=FILE arguments, got 'switch={0}'"),
        ([(":0", ONE)], "ends-seeds reads LEARNER:SEED=FILE arguments, got ':0={0}'"),
        ([("switch:", ONE)], "ends-seeds reads LEARNER:SEED=FILE arguments, got 'switch:={0}'"),
        ([("switch:0", ONE)] * 2, "{0} and {1} are both learner switch seed 0 (one file a seed)"),
        ([("switch :0", ONE), (" switch: 0 ", ONE)], "{0} and {1} are both learner switch seed 0 (one file a seed)"),
        ([("switch:0", ONE), ("switch:1", 0)], "{0} is given twice (as switch:0 and switch:1; one file a seed)"),
        ([("switch:0", ONE), ("plan:0", 0)], "{0} is given twice (as switch:0 and plan:0; one file a seed)"),
        (
            [("switch:0", ONE), ("plan:0", seed_ends((1, 0, 0, 0, 0), body="point"))],
            "{1} rolled out point: selection 10; {0} ant: selection 10 (one body, places and tasks a table)",
        ),
        ([("switch:0", ONE), ("plan:0", seed_ends((1, 0, 0, 0, 0), tasks=20))], "{1} rolled out ant: selection 20; "),
        (
            [("switch:0", ONE), ("plan:0", seed_ends((1, 0, 0, 0, 0), (1, 0, 0, 0, 0)))],
            "{1} rolled out ant: selection 10, selection_8x8 10; {0} ant: selection 10 (",
        ),
        ([("switch:0", {"rows": [{"variant": "a"}]})], "{0} is of kind 'screen'; ends-seeds reads 'ends' files"),
        ([("switch:0", {"body": "ant", "rows": {"u": {"tasks": 1, "ends": {}}}})], "switch:0={0}: a field is missing"),
    ],
)
def test_the_ends_seeds_table_refuses_bad_labels_and_files_not_rolled_out_alike(tmp_path, capsys, labelled, message):
    status, err, paths = seed_tables(tmp_path, capsys, *labelled)
    assert status == 2 and err.startswith("error: " + message.format(*paths)), err
    assert len(err.splitlines()) == 1
