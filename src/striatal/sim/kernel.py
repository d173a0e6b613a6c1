"""The compiled trial loop: plant, controllers, Gaussian policy and eligibility trace.

This is the one physics kernel of the project. ``simulate``, the learner, the
Gymnasium environments, the sweeps and the benchmarks all call these functions;
:mod:`striatal.sim.reference` re-implements them in plain NumPy for the tests.

Everything here takes plain floats, float64 arrays and, for the trial loops,
the frozen NamedTuples below (Gains, PlantArgs, ControlArgs, ProtocolArgs,
NoiseArgs, TraceArgs, Buffers), which :mod:`striatal.sim.rollout` builds
(``trial_args``, ``batch_args``). Plant arrays are ``[M, m, l, g]``. States are
``[x, x_dot, theta, theta_dot]`` in ``[m, m/s, rad, rad/s]``, theta = 0 upright,
clockwise (pole tip at x + l sin theta).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit, prange, vectorize

__all__ = [
    "BLOW_UP",
    "LOCKSTEP_BLOCK",
    "MODE_BALANCE",
    "MODE_SWINGUP",
    "N_OUT",
    "N_TRAJ",
    "OUT_EARLY",
    "OUT_END_STEP",
    "OUT_FAULT",
    "OUT_MAX_ABS_FORCE",
    "OUT_MAX_ABS_X",
    "OUT_MIN_ABS_THETA",
    "OUT_MIN_ABS_THETA_SWINGUP",
    "OUT_N_SWITCHES",
    "OUT_REWARD",
    "OUT_THETA",
    "OUT_THETA_DOT",
    "OUT_TRACK",
    "OUT_X",
    "OUT_X_DOT",
    "STATUS_EARLY",
    "STATUS_FAILURE",
    "STATUS_FAULT",
    "STATUS_RUNNING",
    "STATUS_SUCCESS",
    "STATUS_TRACK",
    "TRAJ_COLUMNS",
    "TWO_PI",
    "Buffers",
    "ControlArgs",
    "Gains",
    "NoiseArgs",
    "PlantArgs",
    "PlantTerms",
    "ProtocolArgs",
    "TraceArgs",
    "accelerations",
    "energy_error",
    "exp_libm",
    "force",
    "judge",
    "judge_batch",
    "log10_libm",
    "motor_force",
    "plant_step",
    "plant_terms",
    "policy_mean",
    "rk4_force_step",
    "rk4_step",
    "run_trial",
    "run_trials_batch",
    "run_trials_lockstep",
    "sigma_of",
    "sincos_poly",
    "step_batch",
    "switch_weights",
    "trace_step",
    "wrap_angle",
    "wrap_angles",
    "write_summary",
]

TWO_PI = 2.0 * math.pi
#: A state component beyond this magnitude counts as a numerical fault.
BLOW_UP = 1.0e8

# Layout of the per-trial summary row written by :func:`run_trial`.
OUT_REWARD = 0
OUT_END_STEP = 1
OUT_X = 2
OUT_X_DOT = 3
OUT_THETA = 4
OUT_THETA_DOT = 5
OUT_MIN_ABS_THETA_SWINGUP = 6
OUT_MIN_ABS_THETA = 7
OUT_FAULT = 8
OUT_EARLY = 9
OUT_N_SWITCHES = 10
OUT_MAX_ABS_X = 11
OUT_MAX_ABS_FORCE = 12
OUT_TRACK = 13
N_OUT = 14

# Columns of a recorded trajectory row.
TRAJ_COLUMNS = ("t", "x", "x_dot", "theta", "theta_dot", "u", "force", "mode")
N_TRAJ = len(TRAJ_COLUMNS)

MODE_SWINGUP = 0
MODE_BALANCE = 1

# Outcome of :func:`judge`.
STATUS_RUNNING = 0
STATUS_FAULT = 1
STATUS_EARLY = 2
STATUS_SUCCESS = 3
STATUS_FAILURE = 4
STATUS_TRACK = 5


# The kernel's arguments, grouped (frozen, Numba-compatible NamedTuples). Build them
# with the functions of :mod:`striatal.sim.rollout` (trial_args, batch_args, ...), never
# by hand, so that every call site names what it passes.


class Gains(NamedTuple):
    """The learned parameters: W1..W6 (eqs 22-23) and the switching threshold theta_c (eq 21).

    For :func:`run_trials_batch`, W is (B, 6) and theta_c (B,).
    """

    W: np.ndarray
    theta_c: Any


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


class ProtocolArgs(NamedTuple):
    """The trial protocol of eqs 24-25 in steps: see :func:`judge`. check_step -1: never.

    ``track``: the half-length of the track [m]; |x| beyond it ends the trial (inf: none).
    """

    n_steps: int
    check_step: int
    check_x: float
    check_theta: float
    goal_x: float
    goal_theta: float
    reward_success: float
    reward_failure: float
    track: float = math.inf


class NoiseArgs(NamedTuple):
    """Standard normals of the action draws (n_draws,), empty for the mean policy; of the
    sensor (n_steps, 2), empty for none, with the stds of x [m] and theta [rad]."""

    action: np.ndarray
    sensor: np.ndarray
    sensor_std_x: float
    sensor_std_theta: float


class TraceArgs(NamedTuple):
    """The eligibility trace D (6,) updated in place (eq 3) and its decay gamma.

    For :func:`run_trials_batch`, trace is (B, 6).
    """

    gamma: float
    trace: np.ndarray


class Buffers(NamedTuple):
    """Output buffers: the summary row (N_OUT,); the trajectory (n_steps + 1, N_TRAJ) or none
    (0, N_TRAJ)."""

    out: np.ndarray
    traj: np.ndarray


@njit(cache=True)
def wrap_angle(theta: float) -> float:
    """Angle wrapped to (-pi, pi] [rad]: theta - 2 pi ceil((theta - pi) / 2 pi).

    For |theta| < 3 the ceil is 0 and the formula returns theta itself, so that case
    skips the division (bit for bit the same; tests/test_dynamics.py checks it).
    """
    if -3.0 < theta < 3.0:
        return theta
    return theta - TWO_PI * math.ceil((theta - math.pi) / TWO_PI)


@vectorize(cache=True)
def wrap_angles(theta: float) -> float:
    """:func:`wrap_angle` as a NumPy ufunc: any array shape, the same formula bit for bit.

    This and the two below are compiled at their first call, for the input's dtype (a
    signature list would compile them at every import of this module: 0.2 s of
    LLVM work, at start-up, for every command)."""
    return wrap_angle(theta)


@vectorize(cache=True)
def exp_libm(x: float) -> float:
    """exp(x) elementwise by the C library, as ``math.exp``: the same bits on every CPU.

    NumPy's own ``np.exp`` (and log10, tanh, power) take SIMD code paths chosen by
    the CPU (AVX-512 machines get different last bits), so a learning result that
    goes through them would depend on the machine (docs/performance.md).
    """
    return math.exp(x)


@vectorize(cache=True)
def log10_libm(x: float) -> float:
    """log10(x) elementwise by the C library, as ``math.log10`` (see :func:`exp_libm`)."""
    return math.log10(x)


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
    true ``plant`` answers through eqs 8-9.
    """
    return _accelerations_terms(
        x_dot,
        math.sin(theta),
        math.cos(theta),
        theta_dot,
        u,
        plant[0],
        plant[1],
        plant[2],
        plant[3],
        model[0],
        model[1],
        model[2],
        model[3],
        mismatch,
    )


