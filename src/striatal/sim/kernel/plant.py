"""The plant: partial feedback linearization (eqs 13-14), the cart force (eq 12), the
force-level equations of motion (eqs 8-9), RK4, the motor's limit, the energy (eqs 15-16).

Plant arrays are ``[M, m, l, g]``; states ``[x, x_dot, theta, theta_dot]`` in
``[m, m/s, rad, rad/s]``, theta = 0 upright, clockwise (pole tip at x + l sin theta).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = [
    "PlantArgs",
    "PlantTerms",
    "State",
    "StepInputs",
    "accelerations",
    "accelerations_terms",
    "clip_force",
    "energy_error",
    "force",
    "force_accelerations",
    "force_terms",
    "motor_force",
    "plant_step",
    "plant_terms",
    "rk4",
    "rk4_force_step",
    "rk4_step",
    "step_batch",
]


#: A state (x, x_dot, theta, theta_dot) [m, m/s, rad, rad/s].
State = tuple[float, float, float, float]
#: What a plant step takes besides the state: (sin theta, cos theta, the action a, the
#: motor force f [N]).
StepInputs = tuple[float, float, float, float]


class PlantArgs(NamedTuple):
    """The true plant and the controller's model of it, each [M, m, l, g]; the RK4 step [s].

    ``hold_force``: hold the motor force of eq 12 (computed at the step's start with the
    model) over the step and integrate the plant's eqs 8-9, instead of holding u
    (the chapter's idealisation); ``max_force``: the motor's limit [N] (inf: none).
    See :func:`run_trial` and docs/paper-notes.md section 9.
    """

    plant: np.ndarray
    model: np.ndarray
    mismatch: bool
    dt: float
    hold_force: bool = False
    max_force: float = math.inf


@njit(cache=True)
def accelerations(
    x_dot: float,
    theta: float,
    theta_dot: float,
    u: float,
    plant: np.ndarray,
    model: np.ndarray,
    mismatch: bool,
) -> tuple[float, float]:
    """(x_ddot, theta_ddot) for a commanded cart acceleration u, eqs 13-14.

    Without ``mismatch`` the partial feedback linearization is exact: x_ddot = u and
    theta_ddot = (g sin theta - u cos theta) / l. With ``mismatch`` the motor pushes
    the force of eq 12 computed with the controller's ``model`` parameters, and the
    true ``plant`` answers through eqs 8-9. ``x_dot`` enters neither.
    """
    pt = _array_terms(plant, model, mismatch, 0.0)
    return accelerations_terms(math.sin(theta), math.cos(theta), theta_dot, u, pt)


@njit(cache=True, error_model="numpy")
def accelerations_terms(
    s: float, c: float, theta_dot: float, u: float, pt: PlantTerms
) -> tuple[float, float]:
    """:func:`accelerations` given s = sin theta and c = cos theta, on :class:`PlantTerms`:
    eqs 13-14, or with ``pt.mismatch`` the model's force of eq 12 into the plant's eqs 8-9."""
    if pt.mismatch:
        f = force_terms(
            s, c, theta_dot, u, pt.model_cart_mass, pt.model_m, pt.model_length, pt.model_g
        )
        return force_accelerations(s, c, theta_dot, f, pt.cart_mass, pt.m, pt.length, pt.g)
    return u, (pt.g * s - u * c) / pt.length


@njit(cache=True, inline="always")
def rk4(
    stage: Callable[[float, float, float, PlantTerms], tuple[float, float]],
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    a1: float,
    b1: float,
    u: float,
    pt: PlantTerms,
) -> tuple[float, float, float, float]:
    """One classical Runge-Kutta step of length pt.dt with the input u held.

    (a1, b1): the accelerations at the step's start; ``stage(theta, theta_dot, u, pt)``
    gives (x_ddot, theta_ddot) at the later stages (the accelerations depend on neither
    x nor x_dot). The one RK4 of the kernel: u held, force held, limited motor, and the
    lockstep's polynomial sin/cos differ only in ``stage``.
    """
    dt = pt.dt
    h = 0.5 * dt
    xd2 = x_dot + h * a1
    thd2 = theta_dot + h * b1
    a2, b2 = stage(theta + h * theta_dot, thd2, u, pt)
    xd3 = x_dot + h * a2
    thd3 = theta_dot + h * b2
    a3, b3 = stage(theta + h * thd2, thd3, u, pt)
    xd4 = x_dot + dt * a3
    thd4 = theta_dot + dt * b3
    a4, b4 = stage(theta + dt * thd3, thd4, u, pt)
    w = dt / 6.0
    return (
        x + w * (x_dot + 2.0 * xd2 + 2.0 * xd3 + xd4),
        x_dot + w * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        theta + w * (theta_dot + 2.0 * thd2 + 2.0 * thd3 + thd4),
        theta_dot + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
    )


@njit(cache=True)
def _u_stage(theta: float, theta_dot: float, u: float, pt: PlantTerms) -> tuple[float, float]:
    """The accelerations of eqs 13-14 (or 12 and 8-9) with u held: an RK4 stage."""
    return accelerations_terms(math.sin(theta), math.cos(theta), theta_dot, u, pt)


@njit(cache=True)
def _force_stage(theta: float, theta_dot: float, f: float, pt: PlantTerms) -> tuple[float, float]:
    """The plant's accelerations of eqs 8-9 with the force f [N] held: an RK4 stage."""
    return force_accelerations(
        math.sin(theta), math.cos(theta), theta_dot, f, pt.cart_mass, pt.m, pt.length, pt.g
    )


@njit(cache=True)
def rk4_step(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    u: float,
    dt: float,
    plant: np.ndarray,
    model: np.ndarray,
    mismatch: bool,
) -> tuple[float, float, float, float]:
    """One classical Runge-Kutta step of length dt with u held constant."""
    pt = _array_terms(plant, model, mismatch, dt)
    a1, b1 = _u_stage(theta, theta_dot, u, pt)
    return rk4(_u_stage, x, x_dot, theta, theta_dot, a1, b1, u, pt)


@njit(cache=True)
def force(theta: float, theta_dot: float, u: float, plant: np.ndarray) -> float:
    """Cart force f [N] that realises x_ddot = u, eq 12."""
    return force_terms(
        math.sin(theta), math.cos(theta), theta_dot, u, plant[0], plant[1], plant[2], plant[3]
    )


@njit(cache=True, error_model="numpy")
def force_terms(
    s: float,
    c: float,
    theta_dot: float,
    u: float,
    cart_mass: float,
    m: float,
    length: float,
    g: float,
) -> float:
    """Eq 12 on plain floats (the model's [M, m, l, g])."""
    return (cart_mass + m - m * c * c) * u + m * g * c * s - m * length * theta_dot * theta_dot * s


@njit(cache=True, error_model="numpy")
def force_accelerations(
    s: float,
    c: float,
    theta_dot: float,
    f: float,
    cart_mass: float,
    m: float,
    length: float,
    g: float,
) -> tuple[float, float]:
    """(x_ddot, theta_ddot) of the true plant [M, m, l, g] pushed by a cart force f [N].

    Eqs 8-9 solved for the accelerations (the point mass of eq 10):
    x_ddot = (f + m l theta_dot^2 s - m g s c) / (M + m - m c^2),
    theta_ddot = (g s - x_ddot c) / l, with s = sin theta, c = cos theta.
    """
    x_ddot = (f + m * length * theta_dot * theta_dot * s - m * g * s * c) / (
        cart_mass + m - m * c * c
    )
    return x_ddot, (g * s - x_ddot * c) / length


@njit(cache=True)
def rk4_force_step(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    f: float,
    dt: float,
    plant: np.ndarray,
) -> tuple[float, float, float, float]:
    """One classical RK4 step of length dt of eqs 8-9 with the cart force f [N] held."""
    pt = _array_terms(plant, plant, False, dt)
    a1, b1 = _force_stage(theta, theta_dot, f, pt)
    return rk4(_force_stage, x, x_dot, theta, theta_dot, a1, b1, f, pt)


class PlantTerms(NamedTuple):
    """:class:`PlantArgs` as plain floats, unpacked once per trial (:func:`plant_terms`).

    The trial loops take these instead of the parameter arrays: a loop that stores to
    an output buffer would otherwise load the arrays' entries again at every step
    (the compiler cannot rule out that the arrays alias the buffer). ``limited``:
    ``max_force`` is finite.
    """

    cart_mass: float
    m: float
    length: float
    g: float
    model_cart_mass: float
    model_m: float
    model_length: float
    model_g: float
    mismatch: bool
    dt: float
    hold_force: bool
    max_force: float
    limited: bool


@njit(cache=True)
def _array_terms(
    plant: np.ndarray,
    model: np.ndarray,
    mismatch: bool,
    dt: float,
    hold_force: bool = False,
    max_force: float = math.inf,
) -> PlantTerms:
    """The :class:`PlantTerms` of the plant and model arrays [M, m, l, g]."""
    return PlantTerms(
        plant[0],
        plant[1],
        plant[2],
        plant[3],
        model[0],
        model[1],
        model[2],
        model[3],
        mismatch,
        dt,
        hold_force,
        max_force,
        max_force < math.inf,
    )


@njit(cache=True)
def plant_terms(plant: PlantArgs) -> PlantTerms:
    """The :class:`PlantTerms` of ``plant``: its arrays' entries read once."""
    return _array_terms(
        plant.plant, plant.model, plant.mismatch, plant.dt, plant.hold_force, plant.max_force
    )


@njit(cache=True, error_model="numpy")
def _accelerations_limited(
    theta: float,
    theta_dot: float,
    u: float,
    pt: PlantTerms,
) -> tuple[float, float]:
    """The accelerations of eqs 13-14 (u held) behind a motor limited to |f| <= pt.max_force [N].

    The force of eq 12 that realises u (with the model) is computed at this state;
    within the limit the accelerations are :func:`accelerations`' (the same arithmetic),
    beyond it the true plant answers the clipped force through eqs 8-9. An RK4 stage.
    """
    s = math.sin(theta)
    c = math.cos(theta)
    f = force_terms(s, c, theta_dot, u, pt.model_cart_mass, pt.model_m, pt.model_length, pt.model_g)
    if abs(f) <= pt.max_force:
        return accelerations_terms(s, c, theta_dot, u, pt)
    fc = pt.max_force if f > 0.0 else -pt.max_force
    return force_accelerations(s, c, theta_dot, fc, pt.cart_mass, pt.m, pt.length, pt.g)


@njit(cache=True)
def clip_force(f: float, max_force: float) -> float:
    """f clipped to [-max_force, max_force] (NaN stays NaN)."""
    if f > max_force:
        return max_force
    if f < -max_force:
        return -max_force
    return f


@njit(cache=True)
def motor_force(
    s: float,
    c: float,
    otheta: float,
    theta_dot: float,
    a: float,
    noisy_sensor: bool,
    pt: PlantTerms,
) -> float:
    """The motor's force f [N] over a step: eq 12 with the model for the action a, clipped.

    ``s``, ``c``: sin and cos of the true theta; ``otheta``: the angle the controller
    sees; ``pt``: :func:`plant_terms` of the trial's PlantArgs. With the force held and
    a noisy sensor the digital controller computes eq 12 from the angle it sees.
    Shared by :func:`run_trial` and the online learners' loops.
    """
    if pt.hold_force and noisy_sensor:
        s = math.sin(otheta)
        c = math.cos(otheta)
    f = force_terms(s, c, theta_dot, a, pt.model_cart_mass, pt.model_m, pt.model_length, pt.model_g)
    if pt.limited:
        f = clip_force(f, pt.max_force)
    return f


@njit(cache=True)
def plant_step(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    s: float,
    c: float,
    a: float,
    f: float,
    pt: PlantTerms,
) -> tuple[float, float, float, float]:
    """One control step dt of the plant (eqs 8-9 or 13-14) under the action a held.

    ``s``, ``c``: sin and cos of theta; ``f``: the step's motor force
    (:func:`motor_force`); ``pt``: :func:`plant_terms` of the trial's PlantArgs. With
    ``hold_force`` f is held (:func:`rk4_force_step`'s arithmetic); with a finite
    ``max_force`` u is held behind the limited motor (:func:`_accelerations_limited` at
    every stage); otherwise u is held (:func:`rk4_step`'s arithmetic). The one plant
    step of :func:`run_trial` and of the online learners' compiled loops.
    """
    if pt.hold_force:
        a1, b1 = force_accelerations(s, c, theta_dot, f, pt.cart_mass, pt.m, pt.length, pt.g)
        return rk4(_force_stage, x, x_dot, theta, theta_dot, a1, b1, f, pt)
    if pt.limited:
        a1, b1 = _accelerations_limited(theta, theta_dot, a, pt)
        return rk4(_accelerations_limited, x, x_dot, theta, theta_dot, a1, b1, a, pt)
    a1, b1 = accelerations_terms(s, c, theta_dot, a, pt)
    return rk4(_u_stage, x, x_dot, theta, theta_dot, a1, b1, a, pt)


@njit(cache=True)
def energy_error(theta: float, theta_dot: float, plant: np.ndarray) -> float:
    """E~ = E_p - E_d, eqs 15-16 [J]."""
    m = plant[1]
    length = plant[2]
    g = plant[3]
    return 0.5 * m * length * length * theta_dot * theta_dot + m * g * length * (
        math.cos(theta) - 1.0
    )


@njit(cache=True)
def step_batch(
    states: np.ndarray,
    u: np.ndarray,
    dt: float,
    n_substeps: int,
    plant: np.ndarray,
    model: np.ndarray,
    mismatch: bool,
    out: np.ndarray,
) -> None:
    """Advance each row of ``states`` (B, 4) by n_substeps RK4 steps with u[b] held."""
    for b in range(states.shape[0]):
        x = states[b, 0]
        x_dot = states[b, 1]
        theta = states[b, 2]
        theta_dot = states[b, 3]
        for _ in range(n_substeps):
            x, x_dot, theta, theta_dot = rk4_step(
                x, x_dot, theta, theta_dot, u[b], dt, plant, model, mismatch
            )
        out[b, 0] = x
        out[b, 1] = x_dot
        out[b, 2] = theta
        out[b, 3] = theta_dot
