"""Run by ``striatal bench`` in a fresh interpreter: import time and first kernel calls, as JSON.

    python -P path/to/striatal/bench/first_call.py

Prints one JSON line: ``import_seconds`` (NumPy and :mod:`striatal.sim.bench`, which
loads the kernel), ``first_run_trial_seconds``, ``first_run_trials_batch_seconds`` and
the Numba ``cache_misses``. With an empty NUMBA_CACHE_DIR the first calls include
compilation (cold start). Run as a file, not with ``-m``, so that nothing of striatal
is imported before the timed import.
"""

from __future__ import annotations

import json
import time


def main() -> None:
    t0 = time.perf_counter()
    import numpy as np  # the imports are what is timed

    from striatal.sim import bench, kernel

    t_import = time.perf_counter() - t0
    rng = np.random.default_rng(0)
    setup = bench.TrialSetup.chapter(1.0, 0.01)
    t0 = time.perf_counter()
    bench.run_scalar_trial(setup, rng, np.empty(kernel.N_OUT))
    t_scalar = time.perf_counter() - t0
    t0 = time.perf_counter()
    bench.run_batch_trials(setup, 2, rng, np.empty((2, kernel.N_OUT)))
    t_batch = time.perf_counter() - t0
    print(
        json.dumps(
            {
                "import_seconds": t_import,
                "first_run_trial_seconds": t_scalar,
                "first_run_trials_batch_seconds": t_batch,
                "cache_misses": bench.cache_misses(),
            }
        )
    )


if __name__ == "__main__":
    main()