@njit(cache=True, error_model="numpy")
def _accelerations_terms(
    x_dot: float,
    s: float,
    c: float,
    theta_dot: float,
    u: float,
    cart_mass: float,
    m: float,
    length: float,
    g: float,
    model_cart_mass: float,
    mh: float,
    model_length: float,
    model_g: float,
    mismatch: bool,
) -> tuple[float, float]:
    """Eqs 13-14 (or eqs 12 and 8-9 with ``mismatch``) on plain floats: plant [M, m, l, g]
    and model, so that loops over trials hold no array of parameters."""
    if mismatch:
        f = (model_cart_mass + mh - mh * c * c) * u + mh * model_g * c * s
        f -= mh * model_length * theta_dot * theta_dot * s
        x_ddot = (f + m * length * theta_dot * theta_dot * s - m * g * s * c) / (
            cart_mass + m - m * c * c
        )
    else:
        x_ddot = u
    return x_ddot, (g * s - x_ddot * c) / length


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
    return _rk4_terms(
        x,
        x_dot,
        theta,
        theta_dot,
        math.sin(theta),
        math.cos(theta),
        u,
        dt,
        plant[0],
        plant[1],
        plant[2],
        plant[3],
        model[0],
        model[1],
        model[2],
        model[3],
        mismatch,
    )


@njit(cache=True, error_model="numpy")
def _rk4_terms(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    s: float,
    c: float,
    u: float,
    dt: float,
    cart_mass: float,
    m: float,
    length: float,
    g: float,
    model_cart_mass: float,
    mh: float,
    model_length: float,
    model_g: float,
    mismatch: bool,
) -> tuple[float, float, float, float]:
    """:func:`rk4_step` on plain floats, given s = sin theta and c = cos theta of the first
    stage: plant [M, m, l, g] and model (eqs 13-14, or 12 and 8-9)."""
    a1, b1 = _accelerations_terms(
        x_dot,
        s,
        c,
        theta_dot,
        u,
        cart_mass,
        m,
        length,
        g,
        model_cart_mass,
        mh,
        model_length,
        model_g,
        mismatch,
    )
    h = 0.5 * dt
    xd2 = x_dot + h * a1
    thd2 = theta_dot + h * b1
    t2 = theta + h * theta_dot
    a2, b2 = _accelerations_terms(
        xd2,
        math.sin(t2),
        math.cos(t2),
        thd2,
        u,
        cart_mass,
        m,
        length,
        g,
        model_cart_mass,
        mh,
        model_length,
        model_g,
        mismatch,
    )
    xd3 = x_dot + h * a2
    thd3 = theta_dot + h * b2
    t3 = theta + h * thd2
    a3, b3 = _accelerations_terms(
        xd3,
        math.sin(t3),
        math.cos(t3),
        thd3,
        u,
        cart_mass,
        m,
        length,
        g,
        model_cart_mass,
        mh,
        model_length,
        model_g,
        mismatch,
    )
    xd4 = x_dot + dt * a3
    thd4 = theta_dot + dt * b3
    t4 = theta + dt * thd3
    a4, b4 = _accelerations_terms(
        xd4,
        math.sin(t4),
        math.cos(t4),
        thd4,
        u,
        cart_mass,
        m,
        length,
        g,
        model_cart_mass,
        mh,
        model_length,
        model_g,
        mismatch,
    )
    w = dt / 6.0
    return (
        x + w * (x_dot + 2.0 * xd2 + 2.0 * xd3 + xd4),
        x_dot + w * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        theta + w * (theta_dot + 2.0 * thd2 + 2.0 * thd3 + thd4),
        theta_dot + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
    )


@njit(cache=True)
def force(theta: float, theta_dot: float, u: float, plant: np.ndarray) -> float:
    """Cart force f [N] that realises x_ddot = u, eq 12."""
    return _force_sc(math.sin(theta), math.cos(theta), theta_dot, u, plant)


@njit(cache=True, error_model="numpy")
def _force_sc(s: float, c: float, theta_dot: float, u: float, plant: np.ndarray) -> float:
    """:func:`force` given s = sin theta and c = cos theta."""
    return _force_terms(s, c, theta_dot, u, plant[0], plant[1], plant[2], plant[3])


