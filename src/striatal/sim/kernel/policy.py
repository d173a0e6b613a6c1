"""The controllers and the Gaussian policy: the switch (section 2.3, section 4), the
balancing (eq 22) and swing-up (eq 23) means, sigma (eq 5 with eqs 22-23) and d mu / d W.

Readings: docs/paper-notes.md, sections 1-4.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from striatal.sim.kernel.libm import wrap_angle

__all__ = [
    "MODE_BALANCE",
    "MODE_SWINGUP",
    "BatchGains",
    "ControlArgs",
    "Gains",
    "PolicyTerms",
    "balancing_law",
    "balancing_roots",
    "policy_gradient",
    "policy_mean",
    "policy_of",
    "policy_terms",
    "sigma_of",
    "swingup_coefficients",
    "swingup_law",
    "switch_weights",
]

MODE_SWINGUP = 0
MODE_BALANCE = 1


class Gains(NamedTuple):
    """The learned parameters of one trial: W1..W6 (eqs 22-23), (6,), and the switching
    threshold theta_c (eq 21)."""

    W: np.ndarray
    theta_c: float


class BatchGains(NamedTuple):
    """The learned parameters of B trials (the batch kernels): row b of ``W`` (B, 6) and
    ``theta_c`` (B,) is trial b's :class:`Gains`."""

    W: np.ndarray
    theta_c: np.ndarray


class ControlArgs(NamedTuple):
    """The controller's readings: eq-20 sign (+1 corrected, -1 printed), switch, action rate.

    ``inhibition``: gamma of the soft switch; ``action_every``: steps an action is held;
    ``chapter_eligibility``: the printed e1 instead of the score (docs/paper-notes.md section 2).
    """

    sign: float
    soft: bool
    inhibition: float
    action_every: int
    chapter_eligibility: bool


@njit(cache=True, inline="always")
def switch_weights(
    abs_theta: float, theta_c: float, soft: bool, inhibition: float
) -> tuple[float, float]:
    """(balancing weight, swing-up weight).

    Hard switch (section 2.3): balancing while |theta| < theta_c. Soft switch
    (section 4, read as in docs/paper-notes.md section 4): clip(gamma (theta_c - |theta|), 0, 1)
    and clip(gamma (|theta| - theta_c), 0, 1).
    """
    if not soft:
        if abs_theta < theta_c:
            return 1.0, 0.0
        return 0.0, 1.0
    wb = min(max(inhibition * (theta_c - abs_theta), 0.0), 1.0)
    ws = min(max(inhibition * (abs_theta - theta_c), 0.0), 1.0)
    return wb, ws


@njit(cache=True)
def sigma_of(w6: float) -> float:
    """Policy standard deviation sigma = 0.1 + 1 / (1 + exp(-W6)), eqs 22-23.

    Reading: docs/paper-notes.md section 3.
    """
    return 0.1 + 1.0 / (1.0 + math.exp(-w6))


class PolicyTerms(NamedTuple):
    """The policy of a trial as plain floats (:func:`policy_of`): W1..W5, theta_c, sigma
    (eq 5), sqrt(W1 g) and sqrt(g / W1) (eq 22), the readings of :class:`ControlArgs` and
    the model's m [kg], l [m], g [m/s^2]. Rebuilt when the gains change."""

    w1: float
    w2: float
    w3: float
    w4: float
    w5: float
    theta_c: float
    sigma: float
    root: float
    inv_root: float
    sign: float
    soft: bool
    inhibition: float
    chapter_eligibility: bool
    m: float
    length: float
    g: float


