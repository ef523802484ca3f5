"""The package's import graph is a DAG whose bottom is ``envs``, and the light entry points stay light."""

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

from antmaze_hirl.registration import ENV_IDS

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "antmaze_hirl"

# Bottom up. A module may import its own unit (package or root module) and any unit of a lower layer, never
# one of its own layer or above, not even inside a function. The root package's __init__ is the top.
LAYERS = (
    ("_lazy", "atomic_io", "cli_validation"),
    ("envs",),
    # Playing episodes needs only the envs; its own layer lets every layer above play through it.
    ("rollout",),
    ("experts", "sb3_ext"),
    ("plotting", "registration"),
    ("dagger",),
    # The study kit runs the experiment protocol, so it sits on top of it.
    ("experiments",),
    ("study",),
    ("demo",),
    ("cli", "__init__"),
)
LAYER = {unit: index for index, units in enumerate(LAYERS) for unit in units}
HEAVY = ("torch", "stable_baselines3", "tensorboard")


def unit_of(module: str) -> str:
    """``antmaze_hirl.envs.reach`` -> ``envs``; the root package itself -> ``__init__``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """Every ``antmaze_hirl`` module that ``path`` imports, at any depth (functions, TYPE_CHECKING blocks)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module is not None and node.level == 0:
            if node.module == "antmaze_hirl":  # `from antmaze_hirl import atomic_io` names the unit imported
                found += [(node.lineno, f"antmaze_hirl.{alias.name}") for alias in node.names]
            else:
                found.append((node.lineno, node.module))
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            found.append((node.lineno, "<relative import>"))
    return [(line, name) for line, name in found if name.split(".")[0] == "antmaze_hirl" or name.startswith("<")]


def package_modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_every_unit_of_the_package_has_a_layer():
    units = {unit_of(".".join(path.relative_to(ROOT).with_suffix("").parts)) for path in package_modules()}
    assert units <= set(LAYER), f"give these a layer in LAYERS: {sorted(units - set(LAYER))}"


@pytest.mark.parametrize("path", package_modules(), ids=lambda path: str(path.relative_to(PACKAGE)))
def test_no_module_imports_its_own_layer_or_above(path):
    own = unit_of(".".join(path.relative_to(ROOT).with_suffix("").parts))
    for line, name in imported_modules(path):
        assert name != "<relative import>", f"{path.name}:{line}: use absolute imports"
        other = unit_of(name)
        assert other == own or LAYER[other] < LAYER[own], (
            f"{path.relative_to(ROOT)}:{line} imports {name}: layer of {other!r} is not below {own!r}"
        )


def test_the_checker_sees_imports_inside_functions(tmp_path):
    source = tmp_path / "m.py"
    source.write_text("def f():\n    from antmaze_hirl.sb3_ext.loading import load_low_level\n")
    assert imported_modules(source) == [(2, "antmaze_hirl.sb3_ext.loading")]


def test_registered_entry_points_lie_below_the_registration():
    for entry_point, _ in ENV_IDS.values():
        module = entry_point.split(":")[0]
        assert LAYER[unit_of(module)] < LAYER["registration"], entry_point


def run_fresh(code: str) -> subprocess.CompletedProcess:
    """Runs ``code`` in a fresh interpreter that imports this checkout's package."""
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)


def test_import_and_reach_envs_and_the_parser_load_neither_torch_nor_sb3():
    result = run_fresh(
        "import sys, gymnasium as gym, antmaze_hirl, antmaze_hirl.cli\n"
        "print(antmaze_hirl.__file__)\n"
        "for env_id in ('antmaze_hirl/PointReach-v0', 'antmaze_hirl/AntReach-v0'):\n"
        "    gym.make(env_id).reset(seed=0)\n"
        "antmaze_hirl.cli.build_parser()\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
        "from antmaze_hirl import HierarchicalAgent\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    location, light, after_export = result.stdout.splitlines()
    assert Path(location).is_relative_to(PACKAGE)
    assert light == "[]"
    assert after_export != "[]"  # the check can see torch: the lazy export did load it
    # gymnasium-robotics was imported (the reach envs are built on it) without its AdroitHand notice.
    assert "AdroitHand" not in result.stderr


def test_root_exports_resolve_lazily_and_are_listed():
    import antmaze_hirl
    from antmaze_hirl.dagger.agent import HierarchicalAgent

    assert antmaze_hirl.HierarchicalAgent is HierarchicalAgent
    assert set(antmaze_hirl.__all__) <= set(dir(antmaze_hirl))
    with pytest.raises(AttributeError, match="has no attribute 'Nope'"):
        _ = antmaze_hirl.Nope


@pytest.mark.parametrize("package", ["antmaze_hirl.envs", "antmaze_hirl.sb3_ext", "antmaze_hirl.experiments"])
def test_a_lazy_package_lists_exactly_its_exports(package):
    module = importlib.import_module(package)
    assert module.__all__ == list(module._EXPORTS)
    assert set(module.__all__) <= set(dir(module))
