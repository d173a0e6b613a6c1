"""Cost per trial against duration / dt (item 4 of ``striatal bench``), printed as a table.

python benchmarks/bench_scaling.py [--dt 0.01] [--seconds 0.3]
"""

from __future__ import annotations

import argparse

import numpy as np

from striatal.bench import measure, timing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--dt", type=float, default=0.01)
    parser.add_argument("--seconds", type=float, default=0.3)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    config = timing.BenchConfig(seconds=args.seconds, repeats=args.repeats, dt=args.dt)
    rng = np.random.default_rng(0)
    measure.first_calls(rng)  # warm-up (compile or cache load) outside the timings
    result = measure.scaling(config, rng)
    for row in result["rows"]:
        print(
            f"{row['duration']:>7g} s {row['n_steps']:>8d} steps "
            f"{row['seconds_per_trial'] * 1e3:9.3f} ms/trial"
        )
    fit = result["fit"]
    print(
        f"fit: {fit['intercept'] * 1e6:.1f} us + {fit['ns_per_step']:.1f} ns x n_steps, "
        f"R^2 = {fit['r2']:.5f}"
    )


if __name__ == "__main__":
    main()
