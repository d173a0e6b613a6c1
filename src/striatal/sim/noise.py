"""Standard normals for trials, drawn compiled, and for batches of trials, on several threads.

A chapter trial needs 6000 standard normals (eq 5), a batch of B trials B x 6000.
NumPy's ``Generator.standard_normal`` draws them at about 10 ns each on one core: as
long as the SIMD kernel takes to run the trials on two. :func:`standard_normals` draws
the same numbers (NumPy's ziggurat on the generator's own bits, as Numba compiles
it for a ``Generator``: the same numbers and the same state after) in about half the
time, with the GIL released. Parts drawn from
different generators can be filled by threads at once, each part the same numbers
as drawn alone. That pays only while Numba's own threads sleep between kernel calls:
under libgomp's default wait policy they spin after each parallel region and take
the cores back (``striatal`` sets OMP_WAIT_POLICY=PASSIVE unless it is set).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

__all__ = ["idle_kernel_threads", "row_parts", "run_parts", "standard_normals"]

_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


@numba.njit(nogil=True, cache=True)
def _fill_standard_normals(rng: np.random.Generator, out: np.ndarray) -> None:
    for i in range(out.shape[0]):
        out[i] = rng.standard_normal()


def standard_normals(rng: np.random.Generator, out: np.ndarray) -> None:
    """Fill ``out`` (C-contiguous, any shape) with standard normals from ``rng`` in its
    flat order: the numbers, and the generator's state after, of
    ``rng.standard_normal(out=out)`` (tests/test_noise.py), about twice as fast. Like
    NumPy's methods it releases the GIL; unlike them it does not take the generator's
    lock, so no other thread may draw from ``rng`` meanwhile (a run's generator is
    used by one thread at a time)."""
    _fill_standard_normals(rng, out.reshape(-1))


def idle_kernel_threads() -> bool:
    """Whether Numba's threads sleep between kernel calls, so other threads can use the
    cores: not under libgomp's default wait policy, whose threads spin after each
    parallel region."""
    if os.environ.get("OMP_WAIT_POLICY", "").upper() == "PASSIVE":
        return True
    try:
        return numba.threading_layer() != "omp"
    except ValueError:  # no parallel region has run yet: the layer is not chosen
        return False


def row_parts(rows: int, threads: int | None = None) -> list[range]:
    """``range(rows)`` cut into one contiguous part per thread (fewer if rows are few);
    ``threads`` default: Numba's thread count."""
    threads = numba.get_num_threads() if threads is None else threads
    step = max(1, -(-rows // max(1, min(threads, rows))))
    return [range(lo, min(lo + step, rows)) for lo in range(0, rows, step)]


def _pool() -> ThreadPoolExecutor:
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(numba.get_num_threads(), thread_name_prefix="normals")
        return _POOL


def run_parts(parts: Sequence[Callable[[], None]], threads: int | None = None) -> None:
    """Call every part, on a shared pool of Numba's thread count when
    :func:`idle_kernel_threads`, else one after another; the first exception is raised.
    ``threads``: Numba's thread count when the caller has it (each asking releases the GIL).

    Parts must not share a generator or an output row: each is then the same whatever
    runs beside it.
    """
    if len(parts) < 2:
        for part in parts:
            part()
        return
    threads = numba.get_num_threads() if threads is None else threads
    if threads < 2 or not idle_kernel_threads():
        for part in parts:
            part()
        return
    for future in [_pool().submit(part) for part in parts]:
        future.result()
