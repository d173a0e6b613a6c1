"""List-valued options, one convention for every command: comma-separated values.

``--init chapter,random``, ``--alpha-grid 0.5,1,2``, ``--variants chapter,pgpe``. The
forms of the previous release are still read for one release, each with one
deprecation line on stderr: space-separated words (``--init chapter random``,
``legacy_spaces=True``) and a repeated option (``robustness --variant A --variant B``,
:func:`add_repeated_alias`).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any

_quiet = False


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """No deprecation lines while the same command line is parsed a second time."""
    global _quiet
    before, _quiet = _quiet, True
    try:
        yield
    finally:
        _quiet = before


def deprecated(parser: argparse.ArgumentParser, old: str, new: str) -> None:
    """One line on stderr: ``old`` still works in this release, ``new`` is the spelling."""
    if _quiet:
        return
    sys.stderr.write(
        f"{parser.prog}: warning: {old!r} is deprecated and goes in the next release; "
        f"write {new!r}\n"
    )


class CommaList(argparse.Action):
    """An option whose value is a comma-separated list; stored as a tuple of ``item``.

    ``item`` converts one value (``float``, ``str``); ``names`` restricts the values to
    a set of names. With ``legacy_spaces`` the option also takes space-separated words,
    the old form, and says it is deprecated.
    """

    def __init__(
        self,
        option_strings: Sequence[str],
        dest: str,
        *,
        item: Callable[[str], Any] = str,
        names: Sequence[str] | None = None,
        legacy_spaces: bool = False,
        **kwargs: Any,
    ) -> None:
        if "metavar" not in kwargs:
            one = "{" + ",".join(names) + "}" if names else dest.upper().split("_")[0]
            kwargs["metavar"] = f"{one}[,...]"
        super().__init__(option_strings, dest, nargs="+" if legacy_spaces else None, **kwargs)
        self.item = item
        self.names = tuple(names) if names else None

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        words = [values] if isinstance(values, str) else list(values or [])
        flag = option_string or self.dest
        if len(words) > 1:
            deprecated(parser, f"{flag} {' '.join(words)}", f"{flag} {','.join(words)}")
        setattr(namespace, self.dest, self.parse(",".join(words)))

    def parse(self, text: str) -> tuple[Any, ...]:
        """The values of ``text`` (comma-separated), converted and checked."""
        items = []
        for part in (p.strip() for p in text.split(",")):
            if not part:
                continue
            if self.names is not None and part not in self.names:
                raise argparse.ArgumentError(
                    self, f"invalid choice {part!r} (choose from {', '.join(self.names)})"
                )
            try:
                items.append(self.item(part))
            except (ValueError, argparse.ArgumentTypeError) as exc:
                raise argparse.ArgumentError(
                    self, f"{part!r} in the comma-separated list: {exc}"
                ) from None
        if not items and self.default != ():
            raise argparse.ArgumentError(self, f"the list {text!r} names nothing")
        return tuple(items)


class _RepeatedAlias(argparse.Action):
    """The old repeated spelling of a list option: each use adds one value, deprecated."""

    def __init__(self, option_strings: Sequence[str], dest: str, *, new: str, **kwargs: Any):
        super().__init__(option_strings, dest, **kwargs)
        self.new = new

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        deprecated(parser, f"{option_string} {values}", f"{self.new} A,B,...")
        setattr(namespace, self.dest, (*(getattr(namespace, self.dest, None) or ()), values))


def add_repeated_alias(parser: argparse.ArgumentParser, old: str, new: str, dest: str) -> None:
    """Accept ``old X`` (repeatable) as one more value of the list option ``new``."""
    parser.add_argument(
        old,
        dest=dest,
        action=_RepeatedAlias,
        new=new,
        default=argparse.SUPPRESS,
        help=argparse.SUPPRESS,
    )
