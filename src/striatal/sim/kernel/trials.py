"""The trial: the protocol's judge (eqs 24-25), the summary row, the scalar trial loop
and its batch over cores.

Build the arguments with :meth:`striatal.sim.rollout.TrialRequest.args` and
:func:`striatal.sim.rollout.batch_args`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from striatal.sim.kernel.learned import LearnedArgs, LearnedStep, learned_step_of, step_into
from striatal.sim.kernel.libm import wrap_angle
from striatal.sim.kernel.plant import (
    PlantArgs,
    PlantTerms,
    State,
    StepInputs,
    clip_force,
    force,
    motor_force,
    plant_step,
    plant_terms,
)
from striatal.sim.kernel.policy import (
    MODE_BALANCE,
    MODE_SWINGUP,
    BatchGains,
    ControlArgs,
    Gains,
    PolicyTerms,
    policy_of,
    policy_terms,
)
from striatal.sim.kernel.traces import TraceArgs, trace_step

__all__ = [
    "BLOW_UP",
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
    "BatchArgs",
    "Buffers",
    "NoiseArgs",
    "ProtocolArgs",
    "Tally",
    "TrialArgs",
    "judge",
    "judge_batch",
    "judge_start",
    "load_trace",
    "next_action",
    "run_learned_trial",
    "run_learned_trials_batch",
    "run_trial",
    "run_trials_batch",
    "store_trace",
    "tally_force",
    "tally_mode",
    "tally_start",
    "tally_x",
    "trial_loop",
    "write_summary",
]

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


# Outcome of :func:`judge`.
STATUS_RUNNING = 0
STATUS_FAULT = 1
STATUS_EARLY = 2
STATUS_SUCCESS = 3
STATUS_FAILURE = 4
STATUS_TRACK = 5


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


class Buffers(NamedTuple):
    """Output buffers: the summary row (N_OUT,); the trajectory (n_steps + 1, N_TRAJ) or none
    (0, N_TRAJ)."""

    out: np.ndarray
    traj: np.ndarray


class TrialArgs(NamedTuple):
    """The arguments of one scalar trial (:func:`run_trial`, :func:`run_learned_trial`),
    in their order; :meth:`striatal.sim.rollout.TrialRequest.args` builds them."""

    state0: np.ndarray
    gains: Gains
    plant: PlantArgs
    control: ControlArgs
    protocol: ProtocolArgs
    noise: NoiseArgs
    learning: TraceArgs
    buffers: Buffers


class BatchArgs(NamedTuple):
    """The arguments of the batch kernels (:func:`run_trials_batch`,
    :func:`striatal.sim.kernel.run_trials_lockstep`, after the model
    :func:`run_learned_trials_batch`), in their order: row b of
    ``states0`` (B, 4), ``gains``, ``noise`` (B, n_draws), ``learning.trace`` (B, 6) and
    ``outs`` (B, N_OUT) is trial b's; :func:`striatal.sim.rollout.batch_args` builds them."""

    states0: np.ndarray
    gains: BatchGains
    plant: PlantArgs
    control: ControlArgs
    protocol: ProtocolArgs
    noise: np.ndarray
    learning: TraceArgs
    outs: np.ndarray


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


class Tally(NamedTuple):
    """A trial's running statistics: min |theta| [rad] in swing-up and overall, the
    switches between the modes, the last mode (-1 before the first step), max |x| [m]
    and max |f| [N]. Fresh from :func:`tally_start`."""

    min_swing: float
    min_all: float
    n_switches: int
    prev_mode: int
    max_abs_x: float
    max_abs_f: float


@njit(cache=True)
def tally_start(x: float) -> Tally:
    """The :class:`Tally` before a trial's first step from cart position x [m]."""
    return Tally(math.inf, math.inf, 0, -1, abs(x), 0.0)


