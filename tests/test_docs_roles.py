"""The docs build renders the docstrings' Sphinx roles as cross-references (scripts/griffe_sphinx_roles.py)."""

from pathlib import Path

import griffe
import pytest
import yaml
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (scripts/griffe_sphinx_roles.py): the integration tier

ROOT = Path(__file__).resolve().parents[1]
roles = load_script("scripts/griffe_sphinx_roles.py")

PACKAGE = {
    "__init__.py": '"""Top: see :mod:`toy.inner` and :func:`~toy.inner.make`."""\nfrom toy.inner import Thing\n',
    "inner.py": '''"""Inner module."""


class Thing:
    """A thing; :meth:`go` moves it, :attr:`speed_m` is its speed, :class:`gymnasium.Env` is not ours."""

    speed_m: float = 1.0

    def go(self):
        """Goes; see :class:`Thing`, :func:`make` and :func:`the maker <make>` and :data:`.LIMIT`."""


LIMIT = 3
"""A limit."""


def make():
    """Makes a :class:`~toy.Thing` (an alias: linked where it is documented)."""
''',
}


def load_toy(tmp_path):
    (tmp_path / "toy").mkdir()
    for name, text in PACKAGE.items():
        (tmp_path / "toy" / name).write_text(text)
    return griffe.load("toy", search_paths=[str(tmp_path)], extensions=griffe.load_extensions(roles.SphinxRoles))


def ref(path, title):
    return f'<autoref identifier="{path}" optional><code>{title}</code></autoref>'


def test_roles_become_optional_autorefs_in_the_docstrings_scope(tmp_path):
    toy = load_toy(tmp_path)
    assert toy.docstring.value == f"Top: see {ref('toy.inner', 'toy.inner')} and {ref('toy.inner.make', 'make()')}."
    thing = toy["inner.Thing"]
    assert thing.docstring.value == (
        f"A thing; {ref('toy.inner.Thing.go', 'go()')} moves it, {ref('toy.inner.Thing.speed_m', 'speed_m')} is "
        "its speed, `gymnasium.Env` is not ours."
    )
    assert thing["go"].docstring.value == (
        f"Goes; see {ref('toy.inner.Thing', 'Thing')}, {ref('toy.inner.make', 'make()')} and "
        f"{ref('toy.inner.make', 'the maker')} and {ref('toy.inner.LIMIT', 'LIMIT')}."
    )
    assert toy["inner.make"].docstring.value.startswith(f"Makes a {ref('toy.inner.Thing', 'Thing')} (an alias")


def test_an_unknown_name_is_code_not_a_broken_link(tmp_path):
    toy = load_toy(tmp_path)
    collection = griffe.ModulesCollection()
    collection["toy"] = toy
    assert roles.render_roles(toy["inner"], ":func:`nowhere` and :class:`~numpy.ndarray`", collection) == (
        "`nowhere()` and `ndarray`"
    )


def test_mkdocs_loads_the_extension():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text().replace("!!python", "#"))
    options = config["plugins"][1]["mkdocstrings"]["handlers"]["python"]["options"]
    assert "scripts/griffe_sphinx_roles.py:SphinxRoles" in options["extensions"]
