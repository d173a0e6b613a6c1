"""Runs of the plant under the switching controller, on the one compiled kernel.

:func:`simulate` records a whole trajectory (the ``simulate`` command, figures,
animations). :func:`run_trial` runs one trial of the chapter's protocol for the
learner and returns its outcome without recording.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ParamSpec

import numpy as np

from striatal.errors import ParameterError
from striatal.params import (
    CHAPTER_HARDWARE,
    Controller,
    Hardware,
    Plant,
    Simulation,
    require_finite,
    require_finite_positive,
)
from striatal.sim import kernel
from striatal.sim.learned import LearnedPlant

__all__ = [
    "NO_PROTOCOL",
    "BatchArgs",
    "Protocol",
    "SensorNoise",
    "Trajectory",
    "TrialArgs",
    "TrialOutcome",
    "action_draws",
    "batch_args",
    "control_args",
    "noise_arrays",
    "plant_args",
    "protocol_args",
    "recorded_trial",
    "run_kernel",
    "run_trial",
    "simulate",
    "trial",
    "trial_args",
]

P = ParamSpec("P")


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


@dataclass(frozen=True)
class TrialOutcome:
    """What one trial returns. ``final_state`` has theta wrapped to (-pi, pi].

    ``track``: the cart ran off the track (|x| > Hardware.track), which ends the trial.
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
        track = bool(out[kernel.OUT_TRACK])
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
            success=(not fault)
            and (not early)
            and (not track)
            and sim.success.passed(np.array(final)),
            track=track,
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
    n_draws = action_draws(sim, action_every)
    draws_actions = rng is not None and not mean_policy
    noise = rng.standard_normal(n_draws) if draws_actions and rng is not None else np.empty(0)
    if sensor.active:
        if rng is None:
            raise ParameterError("sensor noise needs a random generator (give a seed)")
        sensor_noise = rng.standard_normal((sim.n_steps, 2))
    else:
        sensor_noise = np.empty((0, 2))
    return noise, sensor_noise


# ------------------------------------------------------------------ kernel arguments
# The one place where the kernel's grouped arguments (kernel.Gains, PlantArgs, ...)
# are built from the frozen settings; every caller and test goes through these.

#: The arguments of kernel.run_trial, in its order.
TrialArgs = tuple[
    np.ndarray,
    kernel.Gains,
    kernel.PlantArgs,
    kernel.ControlArgs,
    kernel.ProtocolArgs,
    kernel.NoiseArgs,
    kernel.TraceArgs,
    kernel.Buffers,
]
#: The arguments of kernel.run_trials_batch, in its order.
BatchArgs = tuple[
    np.ndarray,
    kernel.Gains,
    kernel.PlantArgs,
    kernel.ControlArgs,
    kernel.ProtocolArgs,
    np.ndarray,
    kernel.TraceArgs,
    np.ndarray,
]


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


def trial_args(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol,
    noise: np.ndarray | None = None,
    sensor_noise: np.ndarray | None = None,
    sensor: SensorNoise = SensorNoise(),
    gains: np.ndarray | None = None,
    theta_c: float | None = None,
    state0: np.ndarray | None = None,
    model: Plant | None = None,
    action_every: int = 1,
    chapter_eligibility: bool = False,
    gamma: float = 0.0,
    trace: np.ndarray | None = None,
    record: bool = False,
    hardware: Hardware = CHAPTER_HARDWARE,
) -> TrialArgs:
    """The arguments of :func:`striatal.sim.kernel.run_trial`, in its order.

    ``noise``: standard normals of the action draws (None: the mean policy);
    ``sensor_noise`` (n_steps, 2): standard normals scaled by ``sensor``'s stds;
    ``gains`` / ``theta_c`` / ``state0`` override the controller's W, theta_c and
    the simulation's start state; ``trace`` (6,) is updated in place (default
    zeros); ``record`` allocates the (n_steps + 1, N_TRAJ) trajectory; ``hardware``: the
    motor's hold and limit and the track (default: the chapter's idealisation). The
    kernel writes ``args[-1].out`` and ``args[-1].traj``.
    """
    W = np.asarray(controller.gains if gains is None else gains, dtype=float)
    return (
        sim.initial_state if state0 is None else np.asarray(state0, dtype=float),
        kernel.Gains(W=W, theta_c=controller.theta_c if theta_c is None else float(theta_c)),
        plant_args(plant, sim.dt, model, hardware),
        control_args(
            controller, action_every=action_every, chapter_eligibility=chapter_eligibility
        ),
        protocol_args(protocol, sim.dt, sim.n_steps, hardware.track),
        kernel.NoiseArgs(
            action=np.empty(0) if noise is None else noise,
            sensor=np.empty((0, 2)) if sensor_noise is None else sensor_noise,
            sensor_std_x=sensor.x_std,
            sensor_std_theta=sensor.theta_std,
        ),
        kernel.TraceArgs(gamma=gamma, trace=np.zeros(6) if trace is None else trace),
        kernel.Buffers(
            out=np.empty(kernel.N_OUT),
            traj=np.zeros((sim.n_steps + 1 if record else 0, kernel.N_TRAJ)),
        ),
    )


