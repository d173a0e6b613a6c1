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
trial (the plan's :class:`~striatal.sim.rollout.OnlineLearning`); the compiled loop is
:func:`striatal.sim.kernel.run_online_trial`, on the kernel's functions, and the
trial is yielded like any other, so the batch engines batch it.

Between trials: the critic v carries over; theta_c follows eq 21 (``theta_c_rule``)
as in the chapter; D is reset (or carried, ``reset_trace``). The success test
(``success_on`` "mean" in the preset) judges the W the trial started from; on
success that W is the result and the within-trial changes are dropped.

The no-learning control sets alpha = 0: the actor's gains never change, while the
critic keeps learning (it is not part of the controller), so the control runs the
same exploring trials with the same critic as the learning run's first trial.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType

import numpy as np

from striatal.learners.chapter import PolicyConfig, finite_trace, policy_plan, policy_sigma
from striatal.learners.common import theta_c_rule
from striatal.learners.config import LearnerConfig, pick
from striatal.learners.rule import Rule, Trial, TrialContext, TrialPlan, Update
from striatal.learners.state import LearnerState
from striatal.sim.batch import Steps
from striatal.sim.kernel import N_FEATURES, STAT_N, STAT_RETURN, STAT_SUM_DELTA
from striatal.sim.rollout import OnlineLearning, TrialOutcome

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

    def plan(
        self,
        state: LearnerState,
        config: LearnerConfig,
        rng: np.random.Generator,
        context: TrialContext,
    ) -> TrialPlan:
        """:func:`policy_plan` with the online learning of the trial: the critic carried
        over, a fresh critic trace, the running mean square of delta."""
        c = pick(AcConfig, config)
        online = OnlineLearning(
            alpha=c.alpha,
            beta=c.critic_rate,
            discount=c.td_discount,
            critic_decay=c.critic_decay,
            max_step=c.max_step,
            w1_floor=c.w1_floor,
            normalise=c.normalise,
            square_rate=c.rpe_rate,
            critic=initial_critic(state),
            critic_trace=np.zeros(N_FEATURES),
            square=np.array(state.get("rpe_square") or (0.0,), dtype=float),
        )
        return replace(policy_plan(state, config, rng), online=online)

    def run(
        self, config: LearnerConfig, plan: TrialPlan, context: TrialContext
    ) -> Steps[TrialOutcome]:
        """The online trial, with u held (as ever) under the run's force limit and track."""
        held = replace(context, hardware=replace(context.hardware, hold="u"))
        (outcome,) = yield [held.request(plan)]
        return outcome

    def update(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Update:
        plan, outcome, success = trial.plan, trial.outcome, trial.success
        online = plan.online
        assert online is not None
        c = pick(AcConfig, config)
        W, theta_c = np.array(state.W, dtype=float), state.theta_c
        if not success:
            end = online.gains_end
            if np.all(np.isfinite(end)):
                W = end
            theta_c = theta_c_rule(outcome, state.theta_c, c.theta_c_rule)
        critic = online.critic
        if not np.all(np.isfinite(critic)):
            critic = initial_critic(state)
        square = online.square
        if not np.all(np.isfinite(square)):
            square = np.array(state.get("rpe_square") or (0.0,))
        stats = online.stats
        n = stats[STAT_N]
        return Update(
            W=tuple(float(w) for w in W),
            theta_c=float(theta_c),
            memory=(
                ("critic", tuple(float(v) for v in critic)),
                ("trace", finite_trace(plan.trace)),
                ("rpe_square", (float(square[0]),)),
            ),
            # sigma of eq 5 at the trial's start; the trial's return sum r_k, mean TD
            # error and the critic's |v| after it (0 for a trial with no TD step)
            extra=(
                policy_sigma(plan),
                ("return", float(stats[STAT_RETURN])),
                ("mean_delta", float(stats[STAT_SUM_DELTA] / n) if n > 0 else 0.0),
                ("critic_norm", float(np.linalg.norm(online.critic))),
            ),
        )


AC = AcRule()
