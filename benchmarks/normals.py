"""A trial's action normals: NumPy's ``Generator.standard_normal`` against
``striatal.sim.noise.standard_normals`` (Numba's compiled ziggurat on the generator's own
C functions), the same numbers.

    python benchmarks/normals.py [--draws 6000] [--calls 3000] [--repeats 3]

Times, with ``time.thread_time`` (this thread's CPU), ``--calls`` fills of a row of
``--draws`` normals (a 60-s chapter trial draws 6 000), each way in turn, ``--repeats``
times; prints the CPU per call [us] and per normal [ns] of each, and checks that both
drew the same numbers.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from striatal.sim.noise import standard_normals


def per_call(fill: Callable[[], None], calls: int) -> float:
    """CPU seconds of this thread per call of ``fill``."""
    t0 = time.thread_time()
    for _ in range(calls):
        fill()
    return (time.thread_time() - t0) / calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=6000)
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    row = np.empty(args.draws)
    numpy_rng, compiled_rng = np.random.default_rng(0), np.random.default_rng(0)
    ways: dict[str, Callable[[], None]] = {
        "numpy standard_normal(out=)": lambda: numpy_rng.standard_normal(out=row),
        "sim.noise.standard_normals": lambda: standard_normals(compiled_rng, row),
    }
    for fill in ways.values():  # compile or load, and warm up
        fill()
    for repeat in range(1, args.repeats + 1):
        for name, fill in ways.items():
            seconds = per_call(fill, args.calls)
            print(
                f"repeat {repeat}  {name:28s} {seconds * 1e6:7.1f} us a call  "
                f"{seconds / args.draws * 1e9:5.2f} ns a normal",
                flush=True,
            )
    same = numpy_rng.standard_normal(args.draws)
    standard_normals(compiled_rng, row)
    calls = args.repeats * args.calls + 1
    print(f"same numbers after {calls} calls each: {np.array_equal(same, row)}")


if __name__ == "__main__":
    main()
