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
``PYTHONPATH=OLD/src``. Since round 9 each lane's thread does all of this itself
(``advance``, ``prepare`` and ``outcomes`` labelled "lane", and counted among its spans
below); on an older tree the main thread did them.

``--every SECONDS`` (Linux) also prints a utilisation timeline: every SECONDS of wall
time, the cores' worth of CPU the process used, by thread (``main``, the lanes'
``lockstep`` workers, the ``normals`` pool, and ``other``: Numba's own threads), read
from ``/proc/self/task``; the mean number of them ready to run (running or waiting for
a core, sampled every 2 ms; ``ready``: at most the cores counted), which on a shared
machine says what a quiet one would keep busy; and the rows written so far, so that
start-up, the first rounds and the tail when few runs are left can be told apart.

Then where the two cores could idle: each worker thread's calls, their busy time and
the time it waited between them (for the main thread to read its lane's outcomes,
advance its runs and prepare the next calls, or for another lane's call), and the
**lost core-seconds**: the time during the lockstep rounds with fewer than two
threads' worth of work under way (a worker's call counts its Numba threads, at most
its trials; the main thread's ``advance``, ``prepare`` and ``outcomes`` count one), as
core-seconds and as a fraction of two cores. On a loaded machine a thread that waits
for a core counts as under way, so the loss is then a lower bound.
"""

from __future__ import annotations

import argparse
import collections
import functools
import itertools
import os
import shutil
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

TOTAL: dict[str, float] = collections.defaultdict(float)
#: The CPU time of the calling thread in each wrapped function (``time.thread_time``:
#: steadier than wall time on a shared machine; a kernel's other threads not counted).
CPU: dict[str, float] = collections.defaultdict(float)
#: (start, end, threads' worth of work, thread) of each worker call and main-thread span.
SPANS: list[tuple[float, float, int, str]] = []


def timed(owner: Any, name: str, label: str, span: Callable[..., int] | None = None) -> None:
    """Replace ``owner.name`` by a wrapper that adds its wall time to ``TOTAL[label]``;
    with ``span``, each call is also a span in :data:`SPANS`, worth ``span(*args)``
    threads."""
    if not hasattr(owner, name):
        return
    f: Callable[..., Any] = getattr(owner, name)

    @functools.wraps(f)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            return f(*args, **kwargs)
        finally:
            t1 = time.perf_counter()
            TOTAL[label] += t1 - t0
            CPU[label] += time.thread_time() - c0
            if span is not None:
                me = threading.current_thread()
                who = "main" if me is threading.main_thread() else me.name
                SPANS.append((t0, t1, span(*args), who))

    setattr(owner, name, wrapper)


KINDS = ("main", "lockstep", "normals", "other")


def _threads() -> dict[str, tuple[float, int]]:
    """Of this process's threads (Linux; the sampler left out), by kind: their CPU
    seconds so far, and how many are running or waiting for a core (state R)."""
    names = {t.native_id: t.name for t in threading.enumerate()}
    tick = os.sysconf("SC_CLK_TCK")
    cpu: dict[str, float] = collections.defaultdict(float)
    runnable: dict[str, int] = collections.defaultdict(int)
    for task in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{task}/stat", encoding="ascii") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:  # the thread ended
            continue
        name = names.get(int(task), "")
        if name == "sampler":
            continue
        kind = "main" if name == "MainThread" else name.split("_")[0]
        kind = kind if kind in KINDS else "other"
        cpu[kind] += (int(fields[11]) + int(fields[12])) / tick
        runnable[kind] += fields[0] == "R"
    return {k: (cpu[k], runnable[k]) for k in KINDS}


def sample(every: float, stop: threading.Event, rows: Path) -> list[str]:
    """Lines of the utilisation timeline, one per ``every`` seconds until ``stop``: the
    cores' worth of CPU each kind of thread used, and the mean number of threads that
    were running or waiting for a core (read every 2 ms; at most the machine's cores
    counted: what a quiet machine would keep busy, the threads' waits for each other
    as they were here)."""
    cores = os.cpu_count() or 1
    lines = []
    header = " ".join(f"{k:>8s}" for k in KINDS)
    lines.append(f"{'t [s]':>6s} {'cpu':>5s} {header} | {'ready':>5s} {header}  rows")
    t_last, last = time.perf_counter(), _threads()
    ready: dict[str, float] = collections.defaultdict(float)
    busy, n = 0.0, 0
    t_next = t_last + every
    while not stop.wait(0.002):
        now = _threads()
        ready_now = {k: now[k][1] for k in KINDS}
        for k in KINDS:
            ready[k] += ready_now[k]
        busy += min(cores, sum(ready_now.values()))
        n += 1
        t = time.perf_counter()
        if t < t_next:
            continue
        dt = t - t_last
        used = {k: max(0.0, now[k][0] - last[k][0]) / dt for k in KINDS}
        try:
            with open(rows / "runs.csv", encoding="utf-8") as f:
                written = sum(1 for _ in f) - 1
        except OSError:
            written = 0
        lines.append(
            f"{t - START:6.1f} {sum(used.values()):5.2f} "
            + " ".join(f"{used[k]:8.2f}" for k in KINDS)
            + f" | {busy / n:5.2f} "
            + " ".join(f"{ready[k] / n:8.2f}" for k in KINDS)
            + f"  {written}"
        )
        t_last, last, t_next = t, now, t + every
        ready.clear()
        busy, n = 0.0, 0
    return lines


START = time.perf_counter()


def worker_threads(calls: Any, threads: int) -> int:
    """The threads' worth of work of a worker's call: its Numba threads, at most its trials."""
    return min(threads, len(calls.requests))


def one(*_: Any) -> int:
    return 1


def idle() -> None:
    """Print each worker thread's busy and waiting time and the lost core-seconds."""
    workers = sorted({who for *_, who in SPANS if who != "main"})
    for who in workers:
        mine = sorted((a, b) for a, b, _, w in SPANS if w == who)
        busy = sum(b - a for a, b in mine)
        waits = sum(c - b for (_, b), (c, _) in itertools.pairwise(mine))
        print(f"  worker {who}: {len(mine)} calls, busy {busy:.1f} s, waiting {waits:.1f} s")
    edges = [(a, w, who == "main") for a, _, w, who in SPANS]
    edges += [(b, -w, who == "main") for _, b, w, who in SPANS]
    edges.sort(key=lambda e: e[0])
    work, main_busy, last = 0, 0, None
    lost = span = 0.0
    for t, d, on_main in edges:
        if last is not None:
            under_way = min(work + (1 if main_busy else 0), 2)
            lost += (2 - under_way) * (t - last)
            span += t - last
        if on_main:
            main_busy += 1 if d > 0 else -1
        else:
            work += d
        last = t
    print(f"  lockstep rounds {span:.1f} s, lost core-seconds {lost:.1f} ({lost / (2 * span):.1%})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--engine", choices=("batch", "simd"), default="batch")
    parser.add_argument("--out", type=Path, default=Path("sweep-timeline"))
    parser.add_argument("--every", type=float, default=0.0, help="timeline step [s]; 0: none")
    args = parser.parse_args()
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as the CLI sets it
    from striatal.cli import main as striatal
    from striatal.sim import batch

    timed(batch.kernel, "run_trials_batch", "kernel (worker)")
    timed(batch.kernel, "run_trials_lockstep", "kernel (worker)")
    timed(batch, "_draw_noise", "noise (prepare, or worker after)")
    timed(batch, "run_requests", "run_requests (worker, before)")
    timed(batch, "_timed", "kernel calls (worker)", worker_threads)
    timed(batch, "prepare", "prepare (lane)", one)
    timed(batch.Lockstep, "_advance", "advance (lane)", one)
    if hasattr(batch, "Calls"):
        timed(batch.Calls, "outcomes", "outcomes (lane)", one)
    shutil.rmtree(args.out, ignore_errors=True)
    command = ["sweep", "--seeds", str(args.seeds), "--init", "chapter", "--max-trials", "1000"]
    command += ["--no-progress", "--engine", args.engine, "--out", str(args.out)]
    load = os.getloadavg()[0]
    stop = threading.Event()
    timeline: list[str] = []
    sampler = threading.Thread(
        target=lambda: timeline.extend(sample(args.every, stop, args.out)), name="sampler"
    )
    if args.every > 0:
        sampler.start()
    t0, c0 = time.perf_counter(), time.process_time()
    striatal(command)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    stop.set()
    if args.every > 0:
        sampler.join()
    print(f"wall {wall:.1f} s, cpu {cpu:.1f} s, load {load:.1f} -> {os.getloadavg()[0]:.1f}")
    print(f"(the sweep started {t0 - START:.1f} s after this script's imports)")
    print("\n".join(timeline))
    for label, seconds in sorted(TOTAL.items()):
        print(f"  {label:32s} {seconds:7.1f} s  {seconds / wall:5.2f}  cpu {CPU[label]:6.2f} s")
    idle()


if __name__ == "__main__":
    main()
