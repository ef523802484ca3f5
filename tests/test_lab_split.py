"""The library and the lab apart: ``antmaze_hirl`` never imports the lab, its wheel holds no lab module, and the
unit tier reads no committed results (the lab's data; its checks run in the integration tier)."""

import ast
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from conftest import COMMITTED_RESULTS, UNIT_TIER_GUARD

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "antmaze_hirl"
LAB = ("scripts", "antmaze_lab", "benchmarks")
"""The lab's top-level packages and folders: the paper's runners, reports and speed tools."""


def lab_imports(path: Path) -> list[tuple[int, str]]:
    """Each import of a lab module in ``path``, at any depth: import statements, and ``importlib.import_module`` /
    ``__import__`` / ``spec_from_file_location`` calls whose first string names one (by module or by path)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module is not None and node.level == 0:
            found.append((node.lineno, node.module))
        elif isinstance(node, ast.Call):
            called = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            texts = [arg.value for arg in node.args if isinstance(arg, ast.Constant) and isinstance(arg.value, str)]
            if called in ("import_module", "__import__", "spec_from_file_location", "run_path") and texts:
                found += [(node.lineno, text.replace("/", ".").removesuffix(".py")) for text in texts]
    return [(line, name) for line, name in found if name.split(".")[0] in LAB]


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda path: str(path.relative_to(PACKAGE)))
def test_the_library_never_imports_the_lab(path):
    found = lab_imports(path)
    assert not found, f"{path.relative_to(ROOT)} imports the lab: {found} (the lab is a client of the package)"


def test_the_scan_sees_imports_inside_functions_and_by_name_or_path(tmp_path):
    source = tmp_path / "m.py"
    source.write_text(
        "import importlib\n"
        "def f():\n"
        "    from antmaze_lab.preregistration import x\n"
        "    import scripts.paper_tables\n"
        "    importlib.import_module('benchmarks.trial_speed')\n"
        "    importlib.util.spec_from_file_location('t', 'scripts/results_tables.py')\n"
        "    from antmaze_hirl.experiments import config\n"
    )
    assert [line for line, _ in lab_imports(source)] == [3, 4, 5, 6]


@pytest.mark.integration  # builds the wheel (about a minute)
def test_the_wheel_holds_the_package_and_no_lab_module(tmp_path):
    # Built from a copy of the checkout (setuptools builds in the source tree), without the results and the docs.
    skipped = (".git", ".venv*", ".hypothesis", ".*cache", "__pycache__", "*.egg-info", "build", "dist", "runs")
    heavy = shutil.ignore_patterns(*skipped, "results", "docs")
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=heavy)
    pip = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(tmp_path)]
    subprocess.run([*pip, str(source)], check=True, capture_output=True, timeout=600)
    (wheel,) = tmp_path.glob("antmaze_hirl-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    top = {name.split("/")[0] for name in names}
    assert top == {"antmaze_hirl", next(name for name in top if name.endswith(".dist-info"))}, sorted(top)
    assert "antmaze_hirl/cli.py" in names and "antmaze_hirl/policies/ant_td3.zip" in names
    assert not [name for name in names if set(Path(name).parts) & set(LAB)]


def test_the_unit_tier_refuses_to_read_the_committed_results():
    if not UNIT_TIER_GUARD:
        pytest.skip("the guard is on in the unit tier only (-m 'not integration')")
    with pytest.raises(PermissionError, match=r"^the unit tier reads no committed results: .*index\.json; mark the"):
        (Path(COMMITTED_RESULTS) / "index.json").read_text()
    assert (ROOT / "pyproject.toml").read_text()  # the rest of the checkout reads as ever
