"""Rewrites the generated blocks of the docs from the commands that print them (``--check``: compare only).

A generated block is the output of one command, pasted between two markers in a Markdown page::

    <!-- generated: python -m antmaze_lab.paper_tables results/paper_experiment/point --tables -->
    | method | ... |
    <!-- end generated -->

The command runs from the repository root with this interpreter (``python`` is replaced by
``sys.executable``; no shell, so no pipes or globs), and the block becomes its standard output, stripped.
Every figure in such a block therefore comes from a committed results file through a command a reader can
rerun; ``tests/test_generated_docs.py`` runs ``--check`` so a block that no longer matches its files fails.

Usage: python scripts/generate_docs.py [--check] [PAGE ...]   (default: README.md and docs/**/*.md)
"""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from antmaze_hirl.atomic_io import atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
START = re.compile(r"^<!-- generated: (?P<command>.+?) -->$")
END = "<!-- end generated -->"
COMMAND_TIMEOUT_S = 300


class BlockError(ValueError):
    """A page whose markers do not pair up, or a block whose command cannot run."""


@dataclass(frozen=True)
class Block:
    """One generated block: its page, the 1-based line of its start marker, its command and current text."""

    page: Path
    line: int
    command: str
    text: str


def find_blocks(page: Path, text: str) -> list[Block]:
    """The generated blocks of one page's ``text``, in order.

    Raises:
        BlockError: On a start marker without its end marker, an end marker without a start, or a nested start,
            naming the page and line.
    """
    blocks: list[Block] = []
    open_at: tuple[int, str] | None = None
    body: list[str] = []
    for number, line in enumerate(text.splitlines(), start=1):
        start = START.match(line)
        if start:
            if open_at is not None:
                raise BlockError(
                    f"{page}:{number}: a generated block starts inside the one opened at line {open_at[0]}"
                )
            open_at, body = (number, start["command"]), []
        elif line == END:
            if open_at is None:
                raise BlockError(f"{page}:{number}: {END!r} without a '<!-- generated: COMMAND -->' before it")
            blocks.append(Block(page, open_at[0], open_at[1], "\n".join(body)))
            open_at = None
        elif open_at is not None:
            body.append(line)
    if open_at is not None:
        raise BlockError(f"{page}:{open_at[0]}: a generated block has no {END!r}")
    return blocks


def run_command(block: Block) -> str:
    """The standard output of ``block``'s command, stripped.

    Raises:
        BlockError: If the command does not start with ``python``, exits non-zero (with its last error line), or runs
            past :data:`COMMAND_TIMEOUT_S`.
    """
    argv = shlex.split(block.command)
    if not argv or argv[0] != "python":
        raise BlockError(
            f"{block.page}:{block.line}: a generated block's command must start with 'python', got {block.command!r}"
        )
    try:
        result = subprocess.run(
            [sys.executable, *argv[1:]],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=COMMAND_TIMEOUT_S,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise BlockError(f"{block.page}:{block.line}: {block.command!r} ran past {COMMAND_TIMEOUT_S} s") from None
    if result.returncode != 0:
        last = (result.stderr.strip().splitlines() or ["(no error output)"])[-1]
        raise BlockError(f"{block.page}:{block.line}: {block.command!r} exited {result.returncode}: {last}")
    return result.stdout.strip()


def regenerate(text: str, outputs: dict[int, str]) -> str:
    """``text`` with the body of the block starting at each line number in ``outputs`` replaced by its output."""
    lines = text.splitlines()
    result: list[str] = []
    skipping = False
    for number, line in enumerate(lines, start=1):
        if skipping:
            if line == END:
                skipping = False
                result.append(line)
            continue
        result.append(line)
        if number in outputs:
            result.extend(outputs[number].splitlines())
            skipping = True
    return "\n".join(result) + ("\n" if text.endswith("\n") else "")


def default_pages() -> list[Path]:
    """README.md and every page under docs/."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def main(argv: list[str] | None = None) -> int:
    """Rewrites (or with ``--check`` compares) every generated block; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("pages", nargs="*", type=Path, help="Markdown pages (default: README.md and docs/**/*.md)")
    parser.add_argument("--check", action="store_true", help="compare only: exit 1 naming every stale block")
    args = parser.parse_args(argv)
    for page in args.pages:
        if not page.is_file():
            parser.error(f"no such page: {page}")
    stale: list[str] = []
    try:
        for page in args.pages or default_pages():
            text = page.read_text()
            blocks = find_blocks(page, text)
            outputs = {block.line: run_command(block) for block in blocks}
            changed = [block for block in blocks if block.text.strip() != outputs[block.line]]
            stale += [f"{block.page}:{block.line}: stale, regenerate with {block.command!r}" for block in changed]
            if changed and not args.check:
                atomic_write_text(page, regenerate(text, outputs))
    except BlockError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    for line in stale:
        print(line)
    if args.check and stale:
        return 1
    print(f"{len(stale)} block(s) {'stale' if args.check else 'rewritten'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
