"""Where a Brian2 learning trial's CPU goes: the compiled child against this process.

Three measurements in one process, on the chapter's W(0), network seed ``--seed``,
``--neurons`` neurons:

1. **The child's start against its simulation.** The compiled program run for each of
   ``--durations`` s (one program per run length; compiled first if not cached, and that
   time left out), ``--repeats`` times each, with exploration: the child's CPU time
   (``RUSAGE_CHILDREN``) per run, and a line fitted through (duration, CPU): its
   intercept is what a launch costs whatever it simulates (starting the binary, reading
   the run_args and the static arrays, writing the results), its slope the simulation.
2. **This process per trial.** ``--trials`` learning trials of ``--duration-learn`` s
   (:func:`striatal.neural.driver.learn_network`, alpha 5), after one warm-up trial: this
   process's CPU (``RUSAGE_SELF``) and the child's per trial.
3. **The translation.** nengo's full build of a seed against the kept build re-solving
   only the switch's decoders for a new theta_c (:func:`striatal.neural.translate.translate`).

Prints ratios measured in the same run; absolute times depend on the machine's load.
Example (docs/neural.md):

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_trial_cost.py
"""

from __future__ import annotations

import argparse
import resource
import sys
import time

import numpy as np

from striatal.neural.brian import compiled_network
from striatal.neural.driver import learn_network
from striatal.neural.interpret import pathway_coefficients
from striatal.neural.network import NetworkConfig
from striatal.neural.translate import forget_builds, translate
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    CHAPTER_THETA0,
    Controller,
    Plant,
    Simulation,
)


def cpu(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--durations", type=float, nargs="+", default=[1.0, 5.0, 30.0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--trials", type=int, default=4)
    parser.add_argument("--duration-learn", type=float, default=30.0)
    parser.add_argument("--neurons", type=int, default=2500)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    plant, config = Plant(), NetworkConfig(neurons=args.neurons)
    start = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
    tr = translate(start, plant, config, args.seed)
    c = pathway_coefficients(start.gains, plant, start.sign)
    state0 = np.array([0.0, 0.0, CHAPTER_THETA0, 0.0])
    points = []
    for duration in args.durations:
        program = compiled_network(tr, duration, 0.01)
        for k in range(args.repeats):
            noise = np.random.default_rng(k).standard_normal(program.n_control)
            r = program.run(tr, c, plant, state0, sigma=0.7, noise=noise)
            points.append((duration, r.cpu_time))
        got = [p for d, p in points if d == duration]
        print(f"child, {duration:g}-s run: CPU {np.median(got):.3f} s (median of {len(got)})")
    slope, intercept = np.polyfit(*np.array(points).T, 1)
    print(
        f"child: {slope:.4f} CPU s per simulated s + {intercept:.3f} s per launch; a "
        f"{args.duration_learn:g}-s run's launch share "
        f"{intercept / (intercept + slope * args.duration_learn):.1%}"
    )

    sim = Simulation(theta0=CHAPTER_THETA0, duration=args.duration_learn)
    learn_network(start, plant, sim, config, args.seed, trials=1, simulator="brian2")
    s0, c0 = cpu(resource.RUSAGE_SELF), cpu(resource.RUSAGE_CHILDREN)
    learn_network(start, plant, sim, config, args.seed, trials=args.trials, simulator="brian2")
    own = (cpu(resource.RUSAGE_SELF) - s0) / args.trials
    child = (cpu(resource.RUSAGE_CHILDREN) - c0) / args.trials
    print(
        f"learning trial ({args.duration_learn:g} s, {args.trials} trials): child {child:.3f} "
        f"CPU s, this process {own:.3f} CPU s; the child's share {child / (child + own):.1%}"
    )

    thetas = [0.6 + 0.01 * k for k in range(6)]
    t0 = time.process_time()
    for th in thetas:
        forget_builds()
        translate(start.with_gains(start.gains, th), plant, config, args.seed)
    full = (time.process_time() - t0) / len(thetas)
    t0 = time.process_time()
    for th in thetas:
        translate(start.with_gains(start.gains, th + 0.005), plant, config, args.seed)
    kept = (time.process_time() - t0) / len(thetas)
    print(
        f"translation: full nengo build {full:.3f} CPU s, kept build re-solving the switch "
        f"{kept:.4f} CPU s ({full / kept:.0f} times less)"
    )
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