@njit(cache=True)
def policy_of(
    W: np.ndarray, theta_c: float, control: ControlArgs, m: float, length: float, g: float
) -> PolicyTerms:
    """The :class:`PolicyTerms` of gains W (6,) (or (5,): sigma NaN), theta_c and the model."""
    root, inv_root = balancing_roots(W[0], g)
    sigma = sigma_of(W[5]) if W.shape[0] > 5 else math.nan
    return PolicyTerms(
        W[0],
        W[1],
        W[2],
        W[3],
        W[4],
        theta_c,
        sigma,
        root,
        inv_root,
        control.sign,
        control.soft,
        control.inhibition,
        control.chapter_eligibility,
        m,
        length,
        g,
    )


@njit(cache=True)
def policy_mean(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    W: np.ndarray,
    theta_c: float,
    sign: float,
    soft: bool,
    inhibition: float,
    model: np.ndarray,
    chapter_eligibility: bool,
    grad: np.ndarray,
) -> float:
    """Mean action mu (eq 22 or 23, blended by the switch) and d mu / d W1..W5 into ``grad``.

    ``theta`` is wrapped first. Balancing, eq 22 with the sign reading ``sign``
    (+1 corrected, -1 printed):
    mu1 = sign ((1 + W1 l) g theta + 2 l sqrt(W1 g) theta_dot) - W2 x - W3 x_dot.
    Swing-up, eq 23: mu2 = W4 E~ theta_dot cos theta - W5^2/4 x - W5 x_dot.
    With ``chapter_eligibility`` the W1 entry is the chapter's printed
    -l (g theta - sqrt(g / W1) theta_dot) instead of the true derivative.
    """
    control = ControlArgs(sign, soft, inhibition, 1, chapter_eligibility)
    pol = policy_of(W, theta_c, control, model[1], model[2], model[3])
    mu, g1, g2, g3, g4, g5 = policy_terms(x, x_dot, wrap_angle(theta), theta_dot, 0.0, False, pol)
    grad[0] = g1
    grad[1] = g2
    grad[2] = g3
    grad[3] = g4
    grad[4] = g5
    return mu


@njit(cache=True)
def balancing_roots(w1: float, g: float) -> tuple[float, float]:
    """(sqrt(W1 g), sqrt(g / W1)) of the balancing law (eq 22) and its W1 eligibility.

    sqrt(g / W1) is NaN for W1 = 0 (the balancing law then raises when it is used).
    ``g`` [m/s^2]: the model's gravity.
    """
    return math.sqrt(w1 * g), math.nan if w1 == 0.0 else math.sqrt(g / w1)


@njit(cache=True)
def policy_terms(
    x: float,
    x_dot: float,
    th: float,
    theta_dot: float,
    cos_th: float,
    have_cos: bool,
    pol: PolicyTerms,
) -> tuple[float, float, float, float, float, float]:
    """(mu, d mu / d W1..W5) of :func:`policy_mean` for a wrapped ``th`` [rad] (eqs 22-23):
    :func:`policy_gradient`, raising ZeroDivisionError where the balancing law is used
    with W1 = 0 (it has no sqrt(g / W1)).

    ``cos_th`` = cos th when ``have_cos`` (else computed here); ``pol``: :func:`policy_of`.
    """
    if pol.w1 == 0.0:
        wb, _ = switch_weights(abs(th), pol.theta_c, pol.soft, pol.inhibition)
        if wb > 0.0:
            raise ZeroDivisionError("W1 = 0: the balancing law (eq 22) has no sqrt(g / W1)")
    return policy_gradient(x, x_dot, th, theta_dot, cos_th, have_cos, pol)


