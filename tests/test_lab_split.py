"""The library and the lab apart: ``antmaze_hirl`` never imports the lab, its wheel holds no lab module, and the
unit tier reads no committed results (the lab's data; its checks run in the integration tier)."""

import ast
import importlib.util
import os
import shutil
import subprocess
import sys
import zipfile
from itertools import pairwise
from pathlib import Path
from types import SimpleNamespace

import pytest
from conftest import (
    COMMITTED_RESULTS,
    LAB_CODE,
    UNIT_TIER_GUARD,
    marked_out_whole,
    marks_out,
    pytest_ignore_collect,
    selects_a_test_marked,
    whole_file_marks,
)

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "antmaze_hirl"
LAB = ("scripts", "antmaze_lab", "benchmarks")
"""The lab's top-level packages and folders: the paper's runners, reports and speed tools."""


LOADERS = ("import_module", "__import__", "spec_from_file_location", "run_path", "load_script")
"""The calls that import or load a module by name or by path (``load_script``: the tests' loader of scripts)."""


def _text(node: ast.AST) -> str | None:
    """A string constant's text, or an f-string's leading text (``f"antmaze_lab.{name}"``: ``antmaze_lab.``)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0], ast.Constant):
        return str(node.values[0].value)
    return None


def lab_imports(source: Path | ast.AST) -> list[tuple[int, str]]:
    """Each import of a lab module in ``source`` (a file or a parsed node), at any depth: import statements,
    ``importlib.import_module`` / ``__import__`` / ``spec_from_file_location`` / ``run_path`` / ``load_script``
    calls whose strings name one (by module or by path), and command lines that run one (``[..., "-m",
    "antmaze_lab.x"]`` or ``["python", "scripts/x.py"]``)."""
    tree = ast.parse(source.read_text(), filename=str(source)) if isinstance(source, Path) else source
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module is not None and node.level == 0:
            found.append((node.lineno, node.module))
        elif isinstance(node, ast.Call):
            called = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            texts = [text for arg in node.args if (text := _text(arg)) is not None]
            if called in LOADERS and texts:
                found += [(node.lineno, text.replace("/", ".").removesuffix(".py")) for text in texts]
        elif isinstance(node, (ast.List, ast.Tuple)):
            texts = [_text(element) or "" for element in node.elts]
            run = [
                after
                for before, after in pairwise(["", *texts])
                if before == "-m" or ("/" in after and " " not in after)
            ]
            found += [(node.lineno, text.replace("/", ".")) for text in run]
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


def test_the_unit_tier_refuses_to_run_the_lab_however_it_is_reached(tmp_path):
    # The static scan below parses the forms it knows; the guard sees the lab's code when it runs, whatever led
    # there: here a helper module outside the lab that imports it, and a load by path under a name of our own.
    if not UNIT_TIER_GUARD:
        pytest.skip("the guard is on in the unit tier only (-m 'not integration')")
    assert set(LAB_CODE) == {str(ROOT / folder) + "/" for folder in LAB}
    helper = tmp_path / "indirect_helper.py"
    helper.write_text("import importlib\nNAME = 'antmaze_' + 'lab.preregistered'\nimportlib.import_module(NAME)\n")
    spec = importlib.util.spec_from_file_location("indirect_helper", helper)
    with pytest.raises(ImportError, match=r"^the unit tier runs none of the lab's code: .*antmaze_lab.*; mark the"):
        spec.loader.exec_module(importlib.util.module_from_spec(spec))
    spec = importlib.util.spec_from_file_location("renamed", ROOT / "benchmarks" / "trial_speed.py")
    with pytest.raises(ImportError, match=r"benchmarks.trial_speed\.py; mark the test integration"):
        spec.loader.exec_module(importlib.util.module_from_spec(spec))
    assert not [name for name in sys.modules if name.split(".")[0] in LAB]
    with pytest.raises(ImportError, match=r"^the unit tier runs none of the lab's code: -c 'import antmaze_lab'; mark"):
        subprocess.run([sys.executable, "-c", "import antmaze_lab"], capture_output=True, timeout=60)  # no hook there
    # A bytes path names a file as a str does.
    with pytest.raises(PermissionError, match=r"^the unit tier reads no committed results: .*index\.json; mark the"):
        open(str(Path(COMMITTED_RESULTS) / "index.json").encode(), "rb")


@pytest.mark.parametrize(
    ("command", "cwd", "refused", "named"),
    [
        (["-c", "import antmaze_lab"], None, ImportError, r"-c 'import antmaze_lab'"),
        (["-c", "from scripts import no_such"], None, ImportError, r"-c 'from scripts import no_such'"),
        (["-m", "antmaze_" + "lab.no_such"], None, ImportError, r"-m antmaze_lab\.no_such"),
        (["-Im", "benchmarks.no_such"], None, ImportError, r"-m benchmarks\.no_such"),
        (["-mscripts.no_such"], None, ImportError, r"-m scripts\.no_such"),
        ([ROOT / "benchmarks" / "no_such.py"], None, ImportError, r".*benchmarks.no_such\.py"),
        ([b"scripts/no_such.py"], ROOT, ImportError, r".*scripts.no_such\.py"),
        (["no_such.py"], ROOT / "benchmarks", ImportError, r".*benchmarks.no_such\.py"),  # the cwd given
        (["-c", "open('results/index.json')"], ROOT, PermissionError, r"-c \"open\('results/index\.json'\)\""),
        (
            ["-c", f"open({COMMITTED_RESULTS + 'index.json'!r})"],
            "/",
            PermissionError,
            r"-c \"open\('/.*/index\.json'\)\"",
        ),
    ],
    ids=["c-import", "c-from", "m", "m-joined", "m-attached", "pathlike", "bytes", "cwd", "c-results", "c-absolute"],
)
def test_the_unit_tier_refuses_a_command_line_that_runs_the_lab_or_reads_the_results(command, cwd, refused, named):
    # A child process runs without this process's audit hook: its command line is judged before it starts. The
    # names are ones that do not exist, so that a guard that let one through fails fast.
    if not UNIT_TIER_GUARD:
        pytest.skip("the guard is on in the unit tier only (-m 'not integration')")
    kind = "runs none of the lab's code" if refused is ImportError else "reads no committed results"
    with pytest.raises(refused, match=rf"^the unit tier {kind}: {named}; mark the test integration"):
        subprocess.run([sys.executable, *command], cwd=cwd, capture_output=True, timeout=60)


def test_the_unit_tier_refuses_a_shell_command_that_names_the_lab():
    if not UNIT_TIER_GUARD:
        pytest.skip("the guard is on in the unit tier only (-m 'not integration')")
    lab = r"^the unit tier runs none of the lab's code: -c 'python scripts/no_such\.py'; mark"
    with pytest.raises(ImportError, match=lab):
        subprocess.run("python scripts/no_such.py", shell=True, cwd=ROOT, capture_output=True, timeout=60)
    results = r"^the unit tier reads no committed results: -c 'cat results/index\.json >/dev/null'; mark"
    with pytest.raises(PermissionError, match=results):
        os.system("cat results/index.json >/dev/null")
    # Other commands run, from the checkout too: the package, a path that only contains a lab folder's name.
    ok = [sys.executable, "-c", "import antmaze_hirl, sys; print(sys.argv[1:])", "docs/scripts/results", "-m", "x"]
    assert subprocess.run(ok, cwd=ROOT, capture_output=True, text=True, timeout=120, check=True).stdout.strip()


def unit_tier_lab_imports(path: Path) -> list[tuple[int, str]]:
    """Each import of a lab module (:func:`lab_imports`) in the test module ``path`` that the unit tier runs: none
    where a module-level ``pytestmark`` marks the whole file integration or slow; else each outside the top-level
    tests and classes that are so marked (module-level code and fixtures run for every test of the file)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    if marked_out_whole(tree):
        return []
    found = []
    for node in tree.body:
        definition = isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
        if not (definition and any(marks_out(decorator) for decorator in node.decorator_list)):
            found += lab_imports(node)
    return found


