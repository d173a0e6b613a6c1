"""The compiled trial loop: plant, controllers, Gaussian policy and eligibility trace.

This is the one physics kernel of the project. ``simulate``, the learner, the
Gymnasium environments, the sweeps and the benchmarks all call these functions;
:mod:`striatal.reference` re-implements them in plain NumPy for the tests.

Everything here takes plain floats and float64 arrays (Numba ``njit``). Plant
arrays are ``[M, m, l, g]``. States are ``[x, x_dot, theta, theta_dot]`` in
``[m, m/s, rad, rad/s]``, theta = 0 upright, clockwise (pole tip at x + l sin theta).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

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
N_OUT = 13

# Columns of a recorded trajectory row.
TRAJ_COLUMNS = ("t", "x", "x_dot", "theta", "theta_dot", "u", "force", "mode")
N_TRAJ = len(TRAJ_COLUMNS)

MODE_SWINGUP = 0
MODE_BALANCE = 1


@njit(cache=True)
def wrap_angle(theta: float) -> float:
    """Angle wrapped to (-pi, pi] [rad]."""
    return theta - TWO_PI * math.ceil((theta - math.pi) / TWO_PI)


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
    s = math.sin(theta)
    c = math.cos(theta)
    length = plant[2]
    g = plant[3]
    if mismatch:
        mh = model[1]
        f = (model[0] + mh - mh * c * c) * u + mh * model[3] * c * s
        f -= mh * model[2] * theta_dot * theta_dot * s
        m = plant[1]
        x_ddot = (f + m * length * theta_dot * theta_dot * s - m * g * s * c) / (
            plant[0] + m - m * c * c
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
    a1, b1 = accelerations(x_dot, theta, theta_dot, u, plant, model, mismatch)
    h = 0.5 * dt
    xd2 = x_dot + h * a1
    thd2 = theta_dot + h * b1
    a2, b2 = accelerations(xd2, theta + h * theta_dot, thd2, u, plant, model, mismatch)
    xd3 = x_dot + h * a2
    thd3 = theta_dot + h * b2
    a3, b3 = accelerations(xd3, theta + h * thd2, thd3, u, plant, model, mismatch)
    xd4 = x_dot + dt * a3
    thd4 = theta_dot + dt * b3
    a4, b4 = accelerations(xd4, theta + dt * thd3, thd4, u, plant, model, mismatch)
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
    s = math.sin(theta)
    c = math.cos(theta)
    m = plant[1]
    return (
        (plant[0] + m - m * c * c) * u
        + m * plant[3] * c * s
        - m * plant[2] * theta_dot * theta_dot * s
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
    (section 4, read as in NOTES section 4): clip(gamma (theta_c - |theta|), 0, 1)
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
    """Policy standard deviation sigma = 0.1 + 1 / (1 + exp(-W6)), eqs 22-23 (NOTES section 3)."""
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

    Balancing, eq 22 with the sign reading ``sign`` (+1 corrected, -1 printed):
    mu1 = sign ((1 + W1 l) g theta + 2 l sqrt(W1 g) theta_dot) - W2 x - W3 x_dot.
    Swing-up, eq 23: mu2 = W4 E~ theta_dot cos theta - W5^2/4 x - W5 x_dot.
    With ``chapter_eligibility`` the W1 entry is the chapter's printed
    -l (g theta - sqrt(g / W1) theta_dot) instead of the true derivative.
    """
    length = model[2]
    g = model[3]
    th = wrap_angle(theta)
    wb, ws = switch_weights(abs(th), theta_c, soft, inhibition)
    mu = 0.0
    for i in range(5):
        grad[i] = 0.0
    if wb > 0.0:
        root = math.sqrt(W[0] * g)
        mu += wb * (
            sign * ((1.0 + W[0] * length) * g * th + 2.0 * length * root * theta_dot)
            - W[1] * x
            - W[2] * x_dot
        )
        if chapter_eligibility:
            d1 = -length * (g * th - math.sqrt(g / W[0]) * theta_dot)
        else:
            d1 = sign * length * (g * th + math.sqrt(g / W[0]) * theta_dot)
        grad[0] = wb * d1
        grad[1] = -wb * x
        grad[2] = -wb * x_dot
    if ws > 0.0:
        e_tilde = energy_error(th, theta_dot, model)
        c = math.cos(th)
        mu += ws * (W[3] * e_tilde * theta_dot * c - 0.25 * W[4] * W[4] * x - W[4] * x_dot)
        grad[3] = ws * e_tilde * theta_dot * c
        grad[4] = -ws * (0.5 * W[4] * x + x_dot)
    return mu


