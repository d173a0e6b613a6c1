"""The chapter's learner under its historical module name (kept for existing imports).

Everything here lives in :mod:`striatal.learners`; this module only re-exports it
(it imports :mod:`striatal.learners`, never the reverse). ``train`` is
:func:`striatal.learners.learn`; for a whole run with files use :func:`striatal.train`.
"""

from __future__ import annotations

from striatal.learners import (
    LEARNERS,
    W1_FLOOR,
    LearnerConfig,
    LearnerState,
    TrainResult,
    TrialRecord,
    initial_state,
    learning_step,
    mean_policy_success,
    random_initial_gains,
    theta_c_rule,
)
from striatal.learners import learn as train
from striatal.learners.chapter import gain_update
from striatal.learners.common import THETA_C_FLOOR, THETA_C_RESET_ABOVE, THETA_C_RESET_TO
from striatal.learners.config import Eligibility, RewardKind, SuccessOn, ThetaCRule
from striatal.learners.state import history_columns
from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W

__all__ = [
    "HISTORY_COLUMNS",
    "LEARNERS",
    "THETA_C_FLOOR",
    "THETA_C_RESET_ABOVE",
    "THETA_C_RESET_TO",
    "W1_FLOOR",
    "Eligibility",
    "LearnerConfig",
    "LearnerState",
    "RewardKind",
    "SuccessOn",
    "ThetaCRule",
    "TrainResult",
    "TrialRecord",
    "chapter_start",
    "gain_update",
    "initial_state",
    "learning_step",
    "mean_policy_success",
    "random_initial_gains",
    "theta_c_rule",
    "train",
]

#: history.csv header of the chapter's (and rpe's) learner.
HISTORY_COLUMNS = history_columns(("sigma",))


def chapter_start() -> tuple[tuple[float, ...], float]:
    """W(0) and theta_c(0) of the chapter's run."""
    return CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C
