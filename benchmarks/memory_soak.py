"""Memory over a long training run: resident set size every tenth of the trials.

    PYTHONPATH=src python benchmarks/memory_soak.py --trials 1000000 --out /tmp/soak-run

Runs ``striatal.train`` (the chapter's learner) for ``--trials`` short trials (0.5 s at
dt = 0.1, so the loop and its files, not the physics, dominate) with ``out=``, and
prints VmRSS (/proc/self/status, Linux) at every tenth of them. With ``out`` the
history rows live in history.csv only, so the figure stays flat.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import striatal
from striatal.params import Simulation


def rss_mb() -> int:
    with open("/proc/self/status", encoding="ascii") as f:
        return int(next(line for line in f if line.startswith("VmRSS")).split()[1]) // 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=1_000_000)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    marks: list[tuple[int, int]] = []
    step = max(1, args.trials // 10)

    def on(state: striatal.learners.LearnerState, _record: object) -> None:
        if state.trials_done % step == 0:
            marks.append((state.trials_done, rss_mb()))

    t0 = time.perf_counter()
    run = striatal.train(
        max_trials=args.trials,
        sim=Simulation(duration=0.5, dt=0.1),
        out=args.out,
        on_trial=on,
        checkpoint_every=step,
    )
    print(
        json.dumps(
            {
                "trials": run.trials,
                "wall_seconds": round(time.perf_counter() - t0, 1),
                "rss_mb_at_trial": marks,
            }
        )
    )


if __name__ == "__main__":
    main()
