"""A learned plant step: a polynomial regression of the accelerations.

The step of a plant whose equations of motion are not eqs 8-9 but a fitted regression
(a cerebellar forward model with no cart-pole structure). Inputs: the features
q = (x_dot, sin theta, cos theta, theta_dot, f), f the motor force held over the step
[N], standardised, z = (q - mean) / scale. Outputs: the step's mean accelerations
(x_ddot, theta_ddot). Each of the K members is linear in the F monomials of z,

    a_k(z) = C_k phi(z) + c_k,    phi_j(z) = prod_i z_i ** P[j, i],

and the step takes the members' mean. Velocities advance by dt a, positions and
angles by the trapezoid of the old and new velocities. Each step writes the powers
z_i^p once into a small table and reads every monomial's factors from it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from striatal.sim.kernel.plant import PlantTerms, State, StepInputs

__all__ = [
    "MAX_POWER",
    "N_FACTORS",
    "N_FEATURES",
    "LearnedArgs",
    "LearnedStep",
    "accelerations_into",
    "learned_accelerations",
    "learned_step",
    "learned_step_of",
    "step_into",
]

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


#: Inputs a monomial may have at a non-zero power to be read as a product of three
#: table entries (:func:`learned_step_of`); every cubic monomial has at most three.
N_FACTORS = 3
#: Entries of a row of the power table: z^0 ... z^MAX_POWER.
_ROW = MAX_POWER + 1


class LearnedStep(NamedTuple):
    """What a trial on a learned plant carries to each step (:func:`learned_step_of`):
    the ``model``, a scratch ``table`` (N_FEATURES * (MAX_POWER + 1),) of the
    standardised inputs' powers, z_i^p at i (MAX_POWER + 1) + p, written at every step
    (one per trial, so parallel trials do not share it), and ``factors`` (F, N_FACTORS):
    each monomial's entries of the table at its non-zero powers, in the order of the
    inputs, padded with entry 0 (z_0^0 = 1); (0, N_FACTORS) when a monomial has more
    non-zero powers than N_FACTORS (each monomial is then read from all N_FEATURES)."""

    model: LearnedArgs
    table: np.ndarray
    factors: np.ndarray


@njit(cache=True)
def learned_step_of(model: LearnedArgs) -> LearnedStep:
    """``model`` with a fresh table and its monomials' :attr:`LearnedStep.factors`."""
    P = model.powers
    F = P.shape[0]
    factors = np.zeros((F, N_FACTORS), dtype=np.int64)
    for j in range(F):
        d = 0
        for i in range(N_FEATURES):
            if P[j, i] > 0:
                if d == N_FACTORS:
                    return LearnedStep(
                        model, np.empty(N_FEATURES * _ROW), np.zeros((0, N_FACTORS), np.int64)
                    )
                factors[j, d] = i * _ROW + P[j, i]
                d += 1
    return LearnedStep(model, np.empty(N_FEATURES * _ROW), factors)


@njit(cache=True, inline="always")
def _fill_powers(table: np.ndarray, i: int, z: float) -> None:
    """Row i of ``table``: 1, z, z^2, ..., z^MAX_POWER."""
    v = 1.0
    for p in range(_ROW):
        table[i * _ROW + p] = v
        v *= z


@njit(cache=True, inline="always")
def _monomial(carried: LearnedStep, j: int) -> float:
    """phi_j = prod_i z_i ** P[j, i], the powers read from the table: the product of the
    entries at the non-zero powers, in the order of the inputs (the entries z^0 = 1 left
    out or padded change no bit)."""
    t = carried.table
    if carried.factors.shape[0] > 0:
        f = carried.factors
        return t[f[j, 0]] * t[f[j, 1]] * t[f[j, 2]]
    P = carried.model.powers
    return (
        t[P[j, 0]]
        * t[_ROW + P[j, 1]]
        * t[2 * _ROW + P[j, 2]]
        * t[3 * _ROW + P[j, 3]]
        * t[4 * _ROW + P[j, 4]]
    )


@njit(cache=True)
def accelerations_into(
    x_dot: float,
    s: float,
    c: float,
    theta_dot: float,
    f: float,
    carried: LearnedStep,
) -> tuple[float, float]:
    """(x_ddot, theta_ddot): the members' mean of ``carried.model`` at (x_dot,
    s = sin theta, c = cos theta, theta_dot, f) [m/s^2, rad/s^2], the inputs' powers
    written to ``carried.table`` and each monomial read from it."""
    model = carried.model
    m = model.mean
    sc = model.scale
    table = carried.table
    _fill_powers(table, 0, (x_dot - m[0]) / sc[0])
    _fill_powers(table, 1, (s - m[1]) / sc[1])
    _fill_powers(table, 2, (c - m[2]) / sc[2])
    _fill_powers(table, 3, (theta_dot - m[3]) / sc[3])
    _fill_powers(table, 4, (f - m[4]) / sc[4])
    C = model.coef
    K = C.shape[0]
    F = model.powers.shape[0]
    ax = 0.0
    ath = 0.0
    if K == 1:
        # one member (imagination's mean and each member alone): the same sums, without
        # a loop over members inside the loop over monomials
        cx = C[0, 0]
        cth = C[0, 1]
        for j in range(F):
            phi = _monomial(carried, j)
            ax += cx[j] * phi
            ath += cth[j] * phi
    else:
        for j in range(F):
            phi = _monomial(carried, j)
            for k in range(K):
                ax += C[k, 0, j] * phi
                ath += C[k, 1, j] * phi
    for k in range(K):
        ax += model.intercept[k, 0]
        ath += model.intercept[k, 1]
    return ax / K, ath / K


@njit(cache=True)
def learned_accelerations(
    x_dot: float, s: float, c: float, theta_dot: float, f: float, model: LearnedArgs
) -> tuple[float, float]:
    """:func:`accelerations_into` of ``model`` (:func:`learned_step_of`)."""
    return accelerations_into(x_dot, s, c, theta_dot, f, learned_step_of(model))


@njit(cache=True)
def step_into(state: State, inputs: StepInputs, pt: PlantTerms, carried: LearnedStep) -> State:
    """One control step pt.dt of the learned plant from ``state`` (x, x_dot, theta,
    theta_dot) under the motor force f held, by ``carried.model`` (its powers written to
    ``carried.table``); ``inputs`` (sin theta, cos theta, the action a, f): a enters only
    through f. The step a trial loop calls (:func:`striatal.sim.kernel.run_learned_trial`)."""
    x, x_dot, theta, theta_dot = state
    s, c, _, f = inputs
    dt = pt.dt
    ax, ath = accelerations_into(x_dot, s, c, theta_dot, f, carried)
    v = x_dot + dt * ax
    w = theta_dot + dt * ath
    return x + 0.5 * dt * (x_dot + v), v, theta + 0.5 * dt * (theta_dot + w), w


@njit(cache=True)
def learned_step(state: State, inputs: StepInputs, pt: PlantTerms, model: LearnedArgs) -> State:
    """:func:`step_into` of ``model`` (:func:`learned_step_of`)."""
    return step_into(state, inputs, pt, learned_step_of(model))
