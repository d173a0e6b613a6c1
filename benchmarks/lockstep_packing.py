"""The SIMD kernel on a block of trials that end at different times: CPU per trial-step.

    python benchmarks/lockstep_packing.py [--trials 1024] [--early 0.35] [--repeats 5]

Runs :func:`striatal.sim.kernel.run_trials_lockstep` on one Numba thread over
``--trials`` noisy 60-s chapter trials from the chapter's final W, a fraction
``--early`` of them, at random, without the swing-up's energy gain (W4 = 0: still
hanging at the eq-24 check, where they end at 30 s). The default makes 82.5 % of the
lane-steps of an unpacked block useful, the fraction round 5 counted in a 30-seed
chapter sweep on the SIMD kernel (docs/performance.md). Prints the thread's CPU time
per simulated trial-step (the steps the trials ran, not the lanes stepped), the best of
``--repeats``, and the fraction of trials that ended before 60 s. Run it under two
trees (``PYTHONPATH=TREE/src``) alternately to compare kernels on the same trials; the
outcomes' checksum agrees when the kernels' results do.
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
    parser.add_argument("--trials", type=int, default=1024)
    parser.add_argument("--early", type=float, default=0.35)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    numba.set_num_threads(1)
    rng = np.random.default_rng(0)
    sim = Simulation()
    B = args.trials
    W = np.tile(CHAPTER_FINAL_W, (B, 1))
    W[rng.random(B) < args.early, 3] = 0.0
    requests = [TrialRequest(Plant(), Controller(), sim, Protocol(), gains=W[b]) for b in range(B)]
    noise = rng.standard_normal((B, sim.n_steps))
    best = np.inf
    outs = np.empty(0)
    for _ in range(args.repeats + 1):  # the first call compiles or loads the cache
        call = batch_args(requests, noise.copy())
        c0 = time.thread_time()
        kernel.run_trials_lockstep(*call)
        best = min(best, time.thread_time() - c0)
        outs = call[-1]
    steps = outs[:, kernel.OUT_END_STEP].sum()
    ended = np.mean(outs[:, kernel.OUT_END_STEP] < sim.n_steps)
    print(
        f"{B} trials: {1e9 * best / steps:.2f} ns CPU per trial-step (best of {args.repeats}), "
        f"{ended:.0%} ended before 60 s, outcome checksum {outs.sum():.12e}"
    )


if __name__ == "__main__":
    main()
