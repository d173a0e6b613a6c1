"""Where a batch sweep's wall time goes, in process: the worker thread's kernel calls and
noise, the main thread's Python, each timed by wrapping the function with perf_counter.

    python benchmarks/sweep_timeline.py [--seeds 30] [--engine batch] [--out DIR]

Runs ``striatal sweep --seeds S --init chapter --max-trials 1000 --no-progress --engine E``
in this process and prints, for each wrapped function, its total wall time, its
fraction of the sweep's, and the CPU time of the thread that called it (the kernel's
other threads and the noise's pool not counted). The worker thread runs the kernel
calls (``kernel``: ``run_trials_batch``; ``kernel calls``: all of a lane's calls, with
their noise since it moved there); what the main thread does meanwhile (``advance``:
the runs' generators; ``prepare``: grouping and arguments of a lane's calls, with the
noise before; ``outcomes``) overlaps them. Also runs on a tree without
``prepare`` (the functions it lacks are left out), so two trees can be compared with
``PYTHONPATH=OLD/src``.
"""

from __future__ import annotations

import argparse
import collections
import functools
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

TOTAL: dict[str, float] = collections.defaultdict(float)
#: The CPU time of the calling thread in each wrapped function (``time.thread_time``:
#: steadier than wall time on a shared machine; a kernel's other threads not counted).
CPU: dict[str, float] = collections.defaultdict(float)


def timed(owner: Any, name: str, label: str) -> None:
    """Replace ``owner.name`` by a wrapper that adds its wall time to ``TOTAL[label]``."""
    if not hasattr(owner, name):
        return
    f: Callable[..., Any] = getattr(owner, name)

    @functools.wraps(f)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            return f(*args, **kwargs)
        finally:
            TOTAL[label] += time.perf_counter() - t0
            CPU[label] += time.thread_time() - c0

    setattr(owner, name, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--engine", choices=("batch", "simd"), default="batch")
    parser.add_argument("--out", type=Path, default=Path("sweep-timeline"))
    args = parser.parse_args()
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as the CLI sets it
    from striatal.cli import main as striatal
    from striatal.sim import batch

    timed(batch.kernel, "run_trials_batch", "kernel (worker)")
    timed(batch.kernel, "run_trials_lockstep", "kernel (worker)")
    timed(batch, "_draw_noise", "noise (prepare, or worker after)")
    timed(batch, "run_requests", "run_requests (worker, before)")
    timed(batch, "_timed", "kernel calls (worker)")
    timed(batch, "prepare", "prepare (main)")
    timed(batch.Lockstep, "_advance", "advance (main)")
    if hasattr(batch, "Calls"):
        timed(batch.Calls, "outcomes", "outcomes (main)")
    shutil.rmtree(args.out, ignore_errors=True)
    command = ["sweep", "--seeds", str(args.seeds), "--init", "chapter", "--max-trials", "1000"]
    command += ["--no-progress", "--engine", args.engine, "--out", str(args.out)]
    load = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    striatal(command)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    print(f"wall {wall:.1f} s, cpu {cpu:.1f} s, load {load:.1f} -> {os.getloadavg()[0]:.1f}")
    for label, seconds in sorted(TOTAL.items()):
        print(f"  {label:32s} {seconds:7.1f} s  {seconds / wall:5.2f}  cpu {CPU[label]:6.2f} s")


if __name__ == "__main__":
    main()
