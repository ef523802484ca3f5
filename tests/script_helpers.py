"""Loads a script of ``scripts/`` or ``benchmarks/`` by its path, so that a test can call its functions.

Scripts are not a package and import only ``antmaze_hirl``: no test puts their folders on ``sys.path``.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def load_script(relative_path: str) -> ModuleType:
    """The module of the script at ``relative_path`` (from the repository root), loaded once per session.

    It is registered in ``sys.modules`` under its file's stem, as ``python scripts/x.py`` would name it
    ``__main__`` and dataclasses and pickling need the module registered.

    Raises:
        FileNotFoundError: If no file is at ``relative_path``.
    """
    path = ROOT / relative_path
    if not path.is_file():
        raise FileNotFoundError(f"no script at {relative_path!r} under {ROOT}")
    name = f"script_{path.stem}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
