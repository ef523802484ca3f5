"""scripts/results_tables.py: the results pages' tables, read from the committed JSON files."""

import json
import re
from pathlib import Path

import pytest
from script_helpers import load_script

results_tables = load_script("scripts/results_tables.py")


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
        "new": {"families": {f: in_maze_family(97, flips=2) for f in results_tables.FAMILIES}},
        "old": {"families": {f: in_maze_family(90, flips=5, timeouts=1) for f in results_tables.FAMILIES}},
    }
    (tmp_path / "in_maze" / "tiny.json").write_text(json.dumps({"results": rows}))
    monkeypatch.setattr(results_tables, "RESULTS", tmp_path)
    monkeypatch.setattr(results_tables, "LOADED", [])
    return tmp_path


def test_a_rate_carries_its_wilson_interval_in_percent():
    assert results_tables.rate_cell(185, 200) == "92.5% [88.0, 95.4]"
    assert results_tables.rate_cell(97, 100) == "97% [91.5, 99.0]"
    assert results_tables.rate_cell_of(0.94, 50) == "94% [83.8, 97.9]"
    with pytest.raises(results_tables.ResultsFileError, match=r"a success rate of 0.333 is no whole count of 200"):
        results_tables.count(0.333, 200)


def test_the_pair_table_prints_each_rows_figures_from_the_file(tiny_results):
    text = results_tables.in_maze_pair("in_maze/tiny.json", "new", "old", "stage 6", "stage 5")
    header, rule, *rows = text.splitlines()
    assert header.startswith("| family | stage 6 [95% Wilson] | flips, frozen, timeouts |")
    assert rule == "|" + "---|" * 12
    ant4 = rows[1].split(" | ")
    assert ant4[:4] == ["| ant4 (4x4 held-out layouts, 500 steps)", "97% [91.5, 99.0]", "2, 0, 0", "0.20%"]
    assert ant4[5] == "90% [82.6, 94.5]" and ant4[9] == "1.08" and ant4[-1] == ">= 95%: met |"
    assert rows[-1].startswith("| all 500 episodes |  | 10 flips | 0.20-0.20% |")


def test_a_damaged_results_file_is_a_one_line_error_naming_it(tiny_results, capsys):
    (tiny_results / "in_maze" / "in_maze.json").write_text('{"results": {"shipped": ')
    assert results_tables.main(["in-maze-stage6"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert error.startswith("error: results/in_maze/in_maze.json is not JSON: ")


def test_a_missing_file_or_field_is_a_one_line_error_naming_the_file(tiny_results, capsys):
    assert results_tables.main(["in-maze-tilt"]) == 2
    assert capsys.readouterr().err == "error: results/in_maze/in_maze_tilt.json: no such results file\n"
    data = json.loads((tiny_results / "in_maze" / "tiny.json").read_text())
    del data["results"]["new"]["families"]["u"]["successes"]
    (tiny_results / "in_maze" / "in_maze.json").write_text(json.dumps({"results": {"shipped": data["results"]["new"]}}))
    with pytest.raises(results_tables.ResultsFileError, match=r"results/in_maze/in_maze.json: no field \['results'\]"):
        results_tables.in_maze_pair("in_maze/in_maze.json", "shipped", "runs/device/stage5.zip", "a", "b")
    results_tables.LOADED.clear()
    (tiny_results / "in_maze" / "in_maze.json").write_text(
        json.dumps({"results": {"shipped": data["results"]["new"], "runs/device/stage5.zip": data["results"]["old"]}})
    )
    assert results_tables.main(["in-maze-stage6"]) == 2
    assert capsys.readouterr().err == "error: no field 'successes' in results/in_maze/in_maze.json\n"


@pytest.mark.parametrize("section", list(results_tables.SECTIONS))
def test_every_section_prints_a_table_from_the_committed_files(section, capsys):
    assert results_tables.main([section]) == 0
    assert "|---|" in capsys.readouterr().out


def test_an_unknown_section_is_refused_naming_it(capsys):
    with pytest.raises(SystemExit):
        results_tables.main(["in-maze-stage7"])
    assert "invalid choice: 'in-maze-stage7'" in capsys.readouterr().err


def test_the_headline_rows_are_one_table_whose_links_resolve_from_the_readme_and_the_results_page():
    root = Path(results_tables.__file__).resolve().parent.parent
    docs, readme = results_tables.headline(), results_tables.headline(links_from=".")
    link = re.compile(r"\]\(([^)]+)\)")
    assert link.sub("]()", docs) == link.sub("]()", readme)
    for text, base in ((docs, root / "docs" / "results"), (readme, root)):
        targets = link.findall(text)
        assert len(targets) == len(text.splitlines()) - 2
        assert all((base / target).is_file() for target in targets), targets


def test_an_in_maze_familys_misses_name_each_way_it_failed():
    family = in_maze_family(90, flips=7, timeouts=1) | {"frozen": 2}
    assert results_tables.misses(family) == "7 flips, 2 frozen, 1 timeout"
    assert results_tables.misses(in_maze_family(100, flips=0)) == ""
