"""How far a sweep on the SIMD kernel is from the exact one, row by row (docs/performance.md).

    python benchmarks/sweep_trial_kernel.py RUNS_CSV -- SWEEP OPTIONS

Runs the sweep that ``striatal sweep SWEEP OPTIONS --engine simd`` runs (every trial on
:func:`striatal.sim.kernel.run_trials_lockstep`:
``lockstep_sweep.execute_batch(..., engine="simd")``), prints its wall time
and, against RUNS_CSV (the runs.csv of the same sweep from an exact engine, processes
or batch), how many rows differ and each arm's successes.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from striatal.cli import build_parser
from striatal.cli.sweep import prepare
from striatal.experiments import runs_csv
from striatal.experiments.lockstep_sweep import execute_batch


def main(argv: list[str]) -> int:
    ref_path, rest = Path(argv[0]), argv[argv.index("--") + 1 :]
    specs, _, _ = prepare(build_parser().parse_args(["sweep", *rest]))
    t0 = time.perf_counter()
    rows = runs_csv.sort_rows(execute_batch(specs, engine="simd"))
    wall = time.perf_counter() - t0
    ref = runs_csv.sort_rows(runs_csv.read_runs(ref_path)[0])
    cols = [c for c in runs_csv.RUN_COLUMNS if c != "wall_seconds"]

    def same(a: object, b: object) -> bool:
        return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))  # type: ignore[arg-type]

    differ = sum(any(not same(a[c], b[c]) for c in cols) for a, b in zip(ref, rows, strict=True))
    print(
        f"lockstep trial kernel: wall {wall:.1f} s, {len(rows)} rows, "
        f"{differ} differ from {ref_path}"
    )
    for c in ("success", "trials", "simulations"):
        n = sum(a[c] != b[c] for a, b in zip(ref, rows, strict=True))
        print(f"  {c} differs in {n} rows")
    for arm in sorted({r["arm"] for r in rows}):
        s_ref = sum(r["success"] for r in ref if r["arm"] == arm)
        s_new = sum(r["success"] for r in rows if r["arm"] == arm)
        n = sum(r["arm"] == arm for r in rows)
        print(f"  {arm}: successes {s_ref}/{n} (reference) and {s_new}/{n} (lockstep kernel)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
