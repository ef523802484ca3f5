"""What every results table of the lab shares: reading a committed results file, formatting figures, the command.

Each page module (:data:`TABLE_MODULES`) prints the Markdown tables of one docs page (or of one experiment's
pages) from the committed JSON files under ``results/``, one section per generated block::

    <!-- generated: python -m antmaze_lab.in_maze_tables in-maze-stage6 -->

so every figure of those tables comes from a committed file through a command a reader can rerun; the results
pages' prose names no figure of its own, and a guide's prose names a figure only beside its file. A success
rate measured on a known number of episodes carries its 95% Wilson interval
(:func:`antmaze_hirl.experiments.uncertainty.wilson_interval`). What a row is called (its label, its heads, a
goal it is held to) is written in the page module; what it scored is read from the file.

A missing or damaged file, or a file without a field a section reads, is a one-line error naming the file
(exit status 2). ``python -m antmaze_lab.tables`` lists every module's sections.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from antmaze_hirl.experiments.uncertainty import wilson_interval

TABLE_MODULES = (
    "antmaze_lab.low_level_tables",
    "antmaze_lab.in_maze_tables",
    "antmaze_lab.headline",
    "antmaze_lab.learner_tables",
    "antmaze_lab.other_tables",
    "antmaze_lab.vector_env_tables",
    "antmaze_lab.protocol_tables",
)
"""The page modules whose sections read results files through :func:`load`.

Each has its :class:`Sections` as ``SECTIONS``, and ``main``."""


ROOT = Path(__file__).resolve().parents[1]
"""The repository root (the lab runs from a checkout)."""


RESULTS = ROOT / "results"


class ResultsFileError(ValueError):
    """A results file that is missing, is not JSON, or lacks a field a section reads."""


LOADED: list[str] = []
"""The files read so far in this process (``main`` names them when a field is missing)."""


@dataclass(frozen=True)
class Results:
    """One committed results file: its path under ``results/`` and its parsed JSON."""

    name: str
    data: Any

    def get(self, *keys: str | int) -> Any:
        """The value at ``keys`` (nested dict keys or list indices).

        Raises:
            ResultsFileError: Naming the file and the missing field.
        """
        value = self.data
        for depth, key in enumerate(keys):
            try:
                value = value[key]
            except (KeyError, IndexError, TypeError):
                where = "".join(f"[{k!r}]" for k in keys[: depth + 1])
                raise ResultsFileError(f"results/{self.name}: no field {where}") from None
        return value


def load(name: str, results: Path | None = None) -> Results:
    """The results file ``results/<name>``.

    Raises:
        ResultsFileError: If the file does not exist or is not JSON, naming it.
    """
    path = (results or RESULTS) / name
    LOADED.append(name)
    try:
        return Results(name, json.loads(path.read_text()))
    except FileNotFoundError:
        raise ResultsFileError(f"results/{name}: no such results file") from None
    except json.JSONDecodeError as error:
        raise ResultsFileError(f"results/{name} is not JSON: {error}") from None


def percent(rate: float, trials: int | None = None) -> str:
    """``rate`` in percent: whole on 100 trials or fewer dividing 100, else one decimal."""
    decimals = 0 if trials is not None and trials <= 100 and 100 % trials == 0 else 1
    return f"{100 * rate:.{decimals}f}%"


def count(rate: float, trials: int) -> int:
    """The whole number of successes behind ``rate`` on ``trials``.

    Raises:
        ResultsFileError: If ``rate * trials`` is not a whole number (to 1e-6).
    """
    successes = round(rate * trials)
    if abs(successes - rate * trials) > 1e-6:
        raise ResultsFileError(f"a success rate of {rate} is no whole count of {trials} episodes")
    return successes


def rate_cell(successes: int, trials: int) -> str:
    """``"92.5% [88.0, 95.4]"``: the rate and its 95% Wilson interval, in percent."""
    low, high = wilson_interval(successes, trials)
    return f"{percent(successes / trials, trials)} [{100 * low:.1f}, {100 * high:.1f}]"


def rate_cell_of(rate: float, trials: int) -> str:
    """:func:`rate_cell` of a recorded ``rate`` on ``trials`` episodes."""
    return rate_cell(count(rate, trials), trials)


def times(ratio: float) -> str:
    """``"2.05x"``: a speed or throughput ratio, two decimals."""
    return f"{ratio:.2f}x"


def share(value: float) -> str:
    """A share of subgoals or steps, in percent with two decimals (flip rates are small)."""
    return f"{100 * value:.2f}%"


def table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def families(results: Results, row: str) -> dict[str, Any]:
    """The per-family outcomes of one row (one low level at one smoothing) of an in-maze file."""
    return results.get("results", row, "families")


def success(family: dict[str, Any]) -> str:
    """One family's success with its interval."""
    return rate_cell(family["successes"], family["episodes"])


