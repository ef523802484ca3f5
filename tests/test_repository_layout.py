"""The repository's layout: scripts and benchmarks import only the package, and no test edits ``sys.path``."""

import ast
from pathlib import Path

import pytest
from script_helpers import load_script

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "scripts").glob("*.py")) + sorted((ROOT / "benchmarks").glob("*.py"))
SCRIPT_NAMES = {path.stem for path in SCRIPTS}


def imported_top_names(path: Path) -> list[tuple[int, str]]:
    """The first part of every module ``path`` imports, at any depth, with its line."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name.split(".")[0]) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            found.append((node.lineno, "<relative import>" if node.level else node.module.split(".")[0]))
    return found


@pytest.mark.integration  # a lab check (the scripts' imports)
@pytest.mark.parametrize("path", SCRIPTS, ids=lambda path: str(path.relative_to(ROOT)))
def test_a_script_imports_no_other_script(path):
    # What two scripts share lives in the package, or both are lab modules (antmaze_lab.in_maze_protocol, ...).
    for line, name in imported_top_names(path):
        assert name not in SCRIPT_NAMES and name != "<relative import>", (
            f"{path.relative_to(ROOT)}:{line} imports {name}: move what it needs into antmaze_hirl"
        )
    assert "sys.path" not in path.read_text(), f"{path.relative_to(ROOT)} edits sys.path"


def test_no_test_puts_a_folder_on_sys_path():
    # A test that needs a script's functions loads it by path (script_helpers.load_script) or runs it.
    editing = [
        path.name
        for path in sorted((ROOT / "tests").glob("*.py"))
        if path.name != Path(__file__).name
        and ("sys.path.insert" in path.read_text() or "sys.path.append" in path.read_text())
    ]
    assert editing == []


@pytest.mark.integration  # reads the committed results
def test_the_results_index_matches_the_results_tree():
    results_index = load_script("scripts/results_index.py")
    index = results_index.load_index()
    assert results_index.problems(results_index.RESULTS, index) == []
    assert results_index.replay_problems(index) == []  # every moved entry's options parse under today's module


def full_entry(**fields):
    """An index entry with every field set, then ``fields``."""
    entry = {"command": "python x.py", "committed_in": "abc1234", "made_at": "not recorded", "low_level": "n/a"}
    return entry | {"machine": "not recorded", "supersedes": [], "note": ""} | fields


@pytest.mark.integration  # a lab check (scripts/results_index.py)
def test_the_results_index_check_names_an_unindexed_entry_and_a_removed_one_still_there(tmp_path):
    results_index = load_script("scripts/results_index.py")
    (tmp_path / "in_maze").mkdir()
    (tmp_path / "in_maze" / "in_maze.json").write_text("{}")
    (tmp_path / "in_maze" / "stray.json").write_text("{}")
    gone = {"path": "results/in_maze/gone.json", "commit": "abc1234", "superseded_by": "results/in_maze/in_maze.json"}
    index = {
        "experiments": {"in_maze": {"entries": {"in_maze.json": full_entry(supersedes=["gone.json", "kept.json"])}}},
        "removed": [gone, {"path": "scripts/results_index.py", "commit": "", "superseded_by": "x"}],
    }
    assert results_index.problems(tmp_path, index) == [
        "in_maze/stray.json: on disk, not in results/index.json",
        "scripts/results_index.py: listed as removed, still on disk",
        "scripts/results_index.py: a removed entry needs its commit and what supersedes it",
        "results/in_maze/kept.json: results/in_maze/in_maze.json's supersedes names it, removed does not list it "
        "(a superseded entry leaves the tree, named in both)",
        "scripts/results_index.py: no entry's supersedes names it, removed gives x as superseding it "
        "(a superseded entry leaves the tree, named in both)",
    ]


@pytest.mark.integration  # a lab check (scripts/results_index.py)
@pytest.mark.parametrize("field", ["command", "committed_in", "made_at", "low_level", "machine", "supersedes", "note"])
def test_the_results_index_check_refuses_an_entrys_null_or_missing_field_naming_both(tmp_path, field):
    results_index = load_script("scripts/results_index.py")
    (tmp_path / "in_maze").mkdir()
    (tmp_path / "in_maze" / "in_maze.json").write_text("{}")
    missing = full_entry()
    del missing[field]
    for entry in (full_entry(**{field: None}), missing):
        index = {"experiments": {"in_maze": {"entries": {"in_maze.json": entry}}}, "removed": []}
        assert results_index.problems(tmp_path, index) == [
            f"in_maze/in_maze.json: field {field!r} is missing, null or empty (write 'not recorded' or 'n/a')"
        ]
    # A note may be empty; a fact may not: an unknown one is written "not recorded".
    index = {"experiments": {"in_maze": {"entries": {"in_maze.json": full_entry(machine="")}}}, "removed": []}
    assert results_index.problems(tmp_path, index) == [
        "in_maze/in_maze.json: field 'machine' is missing, null or empty (write 'not recorded' or 'n/a')"
    ]


@pytest.mark.integration  # a lab check (scripts/results_index.py)
def test_a_page_quotes_an_entry_by_path_pattern_or_braces():
    results_index = load_script("scripts/results_index.py")
    assert results_index.expand_braces("a_{x,y}.json") == ["a_x.json", "a_y.json"]
    assert results_index.matches("in_maze/in_maze_*.json", "in_maze/in_maze_stage3.json")
    assert results_index.matches("paper_experiment/ant/summary.json", "paper_experiment/ant")
    assert not results_index.matches("paper_experiment/ant_stage5", "paper_experiment/ant")
    assert results_index.matches("leaderboard", "leaderboard/*.json")


@pytest.mark.integration  # a lab check (scripts/results_index.py)
def test_a_moved_script_replays_as_its_lab_module_and_the_check_names_a_stale_move(tmp_path):
    results_index = load_script("scripts/results_index.py")
    moved = {"scripts/in_maze.py": "antmaze_lab.in_maze"}
    recorded = "python scripts/in_maze.py --low-level 'a b.zip' --episodes 10"
    assert (
        results_index.replay_command(recorded, moved)
        == "python -m antmaze_lab.in_maze --low-level 'a b.zip' --episodes 10"
    )
    assert results_index.replay_command("python scripts/in_maze.py", moved) == "python -m antmaze_lab.in_maze"
    for kept in ("python scripts/paper_experiment.py --seeds 2", "antmaze-hirl eval-low --seed 0", "not recorded"):
        assert results_index.replay_command(kept, moved) == kept
    renamed = {"antmaze_lab.in_maze": {"--subgoal-distance": "--subgoal-reach-m"}}
    prefixed = "OMP_NUM_THREADS=1 nice -n 5 python scripts/in_maze.py --subgoal-distance 3 --out x.json"
    assert results_index.replay_command(prefixed, moved, renamed) == (
        "OMP_NUM_THREADS=1 nice -n 5 python -m antmaze_lab.in_maze --subgoal-reach-m 3 --out x.json"
    )
    assert results_index.replay_command("python scripts/in_maze.py --subgoal-distance=3", moved, renamed) == (
        "python -m antmaze_lab.in_maze --subgoal-reach-m=3"
    )
    index = {"experiments": {}, "removed": [], "moved": moved}
    assert results_index.problems(tmp_path, index) == []
    index["moved"] = {"scripts/results_index.py": "antmaze_lab.nowhere"}
    assert results_index.problems(tmp_path, index) == [
        "scripts/results_index.py: moved to antmaze_lab.nowhere, still on disk (a moved script leaves the tree)",
        "scripts/results_index.py: moved to antmaze_lab.nowhere, which is not a module of this checkout",
    ]


@pytest.mark.integration  # a lab check (scripts/results_index.py)
def test_the_check_parses_each_moved_entrys_replayed_options_with_its_modules_parser():
    results_index = load_script("scripts/results_index.py")
    moved = {"scripts/in_maze.py": "antmaze_lab.in_maze", "benchmarks/flip_warning.py": "antmaze_lab.flip_warning"}
    commands = {
        "renamed.json": "nice -n 5 python scripts/in_maze.py --subgoal-distance 3 --out 'a b.json'",
        "not_renamed.json": "python benchmarks/flip_warning.py --subgoal-distance 3",
        "bad_value.json": "python benchmarks/flip_warning.py --mazes many && echo done",
        "python3.json": "python3 scripts/in_maze.py --episodes 1",
        "not_moved.json": "antmaze-hirl eval-low --seed 0",
    }
    entries = {name: full_entry(command=command) for name, command in commands.items()}
    index = {
        "experiments": {"x": {"entries": entries}},
        "moved": moved,
        "renamed_options": {"antmaze_lab.in_maze": {"--subgoal-distance": "--subgoal-reach-m"}},
    }
    assert results_index.replay_problems(index) == [
        "x/python3.json: its command still names scripts/in_maze.py after replay: "
        "'python3 scripts/in_maze.py --episodes 1'",
        "x/not_renamed.json: its replayed options do not parse under antmaze_lab.flip_warning (unrecognized "
        "arguments: --subgoal-distance 3); map a renamed option in renamed_options",
        "x/bad_value.json: its replayed options do not parse under antmaze_lab.flip_warning (argument --mazes: "
        "invalid int value: 'many'); map a renamed option in renamed_options",
    ]


@pytest.mark.integration  # a lab check (benchmarks/)
def test_benchmarks_holds_only_benchmark_scripts():
    # Results go to results/<experiment>/, configs and research scripts to scripts/ (docs/architecture.md).
    others = sorted(p.name for p in (ROOT / "benchmarks").iterdir() if p.suffix != ".py" and p.name != "__pycache__")
    assert others == [], f"benchmarks/ holds {others}: results belong in results/<experiment>/, the rest in scripts/"
