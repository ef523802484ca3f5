"""The lab's results tables (``antmaze_lab.tables`` and its page modules), read from the committed JSON files."""

import importlib
import json
import re
from pathlib import Path

import pytest

from antmaze_lab import headline, in_maze_tables, tables
from antmaze_lab.commands import command_arguments, recorded_command

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab's results tables): the integration tier

SECTIONS = tables.all_sections()
"""Every section, with the page module that prints it."""


def print_section(section):
    """The exit status of the section's command (``python -m MODULE SECTION``)."""
    return SECTIONS[section].main([section])


def in_maze_family(successes, flips=1, timeouts=0):
    return {
        "episodes": 100,
        "successes": successes,
        "success_rate": successes / 100,
        "flips": flips,
        "frozen": 0,
        "timeouts": timeouts,
        "subgoals": 1000,
        "flips_per_subgoal": flips / 1000,
        "mean_low_level_steps": 200.0,
        "seconds": 40.0,
    }


@pytest.fixture
def tiny_results(tmp_path, monkeypatch):
    """A results/ folder with one in-maze file of two rows: ``new`` 97 of 100 per family, ``old`` 90."""
    (tmp_path / "in_maze").mkdir()
    rows = {
        "new": {"families": {f: in_maze_family(97, flips=2) for f in in_maze_tables.FAMILIES}},
        "old": {"families": {f: in_maze_family(90, flips=5, timeouts=1) for f in in_maze_tables.FAMILIES}},
    }
    (tmp_path / "in_maze" / "tiny.json").write_text(json.dumps({"results": rows}))
    monkeypatch.setattr(tables, "RESULTS", tmp_path)
    monkeypatch.setattr(tables, "LOADED", [])
    return tmp_path


def test_a_rate_carries_its_wilson_interval_in_percent():
    assert tables.rate_cell(185, 200) == "92.5% [88.0, 95.4]"
    assert tables.rate_cell(97, 100) == "97% [91.5, 99.0]"
    assert tables.rate_cell_of(0.94, 50) == "94% [83.8, 97.9]"
    with pytest.raises(tables.ResultsFileError, match=r"a success rate of 0.333 is no whole count of 200"):
        tables.count(0.333, 200)


def test_the_pair_table_prints_each_rows_figures_from_the_file(tiny_results):
    text = in_maze_tables.in_maze_pair("in_maze/tiny.json", "new", "old", "stage 6", "stage 5")
    header, rule, *rows = text.splitlines()
    assert header.startswith("| family | stage 6 [95% Wilson] | flips, frozen, timeouts |")
    assert rule == "|" + "---|" * 12
    ant4 = rows[1].split(" | ")
    assert ant4[:4] == ["| ant4 (4x4 held-out layouts, 500 steps)", "97% [91.5, 99.0]", "2, 0, 0", "0.20%"]
    assert ant4[5] == "90% [82.6, 94.5]" and ant4[9] == "1.08" and ant4[-1] == ">= 95%: met |"
    assert rows[-1].startswith("| all 500 episodes |  | 10 flips | 0.20-0.20% |")


def test_a_damaged_results_file_is_a_one_line_error_naming_it(tiny_results, capsys):
    (tiny_results / "in_maze" / "in_maze.json").write_text('{"results": {"shipped": ')
    assert print_section("in-maze-stage6") == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert error.startswith("error: results/in_maze/in_maze.json is not JSON: ")


def test_a_missing_file_or_field_is_a_one_line_error_naming_the_file(tiny_results, capsys):
    assert print_section("in-maze-tilt") == 2
    assert capsys.readouterr().err == "error: results/in_maze/in_maze_tilt.json: no such results file\n"
    data = json.loads((tiny_results / "in_maze" / "tiny.json").read_text())
    del data["results"]["new"]["families"]["u"]["successes"]
    (tiny_results / "in_maze" / "in_maze.json").write_text(json.dumps({"results": {"shipped": data["results"]["new"]}}))
    with pytest.raises(tables.ResultsFileError, match=r"results/in_maze/in_maze.json: no field \['results'\]"):
        in_maze_tables.in_maze_pair("in_maze/in_maze.json", "shipped", "runs/device/stage5.zip", "a", "b")
    tables.LOADED.clear()
    (tiny_results / "in_maze" / "in_maze.json").write_text(
        json.dumps({"results": {"shipped": data["results"]["new"], "runs/device/stage5.zip": data["results"]["old"]}})
    )
    assert print_section("in-maze-stage6") == 2
    assert capsys.readouterr().err == "error: no field 'successes' in results/in_maze/in_maze.json\n"


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize("section", list(SECTIONS))
def test_every_section_prints_a_table_from_the_committed_files(section, capsys):
    assert print_section(section) == 0
    assert "|---|" in capsys.readouterr().out


