"""The repository's layout: scripts and benchmarks import only the package, and no test edits ``sys.path``."""

import ast
from pathlib import Path

import pytest

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


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda path: str(path.relative_to(ROOT)))
def test_a_script_imports_no_other_script(path):
    # What two scripts share lives in the package (antmaze_hirl.experiments.in_maze, ...), not in a script.
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
