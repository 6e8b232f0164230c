"""Griffe extension (for mkdocstrings): nao_arena's docstrings are plain text with a few
Sphinx conventions; this turns them into Markdown that reads the same, without touching
the source.

- a role, ``:class:`~nao_arena.world.World``` or ``:func:`load_map```, becomes a code
  span of its name (``World``; with ``~`` the last part only, as Sphinx shows it);
- a paragraph that ends in ``::`` before an indented block ends in ``:`` (the block is
  a code block in Markdown as it is in reStructuredText).
"""

from __future__ import annotations

import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:py:)?[a-z]+:`(~?)([^`<]*?)(?:\s*<([^`>]*)>)?`")
_LITERAL = re.compile(r"(?<=\S)::(?=\n\s*\n)")


def _role(match: re.Match[str]) -> str:
    tilde, text, target = match.groups()
    name = text.strip() or (target or "").strip()
    if tilde and not target:
        name = name.rsplit(".", 1)[-1]
    return f"`{name}`"


def markdown(text: str) -> str:
    """A docstring's text with its Sphinx roles and ``::`` turned into Markdown."""
    return _LITERAL.sub(":", _ROLE.sub(_role, text))


class SphinxText(griffe.Extension):
    """Rewrites every docstring of the loaded packages (see the module's docstring)."""

    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown(obj.docstring.value)

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        self.on_object(obj=pkg)
