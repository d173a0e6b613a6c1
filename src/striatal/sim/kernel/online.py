"""The compiled online trial of the actor-critic learner, on the kernel's functions.

One trial of the chapter's protocol (eqs 24-25) in which the gains change at every
step, in the manner of Doya (2000, continuous-time actor-critic) and Frémaux et al.
(2013, TD-modulated three-factor rule), discretised at the control step dt:

- a critic V(s) = v . phi(s), linear in :data:`N_FEATURES` bounded features of the
  state (:func:`features`: a bias, the distance from upright, the squared energy
  error E~ of eqs 15-16, the cart's distance and the two speeds);
- a dense reward r_k = -dt cost(s_{k+1}) (:func:`step_cost`: distance from
  upright, squared energy error, cart distance, weights :data:`COST_WEIGHTS`);
- the temporal-difference error delta_k = r_k + gamma_v V(s_{k+1}) - V(s_k) at
  every step: the dopamine-like factor. The protocol's ends in time (eq 24's check
  at 30 s, T_f) are time limits: V(s') is bootstrapped (the critic sees no clock); a
  trial that leaves the track or faults ends in a terminal state worth
  :func:`failure_value`;
- the actor's eligibility trace D of eq 3, updated at every draw by the kernel's own
  :func:`striatal.sim.kernel.trace_step`, and W <- W + clip(alpha delta_k D_k, +-max_step)
  at every step (W1 floored), delta optionally divided by its running rms;
- the critic's trace z <- gamma_v lambda z + phi(s_k) and v <- v + beta delta_k z.

The plant, the controllers, the eligibilities and the trial's bookkeeping are the
kernel's njit functions (:func:`striatal.sim.kernel.plant_step`, ``next_action``,
``judge``, ``Tally``, ``write_summary``): no physics is written here. With
alpha = beta = 0 the trial is :func:`striatal.sim.kernel.run_trial`'s bit for bit
(tests/test_online.py).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from striatal.sim.kernel.libm import wrap_angle
from striatal.sim.kernel.plant import PlantArgs, motor_force, plant_step, plant_terms
from striatal.sim.kernel.policy import BatchGains, ControlArgs, Gains, policy_of
from striatal.sim.kernel.traces import TraceArgs
from striatal.sim.kernel.trials import (
    STATUS_FAULT,
    STATUS_RUNNING,
    STATUS_TRACK,
    NoiseArgs,
    ProtocolArgs,
    batch_row,
    judge,
    judge_start,
    load_trace,
    next_action,
    store_trace,
    tally_force,
    tally_mode,
    tally_start,
    tally_x,
    write_summary,
)

__all__ = [
    "COST_WEIGHTS",
    "FEATURE_NAMES",
    "N_FEATURES",
    "N_STATS",
    "STAT_N",
    "STAT_RETURN",
    "STAT_SUM_DELTA",
    "STAT_SUM_DELTA2",
    "STAT_VALUE0",
    "CriticArgs",
    "failure_value",
    "features",
    "run_online_trial",
    "run_online_trials_batch",
    "step_cost",
]

#: The critic's features phi(s), each in [0, 1) (see :func:`features`).
FEATURE_NAMES = ("bias", "upright", "energy", "cart", "cart_speed", "pole_speed")
N_FEATURES = len(FEATURE_NAMES)
#: Weights of the cost terms (distance from upright, squared energy error, cart distance)
#: of the dense reward r = -dt cost (:func:`step_cost`).
COST_WEIGHTS = (1.0, 1.0, 1.0)

# Layout of the statistics row written by :func:`run_online_trial`.
STAT_SUM_DELTA = 0
STAT_SUM_DELTA2 = 1
STAT_N = 2
STAT_RETURN = 3
STAT_VALUE0 = 4
N_STATS = 5


class CriticArgs(NamedTuple):
    """The online rule's rates and the critic, for :func:`run_online_trial`.

    ``alpha``: the actor's rate; ``beta``: the critic's; ``discount``: gamma_v of
    delta per step; ``critic_decay``: lambda of the critic's trace; ``max_step``:
    bound on each component of one step's change of W; ``w1_floor``: W1's floor;
    ``check_x``: the cart distance [m] that scales the cart feature (eq 24's 3 m);
    ``weights`` (N_FEATURES,) v and ``trace`` (N_FEATURES,) z, updated in place;
    ``stats`` (N_STATS,): written (layout STAT_*); ``normalise``: the actor's factor is
    delta over the root of its running mean square ``square`` (1,) (updated in place,
    0: start at delta^2), which tracks (1 - square_rate) square + square_rate delta^2;
    ``gains_end`` (6,): written, the gains at the trial's end.
    """

    alpha: float
    beta: float
    discount: float
    critic_decay: float
    max_step: float
    w1_floor: float
    check_x: float
    weights: np.ndarray
    trace: np.ndarray
    stats: np.ndarray
    normalise: bool
    square_rate: float
    square: np.ndarray
    gains_end: np.ndarray


@njit(cache=True)
def _energy_ratio(cos_th: float, theta_dot: float, model: np.ndarray) -> float:
    """E~ / (2 E_d) with E~ of eqs 15-16 and E_d = m g l: -1 hanging at rest, 0 upright."""
    length = model[2]
    g = model[3]
    return (0.5 * length * length * theta_dot * theta_dot + g * length * (cos_th - 1.0)) / (
        2.0 * g * length
    )


@njit(cache=True)
def _saturate(q: float) -> float:
    """q / (1 + q) for q >= 0: 0 at 0, 1/2 at 1, below 1."""
    return q / (1.0 + q)


@njit(cache=True)
def features(
    x: float,
    x_dot: float,
    th: float,
    theta_dot: float,
    model: np.ndarray,
    check_x: float,
    phi: np.ndarray,
) -> None:
    """The critic's features phi(s) (N_FEATURES,) of a state, written into ``phi``.

    ``th`` wrapped [rad]; ``model`` [M, m, l, g] the controller's plant. In order
    (FEATURE_NAMES): 1; (1 - cos th) / 2 (0 upright, 1 hanging); sat(e^2) with
    e = E~ / (2 m g l) (eqs 15-16); sat((x / check_x)^2); sat(x_dot^2) [x_dot in m/s];
    sat(theta_dot^2 l / g); sat(q) = q / (1 + q). All in [0, 1), so one step of the
    critic is bounded.
    """
    c = math.cos(th)
    e = _energy_ratio(c, theta_dot, model)
    xr = x / check_x
    phi[0] = 1.0
    phi[1] = 0.5 * (1.0 - c)
    phi[2] = _saturate(e * e)
    phi[3] = _saturate(xr * xr)
    phi[4] = _saturate(x_dot * x_dot)
    phi[5] = _saturate(theta_dot * theta_dot * model[2] / model[3])


@njit(cache=True)
def step_cost(phi: np.ndarray) -> float:
    """The dense reward's cost per second, from the features of the state reached:
    w_1 (1 - cos th) / 2 + w_2 sat(e^2) + w_3 sat((x / check_x)^2) (COST_WEIGHTS)."""
    return 1.0 * phi[1] + 1.0 * phi[2] + 1.0 * phi[3]


@njit(cache=True)
def failure_value(dt: float, discount: float) -> float:
    """The value of the terminal state of a trial that left the track or faulted:
    the largest cost (3 per second) for ever, -3 dt / (1 - gamma_v)."""
    return -3.0 * dt / (1.0 - discount)


@njit(cache=True)
def _dot(v: np.ndarray, phi: np.ndarray) -> float:
    s = 0.0
    for i in range(phi.shape[0]):
        s += v[i] * phi[i]
    return s


@njit(cache=True)
def run_online_trial(
    state0: np.ndarray,
    gains: Gains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: NoiseArgs,
    learning: TraceArgs,
    critic: CriticArgs,
    out: np.ndarray,
) -> None:
    """One trial with the online actor-critic update at every step (module docstring).

    The arguments are :func:`striatal.sim.kernel.run_trial`'s (build them with
    :meth:`striatal.sim.rollout.TrialRequest.args`; no sensor noise, nothing recorded)
    plus ``critic``. The trial starts from ``gains.W`` (6,) (not changed);
    ``critic.gains_end`` holds the gains at the trial's end. ``learning.trace`` (eq 3)
    and ``critic.weights`` / ``critic.trace`` are updated in place; ``out`` (N_OUT,)
    gets the summary row (layout OUT_*) and ``critic.stats`` the sum of delta, of
    delta^2, the number of TD steps, the return sum r_k and V(s_0).
    """
    W = critic.gains_end
    W[:] = gains.W
    theta_c = gains.theta_c
    model = plant.model
    pt = plant_terms(plant)
    dt = plant.dt
    x, x_dot, theta, theta_dot = state0[0], state0[1], state0[2], state0[3]
    discount = critic.discount
    v = critic.weights
    z = critic.trace
    stats = critic.stats
    square = critic.square
    sq_rate = critic.square_rate
    m, length, g = pt.model_m, pt.model_length, pt.model_g
    pol = policy_of(W, theta_c, control, m, length, g)
    d = load_trace(learning.trace)
    phi = np.empty(N_FEATURES)
    phi_next = np.empty(N_FEATURES)
    v_fail = failure_value(dt, discount)
    tally = tally_start(x)
    a = 0.0
    draw = 0
    hold = 0
    sum_delta = 0.0
    sum_delta2 = 0.0
    n_td = 0
    ret = 0.0
    features(x, x_dot, wrap_angle(theta), theta_dot, model, critic.check_x, phi)
    stats[STAT_VALUE0] = _dot(v, phi)
    status, reward, end_step = judge_start(x, x_dot, theta, theta_dot, protocol)
    if status == STATUS_RUNNING:
        for k in range(protocol.n_steps):
            s = math.sin(theta)
            c = math.cos(theta)
            th = wrap_angle(theta)
            _, tally = tally_mode(abs(th), theta_c, tally)
            # the critic's view of s_k (with the weights as they are now)
            features(x, x_dot, th, theta_dot, model, critic.check_x, phi)
            value = _dot(v, phi)
            for i in range(N_FEATURES):
                z[i] = discount * critic.critic_decay * z[i] + phi[i]
            seen = (x, x_dot, th, theta_dot)
            a, d, hold, draw = next_action(
                hold, draw, a, d, seen, c, th == theta, pol, control, noise.action, learning.gamma
            )
            f = motor_force(s, c, theta, theta_dot, a, False, pt)
            tally = tally_force(f, tally)
            x, x_dot, theta, theta_dot = plant_step(x, x_dot, theta, theta_dot, s, c, a, f, pt)
            status, reward = judge(x, x_dot, theta, theta_dot, k + 1, protocol)
            # the TD error: the ends of the protocol in time (eq 24's check at 30 s, T_f)
            # bootstrap, as the critic sees no time; the track and a fault are terminal
            if status != STATUS_TRACK and status != STATUS_FAULT:
                features(x, x_dot, wrap_angle(theta), theta_dot, model, critic.check_x, phi_next)
                r = -dt * step_cost(phi_next)
                delta = r + discount * _dot(v, phi_next) - value
            else:
                r = -3.0 * dt
                delta = r + discount * v_fail - value
            if math.isfinite(delta):
                ret += r
                sum_delta += delta
                sum_delta2 += delta * delta
                n_td += 1
                for i in range(N_FEATURES):
                    v[i] += critic.beta * delta * z[i]
                # the actor's factor: delta, or delta over its running rms
                sq = square[0]
                sq = delta * delta if sq <= 0.0 else (1.0 - sq_rate) * sq + sq_rate * delta * delta
                square[0] = sq
                factor = delta
                if critic.normalise:
                    factor = delta / math.sqrt(sq) if sq > 0.0 else 0.0
                if critic.alpha != 0.0:
                    changed = False
                    for i in range(6):
                        step = critic.alpha * factor * d[i]
                        step = min(max(step, -critic.max_step), critic.max_step)
                        if math.isfinite(step) and step != 0.0:
                            W[i] += step
                            changed = True
                    if changed:
                        W[0] = max(W[0], critic.w1_floor)
                        pol = policy_of(
                            W, theta_c, control, pt.model_m, pt.model_length, pt.model_g
                        )
            tally = tally_x(x, status, tally)
            if status != STATUS_RUNNING:
                end_step = k + 1
                break
    stats[STAT_SUM_DELTA] = sum_delta
    stats[STAT_SUM_DELTA2] = sum_delta2
    stats[STAT_N] = n_td
    stats[STAT_RETURN] = ret
    if noise.action.shape[0] > 0:
        store_trace(learning.trace, d)
    write_summary(out, status, reward, end_step, x, x_dot, theta, theta_dot, tally)


@njit(cache=True, parallel=True, nogil=True)
def run_online_trials_batch(
    states0: np.ndarray,
    gains: BatchGains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    critic: CriticArgs,
    outs: np.ndarray,
) -> None:
    """:func:`run_online_trial` for B independent trials at once, parallel over cores.

    Row b of ``states0`` (B, 4), ``gains.W`` (B, 6), ``gains.theta_c`` (B,), ``noise``
    (B, n_draws), ``learning.trace`` (B, 6), ``outs`` (B, N_OUT) and of the arrays of
    ``critic`` (weights, trace, stats, square, gains_end: (B, ...)) belongs to trial b;
    the rates are shared. Each row equals the scalar trial's bit for bit.
    """
    for b in prange(states0.shape[0]):
        c = critic
        a = batch_row(b, states0, gains, plant, control, protocol, noise, learning, outs)
        run_online_trial(
            a.state0,
            a.gains,
            a.plant,
            a.control,
            a.protocol,
            a.noise,
            a.learning,
            CriticArgs(
                c.alpha,
                c.beta,
                c.discount,
                c.critic_decay,
                c.max_step,
                c.w1_floor,
                c.check_x,
                c.weights[b],
                c.trace[b],
                c.stats[b],
                c.normalise,
                c.square_rate,
                c.square[b],
                c.gains_end[b],
            ),
            outs[b],
        )
