"""The progress bar of a long command: on stderr, only on a terminal, off with --no-progress.

train and sweep draw theirs with the same rule; evaluate and neural use this one.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


def add_progress_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def shown(args: argparse.Namespace) -> bool:
    """A bar only on a terminal, never with --json or --no-progress."""
    return not (args.no_progress or getattr(args, "json", False)) and sys.stderr.isatty()


def bar(args: argparse.Namespace, *, total: float, unit: str) -> Any:
    """A tqdm bar on stderr (disabled unless :func:`shown`); close it when done."""
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, disable=not shown(args), file=sys.stderr)