def test_an_unknown_section_is_refused_naming_it(capsys):
    with pytest.raises(SystemExit):
        in_maze_tables.main(["in-maze-stage7"])
    assert "invalid choice: 'in-maze-stage7'" in capsys.readouterr().err


@pytest.mark.integration  # reads the committed results
def test_the_headline_rows_are_one_table_whose_links_resolve_from_the_readme_and_the_results_page():
    root = Path(tables.__file__).resolve().parent.parent
    docs, readme = headline.headline(), headline.headline(links_from=".")
    link = re.compile(r"\]\(([^)]+)\)")
    assert link.sub("]()", docs) == link.sub("]()", readme)
    for text, base in ((docs, root / "docs" / "results"), (readme, root)):
        targets = link.findall(text)
        assert len(targets) == len(text.splitlines()) - 2
        assert all((base / target).is_file() for target in targets), targets


def test_an_in_maze_familys_misses_name_each_way_it_failed():
    family = in_maze_family(90, flips=7, timeouts=1) | {"frozen": 2}
    assert headline.misses(family) == "7 flips, 2 frozen, 1 timeout"
    assert headline.misses(in_maze_family(100, flips=0)) == ""


GUIDE_FIGURES = {
    "lockstep-agreement": "| ant (3x3) | learner (20 DAgger episodes) | 100 | 69 | 5 | 62 / 65 | 152.0 | 31.6 |",
    "hierarchy-throughput": "no thread setting fell below 0.77x of the other (the widest gap: the ant's lockstep env "
    "at N = 4, 126 steps/s at 1 thread against 164 at 2): the goal of no thread setting below 0.50x of the best holds",
    "lockstep-paths": "| `eval-low` | point | 200 | 200 | 200 | 200 / 200 | 0.67x (slower) |",
    "high-level-ppo": "| `antmaze_hirl/PointMaze-v0` | 256 | 12.89 | 49.13 | 8 | 3.81x |",
    "paper-trial-speed": "The goal of <= 5 min per ant trial is **missed** (CPU, scaled: 14.2 min serial, 9.8 min",
    "ensemble-speed": "| 7 | 851 us | 523 us | 1.63x (>= 1.5x: met) | 1.33x |",
    "untrained-learners": "| 0/30 and 2/30; 1/30 and 0/30 | 0/10, 0/10 | 2/30: 21.3% | 0/10: 27.8% | yes, yes |",
    "learner-selection": "| ant | `next_cell_cnn` | 1 of 100: 1% [0.2, 5.4] | 39 and 36 | 0.75 | 278 |",
    "ray-sweep": "Serial over Ray: 0.83x for the grid alone, 0.70x with the start-up.",
    "steady-ant-maps": "| `giant` | `ensemble: TD3 8ae38455d9435335` | 79% [70.0, 85.8] | 19 / 131,033 | 1.45 [0.87, "
    "2.26] |",
    "steady-ant-in-maze": "| `large`, 100 mazes | `results/steady_ant/student_d1_iter00199.zip`: "
    "`sha256:0b2c0b6ba1af66bc` | 91% [83.8, 95.2] | 9 / 55,170 | 1.63 [0.75, 3.10] |",
    "steady-ant-eval-low": "| `sha256:0b2c0b6ba1af66bc` | 93.0% [88.6, 95.8] | 91.0% [86.2, 94.2] | "
    "93.5% [89.2, 96.2] | 93.0% [88.6, 95.8] | 741 of 800: 92.6% [90.6, 94.2] |",
}
"""One line each guide's section prints from the committed files, as the guides quote it."""


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize(("section", "line"), list(GUIDE_FIGURES.items()))
def test_each_guide_section_prints_its_figures_from_the_committed_files(section, line, capsys):
    assert print_section(section) == 0
    assert line in capsys.readouterr().out


