"""The command a lab run records in its results file, and the options of a recorded one.

A lab runner is a module run from the repository root (``python -m antmaze_lab.in_maze ...``) and writes that
command line into its file (``"command"``). Files written before the runners moved into the lab record
``python scripts/in_maze.py ...`` (or, earlier, ``python benchmarks/in_maze.py ...``) with the same options:
:func:`command_arguments` reads the options of either form, and ``results/index.json``'s ``moved`` map says which
module replays an old script's command (``python scripts/results_index.py --replay ENTRY`` prints it).
"""

from __future__ import annotations

import shlex
from collections.abc import Sequence


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