@njit(cache=True)
def run_trial(
    state0: np.ndarray,
    W: np.ndarray,
    theta_c: float,
    sign: float,
    soft: bool,
    inhibition: float,
    plant: np.ndarray,
    model: np.ndarray,
    mismatch: bool,
    dt: float,
    n_steps: int,
    action_every: int,
    noise: np.ndarray,
    sensor_noise: np.ndarray,
    sensor_std_x: float,
    sensor_std_theta: float,
    chapter_eligibility: bool,
    gamma: float,
    trace: np.ndarray,
    check_step: int,
    check_x: float,
    check_theta: float,
    goal_x: float,
    goal_theta: float,
    reward_success: float,
    reward_failure: float,
    traj: np.ndarray,
    out: np.ndarray,
) -> None:
    """Run one trial of the chapter's protocol (eqs 1-5, 13-14, 21-25) in place.

    A new action a = mu + sigma * noise[j] is drawn every ``action_every`` steps
    (eq 5) and held; at each draw the eligibility e (score of the Gaussian policy
    with the chapter's rescaling, NOTES section 2) enters the trace
    D = e + gamma D (eq 3), updated in ``trace``. An empty ``noise`` runs the mean
    policy (no trace update). ``sensor_noise`` (n_steps, 2) of standard normals,
    scaled by the two stds, corrupts the x and theta the controller sees; empty
    for none. At step ``check_step`` (t = 30 s; -1 for never) the trial ends with
    ``reward_failure`` if |x| > check_x or |theta| > check_theta (eq 24);
    otherwise at the end the reward is ``reward_success`` if |x| < goal_x and
    |theta| < goal_theta, else ``reward_failure`` (eq 25). A non-finite or blown-up
    state ends the trial as a failure with OUT_FAULT = 1. Results go to ``out``
    (layout OUT_*); ``traj`` of shape (n_steps + 1, 8) records t, state (theta
    unwrapped), u, force, mode when it has rows.
    """
    x = state0[0]
    x_dot = state0[1]
    theta = state0[2]
    theta_dot = state0[3]
    stochastic = noise.shape[0] > 0
    noisy_sensor = sensor_noise.shape[0] > 0
    record = traj.shape[0] > 0
    sigma = sigma_of(W[5])
    grad = np.empty(5)
    min_swing = math.inf
    min_all = math.inf
    n_switches = 0
    prev_mode = -1
    max_abs_x = abs(x)
    max_abs_f = 0.0
    a = 0.0
    draw = 0
    reward = 0.0
    fault = 0
    early = 0
    end_step = n_steps
    ended = False
    for k in range(n_steps):
        if k == check_step and (abs(x) > check_x or abs(wrap_angle(theta)) > check_theta):
            reward = reward_failure
            early = 1
            end_step = k
            ended = True
            break
        ox = x
        otheta = theta
        if noisy_sensor:
            ox += sensor_std_x * sensor_noise[k, 0]
            otheta += sensor_std_theta * sensor_noise[k, 1]
        abs_th = abs(wrap_angle(otheta))
        mode = MODE_BALANCE if abs_th < theta_c else MODE_SWINGUP
        if mode == MODE_SWINGUP and abs_th < min_swing:
            min_swing = abs_th
        if abs_th < min_all:
            min_all = abs_th
        if prev_mode >= 0 and mode != prev_mode:
            n_switches += 1
        prev_mode = mode
        if k % action_every == 0:
            mu = policy_mean(
                ox,
                x_dot,
                otheta,
                theta_dot,
                W,
                theta_c,
                sign,
                soft,
                inhibition,
                model,
                chapter_eligibility,
                grad,
            )
            if stochastic:
                eps = sigma * noise[draw]
                a = mu + eps
                for i in range(5):
                    trace[i] = eps * grad[i] + gamma * trace[i]
                trace[5] = (eps * eps - sigma * sigma) * (1.1 - sigma) + gamma * trace[5]
            else:
                a = mu
            draw += 1
        f = force(theta, theta_dot, a, model)
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
        x, x_dot, theta, theta_dot = rk4_step(
            x, x_dot, theta, theta_dot, a, dt, plant, model, mismatch
        )
        if not (
            abs(x) < BLOW_UP
            and abs(x_dot) < BLOW_UP
            and abs(theta) < BLOW_UP
            and abs(theta_dot) < BLOW_UP
        ):
            reward = reward_failure
            fault = 1
            end_step = k + 1
            ended = True
            break
        if abs(x) > max_abs_x:
            max_abs_x = abs(x)
    if not ended:
        if abs(x) < goal_x and abs(wrap_angle(theta)) < goal_theta:
            reward = reward_success
        else:
            reward = reward_failure
    if record:
        traj[end_step, 0] = end_step * dt
        traj[end_step, 1] = x
        traj[end_step, 2] = x_dot
        traj[end_step, 3] = theta
        traj[end_step, 4] = theta_dot
        traj[end_step, 5] = a
        traj[end_step, 6] = force(theta, theta_dot, a, model)
        traj[end_step, 7] = MODE_BALANCE if abs(wrap_angle(theta)) < theta_c else MODE_SWINGUP
    out[OUT_REWARD] = reward
    out[OUT_END_STEP] = end_step
    out[OUT_X] = x
    out[OUT_X_DOT] = x_dot
    out[OUT_THETA] = wrap_angle(theta)
    out[OUT_THETA_DOT] = theta_dot
    out[OUT_MIN_ABS_THETA_SWINGUP] = min_swing
    out[OUT_MIN_ABS_THETA] = min_all
    out[OUT_FAULT] = fault
    out[OUT_EARLY] = early
    out[OUT_N_SWITCHES] = n_switches
    out[OUT_MAX_ABS_X] = max_abs_x
    out[OUT_MAX_ABS_FORCE] = max_abs_f


