"""The index of the committed results: per entry of ``results/<experiment>/``, where it came from and who quotes it.

``results/index.json`` holds, for every entry (a file, or a results folder such as ``paper_experiment/ant``; the
leaderboard's reports count as one entry), what a reader needs to trust or replay it: the command that made it
(as recorded in the file, with the paths of its day), the commit it was committed in, the commit it was made at
where the file records one, the low level (policy hashes, as ``low_level_id`` records them), the machine, the
entries it supersedes and a note. Entries it lists as ``removed`` are gone from the tree and named with the commit where
git still has them. Which pages quote an entry is not stored but read from README.md and docs/**/*.md, so the
table cannot claim a page that no longer quotes the file.

A superseded entry is removed from the tree: the entry that supersedes it names it in ``supersedes``, and
``removed`` names the commit where git still has it. Every field of an entry holds a value: a fact the file
or git does not record is written ``not recorded``, one that does not apply (no low level in an env
benchmark) ``n/a``.

A recorded command names the script of its day. ``moved`` maps each script that has since become a lab module
(``scripts/in_maze.py``, earlier ``benchmarks/in_maze.py``) to that module (``antmaze_lab.in_maze``): the same
options replay it as ``python -m antmaze_lab.in_maze ...`` from the repository root (:func:`replay_command`).

``--check`` compares the index with the tree (exit 1 naming every entry missing from either side, a removed
entry still present, a superseded entry not listed as removed, an entry's null or missing field, a moved
script still on disk or its module missing, or a moved entry whose replayed options today's module does not
parse: :func:`replay_problems`); ``--table`` prints the Markdown tables of ``docs/results/files.md``
(a generated block); ``--replay ENTRY`` prints the command that replays an entry today.

Usage: python scripts/results_index.py [--check | --table | --replay EXPERIMENT/ENTRY]
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
INDEX = RESULTS / "index.json"
FORMAT = "antmaze_hirl.results_index/1"
PAGES_OWN = Path("docs") / "results" / "files.md"
"""The page the table is generated into: it names every entry, so it is left out of "quoted by"."""
COMMAND_CHARS = 100
"""Longer recorded commands are cut in the table (the whole command is in the file and in the index)."""
TICKED = re.compile(r"`+([^`\s]+)`+")
FIELDS = ("command", "committed_in", "made_at", "low_level", "machine", "supersedes", "note")
"""Every entry's fields; each must be present and not null (``note`` may be empty, the others not)."""


def load_index(path: Path = INDEX) -> dict[str, Any]:
    """The index, checked for its format.

    Raises:
        ValueError: If the file is not JSON, or its ``format`` is not :data:`FORMAT`.
    """
    try:
        index = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON: {error}") from None
    if not isinstance(index, dict) or index.get("format") != FORMAT:
        raise ValueError(
            f"{path} has format {index.get('format') if isinstance(index, dict) else index!r}, expected {FORMAT!r}"
        )
    return index


def entry_paths(index: dict[str, Any]) -> list[str]:
    """Every indexed entry as ``experiment/name`` (the leaderboard's ``*.json`` stands for its reports)."""
    return [f"{experiment}/{name}" for experiment, spec in index["experiments"].items() for name in spec["entries"]]


def tree_entries(results: Path, index: dict[str, Any]) -> list[str]:
    """The entries on disk: each child of ``results/<experiment>/``, or ``*.json`` for a folder indexed as one."""
    found = []
    for folder in sorted(path for path in results.iterdir() if path.is_dir()):
        spec = index["experiments"].get(folder.name, {"entries": {}})
        if list(spec["entries"]) == ["*.json"]:
            found.append(f"{folder.name}/*.json")
            continue
        found += [f"{folder.name}/{child.name}" for child in sorted(folder.iterdir())]
    return found


def problems(results: Path, index: dict[str, Any]) -> list[str]:
    """What does not match between the index and the tree, one line each (empty: they match)."""
    indexed, on_disk = set(entry_paths(index)), set(tree_entries(results, index))
    lines = [f"{entry}: on disk, not in results/index.json" for entry in sorted(on_disk - indexed)]
    lines += [f"{entry}: in results/index.json, not on disk" for entry in sorted(indexed - on_disk)]
    for removed in index["removed"]:
        if (ROOT / removed["path"]).exists():
            lines.append(f"{removed['path']}: listed as removed, still on disk")
        if not removed.get("commit") or not removed.get("superseded_by"):
            lines.append(f"{removed['path']}: a removed entry needs its commit and what supersedes it")
    superseded: dict[str, str] = {}  # results/<experiment>/<old> -> the entry that supersedes it
    for experiment, spec in index["experiments"].items():
        for name, entry in spec["entries"].items():
            lines += [
                f"{experiment}/{name}: field {field!r} is missing, null or empty (write 'not recorded' or 'n/a')"
                for field in FIELDS
                if entry.get(field) is None or (entry[field] == "" and field != "note")
            ]
            for old in entry.get("supersedes") or []:
                superseded[f"results/{experiment}/{old}"] = f"results/{experiment}/{name}"
    listed = {removed["path"]: removed.get("superseded_by") for removed in index["removed"]}
    for path in sorted(superseded.keys() | listed.keys()):
        newer, named = superseded.get(path), listed.get(path)
        if newer != named:
            by = f"{newer}'s supersedes names it" if newer else "no entry's supersedes names it"
            said = f"removed gives {named} as superseding it" if path in listed else "removed does not list it"
            lines.append(f"{path}: {by}, {said} (a superseded entry leaves the tree, named in both)")
    for script, module in index.get("moved", {}).items():
        if (ROOT / script).exists():
            lines.append(f"{script}: moved to {module}, still on disk (a moved script leaves the tree)")
        if not (ROOT / Path(*module.split("."))).with_suffix(".py").is_file():
            lines.append(f"{script}: moved to {module}, which is not a module of this checkout")
    return lines


