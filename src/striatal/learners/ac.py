"""An online three-factor actor-critic ("ac"): a TD error as the dopamine signal, every step.

In the spirit of the chapter's own references, Doya (2000, continuous-time
actor-critic) and Frémaux, Sprekeler and Gerstner (2013, TD-modulated
three-factor rules): a small critic V(s) = v . phi(s), linear in six bounded
features of the state (a bias, the distance from upright, the squared energy error
of eqs 15-16, the cart's distance and the two speeds), learns the value of the state
under a dense per-step reward r = -dt cost(s); its temporal-difference error
delta(t) = r(t) + gamma_v V(s(t + dt)) - V(s(t)) is computed at every control step
and gates both the actor, W <- W + alpha delta(t) D(t) with the chapter's
eligibility trace D of eq 3 (the Gaussian policy of eq 5), and the critic,
v <- v + beta delta(t) z(t). With ``normalise`` the actor's factor is delta over its
running rms (mean square tracked at ``rpe_rate`` per step, carried across trials, memory
"rpe_square"), so that alpha does not depend on the reward's scale. W changes within the
trial; the compiled loop is
:func:`striatal.sim.online.run_online_trial`, on the kernel's functions.

Between trials: the critic v carries over; theta_c follows eq 21 (``theta_c_rule``)
as in the chapter; D is reset (or carried, ``reset_trace``). The success test
(``success_on`` "mean" in the preset) judges the W the trial started from; on
success that W is the result and the within-trial changes are dropped.

The no-learning control sets alpha = 0: the actor's gains never change, while the
critic keeps learning (it is not part of the controller), so the control runs the
same exploring trials with the same critic as the learning run's first trial.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from striatal.learners.chapter import PolicyConfig, finite_trace, policy_plan
from striatal.learners.common import theta_c_rule
from striatal.learners.config import LearnerConfig, pick
from striatal.learners.rule import Rule, Trial, TrialPlan, Update
from striatal.learners.state import LearnerState
from striatal.params import Plant
from striatal.sim.kernel import sigma_of
from striatal.sim.online import (
    N_FEATURES,
    N_STATS,
    STAT_N,
    STAT_RETURN,
    STAT_SUM_DELTA,
    online_trial,
)
from striatal.sim.rollout import TrialOutcome

__all__ = ["AC", "AcConfig", "AcRule", "initial_critic"]


@dataclass(frozen=True)
class AcConfig(PolicyConfig):
    """The ac rule's options: the actor's policy options and the critic's."""

    critic_rate: float
    td_discount: float
    critic_decay: float
    normalise: bool
    rpe_rate: float


def initial_critic(state: LearnerState) -> np.ndarray:
    """The critic's weights v (N_FEATURES,) a trial starts from: memory "critic", or 0."""
    old = state.get("critic")
    if len(old) != N_FEATURES:
        return np.zeros(N_FEATURES)
    return np.array(old, dtype=float)


class AcRule(Rule):
    """Online actor-critic: the TD error of a linear critic gates eq 4 at every step.

    The preset was tuned on 8 seeds of its own (W(0) from ``default_rng([s, 7])``,
    s = 0..7; docs/results.md), which no sweep root spawns: ``tuning_root`` None.
    """

    name = "ac"
    summary = "online actor-critic: a TD error gates alpha delta(t) D(t) at every step"
    config_type = AcConfig
    preset = MappingProxyType(
        {
            "alpha": 0.001,
            "gamma": 0.99,
            "max_step": 0.01,
            "success_on": "mean",
            "normalise": True,
            "rpe_rate": 0.001,
            "critic_rate": 0.01,
            "td_discount": 0.99,
            "critic_decay": 0.9,
        }
    )
    control = MappingProxyType({"alpha": 0.0})
    control_also = "the critic still learns (it is not part of the controller)"
    history_columns = ("sigma", "return", "mean_delta", "critic_norm")
    memory_names = ("critic", "trace", "rpe_square")
    runs_trial = True

    def plan(
        self, state: LearnerState, config: LearnerConfig, rng: np.random.Generator, plant: Plant
    ) -> TrialPlan:
        base = policy_plan(state, config, rng)
        return TrialPlan(
            W=base.W,
            theta_c=base.theta_c,
            trace=base.trace,
            gamma=base.gamma,
            rng=base.rng,
            eligibility=base.eligibility,
            scratch={
                "critic": initial_critic(state),
                "critic_trace": np.zeros(N_FEATURES),
                "W_end": base.W.copy(),
                "stats": np.zeros(N_STATS),
                "square": np.array(state.get("rpe_square") or (0.0,), dtype=float),
            },
        )

    def run(self, config: LearnerConfig, plan: TrialPlan, trial: Mapping[str, Any]) -> TrialOutcome:
        """The online trial (:func:`striatal.sim.online.online_trial`); the gains at its end
        and its statistics go to the plan's scratch, the critic is updated there."""
        c = pick(AcConfig, config)
        result = online_trial(
            trial["plant"],
            trial["controller"],
            trial["sim"],
            protocol=trial["protocol"],
            rng=plan.rng,
            gains=plan.W,
            trace=plan.trace,
            gamma=plan.gamma,
            critic=plan.scratch["critic"],
            critic_trace=plan.scratch["critic_trace"],
            alpha=c.alpha,
            beta=c.critic_rate,
            discount=c.td_discount,
            critic_decay=c.critic_decay,
            max_step=c.max_step,
            w1_floor=c.w1_floor,
            action_every=trial["action_every"],
            chapter_eligibility=plan.eligibility == "chapter",
            model=trial["model"],
            # u held, as ever; the run's force limit and track apply
            hardware=replace(trial["hardware"], hold="u"),
            normalise=c.normalise,
            square_rate=c.rpe_rate,
            square=plan.scratch["square"],
        )
        np.copyto(plan.scratch["W_end"], result.W)
        np.copyto(plan.scratch["stats"], result.stats)
        return result.outcome

    def update(self, state: LearnerState, config: LearnerConfig, trial: Trial) -> Update:
        plan, outcome, success = trial.plan, trial.outcome, trial.success
        c = pick(AcConfig, config)
        W, theta_c = np.array(state.W, dtype=float), state.theta_c
        if not success:
            end = plan.scratch["W_end"]
            if np.all(np.isfinite(end)):
                W = end
            theta_c = theta_c_rule(outcome, state.theta_c, c.theta_c_rule)
        critic = plan.scratch["critic"]
        if not np.all(np.isfinite(critic)):
            critic = initial_critic(state)
        square = plan.scratch["square"]
        if not np.all(np.isfinite(square)):
            square = np.array(state.get("rpe_square") or (0.0,))
        return Update(
            W=tuple(float(w) for w in W),
            theta_c=float(theta_c),
            memory=(
                ("critic", tuple(float(v) for v in critic)),
                ("trace", finite_trace(plan.trace)),
                ("rpe_square", (float(square[0]),)),
            ),
        )

    def extra(self, state: LearnerState, plan: TrialPlan) -> tuple[tuple[str, float], ...]:
        """sigma of eq 5 at the trial's start; the trial's return sum r_k, mean TD error
        and the critic's |v| after it (0 for a trial with no TD step)."""
        stats = plan.scratch["stats"]
        n = stats[STAT_N]
        return (
            ("sigma", float(sigma_of(plan.W[5]))),
            ("return", float(stats[STAT_RETURN])),
            ("mean_delta", float(stats[STAT_SUM_DELTA] / n) if n > 0 else 0.0),
            ("critic_norm", float(np.linalg.norm(plan.scratch["critic"]))),
        )


AC = AcRule()
