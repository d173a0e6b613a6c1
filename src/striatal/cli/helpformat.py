"""The help formatter of every command: each default stated once, and only when it says something.

argparse's ``ArgumentDefaultsHelpFormatter`` appends ``(default: X)`` to every option,
``(default: None)`` for an option whose default is "not given" and a second default
after help that already states one ("default 2000 (default: None)"). This one
appends ``(default: X)`` only when X is a value (not None, not a flag's False) and
the help does not already say "default".
"""

from __future__ import annotations

import argparse
import re
from pathlib import PurePath
from typing import Any

#: Help that already states its default ("default 2000", "(default: the one beside ...)").
STATES_DEFAULT = re.compile(r"\bdefault", re.IGNORECASE)

# Flags: their default is the absence of the flag, which says nothing.
_FLAG_ACTIONS: tuple[type[argparse.Action], ...] = (
    argparse._StoreTrueAction,
    argparse._StoreFalseAction,
    argparse._StoreConstAction,
    argparse._AppendConstAction,
    argparse._CountAction,
    argparse._HelpAction,
    argparse._VersionAction,
)


def default_text(value: Any) -> str:
    """A default as a user writes it on the command line: lists comma-separated."""
    if isinstance(value, list | tuple):
        return ",".join(default_text(v) for v in value)
    if isinstance(value, PurePath):
        return str(value)
    return str(value)


def default_note(text: str) -> str:
    """``(default: text)``: how help states a default that argparse does not hold (an
    option whose default depends on another, or is "none")."""
    return f"(default: {text})"


def states_default(action: argparse.Action) -> bool:
    """Whether the help appends ``(default: X)`` to this action's help."""
    if action.default is None or action.default is argparse.SUPPRESS:
        return False
    if isinstance(action, _FLAG_ACTIONS):
        return False
    if not action.option_strings and action.nargs not in (argparse.OPTIONAL, argparse.ZERO_OR_MORE):
        return False  # a required positional has no default
    if isinstance(action.default, list | tuple) and not action.default:
        return False  # an empty list: "none", which the help says if it matters
    return not STATES_DEFAULT.search(action.help or "")


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """``(default: X)`` after an option's help, once, and never ``(default: None)``."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if not states_default(action):
            return text
        # the help is %-expanded by argparse: a % in the default must stay literal
        stated = default_text(action.default).replace("%", "%%")
        return f"{text} {default_note(stated)}" if text else default_note(stated)
