import ast
import copy
import dataclasses
import functools
import itertools
import os
import re
import shlex
import sys
from collections import OrderedDict
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl import PathOracle
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.old_folders import SETTINGS_BEFORE_PROTOCOL_2

# torch, SB3 and the trainer are imported where they are used, not here: pytest-xdist's controller imports this
# file too, and runs no test, so their imports (seconds of CPU) would only delay the workers' start.


@pytest.fixture(scope="session", autouse=True)
def one_torch_thread():
    """One torch thread in every process that runs tests: small networks gain nothing from two, and results stay
    the same on every machine."""
    import torch

    torch.set_num_threads(1)


_ROOT = Path(__file__).resolve().parents[1]
COMMITTED_RESULTS = str(_ROOT / "results") + os.sep
"""The lab's committed results, which the unit tier never reads (its checks are integration tests)."""
LAB_PACKAGES = ("antmaze_lab", "scripts", "benchmarks")
"""The lab's top-level packages and folders, which the unit tier never runs (CONTRIBUTING.md)."""
LAB_CODE = tuple(str(_ROOT / folder) + os.sep for folder in LAB_PACKAGES)
"""The lab's code, which the unit tier never runs: its checks are integration tests (CONTRIBUTING.md)."""
UNIT_TIER_GUARD = False
"""Whether this run refuses to open a file under :data:`COMMITTED_RESULTS` or to run the lab's code
(:data:`LAB_CODE`), in this process or through a command line it starts: a run that leaves out integration."""

_MARK_INTEGRATION = "; mark the test integration (pyproject.toml)"
_COMMAND_LINES = {
    # audit event: (executable, argv, cwd) from its arguments (the Python docs' audit events table)
    "subprocess.Popen": lambda args: (args[0], args[1], args[2]),
    "os.system": lambda args: ("/bin/sh", ["/bin/sh", "-c", args[0]], None),
    "os.posix_spawn": lambda args: (args[0], args[1], None),
    "os.exec": lambda args: (args[0], args[1], None),
    "os.spawn": lambda args: (args[1], args[2], None),
}


def _refused_path(text: str, cwd: str, named: str | None = None) -> Exception | None:
    """The error for a path (relative ones to ``cwd``) under the results or the lab's code, the folders themselves
    too; ``named`` is what the message names (default: the path)."""
    path = os.path.abspath(os.path.join(cwd, text))
    if (path + os.sep).startswith(COMMITTED_RESULTS):
        return PermissionError(f"the unit tier reads no committed results: {named or path}{_MARK_INTEGRATION}")
    if (path + os.sep).startswith(LAB_CODE):
        return ImportError(f"the unit tier runs none of the lab's code: {named or path}{_MARK_INTEGRATION}")
    return None


def _refused_code(code: str, cwd: str) -> Exception | None:
    """The error for a ``-c`` string (Python's or a shell's) that names the lab or the results: ``antmaze_lab``
    anywhere, an import of ``scripts``/``benchmarks``, or a quoted string or shell word that is such a path."""
    named = f"-c {code[:120]!r}"
    if "antmaze_lab" in code or re.search(r"\b(?:import|from)\s+(?:scripts|benchmarks)\b", code):
        return ImportError(f"the unit tier runs none of the lab's code: {named}{_MARK_INTEGRATION}")
    try:
        words = shlex.split(code)
    except ValueError:  # Python code is seldom a balanced shell line
        words = []
    quoted = [match.group(2) for match in re.finditer(r"(['\"])(.*?)\1", code)]
    absolute = [folder for folder in (COMMITTED_RESULTS, *LAB_CODE) if folder.rstrip(os.sep) in code]
    for text in [*absolute, *quoted, *words]:
        if refusal := _refused_path(text, cwd, named):
            return refusal
    return None


def _interpreter_options(argv: list[str]):
    """Each ``-m``/``-c`` option of a command line and its value, joined (``-mname``) or in a cluster (``-Im``)."""
    for index, word in enumerate(argv):
        if not word.startswith("-") or word.startswith("--"):
            continue
        for position, letter in enumerate(word[1:], start=2):
            if letter in "WX":  # options whose value may hold an m or a c (-Ximporttime)
                break
            if letter in "mc":
                value = word[position:] or (argv[index + 1] if index + 1 < len(argv) else "")
                yield f"-{letter}", value
                break