def test_the_unit_tier_never_imports_the_lab(tmp_path):
    # The lab's checks run in the integration tier (CONTRIBUTING.md): a unit-tier test that imports antmaze_lab or
    # loads a script of scripts/ or benchmarks/ is marked integration. First the scan itself, on a crafted module.
    crafted = tmp_path / "test_crafted.py"
    crafted.write_text(
        "import pytest\n"
        "COMMAND = [sys.executable, '-m', 'antmaze_lab.in_maze']\n"
        "def test_unit(name):\n"
        "    importlib.import_module(f'antmaze_lab.{name}')\n"
        "    load_script('benchmarks/trial_speed.py')\n"
        "@pytest.mark.parametrize('x', [pytest.param(1, marks=pytest.mark.integration)])\n"
        "def test_one_case_marked(x):\n"
        "    from antmaze_lab import tables\n"
        "@pytest.mark.integration  # a lab check\n"
        "def test_lab():\n"
        "    from antmaze_lab import tables\n"
        "@pytest.mark.slow(reason='long')\n"
        "class TestLab:\n"
        "    def test_run(self):\n"
        "        subprocess.run(['python', 'scripts/in_maze.py'])\n"
    )
    assert [line for line, _ in unit_tier_lab_imports(crafted)] == [2, 4, 5, 8]
    crafted.write_text("import pytest\nfrom antmaze_lab import tables\npytestmark = [pytest.mark.integration]\n")
    assert unit_tier_lab_imports(crafted) == []

    found = {
        path.name: lines
        for path in sorted(Path(__file__).parent.glob("*.py"))
        if (lines := unit_tier_lab_imports(path))
    }
    assert not found, f"unit-tier tests import the lab (line, module): {found}; mark them integration"