@njit(cache=True)
def tally_mode(abs_th: float, theta_c: float, tally: Tally) -> tuple[int, Tally]:
    """(mode, tally) at a step seen at |theta| = abs_th (wrapped): the hard switch of eq 21."""
    mode = MODE_BALANCE if abs_th < theta_c else MODE_SWINGUP
    min_swing = tally.min_swing
    if mode == MODE_SWINGUP and abs_th < min_swing:
        min_swing = abs_th
    min_all = tally.min_all
    if abs_th < min_all:
        min_all = abs_th
    n_switches = tally.n_switches
    if tally.prev_mode >= 0 and mode != tally.prev_mode:
        n_switches += 1
    return mode, Tally(min_swing, min_all, n_switches, mode, tally.max_abs_x, tally.max_abs_f)


@njit(cache=True)
def tally_force(f: float, tally: Tally) -> Tally:
    """``tally`` with max |f| over the step's motor force f [N]."""
    if abs(f) > tally.max_abs_f:
        t = tally
        return Tally(t.min_swing, t.min_all, t.n_switches, t.prev_mode, t.max_abs_x, abs(f))
    return tally


@njit(cache=True)
def tally_x(x: float, status: int, tally: Tally) -> Tally:
    """``tally`` with max |x| over the state reached (not a faulted one)."""
    if status != STATUS_FAULT and abs(x) > tally.max_abs_x:
        t = tally
        return Tally(t.min_swing, t.min_all, t.n_switches, t.prev_mode, abs(x), t.max_abs_f)
    return tally


@njit(cache=True)
def judge_start(
    x: float, x_dot: float, theta: float, theta_dot: float, protocol: ProtocolArgs
) -> tuple[int, float, int]:
    """(status, reward, end_step) before the first step: :func:`judge` at step 0 when the
    eq-24 check is at step 0 (an ended trial's end_step 0), else running to n_steps."""
    if protocol.check_step == 0:
        status, reward = judge(x, x_dot, theta, theta_dot, 0, protocol)
        if status != STATUS_RUNNING:
            return status, reward, 0
        return status, reward, protocol.n_steps
    return STATUS_RUNNING, 0.0, protocol.n_steps


@njit(cache=True, inline="always")
def next_action(
    hold: int,
    draw: int,
    a: float,
    d: tuple[float, float, float, float, float, float],
    seen: tuple[float, float, float, float],
    cos_th: float,
    have_cos: bool,
    pol: PolicyTerms,
    control: ControlArgs,
    normals: np.ndarray,
    gamma: float,
) -> tuple[float, tuple[float, float, float, float, float, float], int, int]:
    """(a, D, hold, draw) after a step's policy: a new action every ``control.action_every``
    steps (``hold`` steps left, 0: draw now), held in between.

    At a draw the action is the mean of eqs 22-23 (:func:`policy_terms`) at ``seen``
    (x, x_dot, th wrapped, theta_dot as the controller sees them; ``cos_th`` = cos th
    when ``have_cos``) plus sigma ``normals[draw]`` (eq 5), and the trace D (6,) of
    eq 3 takes its eligibility (:func:`trace_step`); empty ``normals``: the mean, D kept.
    """
    if hold == 0:
        hold = control.action_every
        x, x_dot, th, theta_dot = seen
        mu, g1, g2, g3, g4, g5 = policy_terms(x, x_dot, th, theta_dot, cos_th, have_cos, pol)
        if normals.shape[0] > 0:
            eps = pol.sigma * normals[draw]
            a = mu + eps
            d0, d1, d2, d3, d4, d5 = d
            d = trace_step(eps, pol.sigma, gamma, g1, g2, g3, g4, g5, d0, d1, d2, d3, d4, d5)
        else:
            a = mu
        draw += 1
    return a, d, hold - 1, draw


