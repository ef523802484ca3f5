"""The command a lab run records in its results file, and the options of a recorded one.

A lab runner is a module run from the repository root (``python -m antmaze_lab.in_maze ...``) and writes that
command line into its file (``"command"``). Files written before the runners moved into the lab record
``python scripts/in_maze.py ...`` (or, earlier, ``python benchmarks/in_maze.py ...``) with the same options:
:func:`command_arguments` reads the options of either form, and ``results/index.json``'s ``moved`` map says which
module replays an old script's command (``python scripts/results_index.py --replay ENTRY`` prints it).

Each runner's ``build_parser()`` is its command line's parser; :func:`option_error` parses a recorded command's
options with it, and ``python -m antmaze_lab.commands`` does so for a JSON list on standard input (how
``scripts/results_index.py --check``, which cannot import the lab, checks that every moved entry still replays).
"""

from __future__ import annotations

import argparse
import importlib
import json
import shlex
import sys
from collections.abc import Sequence
from typing import NoReturn


def recorded_command(module: str, argv: Sequence[str]) -> str:
    """The command line that replays a run of lab module ``module`` with options ``argv``, from the repository root.

    ``recorded_command("antmaze_lab.in_maze", ["--episodes", "10"])`` is
    ``"python -m antmaze_lab.in_maze --episodes 10"``; each argument is quoted for a POSIX shell.
    """
    return shlex.join(["python", "-m", module, *argv])


def command_arguments(command: str) -> list[str]:
    """The options and operands of a recorded command, without the program that ran them.

    Reads ``python -m MODULE ARGS...`` (a lab module) and ``python PATH.py ARGS...`` (a script of its day) alike.

    Raises:
        ValueError: One line naming the command if it is neither form.
    """
    words = shlex.split(command)
    if len(words) >= 3 and words[0] == "python" and words[1] == "-m":
        return words[3:]
    if len(words) >= 2 and words[0] == "python" and words[1].endswith(".py"):
        return words[2:]
    raise ValueError(f"not a recorded run command (python -m MODULE ... or python PATH.py ...): {command!r}")


def option_error(module: str, arguments: Sequence[str]) -> str | None:
    """What lab module ``module``'s parser (its ``build_parser()``) says of ``arguments``.

    ``None`` if it parses all of them, else argparse's one-line message (``unrecognized arguments:
    --subgoal-distance 3``).

    Only the options are read: nothing runs, and no file an option names is opened.

    Raises:
        ValueError: If ``module`` cannot be imported or has no ``build_parser``.
    """
    try:
        build_parser = importlib.import_module(module).build_parser
    except (ImportError, AttributeError) as error:
        raise ValueError(f"{module} has no command-line parser to read options with: {error}") from None
    parser: argparse.ArgumentParser = build_parser()

    def refuse(message: str) -> NoReturn:  # argparse's error() prints and exits; here the message is the answer
        raise _Refused(message)

    parser.error = refuse  # type: ignore[method-assign]
    try:
        _, unknown = parser.parse_known_args(list(arguments))
    except _Refused as refused:
        return str(refused)
    return f"unrecognized arguments: {' '.join(unknown)}" if unknown else None


class _Refused(Exception):
    """A parser's refusal of a recorded command's options (raised in place of argparse's exit)."""


def main() -> int:
    """Reads ``[{"entry", "module", "arguments"}, ...]`` (JSON) from standard input; prints the refused.

    The last line printed is ``{entry: message}`` (JSON) for each entry whose options its module's parser refuses
    (:func:`option_error`).
    """
    failed = {}
    for item in json.load(sys.stdin):
        try:
            message = option_error(item["module"], item["arguments"])
        except ValueError as error:
            message = str(error)
        if message is not None:
            failed[item["entry"]] = message
    print(json.dumps(failed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