@njit(cache=True, error_model="numpy")
def _force_terms(
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
def _force_accelerations(
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
    return _rk4_force_terms(
        x, x_dot, theta, theta_dot, f, dt, plant[0], plant[1], plant[2], plant[3]
    )


@njit(cache=True)
def _rk4_force_terms(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    f: float,
    dt: float,
    cart_mass: float,
    m: float,
    length: float,
    g: float,
) -> tuple[float, float, float, float]:
    """:func:`rk4_force_step` on plain floats: the true plant [M, m, l, g]."""
    a1, b1 = _force_accelerations(
        math.sin(theta), math.cos(theta), theta_dot, f, cart_mass, m, length, g
    )
    h = 0.5 * dt
    xd2 = x_dot + h * a1
    thd2 = theta_dot + h * b1
    t2 = theta + h * theta_dot
    a2, b2 = _force_accelerations(math.sin(t2), math.cos(t2), thd2, f, cart_mass, m, length, g)
    xd3 = x_dot + h * a2
    thd3 = theta_dot + h * b2
    t3 = theta + h * thd2
    a3, b3 = _force_accelerations(math.sin(t3), math.cos(t3), thd3, f, cart_mass, m, length, g)
    xd4 = x_dot + dt * a3
    thd4 = theta_dot + dt * b3
    t4 = theta + dt * thd3
    a4, b4 = _force_accelerations(math.sin(t4), math.cos(t4), thd4, f, cart_mass, m, length, g)
    w = dt / 6.0
    return (
        x + w * (x_dot + 2.0 * xd2 + 2.0 * xd3 + xd4),
        x_dot + w * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        theta + w * (theta_dot + 2.0 * thd2 + 2.0 * thd3 + thd4),
        theta_dot + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
    )


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
def plant_terms(plant: PlantArgs) -> PlantTerms:
    """The :class:`PlantTerms` of ``plant``: its arrays' entries read once."""
    p = plant.plant
    q = plant.model
    return PlantTerms(
        p[0],
        p[1],
        p[2],
        p[3],
        q[0],
        q[1],
        q[2],
        q[3],
        plant.mismatch,
        plant.dt,
        plant.hold_force,
        plant.max_force,
        plant.max_force < math.inf,
    )


@njit(cache=True, error_model="numpy")
def _accelerations_limited(
    x_dot: float,
    theta: float,
    theta_dot: float,
    u: float,
    pt: PlantTerms,
) -> tuple[float, float]:
    """The accelerations of eqs 13-14 (u held) behind a motor limited to |f| <= pt.max_force [N].

    The force of eq 12 that realises u (with the model) is computed at this state;
    within the limit the accelerations are :func:`accelerations`' (the same arithmetic),
    beyond it the true plant answers the clipped force through eqs 8-9.
    """
    s = math.sin(theta)
    c = math.cos(theta)
    f = _force_terms(
        s, c, theta_dot, u, pt.model_cart_mass, pt.model_m, pt.model_length, pt.model_g
    )
    if abs(f) <= pt.max_force:
        return _accelerations_terms(
            x_dot,
            s,
            c,
            theta_dot,
            u,
            pt.cart_mass,
            pt.m,
            pt.length,
            pt.g,
            pt.model_cart_mass,
            pt.model_m,
            pt.model_length,
            pt.model_g,
            pt.mismatch,
        )
    fc = pt.max_force if f > 0.0 else -pt.max_force
    return _force_accelerations(s, c, theta_dot, fc, pt.cart_mass, pt.m, pt.length, pt.g)


@njit(cache=True)
def _rk4_limited(
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    u: float,
    pt: PlantTerms,
) -> tuple[float, float, float, float]:
    """:func:`rk4_step` (u held), every stage's force clipped (:func:`_accelerations_limited`)."""
    dt = pt.dt
    a1, b1 = _accelerations_limited(x_dot, theta, theta_dot, u, pt)
    h = 0.5 * dt
    xd2 = x_dot + h * a1
    thd2 = theta_dot + h * b1
    a2, b2 = _accelerations_limited(xd2, theta + h * theta_dot, thd2, u, pt)
    xd3 = x_dot + h * a2
    thd3 = theta_dot + h * b2
    a3, b3 = _accelerations_limited(xd3, theta + h * thd2, thd3, u, pt)
    xd4 = x_dot + dt * a3
    thd4 = theta_dot + dt * b3
    a4, b4 = _accelerations_limited(xd4, theta + dt * thd3, thd4, u, pt)
    w = dt / 6.0
    return (
        x + w * (x_dot + 2.0 * xd2 + 2.0 * xd3 + xd4),
        x_dot + w * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        theta + w * (theta_dot + 2.0 * thd2 + 2.0 * thd3 + thd4),
        theta_dot + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
    )


@njit(cache=True)
def _clip_force(f: float, max_force: float) -> float:
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
    f = _force_terms(
        s, c, theta_dot, a, pt.model_cart_mass, pt.model_m, pt.model_length, pt.model_g
    )
    if pt.limited:
        f = _clip_force(f, pt.max_force)
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
    ``max_force`` u is held behind the limited motor (:func:`_rk4_limited`); otherwise
    u is held (:func:`rk4_step`'s arithmetic). The one plant step of :func:`run_trial`
    and of the online learners' compiled loops.
    """
    if pt.hold_force:
        return _rk4_force_terms(
            x, x_dot, theta, theta_dot, f, pt.dt, pt.cart_mass, pt.m, pt.length, pt.g
        )
    if pt.limited:
        return _rk4_limited(x, x_dot, theta, theta_dot, a, pt)
    return _rk4_terms(
        x,
        x_dot,
        theta,
        theta_dot,
        s,
        c,
        a,
        pt.dt,
        pt.cart_mass,
        pt.m,
        pt.length,
        pt.g,
        pt.model_cart_mass,
        pt.model_m,
        pt.model_length,
        pt.model_g,
        pt.mismatch,
    )


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
    g = model[3]
    th = wrap_angle(theta)
    mu, g1, g2, g3, g4, g5 = _policy_wrapped(
        x,
        x_dot,
        th,
        theta_dot,
        W,
        theta_c,
        sign,
        soft,
        inhibition,
        model,
        chapter_eligibility,
        math.sqrt(W[0] * g),
        _inv_root(W[0], g),
        0.0,
        False,
    )
    grad[0] = g1
    grad[1] = g2
    grad[2] = g3
    grad[3] = g4
    grad[4] = g5
    return mu


@njit(cache=True)
def _inv_root(w1: float, g: float) -> float:
    """sqrt(g / W1), NaN for W1 = 0 (the balancing law then raises when it is used)."""
    return math.nan if w1 == 0.0 else math.sqrt(g / w1)


@njit(cache=True)
def _policy_wrapped(
    x: float,
    x_dot: float,
    th: float,
    theta_dot: float,
    W: np.ndarray,
    theta_c: float,
    sign: float,
    soft: bool,
    inhibition: float,
    model: np.ndarray,
    chapter_eligibility: bool,
    root: float,
    inv_root: float,
    cos_th: float,
    have_cos: bool,
) -> tuple[float, float, float, float, float, float]:
    """(mu, d mu / d W1..W5) of :func:`policy_mean` for a wrapped ``th``.

    ``root`` = sqrt(W1 g) and ``inv_root`` = sqrt(g / W1) (constant over a trial);
    ``cos_th`` = cos th when ``have_cos`` (else computed here). The same arithmetic.
    """
    return _policy_terms(
        x,
        x_dot,
        th,
        theta_dot,
        W[0],
        W[1],
        W[2],
        W[3],
        W[4],
        theta_c,
        sign,
        soft,
        inhibition,
        model[1],
        model[2],
        model[3],
        chapter_eligibility,
        root,
        inv_root,
        cos_th,
        have_cos,
    )


@njit(cache=True)
def _policy_terms(
    x: float,
    x_dot: float,
    th: float,
    theta_dot: float,
    w1: float,
    w2: float,
    w3: float,
    w4: float,
    w5: float,
    theta_c: float,
    sign: float,
    soft: bool,
    inhibition: float,
    m: float,
    length: float,
    g: float,
    chapter_eligibility: bool,
    root: float,
    inv_root: float,
    cos_th: float,
    have_cos: bool,
) -> tuple[float, float, float, float, float, float]:
    """:func:`_policy_wrapped` on plain floats: W1..W5 and the model's m, l, g (eqs 22-23)."""
    wb, ws = switch_weights(abs(th), theta_c, soft, inhibition)
    mu = 0.0
    g1 = 0.0
    g2 = 0.0
    g3 = 0.0
    g4 = 0.0
    g5 = 0.0
    if wb > 0.0:
        if w1 == 0.0:
            inv_root = math.sqrt(g / w1)  # raises ZeroDivisionError, as g / W1 always did
        mu += wb * (
            sign * ((1.0 + w1 * length) * g * th + 2.0 * length * root * theta_dot)
            - w2 * x
            - w3 * x_dot
        )
        if chapter_eligibility:
            d1 = -length * (g * th - inv_root * theta_dot)
        else:
            d1 = sign * length * (g * th + inv_root * theta_dot)
        g1 = wb * d1
        g2 = -wb * x
        g3 = -wb * x_dot
    if ws > 0.0:
        c = cos_th if have_cos else math.cos(th)
        e_tilde = 0.5 * m * length * length * theta_dot * theta_dot + m * g * length * (c - 1.0)
        mu += ws * (w4 * e_tilde * theta_dot * c - 0.25 * w5 * w5 * x - w5 * x_dot)
        g4 = ws * e_tilde * theta_dot * c
        g5 = -ws * (0.5 * w5 * x + x_dot)
    return mu, g1, g2, g3, g4, g5


@njit(cache=True)
def judge(
    x: float, x_dot: float, theta: float, theta_dot: float, step: int, protocol: ProtocolArgs
) -> tuple[int, float]:
    """(status, reward) of a state reached after ``step`` steps: the trial rules, eqs 24-25.

    The one statement of the chapter's sparse-reward protocol (docs/paper-notes.md
    section 5), shared by :func:`run_trial` and the Gymnasium task
    (:func:`striatal.envs.task.outcome`). In order: a non-finite state or one with a
    component beyond :data:`BLOW_UP` is a numerical fault (STATUS_FAULT, failure
    reward); |x| beyond ``protocol.track`` ends the trial at the track's end
    (STATUS_TRACK, failure reward); at ``step == protocol.check_step`` (t = 30 s)
    before the last step, eq 24 ends the trial (STATUS_EARLY, failure reward) if
    |x| > check_x or |theta| > check_theta; at ``step >= protocol.n_steps`` the trial
    ends with eq 25's reward (STATUS_SUCCESS if |x| < goal_x and |theta| < goal_theta,
    else STATUS_FAILURE). Otherwise STATUS_RUNNING and reward 0.
    """
    if not (
        abs(x) < BLOW_UP
        and abs(x_dot) < BLOW_UP
        and abs(theta) < BLOW_UP
        and abs(theta_dot) < BLOW_UP
    ):
        return STATUS_FAULT, protocol.reward_failure
    if abs(x) > protocol.track:
        return STATUS_TRACK, protocol.reward_failure
    if (
        step == protocol.check_step
        and step < protocol.n_steps
        and (abs(x) > protocol.check_x or abs(wrap_angle(theta)) > protocol.check_theta)
    ):
        return STATUS_EARLY, protocol.reward_failure
    if step >= protocol.n_steps:
        if abs(x) < protocol.goal_x and abs(wrap_angle(theta)) < protocol.goal_theta:
            return STATUS_SUCCESS, protocol.reward_success
        return STATUS_FAILURE, protocol.reward_failure
    return STATUS_RUNNING, 0.0


@njit(cache=True)
def judge_batch(
    states: np.ndarray,
    steps: np.ndarray,
    protocol: ProtocolArgs,
    status: np.ndarray,
    reward: np.ndarray,
) -> None:
    """:func:`judge` for each row of ``states`` (B, 4) reached after ``steps[b]`` steps."""
    for b in range(states.shape[0]):
        status[b], reward[b] = judge(
            states[b, 0], states[b, 1], states[b, 2], states[b, 3], steps[b], protocol
        )


@njit(cache=True)
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


@njit(cache=True)
def write_summary(
    out: np.ndarray,
    status: int,
    reward: float,
    end_step: int,
    x: float,
    x_dot: float,
    theta: float,
    theta_dot: float,
    min_swing: float,
    min_all: float,
    n_switches: int,
    max_abs_x: float,
    max_abs_f: float,
) -> None:
    """Write a trial's summary row ``out`` (N_OUT,), layout OUT_*, as :func:`run_trial` does."""
    out[OUT_REWARD] = reward
    out[OUT_END_STEP] = end_step
    out[OUT_X] = x
    out[OUT_X_DOT] = x_dot
    out[OUT_THETA] = wrap_angle(theta)
    out[OUT_THETA_DOT] = theta_dot
    out[OUT_MIN_ABS_THETA_SWINGUP] = min_swing
    out[OUT_MIN_ABS_THETA] = min_all
    out[OUT_FAULT] = 1.0 if status == STATUS_FAULT else 0.0
    out[OUT_EARLY] = 1.0 if status == STATUS_EARLY else 0.0
    out[OUT_N_SWITCHES] = n_switches
    out[OUT_MAX_ABS_X] = max_abs_x
    out[OUT_MAX_ABS_FORCE] = max_abs_f
    out[OUT_TRACK] = 1.0 if status == STATUS_TRACK else 0.0


@njit(cache=True)
def run_trial(
    state0: np.ndarray,
    gains: Gains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: NoiseArgs,
    learning: TraceArgs,
    buffers: Buffers,
) -> None:
    """Run one trial of the chapter's protocol (eqs 1-5, 13-14, 21-25) in place.

    Build the arguments with :func:`striatal.sim.rollout.trial_args`. A new action
    a = mu + sigma * noise.action[j] is drawn every ``control.action_every`` steps
    (eq 5) and held; at each draw the eligibility e (score of the Gaussian policy
    with the chapter's rescaling, docs/paper-notes.md section 2) enters the trace
    D = e + gamma D (eq 3), updated in ``learning.trace``. An empty
    ``noise.action`` runs the mean policy (no trace update). ``noise.sensor``
    (n_steps, 2) of standard normals, scaled by the two stds, corrupts the x and
    theta the controller sees; empty for none. The trial ends by the rules of
    :func:`judge` (eq 24 check, eq 25 reward, numerical fault), applied to the
    state after every step. Results go to ``buffers.out`` (layout OUT_*);
    ``buffers.traj`` of shape (n_steps + 1, 8) records t, state (theta unwrapped),
    u, force, mode when it has rows.

    What the motor holds over a step dt (the controller's sample period; the policy
    draws every ``control.action_every`` steps): by default u (the chapter's
    idealisation, a feedback linearisation running continuously inside the step).
    With ``plant.hold_force`` the force f of eq 12 is computed once at the step's
    start from the sampled state (the angle the controller sees) with the ``model``,
    held, and the true plant's eqs 8-9 are integrated (:func:`rk4_force_step`).
    ``plant.max_force`` (finite) clips f: with the force held, the held f; with u held,
    the force of every RK4 stage (:func:`_rk4_limited`), so the plant gets u only while
    the motor can deliver it (docs/paper-notes.md section 9). The recorded force and
    OUT_MAX_ABS_FORCE are the (clipped) force at the step's start.
    """
    W = gains.W
    theta_c = gains.theta_c
    model = plant.model
    pt = plant_terms(plant)
    # W1..W5 read once (a store to a buffer would otherwise reload them every step)
    w1 = W[0]
    w2 = W[1]
    w3 = W[2]
    w4 = W[3]
    w5 = W[4]
    dt = plant.dt
    action_every = control.action_every
    trace = learning.trace
    gamma = learning.gamma
    sensor_noise = noise.sensor
    out = buffers.out
    traj = buffers.traj
    n_steps = protocol.n_steps
    x = state0[0]
    x_dot = state0[1]
    theta = state0[2]
    theta_dot = state0[3]
    stochastic = noise.action.shape[0] > 0
    noisy_sensor = sensor_noise.shape[0] > 0
    record = traj.shape[0] > 0
    sigma = sigma_of(W[5])
    sign = control.sign
    soft = control.soft
    inhibition = control.inhibition
    chapter_eligibility = control.chapter_eligibility
    # constant over the trial: the square roots of the balancing law (eq 22)
    root = math.sqrt(W[0] * model[3])
    inv_root = _inv_root(W[0], model[3])
    # the trace D (eq 3) in registers, written back at the end
    d0 = trace[0]
    d1 = trace[1]
    d2 = trace[2]
    d3 = trace[3]
    d4 = trace[4]
    d5 = trace[5]
    max_force = plant.max_force
    limited = max_force < math.inf
    min_swing = math.inf
    min_all = math.inf
    n_switches = 0
    prev_mode = -1
    max_abs_x = abs(x)
    max_abs_f = 0.0
    a = 0.0
    draw = 0
    hold = 0  # steps left before the next action draw (eq 5)
    status = STATUS_RUNNING
    reward = 0.0
    end_step = n_steps
    if protocol.check_step == 0:
        status, reward = judge(x, x_dot, theta, theta_dot, 0, protocol)
        if status != STATUS_RUNNING:
            end_step = 0
    if status == STATUS_RUNNING:
        for k in range(n_steps):
            # sin and cos of theta once a step: the force (eq 12), RK4's first stage
            # and, without sensor noise, the swing-up law (eq 23) share them
            s = math.sin(theta)
            c = math.cos(theta)
            ox = x
            otheta = theta
            if noisy_sensor:
                ox += noise.sensor_std_x * sensor_noise[k, 0]
                otheta += noise.sensor_std_theta * sensor_noise[k, 1]
            th = wrap_angle(otheta)
            abs_th = abs(th)
            mode = MODE_BALANCE if abs_th < theta_c else MODE_SWINGUP
            if mode == MODE_SWINGUP and abs_th < min_swing:
                min_swing = abs_th
            if abs_th < min_all:
                min_all = abs_th
            if prev_mode >= 0 and mode != prev_mode:
                n_switches += 1
            prev_mode = mode
            if hold == 0:
                hold = action_every
                mu, g1, g2, g3, g4, g5 = _policy_terms(
                    ox,
                    x_dot,
                    th,
                    theta_dot,
                    w1,
                    w2,
                    w3,
                    w4,
                    w5,
                    theta_c,
                    sign,
                    soft,
                    inhibition,
                    pt.model_m,
                    pt.model_length,
                    pt.model_g,
                    chapter_eligibility,
                    root,
                    inv_root,
                    c,
                    th == theta,
                )
                if stochastic:
                    eps = sigma * noise.action[draw]
                    a = mu + eps
                    d0, d1, d2, d3, d4, d5 = trace_step(
                        eps, sigma, gamma, g1, g2, g3, g4, g5, d0, d1, d2, d3, d4, d5
                    )
                else:
                    a = mu
                draw += 1
            hold -= 1
            f = motor_force(s, c, otheta, theta_dot, a, noisy_sensor, pt)
            if abs(f) > max_abs_f:
                max_abs_f = abs(f)
            if record:
                traj[k, 0] = k * dt
                traj[k, 1] = x
                traj[k, 2] = x_dot
                traj[k, 3] = theta
                traj[k, 4] = theta_dot
                traj[k, 5] = a
                traj[k, 6] = f
                traj[k, 7] = mode
            x, x_dot, theta, theta_dot = plant_step(x, x_dot, theta, theta_dot, s, c, a, f, pt)
            status, reward = judge(x, x_dot, theta, theta_dot, k + 1, protocol)
            if status == STATUS_FAULT:
                end_step = k + 1
                break
            if abs(x) > max_abs_x:
                max_abs_x = abs(x)
            if status != STATUS_RUNNING:
                end_step = k + 1
                break
    if stochastic:
        trace[0] = d0
        trace[1] = d1
        trace[2] = d2
        trace[3] = d3
        trace[4] = d4
        trace[5] = d5
    if record:
        traj[end_step, 0] = end_step * dt
        traj[end_step, 1] = x
        traj[end_step, 2] = x_dot
        traj[end_step, 3] = theta
        traj[end_step, 4] = theta_dot
        traj[end_step, 5] = a
        f_end = force(theta, theta_dot, a, model)
        traj[end_step, 6] = _clip_force(f_end, max_force) if limited else f_end
        traj[end_step, 7] = MODE_BALANCE if abs(wrap_angle(theta)) < theta_c else MODE_SWINGUP
    write_summary(
        out,
        status,
        reward,
        end_step,
        x,
        x_dot,
        theta,
        theta_dot,
        min_swing,
        min_all,
        n_switches,
        max_abs_x,
        max_abs_f,
    )


@njit(cache=True, parallel=True)
def run_trials_batch(
    states0: np.ndarray,
    gains: Gains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    outs: np.ndarray,
) -> None:
    """:func:`run_trial` for B independent trials at once, parallel over cores.

    Build the arguments with :func:`striatal.sim.rollout.batch_args`. Row b of
    ``states0`` (B, 4), ``gains.W`` (B, 6), ``gains.theta_c`` (B,), ``noise``
    (B, n_draws) (or (B, 0) for the mean policy), ``learning.trace`` (B, 6) and
    ``outs`` (B, N_OUT) belongs to trial b; no sensor noise, nothing recorded.
    The result of each row equals the scalar kernel's bit for bit.
    """
    no_sensor = np.empty((0, 2))
    no_traj = np.empty((0, N_TRAJ))
    for b in prange(states0.shape[0]):
        run_trial(
            states0[b],
            Gains(gains.W[b], gains.theta_c[b]),
            plant,
            control,
            protocol,
            NoiseArgs(noise[b], no_sensor, 0.0, 0.0),
            TraceArgs(learning.gamma, learning.trace[b]),
            Buffers(outs[b], no_traj),
        )


# ---------------------------------------------------------------------- lockstep batch
# Polynomial sin/cos (fdlibm's kernels after a Cody-Waite reduction by pi/2): no libm
# call, so a loop over trials vectorises (AVX2: 4 trials per instruction).
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of pi/2
_PIO2_2 = 6.07710050630396597660e-11  # next 33 bits
_PIO2_3 = 2.02226624871116645580e-21  # next 33 bits
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
#: Trials per lockstep block (one block per thread at a time).
LOCKSTEP_BLOCK = 64


@njit(cache=True, error_model="numpy")
def sincos_poly(x: float) -> tuple[float, float]:
    """(sin x, cos x) without libm: x = k pi/2 + r, |r| <= pi/4, fdlibm's polynomials.

    Within about 1 ulp of math.sin/cos for |x| < 1e5 (k exact in the three-part
    pi/2); accuracy degrades slowly beyond (a state that large faults at 1e8).
    Branch-free, so loops over it vectorise.
    """
    k = np.floor(x * _INV_PIO2 + 0.5)
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    sp = r + (z * r) * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    cr = z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    cp = w + (((1.0 - w) - hz) + z * cr)
    q = k - 4.0 * np.floor(0.25 * k)  # quadrant 0..3
    odd = (q == 1.0) | (q == 3.0)
    s = cp if odd else sp
    c = sp if odd else cp
    s = -s if q >= 2.0 else s
    c = -c if ((q == 1.0) | (q == 2.0)) else c
    return s, c


@njit(cache=True)
def _clip01(v: float) -> float:
    """min(max(v, 0), 1) as selects (NaN gives 1, as min(max(NaN, 0), 1) does)."""
    lo = v if v > 0.0 else 0.0
    return lo if lo < 1.0 else 1.0


# Rows of the per-block state array of the lockstep kernel (fields x lanes).
_F_X, _F_XD, _F_TH, _F_THD, _F_A, _F_ACTIVE, _F_TC = 0, 1, 2, 3, 4, 5, 6
_F_W1, _F_W2, _F_W3, _F_W4, _F_W5, _F_ROOT, _F_INVROOT, _F_SIGMA = 7, 8, 9, 10, 11, 12, 13, 14
_F_EPS, _F_THW, _F_D0 = 15, 16, 17  # D0..D5: 17..22
_F_MINSW, _F_MINALL, _F_NSW, _F_PREV, _F_MAXX, _F_MAXF = 23, 24, 25, 26, 27, 28
_N_FIELDS = 29


@njit(cache=True, error_model="numpy")
def _lockstep_block(
    lo: int,
    hi: int,
    states0: np.ndarray,
    gains: Gains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    outs: np.ndarray,
) -> None:
    """Trials lo..hi-1 of :func:`run_trials_lockstep`, advanced step by step together.

    The state array always has LOCKSTEP_BLOCK lanes (a compile-time row stride, so the
    loops over lanes vectorise without run-time alias checks); the loops step the
    trials rounded up to a multiple of 4, the extra lanes idle copies of the first
    trial, inactive from the start.
    """
    n = hi - lo
    # lanes actually stepped: the trials rounded up to a multiple of 4 (one AVX2
    # vector); the array keeps LOCKSTEP_BLOCK lanes so its row stride is a constant
    L = min(LOCKSTEP_BLOCK, (n + 3) // 4 * 4)
    S = np.zeros((_N_FIELDS, LOCKSTEP_BLOCK))
    status = np.full(LOCKSTEP_BLOCK, STATUS_RUNNING)
    end_step = np.full(LOCKSTEP_BLOCK, protocol.n_steps)
    reward = np.zeros(LOCKSTEP_BLOCK)
    p = plant.plant
    model = plant.model
    mismatch = plant.mismatch
    dt = plant.dt
    h = 0.5 * dt
    w6 = dt / 6.0
    length = model[2]
    g = model[3]
    m = model[1]
    # parameters as plain floats: the loops over lanes read no parameter array
    p_cart, p_pole, p_len, p_g = p[0], p[1], p[2], p[3]
    q_cart, q_pole, q_len, q_g = model[0], model[1], model[2], model[3]
    sign = control.sign
    soft = control.soft
    inhibition = control.inhibition
    chapter = control.chapter_eligibility
    gamma = learning.gamma
    stochastic = noise.shape[1] > 0
    n_steps = protocol.n_steps
    for j in range(L):
        b = lo + j if j < n else lo
        S[_F_X, j] = states0[b, 0]
        S[_F_XD, j] = states0[b, 1]
        S[_F_TH, j] = states0[b, 2]
        S[_F_THD, j] = states0[b, 3]
        S[_F_ACTIVE, j] = 1.0 if j < n else 0.0
        S[_F_MAXX, j] = abs(states0[b, 0])
        S[_F_TC, j] = gains.theta_c[b]
        w1 = gains.W[b, 0]
        S[_F_W1, j] = w1
        S[_F_W2, j] = gains.W[b, 1]
        S[_F_W3, j] = gains.W[b, 2]
        S[_F_W4, j] = gains.W[b, 3]
        S[_F_W5, j] = gains.W[b, 4]
        S[_F_ROOT, j] = math.sqrt(w1 * g)
        S[_F_INVROOT, j] = _inv_root(w1, g)
        S[_F_SIGMA, j] = sigma_of(gains.W[b, 5])
        for i in range(6):
            S[_F_D0 + i, j] = learning.trace[b, i]
        S[_F_MINSW, j] = math.inf
        S[_F_MINALL, j] = math.inf
        S[_F_PREV, j] = -1.0
        if j < n and protocol.check_step == 0:
            st, rw = judge(S[_F_X, j], S[_F_XD, j], S[_F_TH, j], S[_F_THD, j], 0, protocol)
            if st != STATUS_RUNNING:
                status[j] = st
                reward[j] = rw
                end_step[j] = 0
                S[_F_ACTIVE, j] = 0.0
    n_active = 0
    for j in range(L):
        n_active += 1 if S[_F_ACTIVE, j] > 0.0 else 0
    hold = 0
    draw = 0
    k = 0
    while k < n_steps and n_active > 0:
        act = hold == 0
        if act:
            hold = control.action_every
            if stochastic:
                for j in range(n):
                    S[_F_EPS, j] = noise[lo + j, draw]
            draw += 1
        hold -= 1
        # pass 1: switch and statistics
        for j in range(L):
            run = S[_F_ACTIVE, j] > 0.0
            t = S[_F_TH, j]
            tw = t - TWO_PI * np.ceil((t - math.pi) / TWO_PI)
            S[_F_THW, j] = tw
            abs_th = abs(tw)
            bal = abs_th < S[_F_TC, j]
            mode = 1.0 if bal else 0.0
            ms = S[_F_MINSW, j]
            S[_F_MINSW, j] = abs_th if (run and not bal and abs_th < ms) else ms
            ma = S[_F_MINALL, j]
            S[_F_MINALL, j] = abs_th if (run and abs_th < ma) else ma
            prev = S[_F_PREV, j]
            S[_F_NSW, j] += 1.0 if (run and prev >= 0.0 and mode != prev) else 0.0
            S[_F_PREV, j] = mode if run else prev
        # at a draw: the policy (eqs 5, 22-23, switch of section 2.3 or 4), trace (eq 3)
        if act:
            for j in range(L):
                run = S[_F_ACTIVE, j] > 0.0
                tw = S[_F_THW, j]
                tc = S[_F_TC, j]
                abs_th = abs(tw)
                bal = abs_th < tc
                wb_soft = _clip01(inhibition * (tc - abs_th))
                ws_soft = _clip01(inhibition * (abs_th - tc))
                wb = wb_soft if soft else (1.0 if bal else 0.0)
                ws = ws_soft if soft else (0.0 if bal else 1.0)
                on_b = wb > 0.0
                on_s = ws > 0.0
                xj = S[_F_X, j]
                xdj = S[_F_XD, j]
                thdj = S[_F_THD, j]
                w1 = S[_F_W1, j]
                w5 = S[_F_W5, j]
                inv_root = S[_F_INVROOT, j]
                mu_b = (
                    sign * ((1.0 + w1 * length) * g * tw + 2.0 * length * S[_F_ROOT, j] * thdj)
                    - S[_F_W2, j] * xj
                    - S[_F_W3, j] * xdj
                )
                d1_chapter = -length * (g * tw - inv_root * thdj)
                d1_score = sign * length * (g * tw + inv_root * thdj)
                d1 = d1_chapter if chapter else d1_score
                _, cth = sincos_poly(tw)
                e_t = 0.5 * m * length * length * thdj * thdj + m * g * length * (cth - 1.0)
                mu_s = S[_F_W4, j] * e_t * thdj * cth - 0.25 * w5 * w5 * xj - w5 * xdj
                mu = (wb * mu_b if on_b else 0.0) + (ws * mu_s if on_s else 0.0)
                sg = S[_F_SIGMA, j]
                eps = sg * S[_F_EPS, j]
                upd = run and stochastic
                g1 = wb * d1 if on_b else 0.0
                g2 = -wb * xj if on_b else 0.0
                g3 = -wb * xdj if on_b else 0.0
                g4 = ws * e_t * thdj * cth if on_s else 0.0
                g5 = -ws * (0.5 * w5 * xj + xdj) if on_s else 0.0
                t0 = S[_F_D0, j]
                t1 = S[_F_D0 + 1, j]
                t2 = S[_F_D0 + 2, j]
                t3 = S[_F_D0 + 3, j]
                t4 = S[_F_D0 + 4, j]
                t5 = S[_F_D0 + 5, j]
                S[_F_D0, j] = eps * g1 + gamma * t0 if upd else t0
                S[_F_D0 + 1, j] = eps * g2 + gamma * t1 if upd else t1
                S[_F_D0 + 2, j] = eps * g3 + gamma * t2 if upd else t2
                S[_F_D0 + 3, j] = eps * g4 + gamma * t3 if upd else t3
                S[_F_D0 + 4, j] = eps * g5 + gamma * t4 if upd else t4
                S[_F_D0 + 5, j] = (eps * eps - sg * sg) * (1.1 - sg) + gamma * t5 if upd else t5
                act_a = mu + eps if stochastic else mu
                S[_F_A, j] = act_a if run else S[_F_A, j]
        # pass 2: force (eq 12), one RK4 step (eqs 13-14), the fault prefilter of judge
        suspect = 0
        for j in range(L):
            u = S[_F_A, j]
            t = S[_F_TH, j]
            x0 = S[_F_X, j]
            xd0 = S[_F_XD, j]
            thd0 = S[_F_THD, j]
            s1, c1 = sincos_poly(t)
            f = abs(_force_terms(s1, c1, thd0, u, q_cart, q_pole, q_len, q_g))
            a1, b1 = _accelerations_terms(
                xd0,
                s1,
                c1,
                thd0,
                u,
                p_cart,
                p_pole,
                p_len,
                p_g,
                q_cart,
                q_pole,
                q_len,
                q_g,
                mismatch,
            )
            xd2 = xd0 + h * a1
            thd2 = thd0 + h * b1
            s2, c2 = sincos_poly(t + h * thd0)
            a2, b2 = _accelerations_terms(
                xd2,
                s2,
                c2,
                thd2,
                u,
                p_cart,
                p_pole,
                p_len,
                p_g,
                q_cart,
                q_pole,
                q_len,
                q_g,
                mismatch,
            )
            xd3 = xd0 + h * a2
            thd3 = thd0 + h * b2
            s3, c3 = sincos_poly(t + h * thd2)
            a3, b3 = _accelerations_terms(
                xd3,
                s3,
                c3,
                thd3,
                u,
                p_cart,
                p_pole,
                p_len,
                p_g,
                q_cart,
                q_pole,
                q_len,
                q_g,
                mismatch,
            )
            xd4 = xd0 + dt * a3
            thd4 = thd0 + dt * b3
            s4, c4 = sincos_poly(t + dt * thd3)
            a4, b4 = _accelerations_terms(
                xd4,
                s4,
                c4,
                thd4,
                u,
                p_cart,
                p_pole,
                p_len,
                p_g,
                q_cart,
                q_pole,
                q_len,
                q_g,
                mismatch,
            )
            nx = x0 + w6 * (xd0 + 2.0 * xd2 + 2.0 * xd3 + xd4)
            nxd = xd0 + w6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            nth = t + w6 * (thd0 + 2.0 * thd2 + 2.0 * thd3 + thd4)
            nthd = thd0 + w6 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
            run = S[_F_ACTIVE, j] > 0.0
            mf = S[_F_MAXF, j]
            S[_F_MAXF, j] = f if (run and f > mf) else mf
            S[_F_X, j] = nx if run else x0
            S[_F_XD, j] = nxd if run else xd0
            S[_F_TH, j] = nth if run else t
            S[_F_THD, j] = nthd if run else thd0
            ok = abs(nx) < BLOW_UP and abs(nxd) < BLOW_UP
            ok = ok and abs(nth) < BLOW_UP and abs(nthd) < BLOW_UP
            suspect += 0 if (ok or not run) else 1
        k += 1
        # the trial rules (judge) where they can end a trial: a suspect state, the
        # eq-24 check step, the last step; elsewhere judge returns RUNNING
        if suspect > 0 or k == protocol.check_step or k >= n_steps:
            for j in range(L):
                if S[_F_ACTIVE, j] > 0.0:
                    st, rw = judge(S[_F_X, j], S[_F_XD, j], S[_F_TH, j], S[_F_THD, j], k, protocol)
                    if st != STATUS_RUNNING:
                        status[j] = st
                        reward[j] = rw
                        end_step[j] = k
                        S[_F_ACTIVE, j] = 0.0
                        n_active -= 1
                    if st != STATUS_FAULT and abs(S[_F_X, j]) > S[_F_MAXX, j]:
                        S[_F_MAXX, j] = abs(S[_F_X, j])
        else:
            for j in range(L):
                ax = abs(S[_F_X, j])
                mx = S[_F_MAXX, j]
                S[_F_MAXX, j] = ax if (S[_F_ACTIVE, j] > 0.0 and ax > mx) else mx
    for j in range(n):
        b = lo + j
        out = outs[b]
        out[OUT_REWARD] = reward[j]
        out[OUT_END_STEP] = end_step[j]
        out[OUT_X] = S[_F_X, j]
        out[OUT_X_DOT] = S[_F_XD, j]
        out[OUT_THETA] = wrap_angle(S[_F_TH, j])
        out[OUT_THETA_DOT] = S[_F_THD, j]
        out[OUT_MIN_ABS_THETA_SWINGUP] = S[_F_MINSW, j]
        out[OUT_MIN_ABS_THETA] = S[_F_MINALL, j]
        out[OUT_FAULT] = 1.0 if status[j] == STATUS_FAULT else 0.0
        out[OUT_EARLY] = 1.0 if status[j] == STATUS_EARLY else 0.0
        out[OUT_N_SWITCHES] = S[_F_NSW, j]
        out[OUT_MAX_ABS_X] = S[_F_MAXX, j]
        out[OUT_MAX_ABS_FORCE] = S[_F_MAXF, j]
        out[OUT_TRACK] = 0.0
        if stochastic:
            for i in range(6):
                learning.trace[b, i] = S[_F_D0 + i, j]


@njit(cache=True, parallel=True, error_model="numpy")
def run_trials_lockstep(
    states0: np.ndarray,
    gains: Gains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    outs: np.ndarray,
) -> None:
    """:func:`run_trials_batch` with all trials of a block advancing step k together.

    Same arguments (build them with :func:`striatal.sim.rollout.batch_args`) and outputs.
    State, trace and statistics are arrays over the trials of a block of
    :data:`LOCKSTEP_BLOCK`; the loops over trials call no libm function (sin/cos by
    :func:`sincos_poly`), so they vectorise; blocks run in parallel over cores. An
    ended trial is frozen by a mask. The trial rules are :func:`judge`'s. Results
    equal the scalar kernel's up to the round-off of the polynomial sin/cos, which
    the chaotic swing-up can amplify over a trial (tests/test_lockstep.py states the
    tolerance). It refuses (ValueError) the force hold, a force limit and a track:
    run those with :func:`run_trials_batch`.
    """
    if plant.hold_force or plant.max_force < math.inf or protocol.track < math.inf:
        raise ValueError(
            "run_trials_lockstep supports only u held, no force limit and no track: "
            "use run_trials_batch for hold force, max_force or track"
        )
    B = states0.shape[0]
    n_blocks = (B + LOCKSTEP_BLOCK - 1) // LOCKSTEP_BLOCK
    for i in prange(n_blocks):
        lo = i * LOCKSTEP_BLOCK
        hi = min(lo + LOCKSTEP_BLOCK, B)
        _lockstep_block(lo, hi, states0, gains, plant, control, protocol, noise, learning, outs)


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
