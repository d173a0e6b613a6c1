"""The learning rules and the one trial loop they share.

- :mod:`striatal.learners.config`: :class:`LearnerConfig`, every option of a run;
- :mod:`striatal.learners.state`: :class:`LearnerState` (checkpointable),
  :class:`TrialRecord` (a history row), :class:`History`;
- :mod:`striatal.learners.common`: eq 21, the success test, the shaped reward,
  the three-factor update;
- :mod:`striatal.learners.rule`: what a rule supplies (:class:`Rule`);
- the rules: :mod:`~striatal.learners.chapter` (the chapter's, eqs 1-5, 21),
  :mod:`~striatal.learners.rpe` (reward prediction error),
  :mod:`~striatal.learners.pgpe` (exploration in parameter space);
- :mod:`striatal.learners.loop`: the registry :data:`RULES` and the loop :func:`learn`;
- :mod:`striatal.learners.forward`: a cerebellar forward model and the rule that learns
  on it in imagination (``forward``), registered here since it builds on the loop.

The tuned presets live with each rule (:func:`default_config`); ``striatal train``
and :func:`striatal.train` read them from here.
"""

from __future__ import annotations

from striatal.learners.common import (
    initial_state,
    jitter_corners,
    prediction_error_factor,
    random_initial_gains,
    shaped_reward,
    theta_c_rule,
    three_factor_update,
    tracked_baseline,
)
from striatal.learners.config import W1_FLOOR, LearnerConfig
from striatal.learners.forward.rule import FORWARD
from striatal.learners.loop import (
    RULES,
    check_config,
    control_config,
    default_config,
    learn,
    learning_step,
    register,
    rule_of,
)
from striatal.learners.rule import Judging, Rule, Trial, TrialContext, TrialPlan, Update
from striatal.learners.state import History, LearnerState, TrialRecord

__all__ = [
    "LEARNERS",
    "RULES",
    "W1_FLOOR",
    "History",
    "Judging",
    "LearnerConfig",
    "LearnerState",
    "Rule",
    "Trial",
    "TrialContext",
    "TrialPlan",
    "TrialRecord",
    "Update",
    "check_config",
    "control_config",
    "default_config",
    "initial_state",
    "jitter_corners",
    "learn",
    "learning_step",
    "prediction_error_factor",
    "random_initial_gains",
    "register",
    "rule_of",
    "shaped_reward",
    "theta_c_rule",
    "three_factor_update",
    "tracked_baseline",
]

register(FORWARD)
#: The learner names, in the registry's order.
LEARNERS: tuple[str, ...] = tuple(RULES)
