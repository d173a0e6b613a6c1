"""``striatal bench``: each figure of the kernel measured beside its reference in one process.

What is measured (``striatal bench``; the table is docs/performance.md):

1. ``scalar_vs_gymnasium``: single-core env-steps per second of one chapter trial
   (:func:`striatal.sim.kernel.run_trial`: RK4, switching controller, Gaussian policy
   noise, eligibility trace), *including* drawing its standard-normal noise from a
   ``np.random.Generator`` each trial, against Gymnasium's ``CartPole-v1`` step loop
   (``gymnasium.make("CartPole-v1").unwrapped``: Euler physics only, a fixed action,
   reset on termination).
2. ``batch_vs_gymnasium_vector``: :func:`striatal.sim.kernel.run_trials_lockstep` (blocks
   of 64 trials advancing in lockstep, vectorised over trials, blocks over all cores)
   against Gymnasium's ``CartPoleVectorEnv`` (NumPy over the batch, autoreset) at the
   same batch size, and against :func:`striatal.sim.kernel.run_trials_batch` (``prange``
   over scalar trials). Steps are env-steps summed over the batch. The kernel does
   four derivative evaluations per step (RK4), the reference one (Euler).
3. ``train``: wall seconds of ``striatal train --init chapter`` (a fresh process).
4. ``scaling``: seconds per trial against n_steps = duration / dt, with a least-squares
   line (slope [s/step], intercept [s], R^2).
5. ``compile``: the first call of each kernel function in this process (cache load, or
   compilation when the on-disk cache missed) and in a second, fresh process.

Timing: ``time.perf_counter``; warm-up calls excluded; the two sides of a ratio are
timed alternately, repeat by repeat, and the ratio uses the best repeat of each (the
median ratio is reported too).

The modules: :mod:`~striatal.bench.timing` (configuration, alternate timing, ratios),
:mod:`~striatal.bench.measure` (items 1-5 and the sweeps), :mod:`~striatal.bench.anchors`
(``--anchors``: gymnax and EnvPool), :mod:`~striatal.bench.harness` (the report);
:mod:`~striatal.bench.first_call` and :mod:`~striatal.bench.peak_rss` are the scripts
run in a fresh interpreter. The kernel-calling primitives are :mod:`striatal.sim.bench`.
"""

from __future__ import annotations

from striatal.bench.harness import BenchReport, format_report, run_all
from striatal.bench.timing import QUICK, BenchConfig, Comparison, Timing

__all__ = [
    "QUICK",
    "BenchConfig",
    "BenchReport",
    "Comparison",
    "Timing",
    "format_report",
    "run_all",
]
