"""Runs of the plant under the switching controller, on the one compiled kernel.

:class:`TrialRequest` is the one parameter object of a trial: everything a trial
takes, built in one place, run on the scalar kernel by :meth:`TrialRequest.run` (or in
batches by :mod:`striatal.sim.batch`). :func:`simulate` records a whole trajectory
(the ``simulate`` command, figures, animations).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from striatal.errors import ParameterError
from striatal.params import (
    CHAPTER_HARDWARE,
    N_GAINS,
    Controller,
    Hardware,
    Plant,
    Simulation,
    require_finite,
    require_finite_positive,
)
from striatal.sim import kernel
from striatal.sim.learned import LearnedPlant
from striatal.sim.noise import standard_normals

__all__ = [
    "NO_PROTOCOL",
    "NO_SENSOR",
    "OnlineLearning",
    "Protocol",
    "SensorNoise",
    "Trajectory",
    "TrialOutcome",
    "TrialRequest",
    "action_draws",
    "batch_args",
    "control_args",
    "noise_arrays",
    "plant_args",
    "protocol_args",
    "run_trial",
    "simulate",
]


@dataclass(frozen=True)
class Protocol:
    """The chapter's trial protocol and sparse reward, eqs 24-25.

    ``check_time``: the one check of eq 24 (docs/paper-notes.md section 5) [s]; a negative value
    disables it. Rewards: +10 / -5 as printed.
    """

    check_time: float = 30.0
    check_x: float = 3.0
    check_theta: float = math.pi / 6
    goal_x: float = 0.1
    goal_theta: float = math.pi / 9
    reward_success: float = 10.0
    reward_failure: float = -5.0

    def __post_init__(self) -> None:
        for name in ("check_x", "check_theta", "goal_x", "goal_theta"):
            object.__setattr__(self, name, require_finite_positive(name, getattr(self, name)))
        for name in ("check_time", "reward_success", "reward_failure"):
            object.__setattr__(self, name, require_finite(name, getattr(self, name)))

    def check_step(self, dt: float) -> int:
        """Step index of the eq-24 check, or -1 when disabled."""
        return -1 if self.check_time < 0 else int(round(self.check_time / dt))


#: No check, no reward: a plain simulation.
NO_PROTOCOL = Protocol(check_time=-1.0)


@dataclass(frozen=True)
class SensorNoise:
    """Gaussian noise on the x [m] and theta [rad] the controller sees (not the plant)."""

    x_std: float = 0.0
    theta_std: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x_std", "theta_std"):
            v = require_finite(name, getattr(self, name))
            if v < 0.0:
                raise ParameterError(f"{name} must be >= 0, got {v}")
            object.__setattr__(self, name, v)

    @property
    def active(self) -> bool:
        return self.x_std > 0.0 or self.theta_std > 0.0


#: No sensor noise (a frozen default, shared).
NO_SENSOR = SensorNoise()


@dataclass(frozen=True)
class TrialOutcome:
    """What one trial returns. ``final_state`` has theta wrapped to (-pi, pi].

    ``track``: the cart ran off the track (|x| > Hardware.track), which ends the trial.
    ``rows``: the recorded trial (n, N_TRAJ), columns kernel.TRAJ_COLUMNS, when its
    request asked for them (:attr:`TrialRequest.record`); None otherwise.
    """

    reward: float
    ended_at: float
    final_state: tuple[float, float, float, float]
    min_abs_theta_swingup: float
    min_abs_theta: float
    fault: bool
    early: bool
    n_switches: int
    max_abs_x: float
    max_abs_force: float
    success: bool
    track: bool = False
    rows: np.ndarray | None = field(default=None, compare=False, repr=False)

    @property
    def end_reason(self) -> str:
        """Why the trial ended: fault, track, early (eq 24), success or failure (at T_f)."""
        if self.fault:
            return "fault"
        if self.track:
            return "track"
        if self.early:
            return "early"
        return "success" if self.success else "failure"

    @classmethod
    def from_row(
        cls, out: np.ndarray, sim: Simulation, rows: np.ndarray | None = None
    ) -> TrialOutcome:
        """Decode a kernel summary row (layout kernel.OUT_*), with the trial's ``rows``."""
        return cls.from_values(out.tolist(), sim, rows)

    @classmethod
    def from_values(
        cls, v: list[float], sim: Simulation, rows: np.ndarray | None = None
    ) -> TrialOutcome:
        """:meth:`from_row` of a summary row given as a list (``row.tolist()``: a batch's
        rows decoded with one ``outs.tolist()``)."""
        final = (v[kernel.OUT_X], v[kernel.OUT_X_DOT], v[kernel.OUT_THETA], v[kernel.OUT_THETA_DOT])
        fault = bool(v[kernel.OUT_FAULT])
        early = bool(v[kernel.OUT_EARLY])
        track = bool(v[kernel.OUT_TRACK])
        return cls(
            reward=v[kernel.OUT_REWARD],
            ended_at=v[kernel.OUT_END_STEP] * sim.dt,
            final_state=final,
            min_abs_theta_swingup=v[kernel.OUT_MIN_ABS_THETA_SWINGUP],
            min_abs_theta=v[kernel.OUT_MIN_ABS_THETA],
            fault=fault,
            early=early,
            n_switches=int(v[kernel.OUT_N_SWITCHES]),
            max_abs_x=v[kernel.OUT_MAX_ABS_X],
            max_abs_force=v[kernel.OUT_MAX_ABS_FORCE],
            success=(not fault) and (not early) and (not track) and sim.success.passed(final),
            track=track,
            rows=rows,
        )


