"""Timing primitives of the kernel for ``striatal bench`` (the harness is benchmarks/).

The library keeps what a timing needs to call the kernel with no wrapper cost (one
chapter trial set up once, :func:`run_scalar_trial`, :func:`run_batch_trials`), two
timing loops and the Numba cache counter. The harness that compares them with
Gymnasium, the subprocess measurements and the report live in ``benchmarks/harness.py``
of a source checkout; :func:`load_harness` finds and imports it (``striatal bench``
does). The figures and their commands: docs/performance.md.
"""

from __future__ import annotations

import importlib.util
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from striatal.errors import ParameterError
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim import kernel, rollout
from striatal.sim.noise import row_parts, run_parts
from striatal.sim.rollout import Protocol

__all__ = [
    "BENCHMARKS_ENV",
    "TRACE_GAMMA",
    "TrialSetup",
    "batch_normals",
    "benchmarks_dir",
    "cache_misses",
    "calibrate",
    "load_harness",
    "run_batch_trials",
    "run_kernel_trial",
    "run_scalar_trial",
    "timed",
]

#: The eligibility-trace discount of the chapter's learner (LearnerConfig.gamma).
TRACE_GAMMA = 0.999

#: Environment variable naming the benchmarks folder when it is not beside src/.
BENCHMARKS_ENV = "STRIATAL_BENCHMARKS"


@dataclass(frozen=True)
class TrialSetup:
    """The fixed arguments of one chapter trial, built once (no wrapper cost in timings).

    The chapter's learned gains and theta_c from theta0 = 3.12, so every trial swings
    up, balances and runs all its steps (no early end at the 30-s check).
    """

    sim: Simulation
    protocol: Protocol
    controller: Controller
    args: rollout.TrialArgs

    @classmethod
    def chapter(cls, duration: float, dt: float, *, check: bool = True) -> TrialSetup:
        sim = Simulation(duration=duration, dt=dt)
        protocol = Protocol() if check else Protocol(check_time=-1.0)
        controller = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
        args = rollout.trial_args(Plant(), controller, sim, protocol=protocol, gamma=TRACE_GAMMA)
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
    args = rollout.batch_args(
        Plant(),
        setup.controller,
        setup.sim,
        protocol=setup.protocol,
        gains=np.tile(setup.controller.gains, (B, 1)),
        theta_c=np.full(B, setup.controller.theta_c),
        noise=noise,
        gamma=TRACE_GAMMA,
    )
    run = kernel.run_trials_lockstep if lockstep else kernel.run_trials_batch
    run(*args[:-1], outs)
    return int(outs[:, kernel.OUT_END_STEP].sum())


def batch_normals(rng: np.random.Generator, rows: int, n: int) -> np.ndarray:
    """(rows, n) standard normals for a batch of trials, drawn on Numba's thread count.

    The rows are split into one contiguous part per thread, each part drawn from its own
    child of ``rng`` (``rng.spawn``), so the numbers do not depend on the threads' timing
    (:func:`striatal.sim.noise.run_parts`).
    """
    out = np.empty((rows, n))
    parts = row_parts(rows)
    children = rng.spawn(len(parts))

    def part(i: int) -> Callable[[], None]:
        def fill() -> None:
            children[i].standard_normal(out=out[parts[i].start : parts[i].stop])

        return fill

    run_parts([part(i) for i in range(len(parts))])
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


# ---------------------------------------------------------------------------- harness


def benchmarks_dir() -> Path:
    """The benchmarks/ folder: ``$STRIATAL_BENCHMARKS``, else the one beside src/ (a checkout)."""
    env = os.environ.get(BENCHMARKS_ENV)
    here = Path(__file__).resolve().parents[3] / "benchmarks"
    for folder in ([Path(env)] if env else []) + [here]:
        if (folder / "harness.py").is_file():
            return folder
    raise ParameterError(
        "the benchmark harness is benchmarks/harness.py of a source checkout; run from a "
        f"git clone (pip install -e .) or set {BENCHMARKS_ENV}=path/to/benchmarks"
    )


def load_harness() -> ModuleType:
    """Import benchmarks/harness.py (once per process) and return it."""
    name = "striatal_benchmarks_harness"
    if name in sys.modules:
        return sys.modules[name]
    path = benchmarks_dir() / "harness.py"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:  # pragma: no cover - a .py file always has one
        raise ParameterError(f"cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module
