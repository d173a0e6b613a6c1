"""The chapter's switching REINFORCE rule (eqs 1-5, 21): the per-step policy and trace D.

One learning step is one 60-s trial (eqs 24-25) followed by the update of
eqs 3-4 and the theta_c rule of eq 21. The reward is sparse: r_t = 0 except at
the end of the trial (or at the t = 30 s check), so with baseline b = 0 the
per-step rule of section 1.2 changes W only at that instant:
W <- W + alpha (1 - gamma) (r - b) D(T_end). striatal applies the baseline at
that reward event too (docs/paper-notes.md, reading 9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from striatal.learners.common import theta_c_rule
from striatal.learners.config import Eligibility, Eq21Rule, LearnerConfig, pick
from striatal.learners.rule import Rule, Trial, TrialContext, TrialPlan, Update
from striatal.learners.state import LearnerState
from striatal.params import N_GAINS
from striatal.sim.kernel import sigma_of

__all__ = [
    "CHAPTER",
    "ChapterConfig",
    "ChapterRule",
    "PolicyConfig",
    "PolicyRule",
    "chapter_gain_update",
    "gain_update",
    "policy_plan",
    "policy_sigma",
    "policy_trace",
]


@dataclass(frozen=True)
class PolicyConfig:
    """The options of every rule that explores per step with the policy of eq 5 and
    learns through the trace D of eq 3 (see :class:`LearnerConfig` for each)."""

    alpha: float
    gamma: float
    reset_trace: bool
    eligibility: Eligibility
    theta_c_rule: Eq21Rule
    max_step: float
    w1_floor: float


@dataclass(frozen=True)
class ChapterConfig(PolicyConfig):
    """The chapter rule's options: the policy's and the reinforcement baseline b."""

    baseline: float


def gain_update(
    W: np.ndarray,
    trace: np.ndarray,
    reward: float,
    *,
    alpha: float,
    gamma: float,
    baseline: float,
    max_step: float,
    w1_floor: float,
) -> np.ndarray:
    """Eqs 3-4 at the reward event: W + clip(alpha (1 - gamma)(r - b) D), W1 floored.

    A non-finite trace or result leaves W unchanged (a numerical fault never reaches W).
    """
    # on Python's floats: the same IEEE operations, in the same order, as NumPy's
    # elementwise ones, without NumPy's cost per call on six numbers (this runs every trial)
    d = trace.tolist()
    if not all(map(math.isfinite, d)):
        return W.copy()
    scale = alpha * (1.0 - gamma) * (reward - baseline)
    new = [w + min(max(scale * x, -max_step), max_step) for w, x in zip(W.tolist(), d, strict=True)]
    new[0] = max(new[0], w1_floor)
    if not all(map(math.isfinite, new)):
        return W.copy()
    return np.array(new)


def chapter_gain_update(
    W: np.ndarray, trace: np.ndarray, reward: float, c: ChapterConfig
) -> np.ndarray:
    """:func:`gain_update` (eqs 3-4) with the chapter rule's options ``c``."""
    return gain_update(
        W,
        trace,
        reward,
        alpha=c.alpha,
        gamma=c.gamma,
        baseline=c.baseline,
        max_step=c.max_step,
        w1_floor=c.w1_floor,
    )


def policy_trace(state: LearnerState, reset: bool) -> np.ndarray:
    """The trace D a trial starts from: 0, or the one the last trial left (memory "trace")."""
    old = state.get("trace")
    if reset or not old:
        return np.zeros(N_GAINS)
    return np.array(old, dtype=float)


def policy_plan(state: LearnerState, config: LearnerConfig, rng: np.random.Generator) -> TrialPlan:
    """A trial of the Gaussian policy (eq 5) with the state's W and theta_c, its trace
    D (eq 3) carried over or reset: the plan of every rule that explores per step."""
    return TrialPlan(
        W=np.array(state.W, dtype=float),
        theta_c=state.theta_c,
        trace=policy_trace(state, config.reset_trace),
        gamma=config.gamma,
        rng=rng,
        eligibility=config.eligibility,
    )


def finite_trace(trace: np.ndarray) -> tuple[float, ...]:
    """The trace to carry over: itself, or 0 if the trial left it non-finite."""
    values = tuple(trace.tolist())
    if not all(map(math.isfinite, values)):
        return (0.0,) * N_GAINS
    return values


def policy_sigma(plan: TrialPlan) -> tuple[str, float]:
    """The history column ("sigma", the policy std of eq 5 the trial explored with,
    :func:`striatal.sim.kernel.sigma_of` of its W6)."""
    return ("sigma", sigma_of(float(plan.W[5])))


class PolicyRule(Rule):
    """A rule that explores per step with the Gaussian policy of eq 5 (chapter, rpe):
    the plan is :func:`policy_plan`, the history column its sigma."""

    history_columns = ("sigma",)

    def plan(
        self,
        state: LearnerState,
        config: LearnerConfig,
        rng: np.random.Generator,
        context: TrialContext,
    ) -> TrialPlan:
        return policy_plan(state, config, rng)


class ChapterRule(PolicyRule):
    """The chapter's rule: Gaussian policy per step (eq 5), trace D (eq 3), update eq 4.

    No preset: the chapter's learner with striatal's defaults (alpha 5, gamma 0.999),
    set before any sweep ran: ``tuning_root`` None.
    """

    name = "chapter"
    summary = "the chapter's rule (eqs 1-5, 21)"
    config_type = ChapterConfig
    preset = MappingProxyType({})
    control = MappingProxyType({"alpha": 0.0})
    memory_names = ("trace",)
    raw_reward_signal = True

    def update(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Update:
        plan, outcome, reward, success = trial.plan, trial.outcome, trial.reward, trial.success
        c = pick(ChapterConfig, config)
        W, theta_c = plan.W, state.theta_c
        if not success:
            W = chapter_gain_update(plan.W, plan.trace, reward, c)
            theta_c = theta_c_rule(outcome, state.theta_c, c.theta_c_rule)
        return Update(
            W=tuple(W.tolist()),
            theta_c=float(theta_c),
            memory=(("trace", finite_trace(plan.trace)),),
            extra=(policy_sigma(plan),),
        )


CHAPTER = ChapterRule()
