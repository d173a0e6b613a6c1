"""argparse types that refuse a value when it is parsed, before anything is computed.

``type=bounded_int(1, 4096)`` or ``type=bounded_float(0, 600)`` in ``add_argument``:
a value out of range, not finite, or not a number is one line on stderr and exit 2
from the parser, so no command can build an array of that size or overflow on it.
Every parser of the command line reads ``type=int`` as :func:`whole_number`, so no
whole-number option exceeds :data:`MAX_WHOLE` (what a compiled int32 holds).
``action=Refused, message=...``: an option that means something else in this command
(another command's option, an old spelling), refused by name in one line when parsed.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from typing import Any

#: The largest whole number any option takes: 2**31 - 1, an int32 (the kernel's counts).
MAX_WHOLE = 2**31 - 1


def whole_number(text: str) -> int:
    """``int(text)`` within [-MAX_WHOLE, MAX_WHOLE]: the ``type=int`` of every option.

    Text that is no whole number raises ValueError, which argparse reports as
    "invalid int value"; a larger one is refused by name, before any work.
    """
    value = int(text)
    if not -MAX_WHOLE <= value <= MAX_WHOLE:
        shown = text if len(text) <= 24 else f"{text[:20]}... ({len(text.strip())} digits)"
        raise argparse.ArgumentTypeError(f"must be at most {MAX_WHOLE:,} in size, got {shown}")
    return value


whole_number.__name__ = "int"
whole_number.numeric = True  # type: ignore[attr-defined]


def bounded_int(low: int, high: int) -> Callable[[str], int]:
    """A whole number in [low, high]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in [{low:,}, {high:,}], got {value:,}")
        return value

    parse.__name__ = "whole number"
    parse.numeric = True  # type: ignore[attr-defined]
    return parse


def bounded_float(low: float, high: float, *, low_open: bool = True) -> Callable[[str], float]:
    """A finite number in (low, high] (or [low, high] with ``low_open=False``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        above = value > low if low_open else value >= low
        if not (math.isfinite(value) and above and value <= high):
            bracket = "(" if low_open else "["
            raise argparse.ArgumentTypeError(f"must be in {bracket}{low:g}, {high:g}], got {text}")
        return value

    parse.__name__ = "number"
    parse.numeric = True  # type: ignore[attr-defined]
    return parse


class Refused(argparse.Action):
    """An option this command does not take under that name: ``message(value)`` as one
    line on stderr and exit 2 from the parser, before anything is computed or written.
    Hidden from ``--help``; its dest is never read."""

    def __init__(
        self, option_strings: Sequence[str], dest: str, message: Callable[[str], str], **kw: Any
    ) -> None:
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kw)
        self.message = message

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        parser.error(self.message(str(values)))
