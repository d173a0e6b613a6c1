"""First-call cost of the trial kernels in a fresh process: from the cache, and cold.

    python benchmarks/bench_compile.py

Warm: a fresh interpreter whose kernels load from the on-disk Numba cache (written
by any earlier run). Cold: the same with NUMBA_CACHE_DIR pointing at an empty folder,
so both kernels compile.
"""

from __future__ import annotations

import json
import tempfile

from striatal.bench import measure


def main() -> None:
    warm = measure.second_process()
    with tempfile.TemporaryDirectory(prefix="striatal-numba-") as empty:
        cold = measure.second_process(cache_dir=empty)
    print(json.dumps({"cached": warm, "cold": cold}, indent=2))


if __name__ == "__main__":
    main()
