"""README's sweep on each engine in turn: wall times, ratios to the process engine, rows.

    python benchmarks/sweep_engines.py [--repeats 2] [--seeds 100] [--out DIR]

Runs ``striatal sweep --seeds S --init chapter --max-trials 1000 --no-progress`` with
``--engine processes --workers 2``, ``--engine batch`` and ``--engine simd``, one after
another, ``--repeats`` times, each as its own command (compile and start-up included,
as a user sees them), timed with ``time.perf_counter``. Prints each wall time, its
ratio to the processes run of the same repeat, its CPU time (user + system, of the
command and its worker processes), the machine's load average before and after, and
whether the batch rows equal the processes rows (every column but ``wall_seconds``).
Ratios, taken within one repeat, are the figures to read on a shared machine; there the
process engine, whose two workers each need a core, loses most to the other load.
"""

from __future__ import annotations

import argparse
import csv
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

ENGINES = {
    "processes": ["--engine", "processes", "--workers", "2"],
    "batch": ["--engine", "batch"],
    "simd": ["--engine", "simd"],
}


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        found = [{k: v for k, v in r.items() if k != "wall_seconds"} for r in csv.DictReader(f)]
    return sorted(found, key=lambda r: (r["arm"], r["init"], r["seed"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--out", type=Path, default=Path("sweep-engines"))
    args = parser.parse_args()
    striatal = [sys.executable, "-m", "striatal"]
    base = ["sweep", "--seeds", str(args.seeds), "--init", "chapter", "--max-trials", "1000"]
    base.append("--no-progress")
    for repeat in range(1, args.repeats + 1):
        times: dict[str, float] = {}
        for name, flags in ENGINES.items():
            out = args.out / f"{name}{repeat}"
            shutil.rmtree(out, ignore_errors=True)
            load = os.getloadavg()[0]
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run([*striatal, *base, *flags, "--out", str(out)], check=True)
            times[name] = time.perf_counter() - t0
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
            ratio = times[name] / times["processes"]
            print(
                f"repeat {repeat} {name:9s} {times[name]:7.1f} s  / processes {ratio:5.2f}  "
                f"cpu {cpu:6.1f} s  "
                f"(load {load:.1f} -> {os.getloadavg()[0]:.1f})",
                flush=True,
            )
        same = rows(args.out / f"batch{repeat}" / "runs.csv") == rows(
            args.out / f"processes{repeat}" / "runs.csv"
        )
        print(f"repeat {repeat}: batch rows equal processes rows: {same}", flush=True)


if __name__ == "__main__":
    main()
