"""The options of a learning run, one flat frozen record that every front end builds.

Each learning rule reads only its own options from it (its small frozen config,
e.g. :class:`striatal.learners.pgpe.PgpeConfig`, picked by :func:`pick`); the
options the chapter leaves open are listed in docs/paper-notes.md, section 7.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Literal, TypeVar

from striatal.errors import ParameterError
from striatal.params import Hardware, as_float, require_finite, require_finite_positive

__all__ = [
    "W1_FLOOR",
    "Eligibility",
    "LearnerConfig",
    "RewardKind",
    "SuccessOn",
    "ThetaCRule",
    "pick",
    "require_count",
]

SuccessOn = Literal["noisy", "mean"]
ThetaCRule = Literal["swingup", "trial", "clamped", "fixed", "learned"]
Eligibility = Literal["score", "chapter"]
RewardKind = Literal["sparse", "shaped"]

#: Floor that keeps W1 > 0 for sqrt(W1 g) (eq 22): the documented guard.
W1_FLOOR = 1e-3


def require_count(name: str, value: object) -> None:
    """ParameterError unless ``value`` is a whole number >= 1 (text, null or a list too)."""
    try:
        whole = int(value) == value  # type: ignore[call-overload]
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole or value < 1:  # type: ignore[operator]
        raise ParameterError(f"{name} must be a whole number >= 1, got {value!r}")


@dataclass(frozen=True)
class LearnerConfig:
    """Every option of a learning run (the chapter leaves most open: docs/paper-notes.md, 7).

    Build it with :func:`striatal.learners.default_config` (the learner's tuned
    preset, then your changes): ``LearnerConfig(learner="pgpe")`` alone keeps the
    chapter's values of the other fields. Which rule reads which field:
    ``striatal.learners.RULES[name].options``.

    Attributes
    ----------
    learner : the learning rule, a key of :data:`striatal.learners.RULES`.
    max_trials : stop after this many trials if the success test never holds.
    success_on : judge the success test on the noisy trial ("noisy", the chapter) or on
        a noise-free rerun with the mean policy ("mean").
    theta_c_rule : eq 21 with min |theta| under the swing-up ("swingup"), over the whole
        trial ("trial"), over the whole trial but not below eq 21's reset value
        ("clamped"), theta_c kept fixed ("fixed"), or learned with the gains
        ("learned", pgpe).
    action_every : a new action is drawn every this many control steps and held.
    alpha : learning rate of eqs 1/4.
    gamma : discount of the eligibility trace D(t) = e(t) + gamma D(t-1) (eq 3), per draw.
    baseline : reinforcement baseline b of eq 1 (the chapter: 0).
    reset_trace : D starts at 0 in every trial (otherwise it carries over).
    eligibility : "score" (docs/paper-notes.md, section 2) or "chapter" (the printed e1).
    max_step : bound on each component of one update.
    w1_floor : W1 is kept >= this after every update.
    reward : "sparse" (eqs 24-25) or "shaped" (:func:`striatal.learners.common.shaped_reward`).
    rpe_rate : rate beta of the tracked baseline b <- b + beta (r - b) and of the running
        mean square of the prediction error (rpe, pgpe: per trial; ac: per step, of delta).
    normalise : divide the prediction error r - b (ac: the TD error delta, for the actor)
        by its running root mean square.
    explore : parameter-exploration std of W1..W5 (pgpe); theta_c's is 0.3 times it [rad].
    sigma_rate : rate of the log-std adaptation of the exploration (pgpe; 0: fixed).
    decay : synaptic decay lambda of W1..W5 (rpe, pgpe): the update adds
        -rate * lambda * W (rate: alpha for pgpe, alpha (1 - gamma) for rpe).
    plant_jitter : J of pgpe: each trial's true pole mass and length are the nominal
        ones times factors uniform in [1 - J, 1 + J] (0: the nominal plant).
    symmetric : pgpe's symmetric sampling (Sehnke et al. 2010): trials come in pairs
        p + eps, p - eps on the same plant, and one update follows each pair with the
        reward difference (r+ - r-) / 2 in place of r - b.
    robust : the robust stop rule (issue 15, any rule): every trial and check holds the
        motor force of eq 12 over each step (ac's own online trial still holds u), and
        a controller that passes the success test must also pass the robustness set
        (:func:`striatal.sim.robust.stop_check`, every run counted) for the run to stop.
    critic_rate : rate beta of the critic's weights, v <- v + beta delta z (ac).
    td_discount : discount gamma_v per control step of the TD error
        delta = r + gamma_v V(s') - V(s) (ac); 1 - dt / tau for a value horizon tau.
    critic_decay : lambda of the critic's trace z <- gamma_v lambda z + phi(s) (ac).
    max_force : the motor's limit [N] for every trial and check of the run, the
        robustness set's included (None: unlimited; :class:`striatal.params.Hardware`).
    track : the track's half-length [m]: |x| beyond it ends the trial as a failure
        (None: endless).

    ``symmetric`` and ``robust`` (added with issue 15) are left out of :meth:`to_dict`
    when False, and ``max_force`` and ``track`` when None, so the settings and run ids
    of runs without them stay as they were.
    """

    alpha: float = 5.0
    gamma: float = 0.999
    baseline: float = 0.0
    action_every: int = 1
    reset_trace: bool = True
    eligibility: Eligibility = "score"
    success_on: SuccessOn = "noisy"
    theta_c_rule: ThetaCRule = "swingup"
    max_trials: int = 2000
    max_step: float = 1.0
    w1_floor: float = W1_FLOOR
    learner: str = "chapter"
    reward: RewardKind = "sparse"
    rpe_rate: float = 0.1
    normalise: bool = False
    explore: float = 0.3
    sigma_rate: float = 0.0
    decay: float = 0.0
    plant_jitter: float = 0.0
    symmetric: bool = False
    robust: bool = False
    critic_rate: float = 0.01
    td_discount: float = 0.99
    critic_decay: float = 0.9
    max_force: float | None = None
    track: float | None = None

    def __post_init__(self) -> None:
        a = require_finite("alpha", self.alpha)
        if a < 0:
            raise ParameterError(f"alpha must be >= 0, got {self.alpha}")
        g = require_finite("gamma", self.gamma)
        if not 0.0 <= g < 1.0:
            raise ParameterError(f"gamma must be in [0, 1), got {self.gamma}")
        require_finite("baseline", self.baseline)
        require_count("action_every", self.action_every)
        require_count("max_trials", self.max_trials)
        if not (as_float("max_step", self.max_step) > 0):
            raise ParameterError(f"max_step must be > 0 (inf for no bound), got {self.max_step}")
        floor = as_float("w1_floor", self.w1_floor)
        if not (math.isfinite(floor) and floor > 0):
            raise ParameterError(f"w1_floor must be a finite number > 0, got {self.w1_floor}")
        if self.eligibility not in ("score", "chapter"):
            raise ParameterError(
                f"eligibility must be 'score' or 'chapter', got {self.eligibility!r}"
            )
        if self.success_on not in ("noisy", "mean"):
            raise ParameterError(f"success_on must be 'noisy' or 'mean', got {self.success_on!r}")
        if self.theta_c_rule not in ("swingup", "trial", "clamped", "fixed", "learned"):
            raise ParameterError(
                "theta_c_rule must be 'swingup', 'trial', 'clamped', 'fixed' or 'learned', "
                f"got {self.theta_c_rule!r}"
            )
        if not isinstance(self.learner, str):
            raise ParameterError(f"learner must be a name, got {self.learner!r}")
        if self.reward not in ("sparse", "shaped"):
            raise ParameterError(f"reward must be 'sparse' or 'shaped', got {self.reward!r}")
        r = require_finite("rpe_rate", self.rpe_rate)
        if not 0.0 < r <= 1.0:
            raise ParameterError(f"rpe_rate must be in (0, 1], got {self.rpe_rate}")
        e = require_finite("explore", self.explore)
        if not 0.0 < e <= 100.0:
            raise ParameterError(f"explore must be in (0, 100], got {self.explore}")
        if require_finite("sigma_rate", self.sigma_rate) < 0.0:
            raise ParameterError(f"sigma_rate must be >= 0, got {self.sigma_rate}")
        if require_finite("decay", self.decay) < 0.0:
            raise ParameterError(f"decay must be >= 0, got {self.decay}")
        jit = require_finite("plant_jitter", self.plant_jitter)
        if not 0.0 <= jit <= 0.5:
            raise ParameterError(f"plant_jitter must be in [0, 0.5], got {self.plant_jitter}")
        for name in _LATER_FLAGS:
            if not isinstance(getattr(self, name), bool):
                raise ParameterError(f"{name} must be true or false, got {getattr(self, name)!r}")
        cr = require_finite("critic_rate", self.critic_rate)
        if not 0.0 <= cr <= 1.0:
            raise ParameterError(f"critic_rate must be in [0, 1], got {self.critic_rate}")
        td = require_finite("td_discount", self.td_discount)
        if not 0.0 <= td < 1.0:
            raise ParameterError(f"td_discount must be in [0, 1), got {self.td_discount}")
        lam = require_finite("critic_decay", self.critic_decay)
        if not 0.0 <= lam <= 1.0:
            raise ParameterError(f"critic_decay must be in [0, 1], got {self.critic_decay}")
        for name in _LATER_LIMITS:
            if getattr(self, name) is not None:
                object.__setattr__(self, name, require_finite_positive(name, getattr(self, name)))

    @property
    def hardware(self) -> Hardware:
        """The motor and track of every trial and check of the run: the force held with
        ``robust`` (u otherwise, the chapter's idealisation), ``max_force`` and ``track``."""
        return Hardware(
            hold="force" if self.robust else "u", max_force=self.max_force, track=self.track
        )

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        for name in _LATER_FLAGS:
            if not d[name]:
                del d[name]
        for name in _LATER_LIMITS:
            if d[name] is None:
                del d[name]
        return d


#: Flags added after the settings schema 2 (issue 15): stored only when set.
_LATER_FLAGS = ("symmetric", "robust")
#: Limits added with issue 15: stored only when given.
_LATER_LIMITS = ("max_force", "track")

C = TypeVar("C")


def pick(cls: type[C], config: LearnerConfig) -> C:
    """The rule config ``cls`` (a dataclass) with the same-named fields of ``config``."""
    return cls(**{f.name: getattr(config, f.name) for f in fields(cls)})  # type: ignore[arg-type]
