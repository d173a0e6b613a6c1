"""The neural reading of section 4: mu_1 and mu_2 as sums of direct and indirect pathway
activity, and the learning updates as dopamine-gated LTP and LTD.

Section 4 writes the learned control signals as linear forms with numeric
coefficients and reads "positive coefficients as excitatory signal processing as the
direct pathway, and negative coefficients as inhibitory signal processing along the
indirect pathway"; a reward +10 is a phasic dopamine increase (burst), -5 a decrease
(dip); a gain that grows is LTP, one that shrinks is LTD.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.params import Plant, check_gains, check_theta_c
from striatal.sim.kernel.policy import swingup_coefficients

__all__ = [
    "CHAPTER_PRINTED_MU1",
    "CHAPTER_PRINTED_MU2",
    "SIGN_NOTE",
    "Pathway",
    "Plasticity",
    "Term",
    "balancing_terms",
    "linear_form",
    "pathway",
    "pathway_coefficients",
    "plasticity_table",
    "reading",
    "swingup_terms",
]

Pathway = Literal["direct", "indirect", "silent"]

#: mu_1 as section 4 prints it, for the chapter's final W (coefficients of theta,
#: theta_dot, x, x_dot).
CHAPTER_PRINTED_MU1 = {"theta": -21.5, "theta_dot": -6.84, "x": 0.31, "x_dot": 0.8}
#: mu_2 as section 4 prints it (coefficients of E~ theta_dot cos theta, x, x_dot).
CHAPTER_PRINTED_MU2 = {"energy_pump": 0.36, "x": -0.02, "x_dot": -0.29}

SIGN_NOTE = (
    "The chapter prints mu_1 = -21.5 theta - 6.84 theta_dot + 0.31 x + 0.8 x_dot for its "
    "final W. With its own linearization (eq 18) that sign makes the upright unstable; "
    "this project's default (--balance-sign corrected, docs/paper-notes.md section 1) "
    "puts + on both theta terms: +21.30 theta + 6.78 theta_dot for the chapter's final W."
    " Under the corrected sign the theta and theta_dot terms therefore read as direct "
    "(excitatory) pathway activity, where the printed form reads them as indirect "
    "(inhibitory). The cart terms (-W2 x - W3 x_dot) keep the printed sign."
)


def pathway(coefficient: float) -> Pathway:
    """Section 4: positive -> direct (excitatory), negative -> indirect (inhibitory)."""
    if coefficient > 0:
        return "direct"
    if coefficient < 0:
        return "indirect"
    return "silent"


@dataclass(frozen=True)
class Term:
    """One term of mu_1 or mu_2: ``coefficient * signal``."""

    signal: str
    coefficient: float
    formula: str
    pathway: Pathway

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def _term(signal: str, coefficient: float, formula: str) -> Term:
    return Term(signal, float(coefficient), formula, pathway(coefficient))


def balancing_terms(W: Sequence[float], plant: Plant, sign: float = 1.0) -> tuple[Term, ...]:
    """mu_1 of eq 22 as c_theta theta + c_thetadot theta_dot + c_x x + c_xdot x_dot.

    c_theta = s (1 + W1 l) g, c_thetadot = s 2 l sqrt(W1 g), c_x = -W2, c_xdot = -W3;
    s = +1 for the corrected law, -1 for the law as printed (docs/paper-notes.md section 1).
    """
    w = check_gains(W)
    if sign not in (1.0, -1.0):
        raise ParameterError(f"sign must be +1 or -1, got {sign}")
    l, g = plant.length, plant.gravity
    s = "+" if sign > 0 else "-"
    return (
        _term("theta", sign * (1.0 + w[0] * l) * g, f"{s}(1 + W1 l) g"),
        _term("theta_dot", sign * 2.0 * l * math.sqrt(w[0] * g), f"{s}2 l sqrt(W1 g)"),
        _term("x", -w[1], "-W2"),
        _term("x_dot", -w[2], "-W3"),
    )


def swingup_terms(W: Sequence[float]) -> tuple[Term, ...]:
    """mu_2 of eq 23 as W4 (E~ theta_dot cos theta) - (W5^2 / 4) x - W5 x_dot, the
    coefficients of the kernel's law (:func:`striatal.sim.kernel.swingup_coefficients`)."""
    w = check_gains(W, need_positive_w1=False)
    # the kernel's own definition, run as plain Python: a reading compiles nothing
    pump, on_x, on_x_dot = swingup_coefficients.py_func(w[3], w[4])
    return (
        _term("energy_pump", pump, "W4"),
        _term("x", on_x, "-W5^2/4"),
        _term("x_dot", on_x_dot, "-W5"),
    )


