"""The SIMD kernel's cost of a call against its trials: whole vectors against lanes left over.

    python benchmarks/lockstep_lanes.py [--trials 1 4 8 12 16 64] [--repeats 3]

Runs :func:`striatal.sim.kernel.run_trials_lockstep` on one Numba thread over B noisy
60-s chapter trials from the chapter's final W (none ends early), as one block, for
each B of ``--trials``, and prints the thread's CPU time per call (the best of
``--repeats``, each the mean of enough calls to simulate 256 trials) and per
trial-step. A block steps its trials rounded up to :data:`~striatal.sim.kernel.lockstep.VECTOR`
lanes; run it under two trees (``PYTHONPATH=TREE/src``) to compare how each prices the
lanes left over.
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from striatal.params import CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.rollout import Protocol, TrialRequest, batch_args


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, nargs="+", default=[1, 4, 8, 12, 16, 64])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    numba.set_num_threads(1)
    sim = Simulation()
    rng = np.random.default_rng(0)
    for B in args.trials:
        W = np.tile(CHAPTER_FINAL_W, (B, 1))
        requests = [
            TrialRequest(Plant(), Controller(), sim, Protocol(), gains=W[b]) for b in range(B)
        ]
        noise = rng.standard_normal((B, sim.n_steps))
        calls = max(1, 256 // B)
        kernel.run_trials_lockstep(*batch_args(requests, noise.copy()), B)  # compile or load
        best = np.inf
        outs = np.empty(0)
        for _ in range(args.repeats):
            batch = [batch_args(requests, noise.copy()) for _ in range(calls)]
            c0 = time.thread_time()
            for call in batch:
                kernel.run_trials_lockstep(*call, B)
            best = min(best, (time.thread_time() - c0) / calls)
            outs = batch[-1][-1]
        steps = outs[:, kernel.OUT_END_STEP].sum()
        print(
            f"{B:3d} trials: {1e6 * best:8.1f} us CPU per call, "
            f"{1e9 * best / steps:6.2f} ns per trial-step"
        )


if __name__ == "__main__":
    main()