def _refused_command(executable, argv, cwd) -> Exception | None:
    """The error for a command line that names the lab or the results: a path among its words (relative ones to
    ``cwd``, else to this process's), ``-m`` with a lab package, or a ``-c`` string as :func:`_refused_code`."""
    cwd = os.getcwd() if cwd is None else os.fsdecode(cwd)
    argv = [argv] if isinstance(argv, (str, bytes, os.PathLike)) else list(argv)
    words = [os.fsdecode(word) for word in (executable, *argv) if isinstance(word, (str, bytes, os.PathLike))]
    for word in words:
        if refusal := _refused_path(word, cwd):
            return refusal
    for option, value in _interpreter_options(words):
        if option == "-m" and value.split(".")[0] in LAB_PACKAGES:
            return ImportError(f"the unit tier runs none of the lab's code: -m {value}{_MARK_INTEGRATION}")
        if option == "-c" and (refusal := _refused_code(value, cwd)):
            return refusal
    return None


def _unit_tier_guard(event, args):
    # An audit hook (sys.addaudithook): open() and its kin raise "open" before they touch the file, and exec()
    # raises "exec" with the code object it runs, which is how every import or path load of a module runs its
    # body. So the guard sees the lab however a test reaches it in this process (an import, importlib by name or
    # path, a helper module that imports it), where the static scan of tests/test_lab_split.py sees only the forms
    # it parses. A child process has no hook: its command line is judged before it starts (subprocess, os.system,
    # os.exec*/spawn*), which refuses a lab path, -m of a lab package, or a -c naming either. What a child does
    # beyond its command line is not seen: a helper module it imports that imports the lab, a console script or
    # a module of the package that loads the lab, a file path the child builds itself, PYTHONPATH/PYTHONSTARTUP
    # in its environment.
    if event == "open" and isinstance(args[0], (str, bytes, os.PathLike)):
        path = os.path.abspath(os.fsdecode(args[0]))
        if path.startswith(COMMITTED_RESULTS):
            raise PermissionError(f"the unit tier reads no committed results: {path}{_MARK_INTEGRATION}")
    elif event == "exec" and str(getattr(args[0], "co_filename", "")).startswith(LAB_CODE):
        raise ImportError(f"the unit tier runs none of the lab's code: {args[0].co_filename}{_MARK_INTEGRATION}")
    elif event in _COMMAND_LINES and (refusal := _refused_command(*_COMMAND_LINES[event](args))):
        raise refusal


def pytest_configure(config):
    global UNIT_TIER_GUARD
    if "not integration" in (config.getoption("markexpr") or "") and not UNIT_TIER_GUARD:
        sys.addaudithook(_unit_tier_guard)  # for the rest of the process: a hook cannot be removed
        UNIT_TIER_GUARD = True


LEFT_OUT = ("integration", "slow")
"""The markers that take a test out of the unit tier (pyproject.toml's addopts)."""


def _left_out_marks(marker: ast.AST) -> set[str]:
    """The :data:`LEFT_OUT` markers that ``marker`` (a decorator, or a ``pytestmark`` value) applies:
    ``pytest.mark.integration`` or ``.slow``, called or not, or a list of markers. A ``pytest.param(...,
    marks=...)`` marks one case, not the test, and is not read."""
    if isinstance(marker, (ast.List, ast.Tuple)):
        return set().union(*(_left_out_marks(element) for element in marker.elts))
    marker = marker.func if isinstance(marker, ast.Call) else marker
    return {marker.attr} if isinstance(marker, ast.Attribute) and marker.attr in LEFT_OUT else set()


def marks_out(marker: ast.AST) -> bool:
    """Whether ``marker`` (a decorator, or a ``pytestmark`` value) takes a test out of the unit tier."""
    return bool(_left_out_marks(marker))


def _names_pytestmark(node: ast.AST) -> bool:
    """Whether ``node`` names ``pytestmark`` in any way the source shows: the name itself (bound, read, deleted or
    declared global), an attribute or import alias of that name, or the string ``"pytestmark"`` (``globals()[...]``,
    ``setattr``)."""
    if isinstance(node, ast.Name):
        return node.id == "pytestmark"
    if isinstance(node, ast.Attribute):
        return node.attr == "pytestmark"
    if isinstance(node, ast.alias):
        return "pytestmark" in (node.name, node.asname)
    if isinstance(node, (ast.Global, ast.Nonlocal)):
        return "pytestmark" in node.names
    return isinstance(node, ast.Constant) and node.value == "pytestmark"


