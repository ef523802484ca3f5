"""PEP 562 lazy exports: a package names what it exports, and a name's module is imported on first use.

Importing ``antmaze_hirl`` or ``antmaze_hirl.sb3_ext`` must not pull in torch and Stable-Baselines3
(seconds of start-up for a plain registration or ``--help``), so these packages resolve their exports
only when one is asked for.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(
    package: str, exports: Mapping[str, str], eager: Mapping[str, Any]
) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """A package's ``__getattr__``, ``__dir__`` and ``__all__``, importing each export's module on first access.

    Args:
        package: The package's ``__name__`` (for the error message).
        exports: ``name -> module`` that defines ``name``.
        eager: The package's own globals (what ``dir()`` lists besides the exports); the resolved value
            is cached there, so the import happens once.

    Returns:
        ``(__getattr__, __dir__, __all__)`` to assign in the package's ``__init__``; ``__all__`` lists
        ``exports``' names in their order (a package that also exports names it defines itself adds those).
    """

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        eager[name] = value  # later lookups find a plain global, without calling __getattr__ again
        return value

    def __dir__() -> list[str]:
        return sorted({*eager, *exports})

    return __getattr__, __dir__, list(exports)