def replay_command(command: str, moved: dict[str, str], renamed: dict[str, dict[str, str]] | None = None) -> str:
    """The command that replays recorded ``command`` under today's code, from the repository root.

    ``python scripts/in_maze.py --episodes 10`` with ``scripts/in_maze.py`` moved to ``antmaze_lab.in_maze`` is
    ``python -m antmaze_lab.in_maze --episodes 10``: the script's module, wherever ``python SCRIPT`` stands in
    the command (after ``nice`` or an environment prefix too), and each option that ``renamed[module]`` maps
    (``--subgoal-distance`` -> ``--subgoal-reach-m``) under its new name. Defaults may have changed since the
    entry's commit, so this replays the run's options, not necessarily its figures: the exact run is that
    commit's checkout. Any other command (not moved, ``antmaze-hirl ...``, ``not recorded``) is returned as it is.
    """
    for script, module in moved.items():
        pattern = rf"(^|\s)python\s+{re.escape(script)}(?=\s|$)"
        if re.search(pattern, command):
            command = re.sub(pattern, rf"\1python -m {module}", command, count=1)
            for old, new in (renamed or {}).get(module, {}).items():
                command = re.sub(rf"(?<=\s){re.escape(old)}(?=[\s=]|$)", new, command)
            return command
    return command


SHELL_OPERATORS = frozenset({"&&", "||", ";", "|", "&", ">", ">>", "2>", "2>&1"})
"""Words that end a command's options (a recorded command that went on with another, or a redirection)."""


def replay_problems(index: dict[str, Any], root: Path = ROOT) -> list[str]:
    """Each entry whose command does not replay under today's code, one line naming it (empty: all replay).

    A moved entry's replayed command (:func:`replay_command`) must parse whole under its module's parser (the
    module's ``build_parser()``, run as ``python -m antmaze_lab.commands`` from ``root``: this script cannot import
    the lab), and no entry's command may still name a moved script after replay (a form :func:`replay_command`
    does not read, such as ``python3 SCRIPT``).
    """
    moved, renamed = index.get("moved", {}), index.get("renamed_options", {})
    lines: list[str] = []
    items: list[dict[str, Any]] = []
    for experiment, spec in index["experiments"].items():
        for name, entry in spec["entries"].items():
            recorded = entry["command"]
            command = replay_command(recorded, moved, renamed)
            for script in moved:
                if re.search(rf"(?<![\w/.-]){re.escape(script)}(?=\s|$)", command):
                    lines.append(f"{experiment}/{name}: its command still names {script} after replay: {command!r}")
            if command == recorded:
                continue
            words = shlex.split(command)
            start = words.index("-m") + 2  # replay_command wrote "python -m MODULE" in place of "python SCRIPT"
            end = next((i for i, word in enumerate(words) if i >= start and word in SHELL_OPERATORS), len(words))
            items.append({"entry": f"{experiment}/{name}", "module": words[start - 1], "arguments": words[start:end]})
    if not items:
        return lines
    checked = subprocess.run(
        [sys.executable, "-m", "antmaze_lab.commands"],
        input=json.dumps(items),
        capture_output=True,
        text=True,
        cwd=root,
        check=False,
    )
    if checked.returncode != 0 or not checked.stdout.strip():
        why = (checked.stderr.strip().splitlines() or ["no output"])[-1]
        return [*lines, f"python -m antmaze_lab.commands could not parse the moved entries' options: {why}"]
    modules = {item["entry"]: item["module"] for item in items}
    failed = json.loads(checked.stdout.strip().splitlines()[-1])
    lines += [
        f"{entry}: its replayed options do not parse under {modules[entry]} ({message}); map a renamed option in "
        "renamed_options"
        for entry, message in failed.items()
    ]
    return lines


def expand_braces(token: str) -> list[str]:
    """``a_{x,y}.json`` -> ``["a_x.json", "a_y.json"]`` (one level, as the pages write them)."""
    match = re.search(r"\{([^{}]*)\}", token)
    if match is None:
        return [token]
    return [token[: match.start()] + part + token[match.end() :] for part in match.group(1).split(",")]


