"""The table of a learner, its control and random search from sweeps' runs.csv files.

Pooled over the sweep folders given, then per root: Wilson intervals of the success
rate, the percentile-bootstrap interval of the median real simulated seconds of the
solved runs (``experiments.stats.bootstrap_interval``, ``np.random.default_rng(0)``),
real trials, imagined simulations and seconds (not counted), wall seconds; then the
learner paired with random search on every seed (Wilcoxon signed-rank on real
simulated seconds, an unsolved seed at what it spent; McNemar's exact test).

    python benchmarks/forward_eval_table.py fgg30-r1 fgg30-r2
"""

from __future__ import annotations

import csv
import sys

import numpy as np
from scipy.stats import wilcoxon

from striatal.experiments import stats


def main(dirs: list[str]) -> None:
    rows: dict[str, dict[tuple[str, str], dict[str, str]]] = {}
    for d in dirs:
        root = d.rstrip("/")[-1]
        with open(f"{d}/runs.csv", encoding="utf-8") as f:
            for r in csv.DictReader(f):
                rows.setdefault(r["arm"], {})[(root, r["seed"])] = r
    rng = np.random.default_rng(0)
    for arm, runs in rows.items():
        ok = [r for r in runs.values() if r["success"] == "1"]
        w = stats.wilson_interval(len(ok), len(runs))
        secs = [float(r["simulated_seconds"]) for r in ok]
        iv = stats.bootstrap_interval(secs, stats.median, rng) if len(secs) > 1 else None
        ci = "-" if iv is None or iv.low is None else f"[{iv.low:,.0f}, {iv.high:,.0f}]"
        med = f"{np.median(secs):,.0f} {ci}" if secs else "-"
        trials = f"{np.median([int(r['trials']) for r in ok]):.0f}" if ok else "-"
        im = [int(r["imagined_simulations"]) for r in runs.values()]
        ims = [float(r["imagined_seconds"]) for r in runs.values()]
        wall = [float(r["wall_seconds"]) for r in runs.values()]
        print(
            f"| {arm} | {len(ok)}/{len(runs)} [{100 * w.low:.0f} %, {100 * w.high:.0f} %] "
            f"| {med} | {trials} | {np.median(im):,.0f} ({sum(im):,}) | {np.median(ims):,.0f} "
            f"| {np.median(wall):.1f} ({max(wall):.0f}) |"
        )
        for root in sorted({k[0] for k in runs}):
            sub = [
                float(r["simulated_seconds"])
                for k, r in runs.items()
                if k[0] == root and r["success"] == "1"
            ]
            n = sum(1 for k in runs if k[0] == root)
            print(
                f"    root {root}: {len(sub)}/{n}, "
                f"median {np.median(sub) if sub else float('nan'):,.0f}"
            )
    learner, rand = rows["learner"], rows["random"]
    keys = sorted(learner)
    a = [float(learner[k]["simulated_seconds"]) for k in keys]
    b = [float(rand[k]["simulated_seconds"]) for k in keys]
    print(
        f"paired real s: learner below random on {sum(x < y for x, y in zip(a, b, strict=True))}"
        f" of {len(keys)}, Wilcoxon p = {wilcoxon(a, b).pvalue:.2g}"
    )
    print(
        "McNemar:",
        stats.mcnemar_test(
            {i: learner[k]["success"] == "1" for i, k in enumerate(keys)},
            {i: rand[k]["success"] == "1" for i, k in enumerate(keys)},
        ),
    )
    solved_a = [
        float(learner[k]["simulated_seconds"]) for k in keys if learner[k]["success"] == "1"
    ]
    solved_b = [float(rand[k]["simulated_seconds"]) for k in keys if rand[k]["success"] == "1"]
    print(
        f"ratio of the solved medians {np.median(solved_a) / np.median(solved_b):.2f}; "
        f"learner within 900 s: {sum(v <= 900 for v in solved_a)} of {len(keys)}"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
