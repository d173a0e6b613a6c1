"""The eligibility trace of eq 3, fed by the Gaussian policy's eligibilities (eq 2).

Reading: docs/paper-notes.md section 2.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = [
    "TraceArgs",
    "trace_step",
]


class TraceArgs(NamedTuple):
    """The eligibility trace D (6,) updated in place (eq 3) and its decay gamma.

    For :func:`run_trials_batch`, trace is (B, 6).
    """

    gamma: float
    trace: np.ndarray


@njit(cache=True, inline="always")
def trace_step(
    eps: float,
    sigma: float,
    gamma: float,
    g1: float,
    g2: float,
    g3: float,
    g4: float,
    g5: float,
    d0: float,
    d1: float,
    d2: float,
    d3: float,
    d4: float,
    d5: float,
) -> tuple[float, float, float, float, float, float]:
    """The trace D = e + gamma D of eq 3 after one draw a = mu + eps (eq 5).

    e: the Gaussian policy's eligibilities with the chapter's rescaling
    (docs/paper-notes.md section 2): eps d mu / d W_i for W1..W5 (``g1``..``g5``,
    :func:`policy_mean`'s gradient) and (eps^2 - sigma^2)(1.1 - sigma) for W6.
    """
    return (
        eps * g1 + gamma * d0,
        eps * g2 + gamma * d1,
        eps * g3 + gamma * d2,
        eps * g4 + gamma * d3,
        eps * g5 + gamma * d4,
        (eps * eps - sigma * sigma) * (1.1 - sigma) + gamma * d5,
    )