def batch_args(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    *,
    protocol: Protocol,
    gains: np.ndarray,
    theta_c: np.ndarray,
    noise: np.ndarray | None = None,
    states0: np.ndarray | None = None,
    model: Plant | None = None,
    action_every: int = 1,
    chapter_eligibility: bool = False,
    gamma: float = 0.0,
    traces: np.ndarray | None = None,
    hardware: Hardware = CHAPTER_HARDWARE,
) -> BatchArgs:
    """The arguments of :func:`striatal.sim.kernel.run_trials_batch`, in its order.

    B trials: ``gains`` (B, 6) and ``theta_c`` (B,) per trial; ``noise`` (B, n_draws)
    action normals (None: the mean policy); ``states0`` (B, 4) (default: the
    simulation's start state on every row); ``traces`` (B, 6) updated in place
    (default zeros). ``controller`` gives the readings (sign, switch) only;
    ``hardware`` as in :func:`trial_args` (run_trials_lockstep refuses all but the
    default). The kernel writes ``args[-1]`` (B, N_OUT).
    """
    if isinstance(plant, LearnedPlant):
        raise ParameterError("the batch kernels run physical plants only, not a learned plant")
    W = np.ascontiguousarray(gains, dtype=float)
    B = W.shape[0]
    if W.shape != (B, 6):
        raise ParameterError(f"gains must be (B, 6), got {W.shape}")
    tc = np.ascontiguousarray(theta_c, dtype=float)
    if tc.shape != (B,):
        raise ParameterError(f"theta_c must be (B,) = ({B},), got {tc.shape}")
    s0 = np.tile(sim.initial_state, (B, 1)) if states0 is None else states0
    return (
        np.ascontiguousarray(s0, dtype=float),
        kernel.Gains(W=W, theta_c=tc),
        plant_args(plant, sim.dt, model, hardware),
        control_args(
            controller, action_every=action_every, chapter_eligibility=chapter_eligibility
        ),
        protocol_args(protocol, sim.dt, sim.n_steps, hardware.track),
        np.empty((B, 0)) if noise is None else noise,
        kernel.TraceArgs(gamma=gamma, trace=np.zeros((B, 6)) if traces is None else traces),
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
    outcome, data = trial(
        plant,
        controller,
        sim,
        protocol=protocol,
        trace=np.zeros(6),
        gamma=0.0,
        rng=rng,
        model=model,
        sensor=sensor,
        action_every=action_every,
        hardware=hardware,
        record=True,
    )
    return Trajectory(
        data=data,
        outcome=outcome,
        plant=plant,
        controller=controller,
        sim=sim,
    )


def trial(
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
    hardware: Hardware = CHAPTER_HARDWARE,
    record: bool = False,
) -> tuple[TrialOutcome, np.ndarray]:
    """One trial of the protocol and its recorded rows (n, 8), columns
    kernel.TRAJ_COLUMNS (none unless ``record``); the eligibility trace ``trace`` (6,)
    is updated in place.

    ``gains`` may override ``controller.gains`` without validation (the learner's
    guarded W); ``rng`` None runs the mean policy. ``mean_policy`` runs the mean
    policy even with a generator, which then draws only the sensor noise. The noise
    draws from ``rng`` do not depend on ``record``.
    """
    noise, sensor_noise = noise_arrays(sim, action_every, rng, sensor, mean_policy)
    args = trial_args(
        plant,
        controller,
        sim,
        protocol=protocol,
        noise=noise,
        sensor_noise=sensor_noise,
        sensor=sensor,
        gains=gains,
        model=model,
        action_every=action_every,
        chapter_eligibility=chapter_eligibility,
        gamma=gamma,
        trace=trace,
        record=record,
        hardware=hardware,
    )
    run_kernel(plant, args)
    out, traj = args[-1]
    end = int(out[kernel.OUT_END_STEP])
    return TrialOutcome.from_row(out, sim), traj[: end + 1]


def _outcome_of(run: Callable[P, tuple[TrialOutcome, np.ndarray]]) -> Callable[P, TrialOutcome]:
    def outcome(*args: P.args, **kwargs: P.kwargs) -> TrialOutcome:
        return run(*args, **kwargs)[0]

    return outcome


#: One trial of the protocol without its rows: :func:`trial`'s outcome.
run_trial = _outcome_of(trial)
run_trial.__name__ = run_trial.__qualname__ = "run_trial"
run_trial.__doc__ = """One trial of the protocol, its outcome: :func:`trial` (same arguments),
nothing recorded unless ``record``; the eligibility trace ``trace`` (6,) is updated in place."""


def recorded_trial(
    plant: Plant, controller: Controller, sim: Simulation, **options: Any
) -> tuple[TrialOutcome, np.ndarray]:
    """:func:`trial` with its rows recorded (the same keyword options; same noise draws)."""
    return trial(plant, controller, sim, record=True, **options)


def run_kernel(plant: Plant, args: TrialArgs) -> None:
    """Run the kernel trial of :func:`trial_args`' ``args`` on ``plant``:
    :func:`striatal.sim.kernel.run_trial`, or on a :class:`~striatal.sim.learned.LearnedPlant`
    :func:`striatal.sim.kernel.run_learned_trial` with its dynamics."""
    if isinstance(plant, LearnedPlant):
        assert plant.dynamics is not None
        kernel.run_learned_trial(plant.dynamics.args, args)
    else:
        kernel.run_trial(*args)