@njit(cache=True)
def load_trace(trace: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """The trace D (6,) of eq 3 as a tuple (held in registers over a trial)."""
    return trace[0], trace[1], trace[2], trace[3], trace[4], trace[5]


@njit(cache=True)
def store_trace(trace: np.ndarray, d: tuple[float, float, float, float, float, float]) -> None:
    """Write the tuple D back into ``trace`` (6,)."""
    trace[0] = d[0]
    trace[1] = d[1]
    trace[2] = d[2]
    trace[3] = d[3]
    trace[4] = d[4]
    trace[5] = d[5]


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
    tally: Tally,
) -> None:
    """Write a trial's summary row ``out`` (N_OUT,), layout OUT_*, as :func:`run_trial` does."""
    out[OUT_REWARD] = reward
    out[OUT_END_STEP] = end_step
    out[OUT_X] = x
    out[OUT_X_DOT] = x_dot
    out[OUT_THETA] = wrap_angle(theta)
    out[OUT_THETA_DOT] = theta_dot
    out[OUT_MIN_ABS_THETA_SWINGUP] = tally.min_swing
    out[OUT_MIN_ABS_THETA] = tally.min_all
    out[OUT_FAULT] = 1.0 if status == STATUS_FAULT else 0.0
    out[OUT_EARLY] = 1.0 if status == STATUS_EARLY else 0.0
    out[OUT_N_SWITCHES] = tally.n_switches
    out[OUT_MAX_ABS_X] = tally.max_abs_x
    out[OUT_MAX_ABS_FORCE] = tally.max_abs_f
    out[OUT_TRACK] = 1.0 if status == STATUS_TRACK else 0.0


@njit(cache=True)
def _record(
    traj: np.ndarray,
    k: int,
    dt: float,
    state: tuple[float, float, float, float],
    a: float,
    f: float,
    mode: int,
) -> None:
    """Row k of the trajectory: t, the state (theta unwrapped), u, force, mode."""
    traj[k, 0] = k * dt
    traj[k, 1] = state[0]
    traj[k, 2] = state[1]
    traj[k, 3] = state[2]
    traj[k, 4] = state[3]
    traj[k, 5] = a
    traj[k, 6] = f
    traj[k, 7] = mode


