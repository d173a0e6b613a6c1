"""Wall and CPU time of the generic forward learner, one run at a time, on the tuning root.

    python benchmarks/forward_generic_wall.py [--root 0] [--first 0] [--seeds 8]
        [--imagine-trials 2000] [--forward-model generic]

Runs ``striatal.train("forward", forward_model=..., robust=True, init="random",
max_trials=300)`` on the run seeds ``spawn_seeds(root, first + seeds)[first:]`` (root 0
is the tuning root), one after the other in this process, and prints per run its
real trials, real simulated seconds, imagined simulations, wall seconds and CPU
seconds of this process (``time.process_time``), then their medians and the load
average before and after. The CPU seconds hold up on a shared machine, the wall
seconds do not. The same script runs on an older checkout (it uses only
``striatal.train`` and ``spawn_seeds``, through ``forward_runs`` beside it, and the
forward rule's ``imagined``), so the two can be compared in one session, side by side.
The first run includes the compilation cache's loading and scikit-learn's import.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from forward_runs import (  # beside this script (benchmarks/ is its sys.path[0])
    add_run_options,
    run_seeds,
    train_forward,
)

from striatal.learners.forward.rule import FORWARD


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_options(parser, seeds=8, forward_model="generic")
    parser.add_argument("--imagine-trials", type=int, default=2000)
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    seeds = run_seeds(args)
    rows = []
    for i, seed in enumerate(seeds, start=args.first):
        wall, cpu = time.perf_counter(), time.process_time()
        run = train_forward(seed, args.forward_model, imagine_trials=args.imagine_trials)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        imagined = FORWARD.imagined(run.state)[0]
        rows.append((run.success, run.trials, run.state.simulated_seconds, imagined, wall, cpu))
        print(
            f"seed #{i}: robust {run.success}, {run.trials} real trials, "
            f"{run.state.simulated_seconds:.0f} real s, {imagined} imagined, "
            f"wall {wall:.1f} s, CPU {cpu:.1f} s",
            flush=True,
        )
    robust = sum(r[0] for r in rows)
    med = [statistics.median(r[k] for r in rows) for k in (2, 3, 4, 5)]
    per_imagined = 1e3 * sum(r[5] for r in rows) / max(sum(r[3] for r in rows), 1)
    print(
        f"robust {robust}/{len(rows)}; medians: {med[0]:.0f} real s, {med[1]:.0f} imagined, "
        f"wall {med[2]:.1f} s, CPU {med[3]:.1f} s; "
        f"CPU per imagined simulation {per_imagined:.2f} ms"
    )
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
