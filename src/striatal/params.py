"""Frozen parameter sets: the plant, the controller and the chapter's constants.

Only independent quantities are stored; derived ones are properties. Every
constructor validates its fields and raises :class:`ParameterError` with a
message a user can act on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Literal

import numpy as np

from striatal.errors import ParameterError

__all__ = [
    "CHAPTER_FINAL_THETA_C",
    "CHAPTER_FINAL_W",
    "CHAPTER_HARDWARE",
    "CHAPTER_INITIAL_THETA_C",
    "CHAPTER_INITIAL_W",
    "CHAPTER_THETA0",
    "MAX_STEPS",
    "N_GAINS",
    "BalanceSign",
    "Controller",
    "Hardware",
    "HoldKind",
    "Plant",
    "Simulation",
    "SuccessTest",
    "SwitchKind",
    "as_float",
    "check_dt",
    "check_gains",
    "check_seed",
    "check_theta_c",
    "require_finite",
    "require_finite_positive",
]

#: W(0) of the chapter's run (section 3), with theta_c(0) = 0.6.
CHAPTER_INITIAL_W: tuple[float, ...] = (0.6813, -0.3795, -0.8318, 0.5028, 0.7095, 0.4289)
CHAPTER_INITIAL_THETA_C = 0.6
#: The gains and threshold the chapter reports after 553 trials (section 3).
CHAPTER_FINAL_W: tuple[float, ...] = (1.1736, -0.3092, -0.8027, 0.3563, 0.2949, 1.1945)
CHAPTER_FINAL_THETA_C = 0.9035
#: Initial pole angle of every trial in the chapter [rad] (theta = 0 is upright).
CHAPTER_THETA0 = 3.12
N_GAINS = 6
#: Most control steps one run may take (duration / dt): 1e7 steps is 28 hours at dt = 0.01 s,
#: and a recorded trajectory of that length already needs 640 MB.
MAX_STEPS = 10_000_000

BalanceSign = Literal["corrected", "chapter"]
SwitchKind = Literal["hard", "soft"]
HoldKind = Literal["u", "force"]


def as_float(name: str, value: object) -> float:
    """``float(value)``, or ParameterError naming ``name`` if it is not a number.

    Text ("1.8") and true/false are not numbers, whatever ``float`` would make of them:
    every front (keyword arguments, Gymnasium kwargs, files) is held to that here.
    """
    if isinstance(value, str | bytes | bytearray | bool) or type(value).__name__ == "bool_":
        raise ParameterError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None


def require_finite_positive(name: str, value: float) -> float:
    """Return ``value`` as float, or raise ParameterError if it is not finite and > 0."""
    v = as_float(name, value)
    if not math.isfinite(v) or v <= 0.0:
        raise ParameterError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def require_finite(name: str, value: float) -> float:
    """Return ``value`` as float, or raise ParameterError if it is NaN or infinite."""
    v = as_float(name, value)
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be a finite number, got {value!r}")
    return v


def check_seed(seed: object) -> int:
    """A seed for ``np.random.default_rng``: a whole number >= 0, else ParameterError."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError(f"seed must be a whole number >= 0, got {seed!r}")
    return int(seed)


def check_gains(gains: object, *, need_positive_w1: bool = True) -> tuple[float, ...]:
    """Validate the six gains W1..W6 (eqs 22-23) and return them as a tuple of floats.

    W1 enters the balancing law through sqrt(W1 g) (eq 20), so it must be > 0
    unless ``need_positive_w1`` is False.
    """
    if isinstance(gains, str | bytes):
        raise ParameterError(f"gains must be six numbers W1..W6, not text {gains!r}")
    try:
        raw = np.asarray(gains)
        if raw.dtype.kind not in "iuf":  # text, true/false or objects are not gains
            raise ValueError(f"got {gains!r}")
        values = tuple(float(w) for w in raw.astype(float).ravel())
    except (TypeError, ValueError, OverflowError) as exc:
        raise ParameterError(f"gains must be six numbers W1..W6: {exc}") from None
    if len(values) != N_GAINS:
        raise ParameterError(f"gains must be six numbers W1..W6, got {len(values)}")
    for i, w in enumerate(values):
        if not math.isfinite(w):
            raise ParameterError(f"gain W{i + 1} must be finite, got {w!r}")
    if need_positive_w1 and values[0] <= 0.0:
        raise ParameterError(
            "gain W1 must be > 0 because the balancing law uses sqrt(W1*g) (eq 20), "
            f"got {values[0]}"
        )
    return values


