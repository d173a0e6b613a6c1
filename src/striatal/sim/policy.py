"""The Gaussian policy of eqs 5, 22-23 and its eligibilities (eq 2).

The readings: docs/paper-notes.md, sections 2-3.

sigma = 0.1 + sigmoid(W6) in both modes. The eligibilities are the score
d ln pi / d W_i with the chapter's rescaling: the mean weights drop 1/sigma^2,
e_i = (a - mu) d mu / d W_i, and the sigma weight is printed as
e_6 = ((a - mu)^2 - sigma^2)(1.1 - sigma), i.e. the score times sigma^3 / (sigma - 0.1).
"""

from __future__ import annotations

import numpy as np

from striatal.params import Controller, Plant
from striatal.sim.control import mean_action

__all__ = [
    "eligibilities",
    "log_prob",
    "log_prob_of",
    "mean_gradient",
    "rescaling",
    "sigma",
]


def sigma(w6: np.ndarray | float) -> np.ndarray:
    """sigma = 0.1 + 1 / (1 + exp(-W6)), eqs 22-23."""
    return 0.1 + 1.0 / (1.0 + np.exp(-np.asarray(w6, dtype=float)))


def log_prob(a: np.ndarray | float, mu: np.ndarray | float, sig: np.ndarray | float) -> np.ndarray:
    """ln pi(a) of the Gaussian of eq 5."""
    a, mu, sig = (np.asarray(v, dtype=float) for v in (a, mu, sig))
    return -0.5 * ((a - mu) / sig) ** 2 - np.log(sig) - 0.5 * np.log(2.0 * np.pi)


def log_prob_of(
    a: float, state: np.ndarray, W: np.ndarray, controller: Controller, plant: Plant
) -> float:
    """ln pi(a | state, W) of the switched policy."""
    mu = mean_action(state, controller, plant, W=W)
    return float(log_prob(a, mu, sigma(W[5])))


def mean_gradient(
    state: np.ndarray,
    W: np.ndarray,
    controller: Controller,
    plant: Plant,
    chapter_form: bool = False,
) -> np.ndarray:
    """d mu / d W1..W5 (5,) at one state, analytically (eqs 22-23).

    ``chapter_form`` replaces the W1 entry by the chapter's printed
    -l (g theta - sqrt(g / W1) theta_dot) (docs/paper-notes.md section 2).
    """
    from striatal.sim.control import switch_weights
    from striatal.sim.dynamics import energy_error, wrap_angle

    s = np.asarray(state, dtype=float)
    l, g = plant.length, plant.gravity
    th = float(wrap_angle(s[2]))
    wb, ws = (
        float(w)
        for w in switch_weights(
            np.array(s[2]), controller.theta_c, controller.soft, controller.inhibition
        )
    )
    grad = np.zeros(5)
    if wb > 0:
        if chapter_form:
            d1 = -l * (g * th - np.sqrt(g / W[0]) * s[3])
        else:
            d1 = controller.sign * l * (g * th + np.sqrt(g / W[0]) * s[3])
        grad[:3] = wb * np.array([d1, -s[0], -s[1]])
    if ws > 0:
        e_t = float(energy_error(s, plant))
        grad[3] = ws * e_t * s[3] * np.cos(th)
        grad[4] = -ws * (0.5 * W[4] * s[0] + s[1])
    return grad


def eligibilities(
    a: float,
    state: np.ndarray,
    W: np.ndarray,
    controller: Controller,
    plant: Plant,
    chapter_form: bool = False,
) -> np.ndarray:
    """e (6,) of the chapter (after eq 23) at one state and action."""
    mu = float(mean_action(state, controller, plant, W=W))
    sig = float(sigma(W[5]))
    eps = a - mu
    e = np.empty(6)
    e[:5] = eps * mean_gradient(state, W, controller, plant, chapter_form)
    e[5] = (eps**2 - sig**2) * (1.1 - sig)
    return e


def rescaling(W: np.ndarray) -> np.ndarray:
    """Factors c_i with e_i = c_i * d ln pi / d W_i (the chapter's rescaling, section 1.2)."""
    sig = float(sigma(W[5]))
    c = np.full(6, sig**2)
    c[5] = sig**3 / (sig - 0.1)
    return c