@dataclass(frozen=True)
class Trajectory:
    """A recorded run: ``data`` (n, 8) with columns kernel.TRAJ_COLUMNS.

    theta in ``data`` is the continuous (unwrapped) angle; ``outcome.final_state``
    is wrapped. mode: 1 balancing (|theta| < theta_c), 0 swing-up.
    """

    data: np.ndarray
    outcome: TrialOutcome
    plant: Plant
    controller: Controller
    sim: Simulation
    settings: dict[str, object] = field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        return self.data[:, kernel.TRAJ_COLUMNS.index(name)]

    @property
    def t(self) -> np.ndarray:
        return self.column("t")

    @property
    def states(self) -> np.ndarray:
        """(n, 4) [x, x_dot, theta, theta_dot], theta unwrapped."""
        return self.data[:, 1:5]

    @property
    def switch_times(self) -> list[float]:
        """Times [s] at which the active controller changed."""
        mode = self.column("mode")
        idx = np.nonzero(np.diff(mode) != 0)[0] + 1
        return [float(t) for t in self.t[idx]]


def action_draws(sim: Simulation, action_every: int) -> int:
    """Normals a noisy trial draws for its actions: one per ``action_every`` steps (eq 5)."""
    return -(-sim.n_steps // action_every)


def noise_arrays(
    sim: Simulation,
    action_every: int,
    rng: np.random.Generator | None,
    sensor: SensorNoise,
    mean_policy: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """(action normals, sensor normals) of one trial, drawn from ``rng`` in that order:
    one normal per action step unless the mean policy runs, (n_steps, 2) with sensor noise."""
    noise = np.empty(0)
    if rng is not None and not mean_policy:
        noise = np.empty(action_draws(sim, action_every))
        standard_normals(rng, noise)
    if sensor.active:
        if rng is None:
            raise ParameterError("sensor noise needs a random generator (give a seed)")
        sensor_noise = np.empty((sim.n_steps, 2))
        standard_normals(rng, sensor_noise)
    else:
        sensor_noise = np.empty((0, 2))
    return noise, sensor_noise


# ------------------------------------------------------------------ kernel arguments
# The one place where the kernel's grouped arguments (kernel.Gains, PlantArgs, ...)
# are built from the frozen settings; every caller and test goes through these.


def plant_args(
    plant: Plant, dt: float, model: Plant | None = None, hardware: Hardware = CHAPTER_HARDWARE
) -> kernel.PlantArgs:
    """The true ``plant``, the controller's ``model`` of it (default: the same), dt [s] and
    the motor of ``hardware`` (what it holds, its force limit)."""
    model_plant = plant if model is None else model
    return kernel.PlantArgs(
        plant=plant.as_array(),
        model=model_plant.as_array(),
        mismatch=model_plant != plant,
        dt=dt,
        hold_force=hardware.hold == "force" or isinstance(plant, LearnedPlant),
        max_force=math.inf if hardware.max_force is None else hardware.max_force,
    )


def control_args(
    controller: Controller, *, action_every: int = 1, chapter_eligibility: bool = False
) -> kernel.ControlArgs:
    """The controller's readings (sign, switch) and the action rate, validated."""
    if int(action_every) != action_every or action_every < 1:
        raise ParameterError(f"action_every must be a whole number >= 1, got {action_every}")
    return kernel.ControlArgs(
        sign=controller.sign,
        soft=controller.soft,
        inhibition=controller.inhibition,
        action_every=int(action_every),
        chapter_eligibility=chapter_eligibility,
    )


def protocol_args(
    protocol: Protocol, dt: float, n_steps: int, track: float | None = None
) -> kernel.ProtocolArgs:
    """``protocol`` counted in steps of ``dt``, for a trial of ``n_steps`` steps, on a
    track of half-length ``track`` [m] (None: endless)."""
    return kernel.ProtocolArgs(
        n_steps=n_steps,
        check_step=protocol.check_step(dt),
        check_x=protocol.check_x,
        check_theta=protocol.check_theta,
        goal_x=protocol.goal_x,
        goal_theta=protocol.goal_theta,
        reward_success=protocol.reward_success,
        reward_failure=protocol.reward_failure,
        track=math.inf if track is None else track,
    )


@dataclass(frozen=True)
class OnlineLearning:
    """Learning within a trial: the online actor-critic's rates and critic
    (:func:`striatal.sim.kernel.run_online_trial`). The arrays are updated in place when
    the trial runs: ``critic`` v and ``critic_trace`` z (N_FEATURES,), ``square`` (1,)
    the running mean square of delta, ``stats`` (N_STATS,) written, and ``gains_end``
    (6,) the gains at the trial's end. The rates are described at
    :class:`striatal.sim.kernel.CriticArgs`."""

    alpha: float
    beta: float
    discount: float
    critic_decay: float
    max_step: float
    w1_floor: float
    normalise: bool
    square_rate: float
    critic: np.ndarray
    critic_trace: np.ndarray
    square: np.ndarray
    stats: np.ndarray = field(default_factory=lambda: np.zeros(kernel.N_STATS))
    gains_end: np.ndarray = field(default_factory=lambda: np.zeros(N_GAINS))

    def __post_init__(self) -> None:
        if not 0.0 <= self.discount < 1.0:
            raise ParameterError(f"the TD discount must be in [0, 1), got {self.discount}")
        if not 0.0 <= self.critic_decay <= 1.0:
            raise ParameterError(
                f"the critic's trace decay must be in [0, 1], got {self.critic_decay}"
            )
        if self.critic.shape != (kernel.N_FEATURES,) or self.critic_trace.shape != (
            kernel.N_FEATURES,
        ):
            raise ParameterError(f"the critic and its trace must have shape ({kernel.N_FEATURES},)")

    @property
    def rates(self) -> tuple[float, float, float, float, float, float, bool, float]:
        """The numbers a batch of online trials shares."""
        return (
            self.alpha,
            self.beta,
            self.discount,
            self.critic_decay,
            self.max_step,
            self.w1_floor,
            self.normalise,
            self.square_rate,
        )

    def args(self, check_x: float) -> kernel.CriticArgs:
        """The kernel's :class:`~striatal.sim.kernel.CriticArgs` on these arrays."""
        return kernel.CriticArgs(
            alpha=float(self.alpha),
            beta=float(self.beta),
            discount=float(self.discount),
            critic_decay=float(self.critic_decay),
            max_step=float(self.max_step),
            w1_floor=float(self.w1_floor),
            check_x=check_x,
            weights=self.critic,
            trace=self.critic_trace,
            stats=self.stats,
            normalise=bool(self.normalise),
            square_rate=float(self.square_rate),
            square=self.square,
            gains_end=self.gains_end,
        )


@dataclass(frozen=True, eq=False)
class TrialRequest:
    """One trial of the protocol: the one parameter object of a trial, whatever runs it
    (:meth:`run` on the scalar kernel, :func:`striatal.sim.batch.run_requests` in
    batches).

    ``rng``: the policy noise of eq 5 (None: the mean policy); ``mean_policy`` runs the
    mean policy even with a generator, which then draws only the sensor noise; ``trace``
    (6,): the eligibility trace D (eq 3), updated in place, with discount ``gamma``;
    ``gains`` and ``theta_c`` override ``controller.gains`` and ``controller.theta_c``
    without validation (a learner's guarded W and its threshold);
    ``model``: the plant the controller believes in (None: the true ``plant``);
    ``sensor``: noise on what the controller sees; ``hardware``: the motor's hold and
    limit and the track; ``record``: the outcome carries the trial's rows;
    ``online``: the gains learn within the trial (the actor-critic's online trial);
    ``state0`` [x, x_dot, theta, theta_dot] overrides the simulation's start.
    The noise draws from ``rng`` do not depend on ``record``.
    """

    plant: Plant
    controller: Controller
    sim: Simulation
    protocol: Protocol
    rng: np.random.Generator | None = None
    trace: np.ndarray = field(default_factory=lambda: np.zeros(N_GAINS))
    gamma: float = 0.0
    gains: np.ndarray | None = None
    action_every: int = 1
    chapter_eligibility: bool = False
    model: Plant | None = None
    sensor: SensorNoise = NO_SENSOR
    mean_policy: bool = False
    hardware: Hardware = CHAPTER_HARDWARE
    record: bool = False
    online: OnlineLearning | None = None
    state0: np.ndarray | None = None
    theta_c: float | None = None

    @property
    def draws_actions(self) -> bool:
        """Whether the trial draws action noise (eq 5) from its generator."""
        return self.rng is not None and not self.mean_policy

    @property
    def W(self) -> np.ndarray:
        """The gains the trial starts from (6,)."""
        return np.asarray(self.controller.gains if self.gains is None else self.gains, dtype=float)

    @property
    def threshold(self) -> float:
        """The switching threshold theta_c (eq 21) the trial runs with [rad]."""
        return self.controller.theta_c if self.theta_c is None else self.theta_c

    @property
    def start(self) -> np.ndarray:
        """The state the trial starts from (4,)."""
        return self.sim.initial_state if self.state0 is None else np.asarray(self.state0, float)

    def noise(self) -> tuple[np.ndarray, np.ndarray]:
        """(action normals, sensor normals) of the trial, drawn from ``rng`` as it runs."""
        return noise_arrays(self.sim, self.action_every, self.rng, self.sensor, self.mean_policy)

    def args(
        self, noise: np.ndarray | None = None, sensor_noise: np.ndarray | None = None
    ) -> kernel.TrialArgs:
        """The arguments of :func:`striatal.sim.kernel.run_trial` for the normals given
        (:meth:`noise`; None: none, the mean policy and no sensor noise); the kernel writes
        ``args.buffers`` (and ``args.learning.trace`` is :attr:`trace`)."""
        sim, hardware = self.sim, self.hardware
        return kernel.TrialArgs(
            self.start,
            kernel.Gains(W=self.W, theta_c=self.threshold),
            plant_args(self.plant, sim.dt, self.model, hardware),
            control_args(
                self.controller,
                action_every=self.action_every,
                chapter_eligibility=self.chapter_eligibility,
            ),
            protocol_args(self.protocol, sim.dt, sim.n_steps, hardware.track),
            kernel.NoiseArgs(
                action=np.empty(0) if noise is None else noise,
                sensor=np.empty((0, 2)) if sensor_noise is None else sensor_noise,
                sensor_std_x=self.sensor.x_std,
                sensor_std_theta=self.sensor.theta_std,
            ),
            kernel.TraceArgs(gamma=self.gamma, trace=self.trace),
            kernel.Buffers(
                out=np.empty(kernel.N_OUT),
                traj=np.zeros((sim.n_steps + 1 if self.record else 0, kernel.N_TRAJ)),
            ),
        )

    def run(self) -> TrialOutcome:
        """The trial on the scalar kernel (its rows in the outcome with :attr:`record`)."""
        noise, sensor_noise = self.noise()
        args = self.args(noise, sensor_noise)
        if self.online is not None:
            if self.sensor.active or self.record or isinstance(self.plant, LearnedPlant):
                raise ParameterError(
                    "an online trial runs on a physical plant, without sensor noise, unrecorded"
                )
            critic = self.online.args(self.protocol.check_x)
            kernel.run_online_trial(*args[:7], critic, args.buffers.out)
        elif isinstance(self.plant, LearnedPlant):
            assert self.plant.dynamics is not None
            kernel.run_learned_trial(self.plant.dynamics.args, args)
        else:
            kernel.run_trial(*args)
        out, traj = args.buffers
        rows = traj[: int(out[kernel.OUT_END_STEP]) + 1] if self.record else None
        return TrialOutcome.from_row(out, self.sim, rows)

    @property
    def runs_alone(self) -> bool:
        """Whether no batch kernel takes the trial (sensor noise: the batch kernels have
        none; a recorded trial: they record none; an online trial on a learned plant: no
        kernel runs it)."""
        learned = isinstance(self.plant, LearnedPlant)
        return self.sensor.active or self.record or (learned and self.online is not None)

    def batch_objects(self) -> tuple[object, ...]:
        """What :meth:`batch_key` is made of, the objects by identity (``id``), the
        readings by value: requests
        with equal ``batch_objects`` have equal keys, found without hashing the objects.
        Only for grouping requests that are all alive (an ``id`` can be reused later)."""
        c = self.controller
        return (
            id(self.plant),
            c.balance_sign,
            c.switch,
            c.inhibition,
            id(self.sim),
            id(self.protocol),
            self.action_every,
            self.chapter_eligibility,
            self.gamma,
            id(self.model),
            id(self.hardware),
            self.draws_actions,
            id(self.online),
            self.sensor.active,
            self.record,
        )

    def batch_key(self) -> tuple[object, ...] | None:
        """What a batched kernel call shares with this trial; None if it
        :attr:`runs_alone`. The plant is part of the key, so learned plants share a call
        only with the same model (a learned model is equal only to itself)."""
        if self.runs_alone:
            return None
        c = self.controller
        return (
            self.plant,
            (c.balance_sign, c.switch, c.inhibition),
            self.sim,
            self.protocol,
            self.action_every,
            self.chapter_eligibility,
            self.gamma,
            self.model,
            self.hardware,
            self.draws_actions,
            None if self.online is None else self.online.rates,
        )


def run_trial(request: TrialRequest) -> TrialOutcome:
    """One trial of the protocol on the scalar kernel: ``request.run()``."""
    return request.run()


def batch_args(
    requests: Sequence[TrialRequest], noise: np.ndarray | None = None
) -> kernel.BatchArgs:
    """The arguments of :func:`striatal.sim.kernel.run_trials_batch` for B ``requests``
    that share their :meth:`TrialRequest.batch_key` (the first gives what they share).

    ``noise`` (B, n_draws): their action normals (None: the mean policy). Each row of
    the gains, theta_c and traces is its request's; the traces are copies (write them
    back with :func:`striatal.sim.batch.run_requests`). The kernel writes
    ``args.outs`` (B, N_OUT). On a learned plant the arguments follow its model in
    :func:`striatal.sim.kernel.run_learned_trials_batch` (``args.plant.plant`` unused).
    """
    first = requests[0]
    B = len(requests)
    sim, hardware = first.sim, first.hardware
    return kernel.BatchArgs(
        np.array([r.start for r in requests], dtype=float),
        kernel.BatchGains(
            W=np.array([r.W for r in requests], dtype=float),
            theta_c=np.array([r.threshold for r in requests], dtype=float),
        ),
        plant_args(first.plant, sim.dt, first.model, hardware),
        control_args(
            first.controller,
            action_every=first.action_every,
            chapter_eligibility=first.chapter_eligibility,
        ),
        protocol_args(first.protocol, sim.dt, sim.n_steps, hardware.track),
        np.empty((B, 0)) if noise is None else noise,
        kernel.TraceArgs(gamma=first.gamma, trace=np.array([r.trace for r in requests])),
        np.empty((B, kernel.N_OUT)),
    )


def simulate(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol = NO_PROTOCOL,
    rng: np.random.Generator | None = None,
    model: Plant | None = None,
    sensor: SensorNoise = SensorNoise(),
    action_every: int = 1,
    hardware: Hardware = CHAPTER_HARDWARE,
) -> Trajectory:
    """Record one run of the switching controller from ``sim.initial_state``.

    With ``rng`` None the mean policy acts (deterministic); with a generator the
    Gaussian policy of eq 5 draws its actions from it. ``model`` is the plant the
    controller believes in (default: the true ``plant``); ``hardware``: the motor's hold
    and limit and the track (default: the chapter's idealisation).
    """
    outcome = TrialRequest(
        plant,
        controller,
        sim,
        protocol,
        rng=rng,
        model=model,
        sensor=sensor,
        action_every=action_every,
        hardware=hardware,
        record=True,
    ).run()
    assert outcome.rows is not None
    return Trajectory(
        data=outcome.rows,
        outcome=outcome,
        plant=plant,
        controller=controller,
        sim=sim,
    )