def check_theta_c(theta_c: float) -> float:
    """Validate the switching threshold theta_c of eq 21: finite and in (0, pi)."""
    v = as_float("theta_c", theta_c)
    if not math.isfinite(v) or not 0.0 < v < math.pi:
        raise ParameterError(f"theta_c must be in (0, pi), got {theta_c!r}")
    return v


def _require_positive_fields(record: Any, what: str = "", of: type | None = None) -> None:
    """Every field of the frozen dataclass ``record`` (those of the dataclass ``of``, when
    given: a subclass's own fields are its own to check) set to its value as float;
    ParameterError (naming ``what`` and the field) unless it is finite and > 0."""
    for f in fields(of or record):
        value = require_finite_positive(f"{what}{f.name}", getattr(record, f.name))
        object.__setattr__(record, f.name, value)


def check_dt(dt: float) -> float:
    """Validate a control/integration step: finite and in (0, 0.1] seconds."""
    v = as_float("dt", dt)
    if not math.isfinite(v) or not 0.0 < v <= 0.1:
        raise ParameterError(f"dt must be in (0, 0.1] seconds, got {dt!r}")
    return v


@dataclass(frozen=True)
class Plant:
    """Point-mass cart-pole of section 2.1 (eqs 7-14).

    Attributes
    ----------
    cart_mass : M [kg]
    pole_mass : m [kg], a point mass at the tip of a massless bar
    length : l [m]
    gravity : g [m/s^2]
    """

    cart_mass: float = 1.0
    pole_mass: float = 0.1
    length: float = 1.0
    gravity: float = 9.8

    def __post_init__(self) -> None:
        _require_positive_fields(self, of=Plant)

    @property
    def target_energy(self) -> float:
        """E_d = m g l, the pendulum energy at rest upright (eq 16) [J]."""
        return self.pole_mass * self.gravity * self.length

    def to_dict(self) -> dict[str, float]:
        """The four parameters by name, as settings and summaries record a plant."""
        return {
            "cart_mass": self.cart_mass,
            "pole_mass": self.pole_mass,
            "length": self.length,
            "gravity": self.gravity,
        }

    def as_array(self) -> np.ndarray:
        """``[M, m, l, g]`` as float64, the layout the kernel takes."""
        return np.array([self.cart_mass, self.pole_mass, self.length, self.gravity], dtype=float)

    def scaled(self, *, pole_mass: float = 1.0, length: float = 1.0) -> Plant:
        """A copy with pole mass and length multiplied by the given factors."""
        return Plant(
            cart_mass=self.cart_mass,
            pole_mass=self.pole_mass * pole_mass,
            length=self.length * length,
            gravity=self.gravity,
        )


@dataclass(frozen=True)
class Controller:
    """The switching controller of sections 2.2-2.3 and its readings of the chapter.

    Attributes
    ----------
    gains : W1..W6. W1 = k_b (balancing stiffness, eq 20), W2 = k_p2, W3 = k_v2 (cart
        regulation while balancing), W4 = swing-up energy gain, W5 = k_c (cart
        regulation during swing-up, eq 17), W6 sets the policy's sigma (eq 22-23).
    theta_c : switching threshold [rad]: balancing while |theta| < theta_c (eq 21).
    balance_sign : ``"corrected"`` (default, docs/paper-notes.md section 1) or
        ``"chapter"`` (eq 20 as printed).
    switch : ``"hard"`` (section 2.3) or ``"soft"`` (the cerebellar switch of section 4).
    inhibition : gamma of the soft switch, the strength of lateral inhibition [1/rad].
    """

    gains: tuple[float, ...] = CHAPTER_FINAL_W
    theta_c: float = CHAPTER_FINAL_THETA_C
    balance_sign: BalanceSign = "corrected"
    switch: SwitchKind = "hard"
    inhibition: float = 50.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "gains", check_gains(self.gains))
        object.__setattr__(self, "theta_c", check_theta_c(self.theta_c))
        if self.balance_sign not in ("corrected", "chapter"):
            raise ParameterError(
                f"balance_sign must be 'corrected' or 'chapter', got {self.balance_sign!r}"
            )
        if self.switch not in ("hard", "soft"):
            raise ParameterError(f"switch must be 'hard' or 'soft', got {self.switch!r}")
        object.__setattr__(
            self, "inhibition", require_finite_positive("inhibition", self.inhibition)
        )

    @property
    def sign(self) -> float:
        """+1 for the corrected balancing law, -1 for the printed one (kernel encoding)."""
        return 1.0 if self.balance_sign == "corrected" else -1.0

    @property
    def soft(self) -> bool:
        """True for the cerebellar soft switch."""
        return self.switch == "soft"

    def with_gains(self, gains: object, theta_c: float | None = None) -> Controller:
        """A copy with new gains (and optionally a new theta_c)."""
        return Controller(
            gains=check_gains(gains),
            theta_c=self.theta_c if theta_c is None else theta_c,
            balance_sign=self.balance_sign,
            switch=self.switch,
            inhibition=self.inhibition,
        )

    def to_dict(self) -> dict[str, object]:
        """JSON-ready description of every reading this controller takes."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


@dataclass(frozen=True)
class SuccessTest:
    """The chapter's success test at the final time T_f (end of section 2.4)."""

    theta: float = 0.05
    x: float = 0.05
    theta_dot: float = 0.005
    x_dot: float = 0.005

    def __post_init__(self) -> None:
        _require_positive_fields(self, "success bound ")

    def __str__(self) -> str:
        """The test in one line, as result files state it."""
        return (
            f"|theta|<{self.theta:g}, |x|<{self.x:g}, |theta_dot|<{self.theta_dot:g}, "
            f"|x_dot|<{self.x_dot:g} at T_f"
        )

    def passed(self, state: np.ndarray | Sequence[float]) -> bool:
        """True if ``state`` = [x, x_dot, theta, theta_dot] (theta wrapped) passes every bound."""
        # a non-finite value fails its comparison (NaN compares false), so fails the test
        x, x_dot, theta, theta_dot = (float(v) for v in state)
        return (
            abs(theta) < self.theta
            and abs(x) < self.x
            and abs(theta_dot) < self.theta_dot
            and abs(x_dot) < self.x_dot
        )


