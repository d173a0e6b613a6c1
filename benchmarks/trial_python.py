"""The main thread's Python per trial of a lockstep sweep, in microseconds, no kernel run.

    python benchmarks/trial_python.py [--trials 20000] [--batch 100]
    PYTHONPATH=OLD/src python benchmarks/trial_python.py    # another tree, to compare

Times, with ``time.thread_time`` (this thread's CPU, so other processes' load counts
little), the per-trial work the batch engines do on their main thread for the chapter
rule of README's sweep:

- ``learning step``: a run of ``--trials`` trials of
  :func:`striatal.learners.loop.learn_steps` (each: the generator restored, the rule's
  plan, the request, the success test, the rule's update, the history record and the
  next state), every trial sent the same failed outcome; per trial;
- ``prepare + outcomes``: :func:`striatal.sim.batch.prepare` of ``--batch`` such
  requests from as many generators, without their normals (the ``draw`` stage, or the
  noise a tree draws in ``prepare``, is taken out), and reading their outcomes
  (:meth:`striatal.sim.batch.Calls.outcomes`) from summary rows left as the kernel
  would write them; per request.

Works on trees before and after the noise moved out of ``prepare``: the noise is
switched off by giving the requests no generator of their own draws (mean policy).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from striatal.learners import default_config
from striatal.learners.common import initial_state
from striatal.learners.loop import learn_steps
from striatal.params import Controller, Plant, Simulation
from striatal.sim import batch, kernel
from striatal.sim.rollout import Protocol, TrialOutcome, TrialRequest


def per_call(f: Callable[[], object], n: int, per: int = 1) -> float:
    """CPU microseconds of this thread per ``per``-th of a call of ``f``, best of three
    blocks of ``n`` calls."""
    best = float("inf")
    for _ in range(3):
        t0 = time.thread_time()
        for _ in range(n):
            f()
        best = min(best, time.thread_time() - t0)
    return best / n / per * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20000)
    parser.add_argument("--batch", type=int, default=100)
    args = parser.parse_args()
    config = default_config("chapter", max_trials=args.trials)
    plant, template, sim, protocol = Plant(), Controller(), Simulation(), Protocol()
    state = initial_state(template.gains, template.theta_c, 5)
    row = np.zeros(kernel.N_OUT)
    row[kernel.OUT_END_STEP] = 3000.0
    row[kernel.OUT_REWARD] = -5.0
    row[kernel.OUT_EARLY] = 1.0  # failed the eq-24 check at 30 s
    row[kernel.OUT_THETA] = 3.0
    failed = TrialOutcome.from_row(row, sim)

    def run() -> object:
        steps = learn_steps(plant, template, config, state, sim, protocol)
        requests = next(steps)
        try:
            while True:
                requests = steps.send([failed for _ in requests])
        except StopIteration as stop:
            return stop.value

    requests = [
        TrialRequest(plant, template, sim, protocol, gains=np.asarray(template.gains))
        for _ in range(args.batch)
    ]

    def round_trip() -> object:
        calls = batch.prepare(requests, "simd")
        for call in calls.calls:
            call.args.outs[:] = row
        return calls.outcomes()

    print(f"learning step       {per_call(run, 1, args.trials):7.1f} us per trial")
    rounds = max(1, args.trials // args.batch)
    print(f"prepare + outcomes  {per_call(round_trip, rounds, args.batch):7.1f} us per request")


if __name__ == "__main__":
    main()
