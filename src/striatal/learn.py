"""The chapter's switching REINFORCE learner: trial protocol, traces, update, theta_c rule.

One learning step is one 60-s trial (eqs 24-25) followed by the update of
eqs 3-4 and the theta_c rule of eq 21. The reward is sparse: r_t = 0 except at
the end of the trial (or at the t = 30 s check), so with baseline b = 0 the
per-step rule of section 1.2 changes W only at that instant:
W <- W + alpha (1 - gamma) (r - b) D(T_end). striatal applies the baseline at
that reward event too (docs/paper-notes.md, reading 9).

The learner's state (:class:`LearnerState`) is plain data, JSON-serialisable,
including the random generator's state, so a run can be checkpointed and
resumed to the same result.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.kernel import sigma_of
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    N_GAINS,
    Controller,
    Plant,
    Simulation,
    as_float,
    check_gains,
    check_seed,
    check_theta_c,
    require_finite,
)
from striatal.rollout import Protocol, TrialOutcome, run_trial

SuccessOn = Literal["noisy", "mean"]
ThetaCRule = Literal["swingup", "trial", "fixed", "learned"]
Eligibility = Literal["score", "chapter"]
LearnerKind = Literal["chapter", "rpe", "pgpe"]
RewardKind = Literal["sparse", "shaped"]
#: The learner variants (:mod:`striatal.learners` for the two beyond the chapter).
LEARNERS: tuple[str, ...] = ("chapter", "rpe", "pgpe")

#: Floor that keeps W1 > 0 for sqrt(W1 g) (eq 22): the documented guard.
W1_FLOOR = 1e-3
#: Smallest theta_c the rule of eq 21 may set (only reachable with --theta-c-rule trial).
THETA_C_FLOOR = 0.01
#: Eq 21's thresholds: min|theta| below 1.4 becomes theta_c, otherwise theta_c resets to 0.6.
THETA_C_RESET_ABOVE = 1.4
THETA_C_RESET_TO = 0.6

HISTORY_COLUMNS = (
    "trial",
    "reward",
    "W1",
    "W2",
    "W3",
    "W4",
    "W5",
    "W6",
    "theta_c",
    "sigma",
    "min_abs_theta_swingup",
    "ended_at",
    "success",
    "fault",
    "early",
)


def _require_count(name: str, value: object) -> None:
    """ParameterError unless ``value`` is a whole number >= 1 (text, null or a list too)."""
    try:
        whole = int(value) == value  # type: ignore[call-overload]
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole or value < 1:  # type: ignore[operator]
        raise ParameterError(f"{name} must be a whole number >= 1, got {value!r}")


@dataclass(frozen=True)
class LearnerConfig:
    """Every option of the learner; the chapter leaves most of them open (NOTES section 7).

    Attributes
    ----------
    alpha : learning rate of eqs 1/4.
    gamma : discount of the eligibility trace D(t) = e(t) + gamma D(t-1) (eq 3), per draw.
    baseline : reinforcement baseline b of eq 1 (the chapter: 0).
    action_every : a new action is drawn every this many control steps and held.
    reset_trace : D starts at 0 in every trial (otherwise it carries over).
    eligibility : "score" (NOTES section 2) or "chapter" (the printed e1).
    success_on : judge the success test on the noisy trial ("noisy", the chapter) or on
        a noise-free rerun with the mean policy ("mean").
    theta_c_rule : eq 21 with min |theta| under the swing-up ("swingup"), over the whole
        trial ("trial"), or theta_c kept fixed ("fixed").
    max_trials : stop after this many trials if the success test never holds.
    max_step : bound on each component of one update alpha (1 - gamma)(r - b) D.
    w1_floor : W1 is kept >= this after every update.
    learner : "chapter" (this module), or one of :mod:`striatal.learners`: "rpe" (the
        chapter's per-step rule with a reward baseline that tracks the expected reward)
        or "pgpe" (exploration in parameter space, once per trial).
    reward : "sparse" (eqs 24-25) or "shaped" (:func:`striatal.learners.shaped_reward`).
    rpe_rate : rate beta of the tracked baseline b <- b + beta (r - b) and of the running
        mean square of the prediction error (learners "rpe", "pgpe").
    normalise : divide the prediction error r - b by its running root mean square.
    explore : parameter-exploration std of W1..W5 ("pgpe"); theta_c's is 0.3 times it [rad].
    sigma_rate : rate of the log-std adaptation of the exploration ("pgpe"; 0: fixed).
    decay : synaptic decay lambda of W1..W5 ("rpe", "pgpe"): the update adds
        -rate * lambda * W (rate: alpha for "pgpe", alpha (1 - gamma) for "rpe"), a weak
        prior for small gains; with alpha = 0 nothing changes.
    plant_jitter : J of "pgpe": each trial's true pole mass and length are the nominal
        ones times factors uniform in [1 - J, 1 + J] (0: the nominal plant).
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
    learner: LearnerKind = "chapter"
    reward: RewardKind = "sparse"
    rpe_rate: float = 0.1
    normalise: bool = False
    explore: float = 0.3
    sigma_rate: float = 0.0
    decay: float = 0.0
    plant_jitter: float = 0.0

    def __post_init__(self) -> None:
        a = require_finite("alpha", self.alpha)
        if a < 0:
            raise ParameterError(f"alpha must be >= 0, got {self.alpha}")
        g = require_finite("gamma", self.gamma)
        if not 0.0 <= g < 1.0:
            raise ParameterError(f"gamma must be in [0, 1), got {self.gamma}")
        require_finite("baseline", self.baseline)
        _require_count("action_every", self.action_every)
        _require_count("max_trials", self.max_trials)
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
        if self.theta_c_rule not in ("swingup", "trial", "fixed", "learned"):
            raise ParameterError(
                "theta_c_rule must be 'swingup', 'trial', 'fixed' or 'learned', "
                f"got {self.theta_c_rule!r}"
            )
        if self.learner not in LEARNERS:
            raise ParameterError(
                f"learner must be one of {', '.join(LEARNERS)}, got {self.learner!r}"
            )
        if self.reward not in ("sparse", "shaped"):
            raise ParameterError(f"reward must be 'sparse' or 'shaped', got {self.reward!r}")
        r = require_finite("rpe_rate", self.rpe_rate)
        if not 0.0 < r <= 1.0:
            raise ParameterError(f"rpe_rate must be in (0, 1], got {self.rpe_rate}")
        e = require_finite("explore", self.explore)
        if e <= 0.0:
            raise ParameterError(f"explore must be > 0, got {self.explore}")
        if require_finite("sigma_rate", self.sigma_rate) < 0.0:
            raise ParameterError(f"sigma_rate must be >= 0, got {self.sigma_rate}")
        if require_finite("decay", self.decay) < 0.0:
            raise ParameterError(f"decay must be >= 0, got {self.decay}")
        if self.decay_per_update >= 1.0:
            raise ParameterError(
                f"the decay per update (rate x decay = {self.decay_per_update:g}) must be < 1"
            )
        jit = require_finite("plant_jitter", self.plant_jitter)
        if not 0.0 <= jit <= 0.5:
            raise ParameterError(f"plant_jitter must be in [0, 0.5], got {self.plant_jitter}")
        if jit > 0.0 and self.learner != "pgpe":
            raise ParameterError("plant_jitter needs learner 'pgpe'")
        if self.theta_c_rule == "learned" and self.learner != "pgpe":
            raise ParameterError(
                "theta_c_rule 'learned' (theta_c perturbed and updated with the gains) "
                "needs learner 'pgpe'"
            )
        if self.learner == "pgpe" and self.success_on != "mean":
            raise ParameterError(
                "learner 'pgpe' acts with the mean policy of perturbed gains: "
                "its success test is judged on the mean policy (success_on 'mean')"
            )

    @property
    def update_rate(self) -> float:
        """The rate multiplying factor x eligibility: alpha ("pgpe") or alpha (1 - gamma)."""
        return self.alpha if self.learner == "pgpe" else self.alpha * (1.0 - self.gamma)

    @property
    def decay_per_update(self) -> float:
        """Fraction by which W1..W5 shrink per update: update_rate x decay."""
        return self.update_rate * self.decay

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class LearnerState:
    """Everything a run needs to continue: JSON-serialisable via :meth:`to_dict`."""

    trials_done: int
    W: tuple[float, ...]
    theta_c: float
    trace: tuple[float, ...]
    rng_state: dict[str, Any]
    success: bool = False
    n_positive: int = 0
    reward_mean: float = 0.0
    rpe_square: float = 0.0
    explore: tuple[float, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["W"] = list(self.W)
        d["trace"] = list(self.trace)
        d["explore"] = list(self.explore)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LearnerState:
        """Rebuild from :meth:`to_dict` output; raises ParameterError if anything is off."""
        try:
            W = tuple(float(w) for w in d["W"])
            trace = tuple(float(v) for v in d["trace"])
            state = cls(
                trials_done=int(d["trials_done"]),
                W=W,
                theta_c=float(d["theta_c"]),
                trace=trace,
                rng_state=_checked_rng_state(d["rng_state"]),
                success=bool(d["success"]),
                n_positive=int(d.get("n_positive", 0)),
                reward_mean=float(d.get("reward_mean", 0.0)),
                rpe_square=float(d.get("rpe_square", 0.0)),
                explore=tuple(float(v) for v in d.get("explore", ())),
            )
        except ParameterError:
            raise
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            raise ParameterError(f"learner state is incomplete or malformed: {exc!r}") from None
        if len(W) != N_GAINS or len(trace) != N_GAINS or state.trials_done < 0:
            raise ParameterError("learner state has the wrong number of gains or trials")
        numbers = (*W, *trace, state.theta_c, state.reward_mean, state.rpe_square, *state.explore)
        if not all(math.isfinite(v) for v in numbers):
            raise ParameterError("learner state holds a non-finite number")
        check_theta_c(state.theta_c)
        return state


def _checked_rng_state(value: object) -> dict[str, Any]:
    """``value`` as the state of a PCG64 generator (the learner's), or ParameterError."""
    rng = np.random.default_rng()
    try:
        rng.bit_generator.state = dict(value)  # type: ignore[call-overload]
    except (TypeError, ValueError, KeyError, OverflowError) as exc:
        raise ParameterError(
            f"learner state rng_state is not the state of a PCG64 generator: {exc}"
        ) from None
    return dict(rng.bit_generator.state)


@dataclass(frozen=True)
class TrialRecord:
    """One row of history.csv: the W, theta_c, sigma used in the trial and what happened."""

    trial: int
    reward: float
    W: tuple[float, ...]
    theta_c: float
    sigma: float
    min_abs_theta_swingup: float
    ended_at: float
    success: bool
    fault: bool
    early: bool

    def row(self) -> list[Any]:
        return [
            self.trial,
            self.reward,
            *self.W,
            self.theta_c,
            self.sigma,
            self.min_abs_theta_swingup,
            self.ended_at,
            int(self.success),
            int(self.fault),
            int(self.early),
        ]


@dataclass(frozen=True)
class TrainResult:
    """The outcome of a learning run."""

    success: bool
    trials: int
    W: tuple[float, ...]
    theta_c: float
    seed: int
    wall_seconds: float
    state: LearnerState
    interrupted: bool = False
    settings: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "success": self.success,
            "trials": self.trials,
            "W": list(self.W),
            "theta_c": self.theta_c,
            "seed": self.seed,
            "wall_seconds": self.wall_seconds,
            "interrupted": self.interrupted,
            "learner": self.settings.get("learner", "chapter"),
            "settings": self.settings,
        }


def initial_state(W0: object, theta_c0: float, seed: int) -> LearnerState:
    """The state before trial 1: gains, threshold, a zero trace and a fresh PCG64 stream."""
    gains = check_gains(W0)
    check_theta_c(theta_c0)
    rng = np.random.default_rng(check_seed(seed))
    return LearnerState(
        trials_done=0,
        W=gains,
        theta_c=float(theta_c0),
        trace=(0.0,) * N_GAINS,
        rng_state=dict(rng.bit_generator.state),
    )


def random_initial_gains(rng: np.random.Generator) -> tuple[float, ...]:
    """W(0) uniform in [-1, 1]^6 (the chapter: "randomly initialized"), W1 floored at W1_FLOOR."""
    W = rng.uniform(-1.0, 1.0, size=N_GAINS)
    W[0] = max(W[0], W1_FLOOR)
    return tuple(float(w) for w in W)


def theta_c_rule(outcome: TrialOutcome, theta_c: float, rule: ThetaCRule) -> float:
    """Eq 21: theta_c = min|theta| if it is < 1.4, else 0.6 (reading: NOTES section 6)."""
    if rule in ("fixed", "learned"):
        return theta_c
    m = outcome.min_abs_theta_swingup if rule == "swingup" else outcome.min_abs_theta
    if not math.isfinite(m) or m > THETA_C_RESET_ABOVE:
        return THETA_C_RESET_TO
    return max(m, THETA_C_FLOOR)


def gain_update(
    W: np.ndarray, trace: np.ndarray, reward: float, config: LearnerConfig
) -> np.ndarray:
    """Eqs 3-4 at the reward event: W + clip(alpha (1 - gamma)(r - b) D), W1 floored.

    A non-finite trace leaves W unchanged (a numerical fault never reaches W).
    """
    if not np.all(np.isfinite(trace)):
        return W.copy()
    step = config.alpha * (1.0 - config.gamma) * (reward - config.baseline) * trace
    step = np.clip(step, -config.max_step, config.max_step)
    new = W + step
    new[0] = max(new[0], config.w1_floor)
    if not np.all(np.isfinite(new)):
        return W.copy()
    return new


def mean_policy_success(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    protocol: Protocol,
    W: np.ndarray,
    action_every: int,
    model: Plant | None = None,
) -> bool:
    """The success test on a noise-free run of the mean policy (eqs 22-23) with gains W.

    ``model``: the plant the controller believes in (default: the true ``plant``).
    """
    return run_trial(
        plant,
        controller,
        sim,
        protocol=protocol,
        trace=np.zeros(N_GAINS),
        gamma=0.0,
        rng=None,
        gains=W,
        action_every=action_every,
        model=model,
    ).success


def trial_record(
    state: LearnerState, outcome: TrialOutcome, *, reward: float, sigma: float, success: bool
) -> TrialRecord:
    """The history row of the trial run from ``state`` (its W and theta_c, before the update)."""
    return TrialRecord(
        trial=state.trials_done + 1,
        reward=reward,
        W=state.W,
        theta_c=state.theta_c,
        sigma=sigma,
        min_abs_theta_swingup=outcome.min_abs_theta_swingup,
        ended_at=outcome.ended_at,
        success=success,
        fault=outcome.fault,
        early=outcome.early,
    )


def learning_step(
    state: LearnerState,
    plant: Plant,
    template: Controller,
    sim: Simulation,
    protocol: Protocol,
    config: LearnerConfig,
) -> tuple[LearnerState, TrialRecord]:
    """One trial with (W, theta_c) of ``state``, the success test, then the updates.

    Pure: the same state gives the same result. ``template`` carries the readings
    (balance sign, switch, inhibition); its gains are replaced by the state's.
    Learners other than "chapter" are in :mod:`striatal.learners`.
    """
    if config.learner != "chapter":
        from striatal import learners

        return learners.learning_step(state, plant, template, sim, protocol, config)
    rng = np.random.default_rng()
    rng.bit_generator.state = state.rng_state
    W = np.array(state.W, dtype=float)
    controller = replace(template, theta_c=state.theta_c)
    trace = np.zeros(N_GAINS) if config.reset_trace else np.array(state.trace, dtype=float)
    outcome = run_trial(
        plant,
        controller,
        sim,
        protocol=protocol,
        trace=trace,
        gamma=config.gamma,
        rng=rng,
        gains=W,
        action_every=config.action_every,
        chapter_eligibility=config.eligibility == "chapter",
    )
    if config.success_on == "noisy":
        success = outcome.success
    else:
        success = mean_policy_success(plant, controller, sim, protocol, W, config.action_every)
    record = trial_record(
        state, outcome, reward=outcome.reward, sigma=float(sigma_of(W[5])), success=success
    )
    if success:
        new_W, new_theta_c = W, state.theta_c
    else:
        new_W = gain_update(W, trace, outcome.reward, config)
        new_theta_c = theta_c_rule(outcome, state.theta_c, config.theta_c_rule)
    if not np.all(np.isfinite(trace)):
        trace = np.zeros(N_GAINS)
    new_state = LearnerState(
        trials_done=state.trials_done + 1,
        W=tuple(float(w) for w in new_W),
        theta_c=float(new_theta_c),
        trace=tuple(float(v) for v in trace),
        rng_state=dict(rng.bit_generator.state),
        success=success,
        n_positive=state.n_positive + int(outcome.reward > 0),
    )
    return new_state, record


def train(
    plant: Plant,
    template: Controller,
    config: LearnerConfig,
    seed: int,
    *,
    sim: Simulation | None = None,
    protocol: Protocol | None = None,
    state: LearnerState | None = None,
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
) -> TrainResult:
    """Learn from ``template``'s gains and theta_c (or continue from ``state``).

    Stops at the first trial that passes the success test (its W and theta_c are
    the result, as in the chapter) or after ``config.max_trials`` trials.
    ``on_trial`` is called after every trial (history, checkpoints, progress).
    A KeyboardInterrupt stops the run; the result then has ``interrupted=True``.
    """
    sim = sim or Simulation()
    protocol = protocol or Protocol()
    if state is None:
        state = initial_state(template.gains, template.theta_c, seed)
    t0 = time.perf_counter()
    interrupted = False
    try:
        while not state.success and state.trials_done < config.max_trials:
            state, record = learning_step(state, plant, template, sim, protocol, config)
            if on_trial is not None:
                on_trial(state, record)
    except KeyboardInterrupt:
        interrupted = True
    return TrainResult(
        success=state.success,
        trials=state.trials_done,
        W=state.W,
        theta_c=state.theta_c,
        seed=seed,
        wall_seconds=time.perf_counter() - t0,
        state=state,
        interrupted=interrupted,
        settings={},
    )


def chapter_start() -> tuple[tuple[float, ...], float]:
    """W(0) and theta_c(0) of the chapter's run."""
    return CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C