def without(data, keys):
    """``data`` with the field at ``keys`` (dict keys or list indices, the last one deleted) removed."""
    *path, last = keys
    parent = data
    for key in path:
        parent = parent[key]
    if isinstance(last, dict):  # a row of a list picked by its fields
        parent.remove(next(row for row in parent if last.items() <= row.items()))
    else:
        del parent[last]
    return data


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize(
    ("section", "name", "keys", "error"),
    [
        (
            "lockstep-agreement",
            "lockstep_agreement/lockstep_agreement.json",
            ["rows", 1, "same_success"],
            "no field 'same_success' in results/lockstep_agreement/lockstep_agreement.json",
        ),
        (
            "hierarchy-throughput",
            "hierarchy_throughput/hierarchy_throughput.json",
            ["raw_baselines"],
            "results/hierarchy_throughput/hierarchy_throughput.json: no field ['raw_baselines']",
        ),
        (
            "hierarchy-throughput",
            "hierarchy_throughput/hierarchy_throughput.json",
            ["rows", {"body": "ant", "mode": "lockstep", "num_envs": 16, "torch_threads": 2}],
            "results/hierarchy_throughput/hierarchy_throughput.json: no row for ant, lockstep, N = 16, 2 torch threads",
        ),
        (
            "lockstep-paths",
            "lockstep_paths/lockstep_paths.json",
            ["rows", 4, "speedup"],
            "no field 'speedup' in results/lockstep_paths/lockstep_paths.json",
        ),
        (
            "high-level-ppo",
            "high_level_ppo/high_level_ppo.json",
            ["ratio"],
            "results/high_level_ppo/high_level_ppo.json: no field ['ratio']",
        ),
        (
            "paper-trial-speed",
            "paper_trial_speed/paper_trial_speed.json",
            ["goal_full_trial_s"],
            "results/paper_trial_speed/paper_trial_speed.json: no field ['goal_full_trial_s']",
        ),
        (
            "ensemble-speed",
            "ensemble_speed/ensemble_speed.json",
            ["median_microseconds"],
            "results/ensemble_speed/ensemble_speed.json: no field ['median_microseconds']",
        ),
        (
            "untrained-learners",
            "untrained_learners/untrained_learners_ant.json",
            ["by_variant", "next_cell_cnn"],
            "results/untrained_learners/untrained_learners_ant.json: no field ['by_variant']['next_cell_cnn']",
        ),
        (
            "learner-selection",
            "learner_ablation/learner_selection_ant.json",
            ["variants", "heading_cnn", "untrained_selection_successes"],
            "no field 'untrained_selection_successes' in results/learner_ablation/learner_selection_point.json, "
            "results/learner_ablation/learner_selection_ant.json",
        ),
        (
            "protocol2-goals",
            "protocol2/ant/summary.json",
            ["oracle_success"],
            "results/protocol2/ant/summary.json: no field ['oracle_success']",
        ),
        (
            "ray-sweep",
            "sweep_scaling/sweep_scaling.json",
            ["machine"],
            "results/sweep_scaling/sweep_scaling.json: no field ['machine']",
        ),
        (
            "steady-ant-maps",
            "steady_ant/summary.json",
            ["benchmark", 1, "candidate", "flips"],
            "no field 'flips' in results/steady_ant/summary.json",
        ),
    ],
)
def test_a_guide_section_missing_a_field_is_a_one_line_error_naming_it(
    section, name, keys, error, tmp_path, monkeypatch, capsys
):
    assert print_section(section) == 0
    capsys.readouterr()
    for loaded in set(tables.LOADED):  # the section's files, copied into a results/ of its own
        (tmp_path / loaded).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / loaded).write_text((tables.RESULTS / loaded).read_text())
    damaged = tmp_path / name
    damaged.write_text(json.dumps(without(json.loads(damaged.read_text()), keys)))
    monkeypatch.setattr(tables, "RESULTS", tmp_path)
    assert print_section(section) == 2
    assert capsys.readouterr().err == f"error: {error}\n"


