"""CPU time per simulated second of the spiking network: Brian2 against nengo, one run.

Both simulators run the same network (the chapter's final gains, ``--neurons``, one
network seed) from theta = 3.12 for ``--duration`` s, one after the other in this
process. nengo (the reference) is timed with ``time.process_time`` over its simulation;
Brian2 with the CPU time of the compiled child process (``RUSAGE_CHILDREN``). Building
the network (nengo's builder, both) and generating + compiling the Brian2 program are
excluded and printed apart. Prints one line per simulator and the ratio nengo / Brian2.
Example (docs/neural.md):

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_simulators.py --duration 30 --seed 1
"""

from __future__ import annotations

import argparse

from striatal.neural.network import NetworkConfig
from striatal.neural.run import Simulator, run_network
from striatal.params import CHAPTER_THETA0, Controller, Plant, Simulation


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=30.0, help="simulated seconds")
    parser.add_argument("--neurons", type=int, default=2500)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    sim = Simulation(theta0=CHAPTER_THETA0, duration=args.duration, dt=0.01)
    config = NetworkConfig(neurons=args.neurons)
    per_s = {}
    simulators: tuple[Simulator, ...] = ("brian2", "nengo")
    for simulator in simulators:
        run = run_network(
            Controller(),
            Plant(),
            sim,
            config,
            args.seed,
            record_rates=False,
            simulator=simulator,
            on_compile=lambda where: print(f"(compiling the Brian2 program into {where})"),
        )
        per_s[simulator] = run.cpu_time / args.duration
        switch = run.switch_times[0] if run.switch_times else float("nan")
        print(
            f"{simulator:6s} {run.neurons} neurons, {args.duration:g} s: "
            f"CPU {per_s[simulator]:.4f} s "
            f"per simulated s (wall {run.wall_per_sim_second:.4f}); build {run.build_time:.1f} s, "
            f"compile {run.compile_time:.1f} s; first switch {switch:.2f} s"
        )
    print(f"nengo / brian2 CPU per simulated second: {per_s['nengo'] / per_s['brian2']:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