@njit(cache=True)
def _physical_step(state: State, inputs: StepInputs, pt: PlantTerms, dynamics: int) -> State:
    """:func:`plant_step` (eqs 8-9 or 13-14) as :func:`trial_loop` calls a plant's step."""
    x, x_dot, theta, theta_dot = state
    s, c, a, f = inputs
    return plant_step(x, x_dot, theta, theta_dot, s, c, a, f, pt)


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

    Build the arguments with :meth:`striatal.sim.rollout.TrialRequest.args`. A new action
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
    the force of every RK4 stage (:func:`plant_step`), so the plant gets u only while
    the motor can deliver it (docs/paper-notes.md section 9). The recorded force and
    OUT_MAX_ABS_FORCE are the (clipped) force at the step's start.
    """
    trial_loop(
        _physical_step,
        0,
        TrialArgs(state0, gains, plant, control, protocol, noise, learning, buffers),
    )


@njit(cache=True)
def run_learned_trial(model: LearnedArgs, args: TrialArgs) -> None:
    """:func:`run_trial` on a learned plant: each step is
    :func:`~striatal.sim.kernel.learned_step` of ``model`` (:func:`step_into`, with one
    :func:`learned_step_of` for the trial) under the held motor force (eq 12 with ``plant.model``,
    clipped to ``plant.max_force``); ``args.plant.plant`` is not used."""
    trial_loop(step_into, learned_step_of(model), args)


@njit(cache=True, inline="always")
def trial_loop(step: Callable[..., State], dynamics: int | LearnedStep, args: TrialArgs) -> None:
    """The trial loop of :func:`run_trial` with the plant's step ``step(state, inputs, pt,
    dynamics)`` (:data:`State`, :data:`StepInputs`, :class:`PlantTerms`, and what the step
    carries besides: a learned plant's :class:`LearnedStep`, 0 for the physical plant's),
    returning the next :data:`State`: the one loop of a scalar trial, whatever
    integrates the plant. Inlined where it is called, so that each caller compiles it
    with its step function resolved (a step passed at run time cannot be cached)."""
    state0, gains, plant, control, protocol, noise, learning, buffers = args
    theta_c = gains.theta_c
    pt = plant_terms(plant)
    # the policy's constants read once (a store to a buffer would otherwise reload them)
    pol = policy_of(gains.W, theta_c, control, pt.model_m, pt.model_length, pt.model_g)
    dt = plant.dt
    sensor_noise = noise.sensor
    traj = buffers.traj
    x, x_dot, theta, theta_dot = state0[0], state0[1], state0[2], state0[3]
    stochastic = noise.action.shape[0] > 0
    noisy_sensor = sensor_noise.shape[0] > 0
    record = traj.shape[0] > 0
    d = load_trace(learning.trace)  # the trace D (eq 3) in registers, written back at the end
    tally = tally_start(x)
    a = 0.0
    draw = 0
    hold = 0  # steps left before the next action draw (eq 5)
    status, reward, end_step = judge_start(x, x_dot, theta, theta_dot, protocol)
    if status == STATUS_RUNNING:
        for k in range(protocol.n_steps):
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
            mode, tally = tally_mode(abs(th), theta_c, tally)
            seen = (ox, x_dot, th, theta_dot)
            a, d, hold, draw = next_action(
                hold, draw, a, d, seen, c, th == theta, pol, control, noise.action, learning.gamma
            )
            f = motor_force(s, c, otheta, theta_dot, a, noisy_sensor, pt)
            if record:
                _record(traj, k, dt, (x, x_dot, theta, theta_dot), a, f, mode)
            tally = tally_force(f, tally)
            x, x_dot, theta, theta_dot = step(
                (x, x_dot, theta, theta_dot), (s, c, a, f), pt, dynamics
            )
            status, reward = judge(x, x_dot, theta, theta_dot, k + 1, protocol)
            tally = tally_x(x, status, tally)
            if status != STATUS_RUNNING:
                end_step = k + 1
                break
    if stochastic:
        store_trace(learning.trace, d)
    if record:
        f_end = force(theta, theta_dot, a, plant.model)
        f_end = clip_force(f_end, pt.max_force) if pt.limited else f_end
        mode = MODE_BALANCE if abs(wrap_angle(theta)) < theta_c else MODE_SWINGUP
        _record(traj, end_step, dt, (x, x_dot, theta, theta_dot), a, f_end, mode)
    write_summary(buffers.out, status, reward, end_step, x, x_dot, theta, theta_dot, tally)


@njit(cache=True, nogil=True)
def batch_row(
    b: int,
    states0: np.ndarray,
    gains: BatchGains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    outs: np.ndarray,
) -> TrialArgs:
    """Trial b of a batch (the batch kernels' arguments) as one scalar trial's
    arguments: its rows of the start, gains, noise, trace and output, no sensor noise,
    nothing recorded. The trace and output rows are views: the trial writes them."""
    return TrialArgs(
        states0[b],
        Gains(gains.W[b], gains.theta_c[b]),
        plant,
        control,
        protocol,
        NoiseArgs(noise[b], np.empty((0, 2)), 0.0, 0.0),
        TraceArgs(learning.gamma, learning.trace[b]),
        Buffers(outs[b], np.empty((0, N_TRAJ))),
    )


@njit(cache=True, parallel=True, nogil=True)
def run_trials_batch(
    states0: np.ndarray,
    gains: BatchGains,
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
    ``outs`` (B, N_OUT) belongs to trial b (:func:`batch_row`); no sensor noise, nothing
    recorded. The result of each row equals the scalar kernel's bit for bit.
    """
    for b in prange(states0.shape[0]):
        a = batch_row(b, states0, gains, plant, control, protocol, noise, learning, outs)
        run_trial(a.state0, a.gains, a.plant, a.control, a.protocol, a.noise, a.learning, a.buffers)


@njit(cache=True, parallel=True, nogil=True)
def run_learned_trials_batch(
    model: LearnedArgs,
    states0: np.ndarray,
    gains: BatchGains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    outs: np.ndarray,
) -> None:
    """:func:`run_learned_trial` of one learned ``model`` for B independent trials at
    once, parallel over cores: :func:`run_trials_batch` with each step the learned
    one (each trial with its own scratch table). The arguments after ``model`` are
    :func:`run_trials_batch`'s (:func:`striatal.sim.rollout.batch_args`); no sensor
    noise, nothing recorded. The result of each row equals the scalar kernel's bit for
    bit."""
    for b in prange(states0.shape[0]):
        a = batch_row(b, states0, gains, plant, control, protocol, noise, learning, outs)
        run_learned_trial(model, a)