def whole_file_marks(tree: ast.Module) -> frozenset[str]:
    """The :data:`LEFT_OUT` markers a test module's top-level ``pytestmark`` puts on every test of it.

    Read only where the source settles the value pytest will see: pytest reads the module's ``pytestmark`` as it is
    after the import, so the file must name ``pytestmark`` exactly once, as a target of a top-level ``=``
    statement. Any other mention (a second assignment, one inside ``if``/``try``/a function, ``+=``, an annotated
    assignment, a method call on it, ``globals()["pytestmark"]``) gives the empty set: the file is imported and
    pytest decides.
    """
    mentions = [node for node in ast.walk(tree) if _names_pytestmark(node)]
    assignments = [
        node
        for node in tree.body
        if isinstance(node, ast.Assign) and any(_names_pytestmark(target) for target in node.targets)
    ]
    if len(mentions) != 1 or len(assignments) != 1 or not isinstance(mentions[0], ast.Name):
        return frozenset()
    return frozenset(_left_out_marks(assignments[0].value))


def marked_out_whole(tree: ast.Module) -> bool:
    """Whether a test module's top-level ``pytestmark`` takes all of it out of the unit tier."""
    return bool(whole_file_marks(tree))


def selects_a_test_marked(markexpr: str, markers: frozenset[str]) -> bool:
    """Whether the ``-m`` expression ``markexpr`` selects some test marked with all of ``markers``, whatever its
    other marks.

    Tries every set of the other names in the expression, with pytest's own parser of ``-m``; when that cannot be
    imported or read, or the names are too many to try, it answers yes (the file is imported, as pytest would).
    """
    if not markexpr:
        return True
    names = sorted(set(re.findall(r"[\w.+-]+", markexpr)) - {"and", "or", "not", *markers})
    try:
        from _pytest.mark.expression import Expression

        expression = Expression.compile(markexpr)
    except Exception:  # a private module of pytest's: any change there imports every file, as before
        return True
    if len(names) > 12:
        return True
    for values in itertools.product((False, True), repeat=len(names)):
        marks = {*markers, *(name for name, value in zip(names, values, strict=True) if value)}
        if expression.evaluate(functools.partial(_has_mark, frozenset(marks))):
            return True
    return False


def _has_mark(marks: frozenset[str], name: str, /, **kwargs) -> bool:
    return name in marks  # a mark's keyword arguments (-m "name(key=value)") are not read: both answers are tried


def pytest_ignore_collect(collection_path, config):
    # A file whose module-level pytestmark puts every test in a tier that -m leaves out is not imported: each
    # pytest-xdist worker imports every test file it collects, and the lab's checks import the lab's tables, Ray
    # and Playwright, which cost each worker of the unit tier seconds for tests it deselects (and would run the
    # lab's code in a tier that runs none). The marks are read from the source, not by importing it.
    if collection_path.suffix != ".py" or not collection_path.name.startswith("test_"):
        return None
    try:
        tree = ast.parse(collection_path.read_bytes(), filename=str(collection_path))
    except (OSError, SyntaxError, ValueError):  # ValueError: a null byte, before Python 3.12
        return None  # pytest imports it and reports the file's own error; raised here, it fails the whole folder
    markers = whole_file_marks(tree)
    if markers and not selects_a_test_marked(config.getoption("markexpr") or "", markers):
        return True
    return None


COMPILED_MODELS_KEPT = 48
"""MuJoCo models a test process keeps compiled, by XML text (a point maze holds an 11 MiB skybox: ~0.6 GiB)."""
_compile_mujoco_xml = mujoco.MjModel.from_xml_path
_compiled_models: OrderedDict[bytes, mujoco.MjModel] = OrderedDict()


def _copy_of_compiled_model(filename, *args, **kwargs):
    # Tests build the same mazes again and again (seeded layouts, one env per test), and gymnasium-robotics
    # writes each maze's XML to a fresh temp file and compiles it: about a quarter of the unit tier's CPU
    # time went to compiling models it had compiled before. A compile is deterministic, so a copy of the
    # model compiled from the same XML text (mj_copyModel, ~5 ms) is the model a compile returns; each
    # caller gets its own copy, which it may change (the target marker's size, say).
    if args or kwargs:  # assets or a VFS: compiled as asked
        return _compile_mujoco_xml(filename, *args, **kwargs)
    key = Path(filename).read_bytes()
    if any(name in key for name in (b"file=", b"meshdir=", b"texturedir=", b"assetdir=")):
        return _compile_mujoco_xml(filename)  # files named relative to the XML's folder: one text, other models
    model = _compiled_models.pop(key, None)
    if model is None:
        model = _compile_mujoco_xml(filename)
    _compiled_models[key] = model
    while len(_compiled_models) > COMPILED_MODELS_KEPT:
        _compiled_models.popitem(last=False)
    return copy.copy(model)


mujoco.MjModel.from_xml_path = staticmethod(_copy_of_compiled_model)


class StillController:
    """A picklable low-level controller that outputs zero torques (stands in for a trained ant)."""

    def __call__(self, observation):
        return np.zeros(8)