def selection_oracle(name: str, rows: Sequence[tuple[str, str]]) -> str:
    """Rows (label, key) of an early selection file, which scored eval-low and the oracle's success (``ceiling``)."""
    results = load(name)
    episodes, mazes = results.get("settings", "episodes"), results.get("settings", "mazes")
    best = results.get("best")
    lines = []
    for label, key in rows:
        row = results.get("scores", key)
        lines.append(
            [
                f"{label}{' (the best row)' if key == best else ''}",
                rate_cell_of(row["eval_low"], episodes),
                rate_cell_of(row["ceiling"], mazes),
                f"{row['score']:.3f}",
            ]
        )
    return table(["row", f"eval-low ({episodes} subgoals)", f"oracle success ({mazes} mazes)", "score"], lines)


def lab_parser(module: str, doc: str | None) -> argparse.ArgumentParser:
    """The argument parser of a lab command, ``python -m MODULE``, with the module's docstring as its description."""
    return argparse.ArgumentParser(
        prog=f"python -m {module}", description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )


def refuse_below_one(parser: argparse.ArgumentParser, args: argparse.Namespace, names: Sequence[str]) -> None:
    """Exits through ``parser.error`` (one line, status 2) at the first of the options ``names`` below 1.

    ``names`` are the options' dests, in the order they are checked; the message spells the option as typed:
    ``--chunk-episodes must be >= 1, got 0``.
    """
    for name in names:
        value = getattr(args, name)
        if value < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1, got {value}")


class Sections(dict[str, Callable[[], str]]):
    """A page module's section builders by the name its command takes, and that command.

    A builder joins with ``@SECTIONS.add("name")``; ``SECTIONS.main(argv)`` prints one section
    (``python -m MODULE SECTION``) and returns the exit status: ``--list`` (or no section) names the sections,
    and a bad results file is a one-line error and status 2.

    Args:
        module: The module's import name, the command's ``python -m`` target.
        doc: The command's description (the module's docstring).
    """

    def __init__(self, module: str, doc: str | None) -> None:
        super().__init__()
        self.module, self.doc = module, doc

    def add(self, name: str) -> Callable[[Callable[[], str]], Callable[[], str]]:
        """A decorator adding its function as section ``name``.

        Raises:
            ValueError: If ``name`` is taken.
        """

        def register(builder: Callable[[], str]) -> Callable[[], str]:
            if name in self:
                raise ValueError(f"section {name!r} of {self.module} is added twice")
            self[name] = builder
            return builder

        return register

    def main(self, argv: list[str] | None = None) -> int:
        """Prints one section; returns the exit status (2 with a one-line error on a bad results file)."""
        parser = lab_parser(self.module, self.doc)
        parser.add_argument("section", nargs="?", choices=list(self), help="the table to print (required)")
        parser.add_argument("--list", action="store_true", help="print the section names (default: off)")
        args = parser.parse_args(argv)
        if args.list or args.section is None:
            print("\n".join(self))
            return 0 if args.list else 2
        LOADED.clear()
        try:
            print(self[args.section]())
        except ResultsFileError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        except KeyError as error:
            print(f"error: no field {error} in {', '.join(f'results/{name}' for name in LOADED)}", file=sys.stderr)
            return 2
        return 0


def all_sections() -> dict[str, ModuleType]:
    """Every section of every page module, with the module that prints it (section names are unique)."""
    found: dict[str, ModuleType] = {}
    for name in TABLE_MODULES:
        module = importlib.import_module(name)
        for section in module.SECTIONS:
            if section in found:
                raise ValueError(f"section {section!r} is in both {found[section].__name__} and {name}")
            found[section] = module
    return found


def main(argv: list[str] | None = None) -> int:
    """Lists each page module's sections, one ``module section`` a line."""
    argparse.ArgumentParser(prog="python -m antmaze_lab.tables", description=__doc__).parse_args(argv)
    for section, module in all_sections().items():
        print(f"{module.__name__} {section}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
