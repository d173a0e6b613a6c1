"""The learning rules and the one trial loop they share.

- :mod:`striatal.learners.config`: :class:`LearnerConfig`, every option of a run;
- :mod:`striatal.learners.state`: :class:`LearnerState` (checkpointable),
  :class:`TrialRecord` (a history row), :class:`History`, :class:`TrainResult`;
- :mod:`striatal.learners.common`: eq 21, the success test, the shaped reward,
  the three-factor update;
- :mod:`striatal.learners.rule`: what a rule supplies (:class:`Rule`);
- the rules: :mod:`~striatal.learners.chapter` (the chapter's, eqs 1-5, 21),
  :mod:`~striatal.learners.rpe` (reward prediction error),
  :mod:`~striatal.learners.pgpe` (exploration in parameter space);
- :mod:`striatal.learners.loop`: the registry :data:`RULES` and the loop :func:`learn`.

The tuned presets live with each rule (:func:`default_config`); ``striatal train``
and :func:`striatal.train` read them from here.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from striatal.errors import ParameterError
from striatal.learners.common import (
    initial_state,
    jitter_corners,
    mean_policy_success,
    prediction_error_factor,
    random_initial_gains,
    shaped_reward,
    theta_c_rule,
    three_factor_update,
    tracked_baseline,
)
from striatal.learners.config import W1_FLOOR, LearnerConfig
from striatal.learners.loop import LEARNERS, RULES, check_config, learn, learning_step, rule_of
from striatal.learners.rule import Rule, TrialPlan, Update
from striatal.learners.state import History, LearnerState, TrainResult, TrialRecord

__all__ = [
    "LEARNERS",
    "RULES",
    "W1_FLOOR",
    "History",
    "LearnerConfig",
    "LearnerState",
    "Rule",
    "TrainResult",
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
    "mean_policy_success",
    "prediction_error_factor",
    "random_initial_gains",
    "rule_of",
    "shaped_reward",
    "theta_c_rule",
    "three_factor_update",
    "tracked_baseline",
]


def default_config(learner: str = "chapter", **changes: Any) -> LearnerConfig:
    """The learner's tuned preset with ``changes`` applied, checked by its rule.

    ``default_config("pgpe")`` is what ``striatal train --learner pgpe`` runs;
    ``default_config("chapter")`` is the chapter's learner exactly. With
    ``robust=True`` the rule's ``robust_preset`` is applied over its preset first
    (pgpe: plant_jitter 0.2, alpha 0.5).
    """
    rule = rule_of(learner)
    robust = dict(rule.robust_preset) if changes.get("robust") is True else {}
    try:
        config = replace(LearnerConfig(learner=learner, **rule.preset), **{**robust, **changes})
    except TypeError as exc:
        raise ParameterError(f"unknown learner option: {exc}") from None
    return check_config(config)


def control_config(config: LearnerConfig) -> LearnerConfig:
    """``config``'s no-learning control (its rule's ``control``: alpha 0 for chapter and
    rpe, the same exploration without update for pgpe)."""
    return rule_of(config).control_config(config)
