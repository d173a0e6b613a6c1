"""Timing primitives of the kernel for ``striatal bench`` (the harness is :mod:`striatal.bench`).

What a timing needs to call the kernel with no wrapper cost (one chapter trial set up
once, :func:`run_scalar_trial`, :func:`run_batch_trials`), two timing loops and the
Numba cache counter. The measurements that compare them with Gymnasium, the subprocess
scripts and the report are :mod:`striatal.bench`. The figures and their commands:
docs/performance.md.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim import kernel, rollout
from striatal.sim.noise import standard_normal_rows
from striatal.sim.rollout import Protocol

__all__ = [
    "TRACE_GAMMA",
    "TrialSetup",
    "batch_normals",
    "cache_misses",
    "calibrate",
    "run_batch_trials",
    "run_kernel_trial",
    "run_scalar_trial",
    "timed",
]

#: The eligibility-trace discount of the chapter's learner (LearnerConfig.gamma).
TRACE_GAMMA = 0.999


@dataclass(frozen=True)
class TrialSetup:
    """The fixed arguments of one chapter trial, built once (no wrapper cost in timings).

    The chapter's learned gains and theta_c from theta0 = 3.12, so every trial swings
    up, balances and runs all its steps (no early end at the 30-s check).
    """

    sim: Simulation
    protocol: Protocol
    controller: Controller
    args: kernel.TrialArgs

    @classmethod
    def chapter(cls, duration: float, dt: float, *, check: bool = True) -> TrialSetup:
        sim = Simulation(duration=duration, dt=dt)
        protocol = Protocol() if check else Protocol(check_time=-1.0)
        controller = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
        request = rollout.TrialRequest(Plant(), controller, sim, protocol, gamma=TRACE_GAMMA)
        args = request.args(np.empty(0), np.empty((0, 2)))
        return cls(sim=sim, protocol=protocol, controller=controller, args=args)

    @property
    def n_steps(self) -> int:
        return self.sim.n_steps


def run_scalar_trial(setup: TrialSetup, rng: np.random.Generator, out: np.ndarray) -> int:
    """One stochastic trial, its noise drawn from ``rng`` here; returns the steps run."""
    return run_kernel_trial(setup, rng.standard_normal(setup.n_steps), out)


def run_kernel_trial(setup: TrialSetup, noise: np.ndarray, out: np.ndarray) -> int:
    """One trial of the kernel with the given policy noise (empty: the mean policy)."""
    state0, gains, plant, control, protocol, noise_args, learning, buffers = setup.args
    kernel.run_trial(
        state0,
        gains,
        plant,
        control,
        protocol,
        noise_args._replace(action=noise),
        learning._replace(trace=np.zeros(6)),
        buffers._replace(out=out),
    )
    return int(out[kernel.OUT_END_STEP])


def run_batch_trials(
    setup: TrialSetup,
    batch_size: int,
    rng: np.random.Generator,
    outs: np.ndarray,
    *,
    stochastic: bool = True,
    lockstep: bool = True,
) -> int:
    """``batch_size`` stochastic trials on all cores, noise drawn here; returns steps run.

    ``lockstep``: :func:`striatal.sim.kernel.run_trials_lockstep` (vectorised over trials);
    else :func:`striatal.sim.kernel.run_trials_batch` (one scalar trial per core at a time).
    """
    B = batch_size
    noise = batch_normals(rng, B, setup.n_steps) if stochastic else np.empty((B, 0))
    request = rollout.TrialRequest(
        Plant(), setup.controller, setup.sim, setup.protocol, gamma=TRACE_GAMMA
    )
    args = rollout.batch_args([request] * B, noise)
    run = kernel.run_trials_lockstep if lockstep else kernel.run_trials_batch
    run(*args[:-1], outs)
    return int(outs[:, kernel.OUT_END_STEP].sum())


def batch_normals(rng: np.random.Generator, rows: int, n: int) -> np.ndarray:
    """(rows, n) standard normals for a batch of trials, drawn on Numba's threads.

    The rows are split into one contiguous part per thread (fewer when the rows are
    few), part k drawn from child k of ``rng`` (``rng.spawn``), all in one compiled call
    (:func:`striatal.sim.noise.standard_normal_rows`), the parts on Numba's threads:
    part k holds what ``children[k].standard_normal`` gives it, whatever the threads'
    timing.
    """
    out = np.empty((rows, n))
    threads = numba.get_num_threads()
    step = -(-rows // max(1, min(threads, rows)))
    starts = range(0, rows, max(step, 1))
    children = rng.spawn(len(starts))
    standard_normal_rows(
        children,
        out.reshape(-1),
        [start * n for start in starts],
        [(min(start + step, rows) - start) * n for start in starts],
        threads,
    )
    return out


def cache_misses() -> int:
    """Numba on-disk cache misses (compilations) of the trial kernels in this process."""
    total = 0
    for fn in (kernel.run_trial, kernel.run_trials_batch, kernel.run_trials_lockstep):
        total += sum(fn.stats.cache_misses.values())
    return total


# ---------------------------------------------------------------------------- timing


def calibrate(run: Callable[[], int], seconds: float) -> int:
    """How many calls of ``run`` take about ``seconds`` (one call timed after warm-up)."""
    run()
    t0 = time.perf_counter()
    run()
    one = max(time.perf_counter() - t0, 1e-7)
    return max(1, int(seconds / one))


def timed(run: Callable[[], int], calls: int) -> tuple[int, float]:
    t0 = time.perf_counter()
    steps = 0
    for _ in range(calls):
        steps += run()
    return steps, time.perf_counter() - t0