@njit(cache=True, inline="always")
def policy_gradient(
    x: float,
    x_dot: float,
    th: float,
    theta_dot: float,
    cos_th: float,
    have_cos: bool,
    pol: PolicyTerms,
) -> tuple[float, float, float, float, float, float]:
    """(mu, d mu / d W1..W5) for a wrapped ``th`` [rad]: the switch (section 2.3 or 4)
    blends eq 22's balancing law and eq 23's swing-up law, each with its derivative.

    The one statement of the policy's arithmetic: the scalar trial
    (:func:`policy_terms`) and the lanes of the SIMD kernel
    (:func:`striatal.sim.kernel.run_trials_lockstep`) call it. ``cos_th`` = cos th when
    ``have_cos`` (else computed here); W1 = 0 gives NaN where balancing.
    """
    w1, w5, sign = pol.w1, pol.w5, pol.sign
    m, length, g = pol.m, pol.length, pol.g
    wb, ws = switch_weights(abs(th), pol.theta_c, pol.soft, pol.inhibition)
    mu = 0.0
    g1 = 0.0
    g2 = 0.0
    g3 = 0.0
    g4 = 0.0
    g5 = 0.0
    if wb > 0.0:
        mu_1, d1 = balancing_law(
            x,
            x_dot,
            th,
            theta_dot,
            w1,
            pol.w2,
            pol.w3,
            sign,
            length,
            g,
            pol.root,
            pol.inv_root,
            pol.chapter_eligibility,
        )
        mu += wb * mu_1
        g1 = wb * d1
        g2 = -wb * x
        g3 = -wb * x_dot
    if ws > 0.0:
        c = cos_th if have_cos else math.cos(th)
        mu_2, e_tilde = swingup_law(x, x_dot, theta_dot, c, pol.w4, w5, m, length, g)
        mu += ws * mu_2
        g4 = ws * e_tilde * theta_dot * c
        g5 = -ws * (0.5 * w5 * x + x_dot)
    return mu, g1, g2, g3, g4, g5


@njit(cache=True, inline="always")
def balancing_law(
    x: float,
    x_dot: float,
    th: float,
    theta_dot: float,
    w1: float,
    w2: float,
    w3: float,
    sign: float,
    length: float,
    g: float,
    root: float,
    inv_root: float,
    chapter_eligibility: bool,
) -> tuple[float, float]:
    """(mu_1, d mu_1 / d W1) of eq 22 at the wrapped ``th`` [rad]:
    mu_1 = sign ((1 + W1 l) g th + 2 l sqrt(W1 g) theta_dot) - W2 x - W3 x_dot, with
    ``root`` = sqrt(W1 g) and ``inv_root`` = sqrt(g / W1); with ``chapter_eligibility``
    the chapter's printed -l (g th - sqrt(g / W1) theta_dot) instead of the derivative."""
    mu_1 = sign * ((1.0 + w1 * length) * g * th + 2.0 * length * root * theta_dot) - w2 * x
    mu_1 -= w3 * x_dot
    if chapter_eligibility:
        return mu_1, -length * (g * th - inv_root * theta_dot)
    return mu_1, sign * length * (g * th + inv_root * theta_dot)


@njit(cache=True, inline="always")
def swingup_law(
    x: float,
    x_dot: float,
    theta_dot: float,
    c: float,
    w4: float,
    w5: float,
    m: float,
    length: float,
    g: float,
) -> tuple[float, float]:
    """(mu_2, E~) of eq 23 with c = cos theta: mu_2 = W4 E~ theta_dot c - W5^2/4 x - W5 x_dot,
    E~ = m l^2 theta_dot^2 / 2 + m g l (c - 1) of eqs 15-16 (the model's m, l, g)."""
    e_tilde = 0.5 * m * length * length * theta_dot * theta_dot + m * g * length * (c - 1.0)
    k_pump, k_x, k_x_dot = swingup_coefficients(w4, w5)
    return k_pump * e_tilde * theta_dot * c + k_x * x + k_x_dot * x_dot, e_tilde


@njit(cache=True, inline="always")
def swingup_coefficients(w4: float, w5: float) -> tuple[float, float, float]:
    """The coefficients of mu_2 (eq 23) on its signals E~ theta_dot cos theta, x and
    x_dot: (W4, -W5^2/4, -W5), eq 17 with k_s / (m l) = W4 and k_c = W5."""
    return w4, -0.25 * w5 * w5, -w5
