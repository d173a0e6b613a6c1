"""The compiled trial loop: plant, controllers, Gaussian policy and eligibility trace.

This is the one physics kernel of the project. ``simulate``, the learner, the
Gymnasium environments, the sweeps and the benchmarks all call these functions;
:mod:`striatal.sim.reference` re-implements them in plain NumPy for the tests.

Everything here takes plain floats, float64 arrays and, for the trial loops,
the frozen NamedTuples (Gains, PlantArgs, ControlArgs, ProtocolArgs, NoiseArgs,
TraceArgs, Buffers), which :class:`striatal.sim.rollout.TrialRequest` builds
(``TrialRequest.args``, ``batch_args``). Plant arrays are ``[M, m, l, g]``. States are
``[x, x_dot, theta, theta_dot]`` in ``[m, m/s, rad, rad/s]``, theta = 0 upright,
clockwise (pole tip at x + l sin theta).

The modules, by concern: :mod:`~striatal.sim.kernel.libm` (angle wrap, libm ufuncs,
polynomial sin/cos), :mod:`~striatal.sim.kernel.plant` (eqs 7-14, RK4, the motor),
:mod:`~striatal.sim.kernel.policy` (eqs 15-23, the switch, eq 5's sigma),
:mod:`~striatal.sim.kernel.traces` (eqs 2-3), :mod:`~striatal.sim.kernel.learned`
(a learned plant's step), :mod:`~striatal.sim.kernel.trials`
(the judge of eqs 24-25, the summary, the trial loop and its batch),
:mod:`~striatal.sim.kernel.lockstep` (the vectorised batch) and
:mod:`~striatal.sim.kernel.online` (the actor-critic's trial, learning at every step).
This package exposes their names.
"""

from __future__ import annotations

from striatal.sim.kernel import learned, libm, lockstep, online, plant, policy, traces, trials
from striatal.sim.kernel.learned import *  # noqa: F403
from striatal.sim.kernel.libm import *  # noqa: F403
from striatal.sim.kernel.lockstep import *  # noqa: F403
from striatal.sim.kernel.online import *  # noqa: F403
from striatal.sim.kernel.plant import *  # noqa: F403
from striatal.sim.kernel.policy import *  # noqa: F403
from striatal.sim.kernel.traces import *  # noqa: F403
from striatal.sim.kernel.trials import *  # noqa: F403

__all__ = []
__all__ += learned.__all__
__all__ += libm.__all__
__all__ += lockstep.__all__
__all__ += online.__all__
__all__ += plant.__all__
__all__ += policy.__all__
__all__ += traces.__all__
__all__ += trials.__all__
