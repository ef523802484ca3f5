"""Bounds for every numeric option of the ``antmaze-hirl`` command line, checked while parsing.

:func:`apply_bounds` walks a built parser (every subcommand, ``study`` ones included) and gives each
``int`` or ``float`` option a type that refuses values outside its bounds, NaN and infinity, with a
one-line error and exit status 2, before a handler imports torch or writes a file. An option missing
from :data:`INT_BOUNDS` / :data:`FLOAT_BOUNDS` is a programming error raised when the parser is built,
so a new option cannot skip validation.

Bounds are sanity limits, not tuning advice: seeds fit a 31-bit word so that the ``seed + i`` that
evaluations and trials derive still fit the 32-bit seeds NumPy and SB3 take; counts stop well before a
typo exhausts memory or time; distances and rates are finite and positive.

:data:`SB3_ZIP_WARNING` is the warning that every option loading an SB3 zip gives in its help, and
:data:`SB3_PICKLE_WARNING` the one every option loading an SB3 replay-buffer pickle gives;
:data:`LOW_LEVEL_VALUE` says what an option naming a low-level policy takes, :data:`INIT_FROM_VALUE` what
``train-low --init-from`` (a warm start) takes.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

MAX_SEED = 2**31 - 1
"""Largest ``--seed``: ``seed + i`` for the derived seeds stays below 2**32."""

MAX_STUDY_SEED = 2**32 - 1
"""Largest ``study init --seed`` (:data:`antmaze_hirl.study.plan.MAX_SEED`, not imported: it pulls numpy)."""

SB3_ZIP_WARNING = "SB3 zips hold pickles that can run code: load only files you trust"
"""The help of every option that loads an SB3 zip says this (``docs/guides/low-level.md``, "Load only policy
files you trust")."""

LOW_LEVEL_VALUE = (
    "an SB3 off-policy .zip (TD3, DDPG, SAC, or TQC with sb3-contrib installed) or a low-level name: shipped, "
    "or the ant's ensemble"
)
"""What an option that names a low-level policy to load takes (``load_low_level``'s ``path``), as its help says it.
The names are :data:`antmaze_hirl.sb3_ext.loading.LOW_LEVEL_NAMES`'; they are written out here because that module
imports SB3, which building the parser must not."""

INIT_FROM_VALUE = (
    "an SB3 off-policy .zip of --algo's algorithm, not an action ensemble, or a low-level name of one: the point's "
    "shipped"
)
"""What ``train-low --init-from`` takes (``warm_start_parameters``' ``init_from``), as its help says it. Narrower
than :data:`LOW_LEVEL_VALUE`: a warm start copies one actor network, and an action ensemble's actor has one head a
member, so the names that stand for one (the ant's ``shipped`` and ``ensemble``) are refused there. Written out for
the reason :data:`LOW_LEVEL_VALUE` is."""

SB3_PICKLE_WARNING = "SB3 replay buffers are pickles that can run code: load only files you trust"
"""The help of every option that loads an SB3 replay buffer (a plain pickle, ``load_replay_buffer``) says this."""


@dataclass(frozen=True)
class IntBounds:
    """An integer option's closed range ``[low, high]``."""

    low: int
    high: int
    meaning: str = ""

    def refusal(self, text: str, value: int | None) -> str:
        """Why ``text`` (parsed as ``value``, ``None`` if not an int) is refused: ``must be >= 1 (...), got 0``."""
        meaning = f" ({self.meaning})" if self.meaning else ""
        if value is None:
            return f"must be an int in [{self.low}, {self.high}]{meaning}, got {_shown(text)}"
        bound = f">= {self.low}" if value < self.low else f"<= {self.high}"
        return f"must be {bound}{meaning}, got {_shown(text, quote=False)}"


@dataclass(frozen=True)
class FloatBounds:
    """A float option's range: finite, ``low < value`` (or ``<=`` when ``low_inclusive``), ``value <= high``."""

    low: float
    high: float
    low_inclusive: bool = False

    def describe(self) -> str:
        """``a finite number > low and <= high``."""
        return f"a finite number {'>=' if self.low_inclusive else '>'} {self.low:g} and <= {self.high:g}"


_COUNT = IntBounds(1, 1_000_000)
_EVAL_MAZES = IntBounds(1, 100_000)
_STEPS = IntBounds(1, 10**10)
_CORES = IntBounds(1, 1024)
_METRES = FloatBounds(0.0, 1000.0)

INT_BOUNDS: dict[str, IntBounds] = {
    "seed": IntBounds(0, MAX_SEED),
    "training_seed": IntBounds(0, MAX_SEED),
    "study init:seed": IntBounds(0, MAX_STUDY_SEED),
    "seeds": IntBounds(1, 10_000, "trials per method"),
    "episodes": _COUNT,
    "study init:episodes": IntBounds(1, 100_000),
    "practice": IntBounds(0, 100_000, "0: no practice trial"),
    "participants": IntBounds(1, 10_000),
    "eval_every": _COUNT,
    "eval_episodes": _EVAL_MAZES,
    "final_eval_episodes": _EVAL_MAZES,
    "maze_size": IntBounds(2, 64),
    "gradient_steps": IntBounds(0, 10**7),
    "timesteps": _STEPS,
    "checkpoint_freq": _STEPS,
    "eval_freq": _STEPS,
    "threads": _CORES,
    "jobs": _CORES,
    "cpus_per_trial": _CORES,
    "evaluation_envs": IntBounds(1, 1024, "mazes evaluated at once"),
    "episodes_per_task": IntBounds(1, 10_000),
    "num_envs": IntBounds(1, 1024, "mazes played at once; 1: one after another"),
    "port": IntBounds(0, 65535, "0: any free port"),
}
"""Bounds of the integer options, by ``dest``; ``"COMMAND:dest"`` overrides for one (sub)command."""

FLOAT_BOUNDS: dict[str, FloatBounds] = {
    "subgoal_reach_m": _METRES,
    "clearance_m": _METRES,
    "sample_radius_m": _METRES,
    "decay": FloatBounds(1.0, 1e6, low_inclusive=True),
    "noise": FloatBounds(0.0, 100.0, low_inclusive=True),
    "delay": FloatBounds(0.0, 3600.0, low_inclusive=True),
}
"""Bounds of the float options, by ``dest``; ``"COMMAND:dest"`` overrides for one (sub)command."""


def bounded_int(bounds: IntBounds) -> Callable[[str], int]:
    """An argparse ``type`` parsing a decimal integer within ``bounds``."""

    def parse(text: str) -> int:
        try:
            value = int(text.strip(), 10) if len(text) <= 40 else None  # no 4,300-digit conversions
        except ValueError:
            value = None
        if value is None or not bounds.low <= value <= bounds.high:
            raise argparse.ArgumentTypeError(bounds.refusal(text, value))
        return value

    parse.__name__ = "int"
    return parse


def bounded_float(bounds: FloatBounds) -> Callable[[str], float]:
    """An argparse ``type`` parsing a finite float within ``bounds`` (never NaN or infinity)."""

    def parse(text: str) -> float:
        try:
            value = float(text) if len(text) <= 40 else math.nan
        except ValueError:
            value = math.nan
        above_low = value >= bounds.low if bounds.low_inclusive else value > bounds.low
        if not (math.isfinite(value) and above_low and value <= bounds.high):
            raise argparse.ArgumentTypeError(f"must be {bounds.describe()}, got {_shown(text)}")
        return value

    parse.__name__ = "float"
    return parse


def _shown(text: str, *, quote: bool = True) -> str:
    if len(text) > 40:
        return f"{text[:20]!r}... ({len(text)} characters)"
    return repr(text) if quote else text


def _one_line_error(parser: argparse.ArgumentParser) -> Callable[[str], None]:
    def error(message: str) -> None:
        # "argument --seeds: must be >= 1 ..." -> "--seeds must be >= 1 ...", as the handlers word their checks
        message = re.sub(r"^argument (--[\w-]+)(?:/--[\w-]+)*: must be ", r"\1 must be ", message)
        parser.exit(2, f"{parser.prog}: error: {' '.join(message.split())} (see {parser.prog} --help)\n")

    return error


def all_options(parser: argparse.ArgumentParser, command: str = "") -> list[tuple[str, argparse.Action]]:
    """``(command, action)`` of every option and positional of ``parser`` and its subcommands, ``help`` included.

    ``command`` is the subcommand path, ``"study init"`` for example, ``""`` for the top level.
    """
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.extend(all_options(sub, f"{command} {name}".strip()))
        else:
            found.append((command, action))
    return found


def numeric_options(parser: argparse.ArgumentParser, command: str = "") -> list[tuple[str, argparse.Action]]:
    """``(command, action)`` of every option of ``parser`` and its subcommands whose type is numeric."""
    return [(name, action) for name, action in all_options(parser, command) if _is_numeric(action)]


def _is_numeric(action: argparse.Action) -> bool:
    if action.type in (int, float) or getattr(action, "bounds", None) is not None:
        return True
    return getattr(action.type, "__name__", "") in ("_positive_int",)  # the backends' own int type


def apply_bounds(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Bounds every numeric option of ``parser`` (and its subcommands), and makes usage errors one line.

    Raises:
        KeyError: If a numeric option has no bounds in :data:`INT_BOUNDS` / :data:`FLOAT_BOUNDS`.
    """
    for command, action in numeric_options(parser):
        is_float = action.type is float or isinstance(getattr(action, "bounds", None), FloatBounds)
        table = FLOAT_BOUNDS if is_float else INT_BOUNDS
        bounds = table.get(f"{command}:{action.dest}") or table.get(action.dest)
        if bounds is None:
            raise KeyError(f"antmaze-hirl {command} {action.option_strings or action.dest}: no bounds declared")
        action.bounds = bounds  # type: ignore[attr-defined]  # for the tests and for help texts
        action.type = bounded_float(bounds) if is_float else bounded_int(bounds)
    _set_errors(parser)
    return parser


def _set_errors(parser: argparse.ArgumentParser) -> None:
    parser.error = _one_line_error(parser)  # type: ignore[method-assign]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _set_errors(sub)
