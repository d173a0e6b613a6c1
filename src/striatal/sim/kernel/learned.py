"""A learned plant step: a polynomial regression of the accelerations.

The step of a plant whose equations of motion are not eqs 8-9 but a fitted regression
(a cerebellar forward model with no cart-pole structure). Inputs: the features
q = (x_dot, sin theta, cos theta, theta_dot, f), f the motor force held over the step
[N], standardised, z = (q - mean) / scale. Outputs: the step's mean accelerations
(x_ddot, theta_ddot). Each of the K members is linear in the F monomials of z,

    a_k(z) = C_k phi(z) + c_k,    phi_j(z) = prod_i z_i ** P[j, i],

and the step takes the members' mean. Velocities advance by dt a, positions and
angles by the trapezoid of the old and new velocities.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from striatal.sim.kernel.plant import PlantTerms, State, StepInputs

__all__ = ["MAX_POWER", "N_FEATURES", "LearnedArgs", "learned_accelerations", "learned_step"]

#: Inputs of the learned model: x_dot, sin theta, cos theta, theta_dot, f.
N_FEATURES = 5


class LearnedArgs(NamedTuple):
    """A learned model's arrays: the inputs' ``mean`` and ``scale`` (5,), the monomials'
    exponents ``powers`` (F, 5) (int64, each in [0, MAX_POWER]), the readout ``coef`` (K, 2, F) and
    ``intercept`` (K, 2) of K members."""

    mean: np.ndarray
    scale: np.ndarray
    powers: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray


#: The highest power of one input in a monomial.
MAX_POWER = 6


@njit(cache=True, inline="always")
def _powers(z: float) -> tuple[float, float, float, float, float, float, float]:
    """(1, z, z^2, ..., z^MAX_POWER)."""
    z2 = z * z
    z3 = z2 * z
    return (1.0, z, z2, z3, z2 * z2, z3 * z2, z3 * z3)


@njit(cache=True)
def learned_accelerations(
    x_dot: float, s: float, c: float, theta_dot: float, f: float, model: LearnedArgs
) -> tuple[float, float]:
    """(x_ddot, theta_ddot): the members' mean of ``model`` at (x_dot, s = sin theta,
    c = cos theta, theta_dot, f) [m/s^2, rad/s^2]."""
    m = model.mean
    sc = model.scale
    z0 = (x_dot - m[0]) / sc[0]
    z1 = (s - m[1]) / sc[1]
    z2 = (c - m[2]) / sc[2]
    z3 = (theta_dot - m[3]) / sc[3]
    z4 = (f - m[4]) / sc[4]
    t0 = _powers(z0)
    t1 = _powers(z1)
    t2 = _powers(z2)
    t3 = _powers(z3)
    t4 = _powers(z4)
    P = model.powers
    C = model.coef
    K = C.shape[0]
    ax = 0.0
    ath = 0.0
    for j in range(P.shape[0]):
        phi = t0[P[j, 0]] * t1[P[j, 1]] * t2[P[j, 2]] * t3[P[j, 3]] * t4[P[j, 4]]
        for k in range(K):
            ax += C[k, 0, j] * phi
            ath += C[k, 1, j] * phi
    for k in range(K):
        ax += model.intercept[k, 0]
        ath += model.intercept[k, 1]
    return ax / K, ath / K


@njit(cache=True)
def learned_step(state: State, inputs: StepInputs, pt: PlantTerms, model: LearnedArgs) -> State:
    """One control step pt.dt of the learned plant from ``state`` (x, x_dot, theta,
    theta_dot) under the motor force f held; ``inputs`` (sin theta, cos theta, the action
    a, f): a enters only through f."""
    x, x_dot, theta, theta_dot = state
    s, c, _, f = inputs
    dt = pt.dt
    ax, ath = learned_accelerations(x_dot, s, c, theta_dot, f, model)
    v = x_dot + dt * ax
    w = theta_dot + dt * ath
    return x + 0.5 * dt * (x_dot + v), v, theta + 0.5 * dt * (theta_dot + w), w
