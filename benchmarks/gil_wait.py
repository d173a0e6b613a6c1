"""How long a lockstep lane's GIL-releasing calls take while another thread runs Python,
at Python's default switch interval and at ``sim.batch.SWITCH_INTERVAL``.

    python benchmarks/gil_wait.py [--calls 300]

A lane's worker (:class:`striatal.sim.batch.Lockstep`) makes calls that release the GIL
(each request's draw of 6 000 normals, Numba's thread settings, the kernel) and must
take it back after each; meanwhile the other lane runs its runs' Python. This times
such calls on one thread while another runs a pure-Python loop (the other lane's
stand-in) and, as the reference in the same run, while nothing else runs. Prints the
median and mean wall time of each call [us], per switch interval, the intervals
alternated ``--repeats`` times. A mean far above the median is the wait for the GIL.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections.abc import Callable

import numba
import numpy as np

from striatal.sim.batch import SWITCH_INTERVAL


def python(stop: threading.Event) -> None:
    """Pure Python until ``stop`` is set: the main thread's stand-in."""
    x = 0
    while not stop.is_set():
        for i in range(1000):
            x += i


def timed(call: Callable[[], object], n: int) -> tuple[float, float]:
    """(median, mean) wall time of ``call`` [us], ``n`` calls 1 ms apart."""
    seconds = []
    for _ in range(n):
        t0 = time.perf_counter()
        call()
        seconds.append(time.perf_counter() - t0)
        time.sleep(0.001)
    return float(np.median(seconds)) * 1e6, float(np.mean(seconds)) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    rng = np.random.Generator(np.random.PCG64(0))
    row = np.empty(6000)
    calls: dict[str, Callable[[], object]] = {
        "draw of 6 000 normals": lambda: rng.standard_normal(out=row),
        "numba.get_num_threads": numba.get_num_threads,
        "numba.set_num_threads(1)": lambda: numba.set_num_threads(1),
    }
    for call in calls.values():
        call()
    default = sys.getswitchinterval()
    for repeat in range(1, args.repeats + 1):
        for interval in (default, SWITCH_INTERVAL):
            sys.setswitchinterval(interval)
            for busy in (False, True):
                stop = threading.Event()
                thread = threading.Thread(target=python, args=(stop,))
                if busy:
                    thread.start()
                try:
                    for name, call in calls.items():
                        median, mean = timed(call, args.calls)
                        print(
                            f"repeat {repeat} interval {interval * 1e3:5.2f} ms  "
                            f"{'Python beside' if busy else 'alone        '}  {name:26s} "
                            f"median {median:7.1f} us  mean {mean:7.1f} us",
                            flush=True,
                        )
                finally:
                    stop.set()
                    if busy:
                        thread.join()
    sys.setswitchinterval(default)


if __name__ == "__main__":
    main()