def pathway_coefficients(W: object, plant: Plant, sign: float = 1.0) -> np.ndarray:
    """c(W), the seven pathway coefficients of eqs 22-23, (7,): the terms of
    :func:`balancing_terms` then :func:`swingup_terms`."""
    w = check_gains(W)
    terms = (*balancing_terms(w, plant, sign), *swingup_terms(w))
    return np.array([t.coefficient for t in terms])


_SYMBOL = {
    "theta": "θ",
    "theta_dot": "θ̇",
    "x": "x",
    "x_dot": "ẋ",
    "energy_pump": "Ẽ θ̇ cos θ",
}


def linear_form(name: str, terms: Sequence[Term], digits: int = 4) -> str:
    """``"mu_1 = +21.3 θ + 6.783 θ̇ ..."`` with ``digits`` significant digits."""
    parts = []
    for k, t in enumerate(terms):
        mag = f"{abs(t.coefficient):.{digits}g}"
        op = ("-" if t.coefficient < 0 else "") if k == 0 else ("- " if t.coefficient < 0 else "+ ")
        parts.append(f"{op}{mag} {_SYMBOL.get(t.signal, t.signal)}")
    return f"{name} = " + " ".join(parts)


# --------------------------------------------------------------------------- plasticity


@dataclass(frozen=True)
class Plasticity:
    """Counts of updates of one weight, split by the sign of the reward that drove them.

    An update is W(trial k + 1) - W(trial k), the change made after trial k's reward.
    """

    weight: str
    ltp_after_burst: int
    ltd_after_burst: int
    ltp_after_dip: int
    ltd_after_dip: int
    unchanged: int

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def plasticity_table(W: np.ndarray, reward: np.ndarray) -> tuple[Plasticity, ...]:
    """LTP/LTD counts per gain from the W used in successive trials and their rewards.

    ``W``: (n, 6), the gains used in trials 1..n (history.csv); ``reward``: (n,).
    The n - 1 updates between consecutive trials are counted; the update after the
    last trial is not in the history. A positive reward is a dopamine burst, a
    negative one a dip (section 4).
    """
    Wa = np.asarray(W, dtype=float)
    r = np.asarray(reward, dtype=float)
    if Wa.ndim != 2 or Wa.shape[1] != 6 or r.shape != (Wa.shape[0],):
        raise ParameterError("plasticity_table needs W of shape (n, 6) and reward of shape (n,)")
    dW = np.diff(Wa, axis=0)
    rr = r[:-1]
    burst, dip = rr > 0, rr < 0
    table = []
    for i in range(6):
        d = dW[:, i]
        table.append(
            Plasticity(
                weight=f"W{i + 1}",
                ltp_after_burst=int(np.sum((d > 0) & burst)),
                ltd_after_burst=int(np.sum((d < 0) & burst)),
                ltp_after_dip=int(np.sum((d > 0) & dip)),
                ltd_after_dip=int(np.sum((d < 0) & dip)),
                unchanged=int(np.sum(d == 0)),
            )
        )
    return tuple(table)


def reading(
    W: Sequence[float],
    theta_c: float,
    plant: Plant,
    balance_sign: str = "corrected",
) -> dict[str, object]:
    """The whole section-4 reading of one gain set as a JSON-ready dict."""
    if balance_sign not in ("corrected", "chapter"):
        raise ParameterError(f"balance_sign must be 'corrected' or 'chapter', got {balance_sign!r}")
    sign = 1.0 if balance_sign == "corrected" else -1.0
    mu1 = balancing_terms(W, plant, sign)
    mu2 = swingup_terms(W)
    return {
        "W": list(check_gains(W)),
        "theta_c": check_theta_c(theta_c),
        "balance_sign": balance_sign,
        "plant": {"length": plant.length, "gravity": plant.gravity},
        "mu_1": {
            "form": linear_form("mu_1", mu1),
            "terms": [t.to_dict() for t in mu1],
        },
        "mu_2": {
            "form": linear_form("mu_2", mu2),
            "terms": [t.to_dict() for t in mu2],
        },
        "chapter_printed": {"mu_1": CHAPTER_PRINTED_MU1, "mu_2": CHAPTER_PRINTED_MU2},
        "sign_note": SIGN_NOTE,
    }
