"""The online actor-critic's trial: a :class:`~striatal.sim.rollout.TrialRequest` whose
``online`` (:class:`~striatal.sim.rollout.OnlineLearning`) makes the gains learn at
every step (the compiled loop and the critic: :mod:`striatal.sim.kernel.online`, whose
names this module also gives).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from striatal.errors import ParameterError
from striatal.sim.kernel import online as _kernel
from striatal.sim.kernel.online import *  # noqa: F403
from striatal.sim.rollout import TrialOutcome, TrialRequest

__all__ = ["OnlineTrial", "online_trial", *_kernel.__all__]


class OnlineTrial(NamedTuple):
    """What :func:`online_trial` returns: the outcome, the gains at the trial's end
    (6,) and the statistics row (N_STATS,, layout STAT_*)."""

    outcome: TrialOutcome
    W: np.ndarray
    stats: np.ndarray


def online_trial(request: TrialRequest) -> OnlineTrial:
    """Run ``request`` (its ``online`` set) on the scalar kernel: its outcome, the gains at
    its end and its statistics (copies; the critic, its trace and the mean square are
    updated in place in ``request.online``)."""
    if request.online is None:
        raise ParameterError("an online trial needs TrialRequest.online (its critic and rates)")
    outcome = request.run()
    return OnlineTrial(outcome, request.online.gains_end.copy(), request.online.stats.copy())