LAB_MARKER = re.compile(r"^<!-- generated: python -m (antmaze_lab\.\w+) (?!-)(\S+)", re.MULTILINE)


def test_every_generated_block_of_a_page_module_names_one_of_its_sections():
    # The pages are read, not the results: a block renamed or moved to another module fails here, in the unit tier.
    root = Path(tables.__file__).resolve().parent.parent
    pages = [root / "README.md", *sorted((root / "docs").rglob("*.md"))]
    named = [(page.name, *found) for page in pages for found in LAB_MARKER.findall(page.read_text())]
    table_modules = {module: importlib.import_module(module).SECTIONS for module in tables.TABLE_MODULES}
    checked = [(page, module, section) for page, module, section in named if module in table_modules]
    assert len(checked) >= 36, checked
    for page, module, section in checked:
        assert section in table_modules[module], f"{page}: {module} has no section {section!r}"
    assert len(SECTIONS) == sum(len(sections) for sections in table_modules.values())  # no section in two modules


def write_results(root, name, data):
    (root / name).parent.mkdir(parents=True, exist_ok=True)
    (root / name).write_text(json.dumps(data))


def test_the_smoothing_table_lists_the_rows_the_sweeps_wrote(tmp_path, monkeypatch):
    # The inventory is the results folder: a new distance file is a new row, with no list in the lab to edit.
    monkeypatch.setattr(tables, "RESULTS", tmp_path)
    write_results(
        tmp_path,
        in_maze_tables.SMOOTHING,
        {"expert_max_distance": 2.0, "results": {"shipped": {}, "shipped smoothing=0.5": {}}},
    )
    for distance_m in (3.0, 1.5, 12.0):
        write_results(
            tmp_path,
            f"in_maze/in_maze_distance_{distance_m:g}.json",
            {"expert_max_distance": distance_m, "results": {"shipped": {}}},
        )
    rows = in_maze_tables.smoothing_rows()
    assert [row.label for row in rows] == ["2 m, none (stage 2)", "2 m, 0.5", "1.5 m, none", "3 m, none", "12 m, none"]
    assert [row.row for row in rows] == ["shipped", "shipped smoothing=0.5", "shipped", "shipped", "shipped"]
    assert rows[-1].file == "in_maze/in_maze_distance_12.json"


def test_a_selection_table_lists_the_rows_its_run_scored(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, "RESULTS", tmp_path)
    name = "select_low_level/merged.json"
    scores = {"old.zip": {}, "b/snapshots/step_5000.zip": {}, "a/snapshots/step_7000.zip": {}}
    command = "python scripts/select_low_level.py b/snapshots/step_5000.zip a/snapshots/step_7000.zip --mazes 100"
    write_results(tmp_path, name, {"command": command, "scores": scores})
    # A merged file scored more rows than its last run: the command names that run's own.
    assert in_maze_tables.run_policies(name) == ["b/snapshots/step_5000.zip", "a/snapshots/step_7000.zip"]
    # A run since the lab split records the module it ran; the same options give the same rows.
    moved = "python -m antmaze_lab.select_low_level b/snapshots/step_5000.zip --mazes 100"
    write_results(tmp_path, "select_low_level/new.json", {"command": moved, "scores": scores})
    assert in_maze_tables.run_policies("select_low_level/new.json") == ["b/snapshots/step_5000.zip"]
    assert in_maze_tables.scored_rows(name, str.upper) == [(key.upper(), key) for key in scores]
    ensembles = [
        in_maze_tables.ensemble_label(key) for key in (in_maze_tables.STAGE4, "train_runs/ensembles/t750_s3.zip")
    ]
    assert ensembles == ["stage 4 (tilt 750k alone)|1", "t750 + s3|2"]


def test_an_in_maze_row_is_the_policy_its_run_was_given(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, "RESULTS", tmp_path)
    command = "python scripts/in_maze.py --low-level /elsewhere/step_5000.zip --action-smoothing 0,0.5 --out x.json"
    write_results(tmp_path, "in_maze/f.json", {"command": command})
    row = in_maze_tables.trained_row("late", "in_maze/f.json", "0.5")
    assert row == in_maze_tables.InMazeRow("late", "in_maze/f.json", "/elsewhere/step_5000.zip smoothing=0.5")
    assert in_maze_tables.trained_row("plain", "in_maze/f.json").row == "/elsewhere/step_5000.zip"


