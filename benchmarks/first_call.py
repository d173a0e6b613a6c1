"""Run by the harness in a fresh interpreter: import time and first kernel calls, as JSON.

    python benchmarks/first_call.py

With an empty NUMBA_CACHE_DIR the first calls include compilation (cold start).
"""

from __future__ import annotations

import json
import time

t0 = time.perf_counter()
import numpy as np  # noqa: E402  (the import is what is timed)

from striatal.sim import bench, kernel  # noqa: E402

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
