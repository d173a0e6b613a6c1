"""Sizes checked before they are allocated.

A count computed from user input (snapshots, frames, steps) is computed in
floating point first and refused with a :class:`~striatal.errors.ParameterError`
when it is not finite or exceeds its cap, so no array is ever built just to find
out that it is too big (docs/reliability.md).
"""

from __future__ import annotations

import math

from striatal.errors import ParameterError

__all__ = [
    "count_of_steps",
]


def count_of_steps(span: float, step: float, *, cap: int, what: str, fix: str) -> int:
    """``floor(span / step) + 1``: the points 0, step, 2 step, ... <= span, at most ``cap``.

    ``span`` [s] >= 0 and ``step`` [s] > 0, both finite. ``what`` names the points in the
    message ("frames"), ``fix`` says which option to change. Raises ParameterError
    without allocating anything when the count is above ``cap`` (or not finite).
    """
    if not (math.isfinite(step) and step > 0):
        raise ParameterError(f"the interval between {what} must be a finite number > 0, got {step}")
    if not (math.isfinite(span) and span >= 0):
        raise ParameterError(f"the time span must be a finite number >= 0 s, got {span}")
    n = span / step + 1.0  # a float: inf or 1e300 here is refused, not allocated
    if not n <= cap + 1:
        shown = f"{n:,.0f}" if n < 1e12 else f"{n:.3g}" if math.isfinite(n) else "too many"
        raise ParameterError(f"{shown} {what} is more than {cap:,}: {fix}")
    n_points = int(math.floor(span / step + 1e-9)) + 1
    if n_points > cap:
        raise ParameterError(f"{n_points:,} {what} is more than {cap:,}: {fix}")
    return n_points
