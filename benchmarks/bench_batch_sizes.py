"""Cost per trial-step against the batch size B, beside the scalar kernel in the same run.

    python benchmarks/bench_batch_sizes.py [--duration 10] [--repeats 3] [--sizes 1,4,...]

For each B: ``kernel.run_trials_lockstep`` and ``kernel.run_trials_batch`` (prange over
scalar trials) on B chapter trials (noise drawn inside the timing), and
``kernel.run_trial`` on one trial, timed alternately (best of the repeats, warm-up
excluded). Prints ns per trial-step and each batch kernel's speed-up over the scalar
kernel timed in the same run.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from striatal.sim import bench, kernel


def best(run, repeats: int) -> float:  # type: ignore[no-untyped-def]
    """Best seconds of one call over ``repeats`` timed calls (after one warm-up)."""
    run()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sizes", default="1,4,16,64,256,1024,4096")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    setup = bench.TrialSetup.chapter(args.duration, 0.01)
    n = setup.n_steps
    out = np.empty(kernel.N_OUT)
    rows = []
    for B in (int(b) for b in args.sizes.split(",")):
        outs = np.empty((B, kernel.N_OUT))
        calls = max(1, 4096 // B)  # the scalar side runs about as many trials

        def scalar(calls: int = calls) -> None:
            for _ in range(calls):
                bench.run_scalar_trial(setup, rng, out)

        def lock(B: int = B, outs: np.ndarray = outs) -> None:
            bench.run_batch_trials(setup, B, rng, outs)

        def prange(B: int = B, outs: np.ndarray = outs) -> None:
            bench.run_batch_trials(setup, B, rng, outs, lockstep=False)

        t_s = t_l = t_p = float("inf")
        for _ in range(args.repeats):
            t_s = min(t_s, best(scalar, 1) / calls)
            t_l = min(t_l, best(lock, 1))
            t_p = min(t_p, best(prange, 1))
        row = {
            "B": B,
            "scalar_ns_per_step": t_s / n * 1e9,
            "lockstep_ns_per_trial_step": t_l / (B * n) * 1e9,
            "prange_ns_per_trial_step": t_p / (B * n) * 1e9,
        }
        row["lockstep_speedup_over_scalar"] = (
            row["scalar_ns_per_step"] / row["lockstep_ns_per_trial_step"]
        )
        row["prange_speedup_over_scalar"] = (
            row["scalar_ns_per_step"] / row["prange_ns_per_trial_step"]
        )
        rows.append(row)
        if not args.json:
            print(
                f"B={B:>5d}  scalar {row['scalar_ns_per_step']:6.1f} ns/step  "
                f"lockstep {row['lockstep_ns_per_trial_step']:6.1f} ns/trial-step "
                f"({row['lockstep_speedup_over_scalar']:4.1f}x)  "
                f"prange {row['prange_ns_per_trial_step']:6.1f} "
                f"({row['prange_speedup_over_scalar']:4.1f}x)",
                flush=True,
            )
    if args.json:
        print(json.dumps({"duration": args.duration, "n_steps": n, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