def quoting_pages(root: Path, entries: list[str]) -> dict[str, list[str]]:
    """For each entry, the pages (README.md, docs/**/*.md but the index's own) that name it in backticks.

    A page names an entry with its path under ``results/`` (``in_maze/in_maze.json``, or a pattern such as
    ``in_maze/in_maze_*.json``), with or without the leading ``results/``, or a file inside a folder entry.
    """
    pages = [root / "README.md", *sorted((root / "docs").rglob("*.md"))]
    quoted: dict[str, list[str]] = {entry: [] for entry in entries}
    for page in pages:
        relative = page.relative_to(root)
        if relative == PAGES_OWN:
            continue
        tokens = {
            name.removeprefix("results/").rstrip("/")
            for token in TICKED.findall(page.read_text())
            for name in expand_braces(token)
        }
        for entry in entries:
            if any(matches(token, entry) for token in tokens):
                quoted[entry].append(relative.as_posix())
    return quoted


def matches(token: str, entry: str) -> bool:
    """Whether a page's ``token`` names ``entry`` (itself, a pattern over it, or a file inside it)."""
    if entry.endswith("/*.json"):  # a folder indexed as one: the folder or any of its reports
        folder = entry.removesuffix("/*.json")
        return token == folder or (token.startswith(folder + "/") and token.endswith(".json"))
    return fnmatch.fnmatchcase(entry, token) or token.startswith(entry + "/")


def cell(text: str) -> str:
    """A table cell: pipes escaped."""
    return text.replace("|", "\\|")


def table(index: dict[str, Any], quoted: dict[str, list[str]]) -> str:
    """The Markdown tables of ``docs/results/files.md``: one per experiment, then the removed entries."""
    lines = []
    for experiment, spec in index["experiments"].items():
        lines += [f"### `results/{experiment}/`", "", f"Made by `{spec['made_by']}`.", ""]
        lines += [
            "| entry | command (as recorded) | committed in | made at | low level | machine "
            "| supersedes, superseded by, note | quoted by |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for name, entry in spec["entries"].items():
            path = f"{experiment}/{name}"
            command = entry["command"]
            if len(command) > COMMAND_CHARS:
                command = command[: COMMAND_CHARS - 3] + "..."
            relations = [f"supersedes `{old}`" for old in entry["supersedes"]]
            if entry["note"]:
                relations.append(cell(entry["note"]))
            pages = ", ".join(f"`{page}`" for page in quoted[path]) or "no page"
            shown = command if command in ("not recorded", "n/a") else f"`{cell(command)}`"
            lines.append(
                f"| `{name}` | {shown} | {entry['committed_in']} "
                f"| {cell(entry['made_at'])} | {cell(entry['low_level'])} | {cell(entry['machine'])} "
                f"| {'; '.join(relations)} | {pages} |"
            )
        lines.append("")
    lines += ["### Removed", "", "| entry | superseded by | in git at | note |", "|---|---|---|---|"]
    lines += [
        f"| `{r['path']}` | `{r['superseded_by']}` | {r['commit']} | {cell(r.get('note', ''))} |"
        for r in index["removed"]
    ]
    if index.get("moved"):
        lines += [
            "",
            "### Moved scripts",
            "",
            "A command recorded as `python SCRIPT OPTIONS` runs today as `python -m MODULE OPTIONS` from the "
            "repository root, options renamed since under their new names (`renamed_options`; `python "
            "scripts/results_index.py --replay EXPERIMENT/ENTRY` prints it; `--check` parses its options with the "
            "module's parser). Defaults may have changed since the run: the exact run is its commit.",
            "",
            "| recorded script | module today |",
            "|---|---|",
        ]
        lines += [f"| `{script}` | `{module}` |" for script, module in index["moved"].items()]
    return "\n".join(lines).rstrip()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="compare results/index.json with the tree")
    mode.add_argument("--table", action="store_true", help="print the tables of docs/results/files.md")
    mode.add_argument(
        "--replay",
        metavar="EXPERIMENT/ENTRY",
        help="print the command that replays this entry today, e.g. in_maze/in_maze.json",
    )
    args = parser.parse_args(argv)
    try:
        index = load_index()
    except ValueError as error:
        parser.error(str(error))
    if args.check:
        found = problems(RESULTS, index) + replay_problems(index)
        print("\n".join(found) if found else f"{INDEX.relative_to(ROOT)}: matches results/")
        return 1 if found else 0
    if args.replay:
        experiment, _, name = args.replay.partition("/")
        entry = index["experiments"].get(experiment, {"entries": {}})["entries"].get(name)
        if entry is None:
            parser.error(
                f"no entry {args.replay!r} in {INDEX.relative_to(ROOT)} (EXPERIMENT/ENTRY, e.g. in_maze/in_maze.json)"
            )
        print(replay_command(entry["command"], index.get("moved", {}), index.get("renamed_options", {})))
        made_at = entry.get("made_at", "not recorded")
        print(f"# under today's code (defaults may differ); the run itself: made at {made_at}", file=sys.stderr)
        return 0
    print(table(index, quoting_pages(ROOT, entry_paths(index))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
