"""A Griffe extension that renders the docstrings' Sphinx roles as cross-references when the docs are built.

The package's docstrings name other objects with Sphinx roles (``:func:`make_maze_env```,
``:class:`~antmaze_hirl.envs.reach.ReachEnv```); mkdocstrings renders Markdown, so without this the API pages
would show the roles as raw text. mkdocs.yml loads it through mkdocstrings-python's ``extensions:`` option;
once Griffe has built the object tree, every docstring's roles become mkdocs-autorefs references:

* a target Griffe finds (a full path, or a name resolved in the docstring's own scope: its members, its
  parents, its module's imports) becomes ``<autoref identifier="full.path" optional>``, a link when that
  object is rendered on some page and plain code when not (``optional``: no warning, so ``--strict`` holds);
* any other target (``gymnasium.vector.VectorEnv``, an attribute of a dependency) becomes inline code.

As Sphinx does, ``~`` shows only the last component, ``title <target>`` shows the title, and ``:func:`` and
``:meth:`` add ``()``. Written here rather than taken from a package: mkdocstrings has no Sphinx-role handler
(its docs suggest this kind of Griffe extension), and this is the one place that knows the package's scopes.
The docstrings themselves are not touched.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(r"(?::py)?:(?P<role>func|class|data|mod|meth|attr|exc|obj|const|type):`(?P<body>[^`]+)`")
EXPLICIT_TITLE = re.compile(r"^(?P<title>.+?)\s*<(?P<target>[^<>]+)>$")
CALLABLE_ROLES = ("func", "meth")


def resolve_target(obj: griffe.Object, target: str, collection: Any) -> str | None:
    """The full path of role target ``target`` seen from ``obj``'s docstring, or ``None`` if Griffe lacks it."""
    name = target.lstrip(".")
    first, _, rest = name.partition(".")
    if first in collection.members:  # a full path: `antmaze_hirl.envs.reach.ReachEnv`
        path = name
    else:
        try:
            path = obj.resolve(first) + (f".{rest}" if rest else "")
        except (griffe.NameResolutionError, ValueError):
            return None
    try:
        found = collection[path]
    except (KeyError, ValueError):
        return None
    if found.is_alias:  # a re-export: link where the object is documented, its own path
        try:
            return found.final_target.path
        except (griffe.AliasResolutionError, griffe.CyclicAliasError):
            return found.target_path
    return found.path


def render_role(obj: griffe.Object, role: str, body: str, collection: Any) -> str:
    """One role as an optional autoref (resolved) or inline code (not)."""
    explicit = EXPLICIT_TITLE.match(body)
    target = (explicit["target"] if explicit else body).strip()
    short = target.startswith("~")
    target = target.lstrip("~")
    if explicit:
        title = explicit["title"]
    else:
        title = target.rsplit(".", 1)[-1] if short else target.lstrip(".")
        if role in CALLABLE_ROLES and not title.endswith(")"):
            title += "()"
    path = resolve_target(obj, target, collection)
    if path is None:
        return f"`{title}`"
    return f'<autoref identifier="{html.escape(path)}" optional><code>{html.escape(title)}</code></autoref>'


def render_roles(obj: griffe.Object, text: str, collection: Any) -> str:
    """``text`` with every Sphinx role of ``obj``'s docstring rendered (:func:`render_role`)."""
    return ROLE.sub(lambda match: render_role(obj, match["role"], match["body"], collection), text)


class SphinxRoles(griffe.Extension):
    """Rewrites the Sphinx roles of every loaded docstring once the object tree is complete."""

    def on_object(self, *, obj: griffe.Object, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        """Renders ``obj``'s docstring's roles (its own docstring only: aliases share their target's)."""
        if obj.is_alias or obj.docstring is None or ":`" not in obj.docstring.value:
            return
        obj.docstring.value = render_roles(obj, obj.docstring.value, loader.modules_collection)

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        """Renders the top package's own docstring, which ``on_object`` does not visit."""
        self.on_object(obj=pkg, loader=loader)