@dataclass(frozen=True)
class Simulation:
    """Settings of one run: start state, duration, control step."""

    theta0: float = CHAPTER_THETA0
    x0: float = 0.0
    duration: float = 60.0
    dt: float = 0.01
    success: SuccessTest = field(default_factory=SuccessTest)

    def __post_init__(self) -> None:
        object.__setattr__(self, "theta0", require_finite("theta0", self.theta0))
        object.__setattr__(self, "x0", require_finite("x0", self.x0))
        object.__setattr__(self, "duration", require_finite_positive("duration", self.duration))
        object.__setattr__(self, "dt", check_dt(self.dt))
        steps = self.duration / self.dt
        if not steps <= MAX_STEPS:
            raise ParameterError(
                f"duration / dt = {steps:.3g} steps is more than {MAX_STEPS:,}: "
                "shorten the duration or raise dt"
            )
        if self.n_steps < 1:
            raise ParameterError("duration must be at least one step dt")

    @property
    def n_steps(self) -> int:
        """Number of control steps: round(duration / dt)."""
        return int(round(self.duration / self.dt))

    @property
    def initial_state(self) -> np.ndarray:
        """[x0, 0, theta0, 0]: at rest, as in the chapter's trials."""
        return np.array([self.x0, 0.0, self.theta0, 0.0], dtype=float)


@dataclass(frozen=True)
class Hardware:
    """The motor and the track the chapter idealises away (docs/paper-notes.md section 9).

    Attributes
    ----------
    hold : what the motor holds over a control step dt. ``"u"`` (default, the chapter's
        idealisation): the commanded acceleration, as if the feedback linearisation of
        eq 12 ran continuously. ``"force"``: a digital controller; the force f of eq 12 is
        computed at the sample with the controller's model and held while the true
        plant's eqs 8-9 integrate.
    max_force : the motor's limit [N] (None: unlimited). With ``hold="force"`` the held
        f is clipped; with ``hold="u"`` the force realising u is clipped at every RK4
        stage, so the plant follows u only while |f| stays within the limit.
    track : half-length of the track [m] (None: endless). |x| beyond it ends the trial
        as a failure (end reason ``"track"``).
    """

    hold: HoldKind = "u"
    max_force: float | None = None
    track: float | None = None

    def __post_init__(self) -> None:
        if self.hold not in ("u", "force"):
            raise ParameterError(f"hold must be 'u' or 'force', got {self.hold!r}")
        for name in ("max_force", "track"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, require_finite_positive(name, value))

    @property
    def idealised(self) -> bool:
        """True for the chapter's setting: u held, no force limit, no track."""
        return self.hold == "u" and self.max_force is None and self.track is None

    def to_dict(self) -> dict[str, object]:
        """JSON-ready (None for no limit)."""
        return asdict(self)


#: The chapter's idealisation: u held over each step, no force limit, an endless track.
CHAPTER_HARDWARE = Hardware()
