"""The chapter's controllers in plain NumPy: swing-up (eqs 15-17, 23), balancing
(eqs 18-20, 22), hard and soft (cerebellar, section 4) switching.

Vectorised over leading axes of ``state`` (..., 4). The compiled twin is
:func:`striatal.sim.kernel.policy_mean`. These laws are written apart from the kernel's
on purpose: they are the independent plain-NumPy reference the kernel is tested against
(tests/test_control.py, :mod:`striatal.sim.reference`), so they never call it.
"""

from __future__ import annotations

import numpy as np

from striatal.params import Controller, Plant
from striatal.sim.dynamics import energy_error, wrap_angle

__all__ = [
    "balancing_gain_matrix",
    "balancing_mean",
    "mean_action",
    "swingup_mean",
    "switch_weights",
]


def balancing_mean(state: np.ndarray, W: np.ndarray, plant: Plant, sign: float = 1.0) -> np.ndarray:
    """mu_1, eq 22: sign ((1 + W1 l) g theta + 2 l sqrt(W1 g) theta_dot) - W2 x - W3 x_dot.

    sign = +1 is the corrected law (docs/paper-notes.md section 1), -1 the printed one.
    """
    s = np.asarray(state, dtype=float)
    l, g = plant.length, plant.gravity
    th = wrap_angle(s[..., 2])
    return (
        sign * ((1.0 + W[0] * l) * g * th + 2.0 * l * np.sqrt(W[0] * g) * s[..., 3])
        - W[1] * s[..., 0]
        - W[2] * s[..., 1]
    )


def swingup_mean(state: np.ndarray, W: np.ndarray, plant: Plant) -> np.ndarray:
    """mu_2, eq 23: W4 E~ theta_dot cos theta - W5^2/4 x - W5 x_dot.

    This is eq 17 with k_s / (m l) = W4 and k_c = W5; the reference of the kernel's
    :func:`striatal.sim.kernel.swingup_law`.
    """
    s = np.asarray(state, dtype=float)
    th = wrap_angle(s[..., 2])
    e_tilde = energy_error(s, plant)
    return W[3] * e_tilde * s[..., 3] * np.cos(th) - 0.25 * W[4] ** 2 * s[..., 0] - W[4] * s[..., 1]


def switch_weights(
    theta: np.ndarray, theta_c: float, soft: bool, inhibition: float
) -> tuple[np.ndarray, np.ndarray]:
    """(balancing weight, swing-up weight) of the hard switch (section 2.3) or the
    cerebellar soft switch (section 4, docs/paper-notes.md section 4):
    clip(gamma (theta_c - |theta|), 0, 1) and clip(gamma (|theta| - theta_c), 0, 1)."""
    a = np.abs(wrap_angle(theta))
    if not soft:
        wb = (a < theta_c).astype(float)
        return wb, 1.0 - wb
    return (
        np.clip(inhibition * (theta_c - a), 0.0, 1.0),
        np.clip(inhibition * (a - theta_c), 0.0, 1.0),
    )


def mean_action(
    state: np.ndarray, controller: Controller, plant: Plant, W: np.ndarray | None = None
) -> np.ndarray:
    """The switched mean action mu = w_b mu_1 + w_s mu_2 (eqs 21-23, section 4)."""
    Wv = np.asarray(controller.gains if W is None else W, dtype=float)
    s = np.asarray(state, dtype=float)
    wb, ws = switch_weights(s[..., 2], controller.theta_c, controller.soft, controller.inhibition)
    with np.errstate(invalid="ignore"):
        mu1 = balancing_mean(s, Wv, plant, controller.sign)
    mu2 = swingup_mean(s, Wv, plant)
    return np.where(wb > 0, wb * mu1, 0.0) + np.where(ws > 0, ws * mu2, 0.0)


def balancing_gain_matrix(W: np.ndarray, plant: Plant, sign: float = 1.0) -> np.ndarray:
    """K (1, 4) with mu_1 = -K state near the upright (theta small)."""
    l, g = plant.length, plant.gravity
    return np.array(
        [[W[1], W[2], -sign * (1.0 + W[0] * l) * g, -sign * 2.0 * l * np.sqrt(W[0] * g)]]
    )
