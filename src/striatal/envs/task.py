"""The swing-up task shared by the scalar and the vector environment.

Settings, observations and rewards only: the physics is :func:`striatal.sim.kernel.rk4_step`
(scalar env) and :func:`striatal.sim.kernel.step_batch` (vector env). Every function
here works on batches (leading axis B) so that both environments compute their
observations and rewards with the very same NumPy calls.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.params import (
    CHAPTER_THETA0,
    MAX_STEPS,
    Plant,
    as_float,
    check_dt,
    require_finite,
    require_finite_positive,
)
from striatal.sim import kernel
from striatal.sim.rollout import Protocol, protocol_args

__all__ = [
    "DEFAULT_U_MAX",
    "OBSERVATION_NAMES",
    "RESET_OPTIONS",
    "ObservationKind",
    "RewardKind",
    "SpaceDtype",
    "SwingUpTask",
    "check_dtype",
    "check_perturbation",
    "check_reset_options",
    "check_state",
    "check_track",
    "dense_reward",
    "observe",
    "outcome",
    "start_state",
    "wrap",
]

ObservationKind = Literal["trig", "raw"]
RewardKind = Literal["chapter", "dense"]
SpaceDtype = Literal["float32", "float64"]

#: Default clip on the commanded cart acceleration u [m/s^2]. The chapter's final
#: controller peaks at |u| = 13.4 m/s^2 (``striatal simulate --chapter-final``), so
#: 50 never clips it.
DEFAULT_U_MAX = 50.0

#: Names of the observation entries, by observation kind.
OBSERVATION_NAMES = {
    "trig": ("x", "x_dot", "sin_theta", "cos_theta", "theta_dot"),
    "raw": ("x", "x_dot", "theta", "theta_dot"),
}


@dataclass(frozen=True)
class SwingUpTask:
    """Settings of one ``striatal/CartPoleSwingUp-v0`` environment.

    Attributes
    ----------
    plant : the point-mass cart-pole (eqs 7-14); the action is x_ddot = u exactly (eq 13).
    dt : control step [s]; each env step is one RK4 step of the kernel with u held.
    duration : episode length [s]; reaching it is a truncation (Gymnasium's time limit).
    u_max : actions are clipped to [-u_max, u_max], in m/s^2.
    observation : ``"trig"`` = [x, x_dot, sin theta, cos theta, theta_dot];
        ``"raw"`` = the kernel state [x, x_dot, theta, theta_dot] (theta unwrapped).
    reward : ``"chapter"`` (sparse eqs 24-25 from ``protocol``) or ``"dense"``
        (DeepMind-Control-style upright-and-centred reward in [0, 1] per step).
    protocol : the check at t = 30 s and the final goal of eqs 24-25 (chapter reward;
        the t = 30 s check terminates the episode in both reward modes).
    initial_state : start state [x, x_dot, theta, theta_dot]; default the chapter's
        x = 0, theta = 3.12 at rest.
    perturbation : half-width of a uniform random offset added to each start state
        component at reset, drawn from the env's ``np_random`` (0: none; below 1e8,
        the kernel's blow-up bound).
    normalised_action : if True the action is in [-1, 1], scaled to u = a * u_max
        inside the env (what most RL libraries expect); if False (default) the action
        is u itself [m/s^2].
    track : half-length of the rails [m]; |x| beyond it after a step ends the episode
        (``terminated``, as in Gymnasium's CartPole; the chapter reward's failure
        reward -5, the dense reward of that state). None (default) or ``inf``: an
        endless track, the chapter's idealisation.
    dtype : ``"float32"`` (default, what RL libraries expect) or ``"float64"``: the
        dtype of the observation and action spaces and of the observations. The
        physics is float64 in both; actions of any real dtype are accepted and used
        as float64, so ``"float64"`` observations make the env bit-exact with the
        kernel under a policy that reads them.
    """

    plant: Plant = field(default_factory=Plant)
    dt: float = 0.01
    duration: float = 60.0
    u_max: float = DEFAULT_U_MAX
    observation: ObservationKind = "trig"
    reward: RewardKind = "chapter"
    protocol: Protocol = field(default_factory=Protocol)
    initial_state: tuple[float, float, float, float] = (0.0, 0.0, CHAPTER_THETA0, 0.0)
    perturbation: float = 0.0
    normalised_action: bool = False
    track: float | None = None
    dtype: SpaceDtype = "float32"

    def __post_init__(self) -> None:
        if not isinstance(self.plant, Plant):
            raise ParameterError(f"plant must be a striatal.Plant, got {self.plant!r}")
        if not isinstance(self.protocol, Protocol):
            raise ParameterError(f"protocol must be a striatal.Protocol, got {self.protocol!r}")
        object.__setattr__(self, "dt", check_dt(self.dt))
        object.__setattr__(self, "duration", require_finite_positive("duration", self.duration))
        object.__setattr__(self, "u_max", require_finite_positive("u_max", self.u_max))
        if self.observation not in OBSERVATION_NAMES:
            raise ParameterError(f"observation must be 'trig' or 'raw', got {self.observation!r}")
        if self.reward not in ("chapter", "dense"):
            raise ParameterError(f"reward must be 'chapter' or 'dense', got {self.reward!r}")
        object.__setattr__(self, "initial_state", check_state(self.initial_state))
        object.__setattr__(self, "perturbation", check_perturbation(self.perturbation))
        if not isinstance(self.normalised_action, bool | np.bool_):
            raise ParameterError(
                f"normalised_action must be True or False, got {self.normalised_action!r}"
            )
        object.__setattr__(self, "normalised_action", bool(self.normalised_action))
        object.__setattr__(self, "track", check_track(self.track))
        object.__setattr__(self, "dtype", check_dtype(self.dtype))
        if not self.normalised_action and self.u_max > float(np.finfo(self.dtype).max):
            raise ParameterError(
                f"u_max = {self.u_max:g} does not fit the {self.dtype} action space; "
                "use dtype='float64' or normalised_action=True"
            )
        steps = self.duration / self.dt
        if not 1 <= round(steps) <= MAX_STEPS:
            raise ParameterError(
                f"duration / dt = {steps:.3g} steps must be between 1 and {MAX_STEPS:,}"
            )

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> SwingUpTask:
        """Build from ``gymnasium.make`` keyword arguments; ParameterError on unknown names."""
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(kwargs) - known)
        if unknown:
            raise ParameterError(f"unknown environment option(s) {unknown}; known: {sorted(known)}")
        if "initial_state" in kwargs and kwargs["initial_state"] is not None:
            kwargs["initial_state"] = check_state(kwargs["initial_state"])
        elif "initial_state" in kwargs:
            del kwargs["initial_state"]
        return cls(**kwargs)

    @property
    def n_steps(self) -> int:
        """Steps in a full episode: round(duration / dt)."""
        return int(round(self.duration / self.dt))

    @property
    def check_step(self) -> int:
        """Step count at which the eq-24 check applies (-1: never)."""
        return self.protocol.check_step(self.dt)

    @property
    def obs_size(self) -> int:
        """Length of one observation: 5 for ``"trig"``, 4 for ``"raw"``."""
        return len(OBSERVATION_NAMES[self.observation])

    @property
    def render_fps(self) -> float:
        """Frames per second that play a recorded episode in real time: 1 / dt."""
        fps = 1.0 / self.dt
        return int(round(fps)) if abs(fps - round(fps)) < 1e-9 * fps else fps


#: Keys ``reset(options=...)`` understands, for the scalar environment.
RESET_OPTIONS = ("initial_state", "perturbation")


def check_perturbation(value: float) -> float:
    """A perturbation half-width in [0, 1e8) [state units], or ParameterError.

    1e8 is the kernel's blow-up bound (:data:`striatal.sim.kernel.BLOW_UP`): a start
    beyond it would end the episode as a fault on its first step.
    """
    p = require_finite("perturbation", value)
    if not 0.0 <= p < kernel.BLOW_UP:
        raise ParameterError(f"perturbation must be >= 0 and < {kernel.BLOW_UP:g}, got {p!r}")
    return p


def check_track(value: object) -> float | None:
    """A track half-length: a finite number > 0 [m], or None for an endless track.

    ``inf`` is read as None. Anything else (0, a negative number, NaN, a bool, text)
    raises ParameterError.
    """
    if value is None:
        return None
    if isinstance(value, bool | np.bool_):
        raise ParameterError(f"track must be a number > 0 [m] or None, got {value!r}")
    t = as_float("track", value)
    if t == math.inf:
        return None
    if not math.isfinite(t) or t <= 0.0:
        raise ParameterError(
            f"track must be a finite number > 0 [m] (half-length of the rails), "
            f"or None / inf for an endless track; got {value!r}"
        )
    return t


def check_dtype(value: object) -> SpaceDtype:
    """``"float32"`` or ``"float64"`` from a name or NumPy type, or ParameterError."""
    try:
        name = np.dtype(value).name if value is not None else None  # type: ignore[call-overload]
    except TypeError:
        name = None
    if name == "float32":
        return "float32"
    if name == "float64":
        return "float64"
    raise ParameterError(f"dtype must be 'float32' or 'float64', got {value!r}")


def check_reset_options(
    options: object, allowed: tuple[str, ...] = RESET_OPTIONS
) -> dict[str, Any]:
    """``reset(options=...)`` as a dict with only ``allowed`` keys, or ParameterError.

    The values are checked where they are used (:func:`start_state`), with the same
    rules as the keyword arguments of ``gymnasium.make``.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ParameterError(
            f"reset options must be a dict (keys {list(allowed)}), got {type(options).__name__}"
        )
    unknown = sorted(str(k) for k in options if k not in allowed)
    if unknown:
        raise ParameterError(f"unknown reset option(s) {unknown}; known: {list(allowed)}")
    return dict(options)


def check_state(state: object) -> tuple[float, float, float, float]:
    """A finite start state [x, x_dot, theta, theta_dot], each |component| < 1e8
    (:data:`striatal.sim.kernel.BLOW_UP`), or ParameterError."""
    try:
        s = np.asarray(state, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ParameterError(f"initial_state must be four numbers, got {state!r}") from None
    if s.shape != (4,) or not np.all(np.isfinite(s)):
        raise ParameterError(
            f"initial_state must be four finite numbers [x, x_dot, theta, theta_dot], got {state!r}"
        )
    if not np.all(np.abs(s) < kernel.BLOW_UP):
        # as for the perturbation: such a start is a numerical fault before the first step
        raise ParameterError(
            f"initial_state components must be < {kernel.BLOW_UP:g} in size, got {state!r}"
        )
    return (float(s[0]), float(s[1]), float(s[2]), float(s[3]))


def start_state(
    task: SwingUpTask, rng: np.random.Generator, options: dict[str, Any] | None
) -> np.ndarray:
    """(4,) start state for a reset: ``options["initial_state"]`` or the task's, plus perturbation.

    ``options["perturbation"]`` overrides the task's perturbation half-width for this reset.
    The generator is used only when the perturbation is > 0. Unknown keys, a
    non-dict ``options`` and out-of-range values raise ParameterError.
    """
    opts = check_reset_options(options)
    base = opts.get("initial_state")
    state = np.array(task.initial_state if base is None else check_state(base), dtype=float)
    p = task.perturbation
    if opts.get("perturbation") is not None:
        p = check_perturbation(opts["perturbation"])
    if p > 0.0:
        state += rng.uniform(-p, p, size=4)
    return state


def wrap(theta: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]: :func:`striatal.sim.kernel.wrap_angle` over an array."""
    result: np.ndarray = kernel.wrap_angles(np.asarray(theta, dtype=float))
    return result


def observe(states: np.ndarray, kind: ObservationKind, dtype: SpaceDtype = "float64") -> np.ndarray:
    """(B, 5) trig or (B, 4) raw observations of kernel states (B, 4), as ``dtype``.

    Computed in float64 and then rounded once to ``dtype``.
    """
    if kind == "raw":
        obs = states.copy()
    else:
        th = states[:, 2]
        obs = np.stack([states[:, 0], states[:, 1], np.sin(th), np.cos(th), states[:, 3]], axis=1)
    # Only a blown-up state (beyond 1e8, already a fault) overflows float32, to inf.
    with np.errstate(over="ignore"):
        return obs.astype(dtype, copy=False)


def _gaussian_tolerance(d: np.ndarray, margin: float, value_at_margin: float = 0.1) -> np.ndarray:
    """dm_control ``rewards.tolerance`` with bounds (0, 0) and a Gaussian sigmoid."""
    scale = math.sqrt(-2.0 * math.log(value_at_margin))
    z = d / margin * scale
    return kernel.exp_libm(-0.5 * z * z)  # the same bits on every CPU


def _quadratic_tolerance(d: np.ndarray, margin: float) -> np.ndarray:
    """dm_control ``rewards.tolerance`` with bounds (0, 0), quadratic sigmoid, value 0 at margin."""
    z = d / margin
    return np.where(np.abs(z) < 1.0, 1.0 - z * z, 0.0)


def dense_reward(states: np.ndarray, u: np.ndarray, u_max: float) -> np.ndarray:
    """(B,) smooth reward in [0, 1], dm_control cartpole swingup's form.

    upright = (cos theta + 1) / 2; centred = (1 + tol(x, margin 2 m)) / 2;
    small control = (4 + quadratic tol(u / u_max, margin 1)) / 5;
    small velocity = (1 + tol(theta_dot, margin 5 rad/s)) / 2; reward = their product.
    """
    upright = (np.cos(states[:, 2]) + 1.0) / 2.0
    centred = (1.0 + _gaussian_tolerance(states[:, 0], 2.0)) / 2.0
    small_control = (4.0 + _quadratic_tolerance(u / u_max, 1.0)) / 5.0
    small_velocity = (1.0 + _gaussian_tolerance(states[:, 3], 5.0)) / 2.0
    return upright * small_control * small_velocity * centred


def outcome(
    task: SwingUpTask, states: np.ndarray, steps: np.ndarray, u: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(reward, terminated, truncated, fault) for states (B, 4) just reached after ``steps`` steps.

    The trial rules are the kernel's own compiled :func:`striatal.sim.kernel.judge`
    (eqs 24-25, docs/paper-notes.md section 5), the function
    :func:`striatal.sim.kernel.run_trial` applies after every step: a non-finite or
    blown-up state ends the episode (termination, failure reward); so does |x| beyond
    ``task.track`` (the cart left the rails; the kernel's STATUS_TRACK); at the check step
    (t = 30 s) the eq-24 test |x| > check_x or |theta| > check_theta terminates with
    the failure reward; at the last step the time limit truncates and the chapter
    reward is eq 25's success or failure. The dense reward replaces the chapter's
    (0 on a fault; the state's dense reward on leaving the track); the t = 30 s check
    and the track terminate in both modes.
    """
    states = np.ascontiguousarray(states, dtype=float)
    B = states.shape[0]
    status = np.empty(B, dtype=np.int64)
    chapter_reward = np.empty(B)
    protocol = protocol_args(task.protocol, task.dt, task.n_steps, task.track)
    kernel.judge_batch(
        states, np.ascontiguousarray(steps, dtype=np.int64), protocol, status, chapter_reward
    )
    fault = status == kernel.STATUS_FAULT
    terminated = fault | (status == kernel.STATUS_EARLY) | (status == kernel.STATUS_TRACK)
    truncated = (status == kernel.STATUS_SUCCESS) | (status == kernel.STATUS_FAILURE)
    if task.reward == "chapter":
        reward = chapter_reward
    else:
        with np.errstate(invalid="ignore", over="ignore"):
            reward = np.where(fault, 0.0, dense_reward(states, u, task.u_max))
    return reward.astype(float), terminated, truncated, fault
