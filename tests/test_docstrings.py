"""Docstrings state the contract and comments say why: no issue numbers, which mean nothing to a reader.

The rule holds in the package and in every script and benchmark (:data:`FOLDERS`).

Both are read from the source (``ast`` and ``tokenize``), so no module is imported.
"""

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "antmaze_hirl"

ISSUE_REFERENCE = re.compile(r"\b(?:issues?|PR|pull request) ?#?\d+\b|(?<![\w&#])#\d{2,}\b", re.IGNORECASE)
"""``issue 31``, ``issues 12``, ``Issue #7``, ``PR 5``, ``#32``; not a hex colour (``#2850dc``) or ``&#39``."""


def _public_docstrings(tree: ast.Module) -> list[tuple[int, str, str]]:
    """``(line, name, text)`` of the module's docstring and of every public class, function and attribute's."""
    found = []
    if (text := ast.get_docstring(tree, clean=False)) is not None:
        found.append((1, "module", text))

    def visit(body: list[ast.stmt], prefix: str) -> None:
        for index, node in enumerate(body):
            if isinstance(node, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                if node.name.startswith("_") and not node.name.startswith("__"):
                    continue
                if (text := ast.get_docstring(node, clean=False)) is not None:
                    found.append((node.lineno, prefix + node.name, text))
                if isinstance(node, ast.ClassDef):
                    visit(node.body, f"{prefix}{node.name}.")
            elif isinstance(node, ast.Assign | ast.AnnAssign) and index + 1 < len(body):
                # An attribute docstring: a string right after the assignment (as Sphinx and mkdocstrings read it).
                following = body[index + 1]
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                names = [target.id for target in targets if isinstance(target, ast.Name)]
                if (
                    names
                    and not all(name.startswith("_") for name in names)
                    and isinstance(following, ast.Expr)
                    and isinstance(following.value, ast.Constant)
                    and isinstance(following.value.value, str)
                ):
                    found.append((following.lineno, prefix + names[0], following.value.value))

    visit(tree.body, "")
    return found


def _comments(source: str) -> list[tuple[int, str]]:
    tokens = tokenize.generate_tokens(io.StringIO(source).readline)
    return [(token.start[0], token.string) for token in tokens if token.type == tokenize.COMMENT]


def issue_references(path: Path) -> list[str]:
    """``path:line name: reference`` for every issue reference in a public docstring or a comment of ``path``."""
    source = path.read_text(encoding="utf-8")
    where = path.relative_to(PACKAGE.parent)
    texts = [(line, name, text) for line, name, text in _public_docstrings(ast.parse(source))]
    texts += [(line, "comment", text) for line, text in _comments(source)]
    return [
        f"{where}:{line} {name}: {match.group(0)!r}"
        for line, name, text in texts
        for match in ISSUE_REFERENCE.finditer(text)
    ]


@pytest.mark.parametrize(
    ("text", "found"),
    [
        ("the default since issue 32", ["issue 32"]),
        ("(Issue #7; see issues 12)", ["Issue #7", "issues 12"]),
        ("fixed in #31, as PR 5 said", ["#31", "PR 5"]),
        ("colour #2850dc, an entity &#39;, 3 issues, issue tracker", []),
        ("stage 6, 95% Wilson interval, 1,968 wall grids", []),
    ],
)
def test_the_matcher_finds_issue_references_and_nothing_else(text, found):
    assert [match.group(0) for match in ISSUE_REFERENCE.finditer(text)] == found


def test_the_scan_finds_references_in_docstrings_and_comments_but_not_in_private_ones(tmp_path, monkeypatch):
    monkeypatch.setattr(f"{__name__}.PACKAGE", tmp_path / "antmaze_hirl")
    sample = tmp_path / "antmaze_hirl" / "sample.py"
    sample.parent.mkdir()
    sample.write_text(
        '"""Module (issue 1)."""\n'
        "LIMIT = 3\n"
        '"""An attribute (#12)."""\n'
        "class Public:\n"
        '    """A class (issue 2)."""\n'
        "    def method(self):\n"
        '        """A method (issue 3)."""\n'
        "        return 1  # a comment (issue 4)\n"
        "def _private():\n"
        '    """Not public (issue 5)."""\n'
    )
    assert issue_references(sample) == [
        "antmaze_hirl/sample.py:1 module: 'issue 1'",
        "antmaze_hirl/sample.py:3 LIMIT: '#12'",
        "antmaze_hirl/sample.py:4 Public: 'issue 2'",
        "antmaze_hirl/sample.py:6 Public.method: 'issue 3'",
        "antmaze_hirl/sample.py:8 comment: 'issue 4'",
    ]


FOLDERS = ("antmaze_hirl", "scripts", "benchmarks")
"""Where the rule holds: the package, and the scripts and benchmarks a reader runs and reads beside it."""

CHECKED = sorted(path for folder in FOLDERS for path in (PACKAGE.parent / folder).rglob("*.py"))


def test_every_folder_has_files_to_check():
    # Guards the parametrisation below: a folder that matched no file would pass it vacuously.
    assert {path.relative_to(PACKAGE.parent).parts[0] for path in CHECKED} == set(FOLDERS)


@pytest.mark.parametrize("path", CHECKED, ids=lambda path: path.relative_to(PACKAGE.parent).as_posix())
def test_no_docstring_or_comment_cites_an_issue_number(path):
    # An issue number goes stale and tells a reader nothing: say why in words, or point at the docs page.
    found = issue_references(path)
    assert not found, "issue references (say why in words instead):\n" + "\n".join(found)