@njit(cache=True, parallel=True)
def run_trials_batch(
    states0: np.ndarray,
    W: np.ndarray,
    theta_c: np.ndarray,
    sign: float,
    soft: bool,
    inhibition: float,
    plant: np.ndarray,
    model: np.ndarray,
    mismatch: bool,
    dt: float,
    n_steps: int,
    action_every: int,
    noise: np.ndarray,
    chapter_eligibility: bool,
    gamma: float,
    traces: np.ndarray,
    check_step: int,
    check_x: float,
    check_theta: float,
    goal_x: float,
    goal_theta: float,
    reward_success: float,
    reward_failure: float,
    outs: np.ndarray,
) -> None:
    """:func:`run_trial` for B independent trials at once, parallel over cores.

    Row b of ``states0`` (B, 4), ``W`` (B, 6), ``theta_c`` (B,), ``noise`` (B, n_draws)
    (or (B, 0) for the mean policy), ``traces`` (B, 6) and ``outs`` (B, N_OUT) belongs
    to trial b; the result of each row equals the scalar kernel's bit for bit.
    """
    no_sensor = np.empty((0, 2))
    no_traj = np.empty((0, N_TRAJ))
    for b in prange(states0.shape[0]):
        run_trial(
            states0[b],
            W[b],
            theta_c[b],
            sign,
            soft,
            inhibition,
            plant,
            model,
            mismatch,
            dt,
            n_steps,
            action_every,
            noise[b],
            no_sensor,
            0.0,
            0.0,
            chapter_eligibility,
            gamma,
            traces[b],
            check_step,
            check_x,
            check_theta,
            goal_x,
            goal_theta,
            reward_success,
            reward_failure,
            no_traj,
            outs[b],
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