def test_a_lab_run_records_a_command_whose_options_read_back(tmp_path):
    command = recorded_command("antmaze_lab.in_maze", ["--low-level", "a b.zip", "--out", str(tmp_path / "x.json")])
    assert command.startswith("python -m antmaze_lab.in_maze --low-level 'a b.zip' --out ")
    assert command_arguments(command) == ["--low-level", "a b.zip", "--out", str(tmp_path / "x.json")]
    assert command_arguments("python scripts/in_maze.py --episodes 10") == ["--episodes", "10"]  # before the move
    with pytest.raises(ValueError, match=r"^not a recorded run command .*: 'antmaze-hirl eval-low --seed 0'$"):
        command_arguments("antmaze-hirl eval-low --seed 0")


def steady_row(successes, episodes, flips=1, steps=10_000, **extra):
    rate = flips * 10_000 / steps
    return {
        "successes": successes,
        "episodes": episodes,
        "flips": flips,
        "low_level_steps": steps,
        "flips_per_10k_steps": rate,
        "flips_per_10k_steps_ci95": [rate / 2, rate * 2],
        **extra,
    }


def test_the_steady_ant_tables_order_the_suites_say_k_and_pool_eval_low(tmp_path, monkeypatch):
    from antmaze_lab import low_level_tables

    monkeypatch.setattr(tables, "RESULTS", tmp_path)

    def pair(suite, per_task, candidate):
        return {
            "suite": suite,
            "episodes_per_task": per_task,
            "tasks": "all",
            "ensemble": steady_row(90, 100, file=f"{suite}_e.json", low_level="ensemble"),
            "candidate": steady_row(candidate, 100, file=f"{suite}_c.json", low_level="student"),
        }

    in_maze = {
        family: {
            "ensemble": steady_row(48, 50, name="shipped", low_level_id="e"),
            "candidate": steady_row(49, 50, name="s.zip", low_level_id="c"),
        }
        for family in ("ant3", "large")
    }
    sets = [
        {"seed": seed, "episodes": 200, "ensemble": {"successes": 180}, "candidate": {"successes": hits}}
        for seed, hits in ((0, 190), (200, 186))
    ]
    for side in ("ensemble", "candidate"):
        sets[0][side]["low_level_id"] = side
    pooled = {"ensemble": {"successes": 360, "episodes": 400}, "candidate": {"successes": 376, "episodes": 400}}
    write_results(
        tmp_path,
        "steady_ant/s.json",
        {
            "benchmark": [pair("giant", 20, 80), pair("ant4", 1, 97)],
            "in_maze": {"families": in_maze},
            "eval_low": {"sets": sets, "pooled": pooled},
        },
    )
    write_results(tmp_path, "steady_ant/old.json", {"benchmark": [pair("large", 20, 91)], "in_maze": None})
    names = ["steady_ant/old.json", "steady_ant/s.json"]
    maps = low_level_tables.steady_ant_maps(names).splitlines()[2:]
    assert [line.split(" | ")[0] for line in maps] == ["| `ant4` (K = 1)"] * 2 + ["| `large`"] * 2 + ["| `giant`"] * 2
    assert "| 97% [" in maps[1]
    in_maze_lines = low_level_tables.steady_ant_in_maze(names).splitlines()[2:]
    assert [line.split(" | ")[:2] for line in in_maze_lines] == [
        ["| `ant3`, 50 mazes", "`shipped`: `e`"],
        ["| `ant3`, 50 mazes", "`s.zip`: `c`"],
        ["| `large`, 50 mazes", "`shipped`: `e`"],
        ["| `large`, 50 mazes", "`s.zip`: `c`"],
    ]
    eval_low = low_level_tables.steady_ant_eval_low(names).splitlines()
    assert eval_low[0] == "| low level | seed 0 (200) | seed 200 (200) | pooled |"
    assert eval_low[3] == "| `candidate` | 95.0% [91.0, 97.3] | 93.0% [88.6, 95.8] | 376 of 400: 94.0% [91.2, 95.9] |"