@pytest.mark.parametrize(
    ("source", "markexpr", "imported"),
    [
        ("pytestmark = pytest.mark.integration", "not slow and not integration", False),
        ("pytestmark = [pytest.mark.slow]", "not slow and not integration", False),
        ("pytestmark = pytest.mark.integration", "integration or slow", True),
        ("pytestmark = pytest.mark.slow", "not integration", True),  # a run that keeps the slow tier
        ("pytestmark = [pytest.mark.integration, pytest.mark.slow]", "not slow", False),
        ("pytestmark = [pytest.mark.integration, pytest.mark.slow]", "integration and not slow", False),
        ("pytestmark = pytest.mark.integration", "not gpu", True),
        ("pytestmark = pytest.mark.integration", "", True),
        ("x = [pytest.param(1, marks=pytest.mark.integration)]", "not integration", True),  # one case, not the file
        ("@pytest.mark.integration\ndef test_one():\n    pass", "not integration", True),  # one test, not the file
        # pytest reads pytestmark as the module holds it after import: a file that binds it more than once, or
        # other than by one top-level assignment, is imported and pytest decides.
        ("pytestmark = pytest.mark.integration\npytestmark = []", "not integration", True),
        ("pytestmark = []\npytestmark = pytest.mark.integration", "not integration", True),
        ("if True:\n    pytestmark = pytest.mark.integration", "not integration", True),
        ("try:\n    pytestmark = pytest.mark.integration\nexcept ImportError:\n    pass", "not integration", True),
        ("def f():\n    global pytestmark\n    pytestmark = pytest.mark.integration", "not integration", True),
        ("pytestmark = [pytest.mark.integration]\npytestmark += [pytest.mark.slow]", "not integration", True),
        ("pytestmark: list = [pytest.mark.integration]", "not integration", True),
        ("pytestmark = [pytest.mark.integration]\npytestmark.clear()", "not integration", True),
        ("pytestmark = pytest.mark.integration\nglobals()['pytestmark'] = []", "not integration", True),
        ("pytestmark = other = pytest.mark.integration", "not integration", False),  # one binding, two names
    ],
)
def test_a_file_is_left_unimported_only_where_the_marker_expression_selects_none_of_its_tests(
    source, markexpr, imported
):
    # pytest_ignore_collect's decision: a file not imported must be one whose every test -m deselects, so that
    # no test is dropped from any tier (CI runs "not slow and not integration", then "integration or slow").
    markers = whole_file_marks(ast.parse("import pytest\n" + source))
    assert (not markers or selects_a_test_marked(markexpr, markers)) is imported


@pytest.mark.parametrize(
    "source",
    [
        b"import pytest\npytestmark = pytest.mark.integration\ndef test_x(:\n",
        b"# -*- coding: no-such-codec -*-\nimport pytest\npytestmark = pytest.mark.integration\n",
        b"import pytest\npytestmark = pytest.mark.integration\nNAME = '\xff'\n",  # not UTF-8
        b"import pytest\x00\n",
    ],
    ids=["syntax", "codec", "bytes", "null"],
)
def test_a_file_that_does_not_parse_is_left_to_pytest(tmp_path, source):
    # pytest imports it and reports the file's own collection error; an error raised from the hook fails the
    # collection of the whole folder instead (no test of it is collected).
    path = tmp_path / "test_broken.py"
    path.write_bytes(source)
    config = SimpleNamespace(getoption={"markexpr": "not slow and not integration"}.get)
    assert pytest_ignore_collect(path, config) is None
