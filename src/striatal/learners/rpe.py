"""The chapter's per-step rule with a dopamine-like reward prediction error ("rpe").

The chapter's Gaussian policy and eligibility trace D (eqs 3-5), but the factor
is a reward prediction error delta = r - b with a baseline that tracks the
expected reward, b <- b + beta (r - b), optionally divided by the running root
mean square of delta (``normalise``); the update alpha (1 - gamma) delta D
(eqs 3-4), minus alpha (1 - gamma) decay W on W1..W5, W1 floored, each step
bounded by max_step; theta_c by eq 21 as in the chapter. Measurements: docs/ablation.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from striatal.learners.chapter import PolicyConfig, PolicyRule, finite_trace, policy_sigma
from striatal.learners.common import (
    baseline_memory,
    check_decay,
    prediction_error,
    theta_c_rule,
    three_factor_update,
)
from striatal.learners.config import LearnerConfig, RewardKind, pick
from striatal.learners.rule import Trial, TrialContext, Update
from striatal.learners.state import LearnerState

__all__ = ["RPE", "RpeConfig", "RpeRule"]


@dataclass(frozen=True)
class RpeConfig(PolicyConfig):
    """The rpe rule's options: the policy's and those of its prediction error."""

    reward: RewardKind
    rpe_rate: float
    normalise: bool
    decay: float

    @property
    def rate(self) -> float:
        """alpha (1 - gamma): the rate of eq 4."""
        return self.alpha * (1.0 - self.gamma)


class RpeRule(PolicyRule):
    """Eq 4 with a tracked reward baseline (a reward prediction error).

    Its preset (normalise) was chosen on ``striatal ablation``'s seeds S = 0..99, which no
    sweep root spawns: ``tuning_root`` None.
    """

    name = "rpe"
    summary = "the chapter's rule with a reward-prediction-error baseline"
    config_type = RpeConfig
    preset = MappingProxyType({"normalise": True})
    control = MappingProxyType({"alpha": 0.0})
    history_columns = ("sigma",)
    memory_names = ("trace", "reward_mean", "rpe_square")

    def check(self, config: LearnerConfig) -> None:
        super().check(config)
        c = pick(RpeConfig, config)
        check_decay(c.rate, c.decay)

    def update(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Update:
        plan, outcome, reward, success = trial.plan, trial.outcome, trial.reward, trial.success
        c = pick(RpeConfig, config)
        factor, b, square = prediction_error(state, reward, c.rpe_rate, c.normalise)
        W, theta_c = plan.W, state.theta_c
        if not success:
            if np.all(np.isfinite(plan.trace)):
                W = three_factor_update(plan.W, plan.trace, factor, c.rate, c.max_step)
                W[:5] -= c.rate * c.decay * plan.W[:5]
                W[0] = max(W[0], c.w1_floor)
            theta_c = theta_c_rule(outcome, state.theta_c, c.theta_c_rule)
        return Update(
            W=tuple(float(w) for w in W),
            theta_c=float(theta_c),
            memory=(("trace", finite_trace(plan.trace)), *baseline_memory(state, b, square)),
            extra=(policy_sigma(plan),),
        )


RPE = RpeRule()
