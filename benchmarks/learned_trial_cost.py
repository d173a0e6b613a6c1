"""CPU per step of a trial on a learned plant, against the physical plant's, in one run.

    python benchmarks/learned_trial_cost.py [--repeats 200]

Fits the generic forward model (``fit_generic``, five members, cubic monomials) on two
recorded 20-s trials of the nominal plant (the chapter's W(0) and its final W, force
held), then runs one 60-s trial of the final W (mean policy, eq 24's check, force held)
on the ensemble's mean and on the physical plant, each ``--repeats`` times on the
scalar kernel, and prints the CPU seconds (``time.process_time``) per simulated step of
each and their ratio. The physical trial is the reference timed in the same run, so
the ratio holds on a shared machine. The same script runs on an older checkout.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from striatal.learners.forward.model import Transitions, fit_generic
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import kernel
from striatal.sim.learned import LearnedPlant
from striatal.sim.robust import ROBUST_HARDWARE
from striatal.sim.rollout import Protocol, TrialRequest, simulate

FINAL = Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
INITIAL = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)


def cpu_per_step(request: TrialRequest, repeats: int) -> tuple[float, str, float]:
    """(CPU seconds per simulated step on the kernel alone, end reason, ended at [s])."""
    outcome = request.run()  # compiles or loads the cache
    args = request.args()
    plant = request.plant
    t0 = time.process_time()
    for _ in range(repeats):
        if isinstance(plant, LearnedPlant):
            assert plant.dynamics is not None
            kernel.run_learned_trial(plant.dynamics.args, args)
        else:
            kernel.run_trial(*args)
    cpu = (time.process_time() - t0) / repeats
    steps = round(outcome.ended_at / request.sim.dt)
    return cpu / steps, outcome.end_reason, outcome.ended_at


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    sim = Simulation(duration=20.0)
    data = Transitions.of(
        [simulate(Plant(), c, sim, hardware=ROBUST_HARDWARE) for c in (FINAL, INITIAL)]
    )
    learned = fit_generic(data, np.random.default_rng(3)).plant(Plant())
    costs = {}
    for name, plant in (("learned", learned), ("physical", Plant())):
        request = TrialRequest(plant, FINAL, Simulation(), Protocol(), hardware=ROBUST_HARDWARE)
        per_step, reason, ended = cpu_per_step(request, args.repeats)
        costs[name] = per_step
        print(f"{name}: {1e9 * per_step:.0f} ns of CPU per step ({reason} at {ended:.2f} s)")
    print(f"learned / physical: {costs['learned'] / costs['physical']:.2f}")


if __name__ == "__main__":
    main()
