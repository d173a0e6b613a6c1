"""List-valued options, one convention for every command: comma-separated values.

``--init chapter,random``, ``--alpha-grid 0.5,1,2``, ``--variants chapter,pgpe``: one
word, so a list never swallows the words after it.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from typing import Any

#: The most values one list option takes (a grid of 1 000 alphas is already 1 000 arms).
MAX_ITEMS = 1_000


class CommaList(argparse.Action):
    """An option whose value is a comma-separated list; stored as a tuple of ``item``.

    ``item`` converts one value (``float``, ``str``); ``names`` restricts the values to
    a set of names.
    """

    def __init__(
        self,
        option_strings: Sequence[str],
        dest: str,
        *,
        item: Callable[[str], Any] = str,
        names: Sequence[str] | None = None,
        max_items: int = MAX_ITEMS,
        **kwargs: Any,
    ) -> None:
        if "metavar" not in kwargs:
            one = "{" + ",".join(names) + "}" if names else dest.upper().split("_")[0]
            kwargs["metavar"] = f"{one}[,...]"
        super().__init__(option_strings, dest, **kwargs)
        self.item = item
        self.names = tuple(names) if names else None
        self.max_items = max_items

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        setattr(namespace, self.dest, self.parse(str(values)))

    def parse(self, text: str) -> tuple[Any, ...]:
        """The values of ``text`` (comma-separated), converted and checked; at most
        ``max_items`` (:data:`MAX_ITEMS`) of them."""
        if text.count(",") >= self.max_items:
            raise argparse.ArgumentError(
                self,
                f"at most {self.max_items:,} comma-separated values, got {text.count(',') + 1:,}",
            )
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