@pytest.fixture
def still_controller():
    return StillController()


def tiny_sac_her(env, learning_starts=100):
    """A small SB3 SAC with HER on a reach env, as a user would bring one (no antmaze_hirl glue)."""
    from stable_baselines3 import SAC, HerReplayBuffer

    return SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        learning_starts=learning_starts,
        batch_size=32,
        policy_kwargs={"net_arch": [32, 32]},
        seed=0,
    )


def point_maze(**kwargs):
    """The tests' small maze: a 3x3 point maze, goal at least 2 cells from the start, the scripted go-to below."""
    settings = {"maze_size": 3, "min_goal_cells": 2, **kwargs}
    return gym.make("antmaze_hirl/PointMaze-v0", low_level=PointGoToController(), **settings)


def make_point_trainer(strategy=None, seed=0, *, env=None, learner=None, policy_settings=None, **kwargs):
    """A DAgger trainer on :func:`point_maze` (or ``env``) with the oracle as expert, seeded by ``seed``.

    ``learner(env, rng)`` builds the learner (default ``HighLevelPolicy.for_env(env, rng=rng, **policy_settings)``);
    the other keyword arguments go to ``DAggerTrainer`` (default ``gradient_steps=5``).
    """
    from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy

    env = env if env is not None else point_maze()
    rng = np.random.default_rng(seed)
    learner = HighLevelPolicy.for_env(env, rng=rng, **(policy_settings or {})) if learner is None else learner(env, rng)
    kwargs = {"gradient_steps": 5, **kwargs}
    return DAggerTrainer(env=env, expert=PathOracle.for_env(env), learner=learner, rng=rng, strategy=strategy, **kwargs)


# The subgoals of ReachEnv("point") at reset(seed=3) and the three plain resets after it, recorded at 0.2.0. A
# feature that is off (probability 0) must draw nothing from the env's stream, or committed figures change.
POINT_SUBGOALS_SEED_3 = [
    [0.51083038, -0.41789375],
    [1.34843411, 0.76218861],
    [-1.16531856, 1.07518948],
    [2.29882936, 0.86257555],
]


def reset_subgoals(env, seed=3, resets=3):
    """``desired_goal`` of ``env.reset(seed=seed)`` and of the ``resets`` plain resets after it."""
    return [env.reset(seed=seed)[0]["desired_goal"]] + [env.reset()[0]["desired_goal"] for _ in range(resets)]


TINY_PROTOCOL1 = ExperimentConfig(
    body="point",
    episodes=3,
    eval_every=2,
    eval_episodes=2,
    final_eval_episodes=3,
    maze_size=3,
    gradient_steps=5,
    **SETTINGS_BEFORE_PROTOCOL_2,
)
"""A protocol-1 experiment small enough for a unit test of the runner (not of the protocol): 3 episodes on 3x3
point mazes held out by seed, evaluated one maze at a time. Tests that need other sizes ``replace`` it."""

TINY_PROTOCOL2 = dataclasses.replace(
    TINY_PROTOCOL1, final_eval_episodes=4, maze_size=4, held_out_layouts=True, protocol=2
)
"""A protocol-2 experiment small enough for a unit test: 3 episodes, 4 held-out 4x4 point mazes per evaluation,
played one after another (evaluation_envs 1: the serial run the lockstep tests compare with)."""


def finished_experiment(tmp_path_factory, name, config, seeds=2, low_level=None):
    """Runs a tiny ``dagger`` experiment into a fresh folder: the folder and its files' bytes (TensorBoard left out).

    ``low_level`` goes to ``run_experiment`` (``None``: the body's shipped policy).
    """
    from antmaze_hirl.experiments import run_experiment

    folder = tmp_path_factory.mktemp(name)
    run_experiment(["dagger"], seeds, config, folder, low_level=low_level, progress_bar=False, tensorboard=False)
    files = {path.name: path.read_bytes() for path in folder.rglob("*") if path.is_file() and "tb" not in path.parts}
    return folder, files


@pytest.fixture(scope="session")
def finished_protocol2(tmp_path_factory):
    """:data:`TINY_PROTOCOL2` run once per session with 2 seeds: the folder and its files' bytes. Read-only:
    a test that writes into it copies it first (:func:`copy_results`)."""
    return finished_experiment(tmp_path_factory, "protocol2", TINY_PROTOCOL2)


def copy_results(source, folder):
    """Copies a results folder's files (TensorBoard left out) into ``folder``."""
    for path in source.rglob("*"):
        if path.is_file() and "tb" not in path.relative_to(source).parts:
            target = folder / path.relative_to(source)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(path.read_bytes())
