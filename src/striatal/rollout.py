"""Runs of the plant under the switching controller, on the one compiled kernel.

:func:`simulate` records a whole trajectory (the ``simulate`` command, figures,
animations). :func:`run_trial` runs one trial of the chapter's protocol for the
learner and returns its outcome without recording.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from striatal import kernel
from striatal.errors import ParameterError
from striatal.params import Controller, Plant, Simulation, require_finite, require_finite_positive


@dataclass(frozen=True)
class Protocol:
    """The chapter's trial protocol and sparse reward, eqs 24-25.

    ``check_time``: the one check of eq 24 (NOTES section 5) [s]; a negative value
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


@dataclass(frozen=True)
class TrialOutcome:
    """What one trial returns. ``final_state`` has theta wrapped to (-pi, pi]."""

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

    @classmethod
    def from_row(cls, out: np.ndarray, sim: Simulation) -> TrialOutcome:
        """Decode a kernel summary row (layout kernel.OUT_*)."""
        final = (
            float(out[kernel.OUT_X]),
            float(out[kernel.OUT_X_DOT]),
            float(out[kernel.OUT_THETA]),
            float(out[kernel.OUT_THETA_DOT]),
        )
        fault = bool(out[kernel.OUT_FAULT])
        early = bool(out[kernel.OUT_EARLY])
        return cls(
            reward=float(out[kernel.OUT_REWARD]),
            ended_at=float(out[kernel.OUT_END_STEP]) * sim.dt,
            final_state=final,
            min_abs_theta_swingup=float(out[kernel.OUT_MIN_ABS_THETA_SWINGUP]),
            min_abs_theta=float(out[kernel.OUT_MIN_ABS_THETA]),
            fault=fault,
            early=early,
            n_switches=int(out[kernel.OUT_N_SWITCHES]),
            max_abs_x=float(out[kernel.OUT_MAX_ABS_X]),
            max_abs_force=float(out[kernel.OUT_MAX_ABS_FORCE]),
            success=(not fault) and (not early) and sim.success.passed(np.array(final)),
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


def _noise_arrays(
    sim: Simulation,
    action_every: int,
    rng: np.random.Generator | None,
    sensor: SensorNoise,
    mean_policy: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    n_draws = -(-sim.n_steps // action_every)
    draws_actions = rng is not None and not mean_policy
    noise = rng.standard_normal(n_draws) if draws_actions and rng is not None else np.empty(0)
    if sensor.active:
        if rng is None:
            raise ParameterError("sensor noise needs a random generator (give a seed)")
        sensor_noise = rng.standard_normal((sim.n_steps, 2))
    else:
        sensor_noise = np.empty((0, 2))
    return noise, sensor_noise


def _call_kernel(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol,
    noise: np.ndarray,
    sensor_noise: np.ndarray,
    sensor: SensorNoise,
    model: Plant | None,
    action_every: int,
    gamma: float,
    chapter_eligibility: bool,
    trace: np.ndarray,
    gains: np.ndarray | None,
    traj: np.ndarray,
) -> np.ndarray:
    if int(action_every) != action_every or action_every < 1:
        raise ParameterError(f"action_every must be a whole number >= 1, got {action_every}")
    model_plant = plant if model is None else model
    W = np.asarray(controller.gains if gains is None else gains, dtype=float)
    out = np.empty(kernel.N_OUT)
    kernel.run_trial(
        sim.initial_state,
        W,
        controller.theta_c,
        controller.sign,
        controller.soft,
        controller.inhibition,
        plant.as_array(),
        model_plant.as_array(),
        model_plant != plant,
        sim.dt,
        sim.n_steps,
        action_every,
        noise,
        sensor_noise,
        sensor.x_std,
        sensor.theta_std,
        chapter_eligibility,
        gamma,
        trace,
        protocol.check_step(sim.dt),
        protocol.check_x,
        protocol.check_theta,
        protocol.goal_x,
        protocol.goal_theta,
        protocol.reward_success,
        protocol.reward_failure,
        traj,
        out,
    )
    return out


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
) -> Trajectory:
    """Record one run of the switching controller from ``sim.initial_state``.

    With ``rng`` None the mean policy acts (deterministic); with a generator the
    Gaussian policy of eq 5 draws its actions from it. ``model`` is the plant the
    controller believes in (default: the true ``plant``).
    """
    noise, sensor_noise = _noise_arrays(sim, action_every, rng, sensor)
    traj = np.zeros((sim.n_steps + 1, kernel.N_TRAJ))
    out = _call_kernel(
        plant,
        controller,
        sim,
        protocol=protocol,
        noise=noise,
        sensor_noise=sensor_noise,
        sensor=sensor,
        model=model,
        action_every=action_every,
        gamma=0.0,
        chapter_eligibility=False,
        trace=np.zeros(6),
        gains=None,
        traj=traj,
    )
    outcome = TrialOutcome.from_row(out, sim)
    end = int(out[kernel.OUT_END_STEP])
    return Trajectory(
        data=traj[: end + 1],
        outcome=outcome,
        plant=plant,
        controller=controller,
        sim=sim,
    )


def run_trial(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol,
    trace: np.ndarray,
    gamma: float,
    rng: np.random.Generator | None,
    gains: np.ndarray | None = None,
    action_every: int = 1,
    chapter_eligibility: bool = False,
    model: Plant | None = None,
    sensor: SensorNoise = SensorNoise(),
    mean_policy: bool = False,
) -> TrialOutcome:
    """One trial of the protocol; the eligibility trace ``trace`` (6,) is updated in place.

    ``gains`` may override ``controller.gains`` without validation (the learner's
    guarded W); ``rng`` None runs the mean policy. ``mean_policy`` runs the mean
    policy even with a generator, which then draws only the sensor noise.
    """
    outcome, _ = _trial(
        plant,
        controller,
        sim,
        protocol=protocol,
        trace=trace,
        gamma=gamma,
        rng=rng,
        gains=gains,
        action_every=action_every,
        chapter_eligibility=chapter_eligibility,
        model=model,
        sensor=sensor,
        mean_policy=mean_policy,
        record=False,
    )
    return outcome


def recorded_trial(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol,
    gains: np.ndarray | None,
    rng: np.random.Generator | None,
    trace: np.ndarray,
    gamma: float,
    action_every: int = 1,
    chapter_eligibility: bool = False,
    model: Plant | None = None,
) -> tuple[TrialOutcome, np.ndarray]:
    """:func:`run_trial` that also returns the recorded rows (n, 8), columns kernel.TRAJ_COLUMNS.

    Same noise draws from ``rng`` as :func:`run_trial`; ``trace`` updated in place.
    """
    return _trial(
        plant,
        controller,
        sim,
        protocol=protocol,
        trace=trace,
        gamma=gamma,
        rng=rng,
        gains=gains,
        action_every=action_every,
        chapter_eligibility=chapter_eligibility,
        model=model,
        sensor=SensorNoise(),
        mean_policy=False,
        record=True,
    )


def _trial(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol,
    trace: np.ndarray,
    gamma: float,
    rng: np.random.Generator | None,
    gains: np.ndarray | None,
    action_every: int,
    chapter_eligibility: bool,
    model: Plant | None,
    sensor: SensorNoise,
    mean_policy: bool,
    record: bool,
) -> tuple[TrialOutcome, np.ndarray]:
    noise, sensor_noise = _noise_arrays(sim, action_every, rng, sensor, mean_policy)
    traj = np.zeros((sim.n_steps + 1 if record else 0, kernel.N_TRAJ))
    out = _call_kernel(
        plant,
        controller,
        sim,
        protocol=protocol,
        noise=noise,
        sensor_noise=sensor_noise,
        sensor=sensor,
        model=model,
        action_every=action_every,
        gamma=gamma,
        chapter_eligibility=chapter_eligibility,
        trace=trace,
        gains=gains,
        traj=traj,
    )
    end = int(out[kernel.OUT_END_STEP])
    return TrialOutcome.from_row(out, sim), traj[: end + 1]
