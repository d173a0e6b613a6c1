"""Griffe extension for the API reference: striatal's ``name : description`` lines.

striatal's docstrings use numpydoc sections but write ``name : description`` on one
line (the type is in the signature), where numpydoc reads the text after the colon
as a type. Before griffe parses a docstring, this moves that text to the next line,
where numpydoc expects the description. Only the lines directly under a
Parameters, Attributes or Other Parameters heading are touched. Sphinx roles
(``:func:`name```) become inline code.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

_SECTIONS = {"Parameters", "Attributes", "Other Parameters"}
_ITEM = re.compile(r"^(?P<name>\*{0,2}[A-Za-z_]\w*(?:, \*{0,2}[A-Za-z_]\w*)*) : (?P<text>.+)$")
_ROLE = re.compile(r":(?:func|class|mod|data|meth|attr|exc):`~?(?P<target>[\w.]+)`")


def split_items(text: str) -> str:
    """``text`` with each section item ``name : description`` split over two lines."""
    lines = text.splitlines()
    out: list[str] = []
    section = None
    for i, line in enumerate(lines):
        underline = i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}
        if underline:
            section = line.strip()
        elif not line.strip() and i + 1 < len(lines) and not lines[i + 1].startswith(" "):
            # A blank line followed by unindented prose ends the section.
            nxt = lines[i + 1].strip()
            if nxt and not _ITEM.match(nxt):
                section = None
        m = _ITEM.match(line) if section in _SECTIONS else None
        if m:
            out.append(m.group("name"))
            out.append("    " + m.group("text"))
        else:
            out.append(line)
    return "\n".join(out)


def plain_roles(text: str) -> str:
    """Sphinx roles (``:func:`~striatal.sim.kernel.rk4_step```) as inline code.

    Not cross-references: many roles name a target relative to their module, which
    autorefs cannot resolve, and strict mode would fail on each of them.
    """
    return _ROLE.sub(lambda m: f"`{m['target']}`", text)


class DescriptionAfterName(griffe.Extension):
    """Rewrite every docstring with :func:`split_items` before it is parsed."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = plain_roles(split_items(obj.docstring.value))
