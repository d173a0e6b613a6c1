"""The table of learners, their controls and baselines from sweeps' runs.csv files.

    python benchmarks/forward_eval_table.py [LABEL=]DIR [[LABEL=]DIR ...]

Each DIR is a sweep folder whose name ends in its root seed (``fgg30-r1``). A sweep's
``learner`` and ``control`` arms are named after ``LABEL`` (default "learner"), its
baselines keep their names (random, cmaes), so sweeps of different learners on the same
root and seeds pool into one table. Per arm, pooled over the roots, then per root:
Wilson intervals of the success rate, the percentile-bootstrap interval of the median
real simulated seconds of the solved runs (``experiments.stats.bootstrap_interval``,
``np.random.default_rng(0)``), real trials, imagined simulations and seconds (not
counted), wall seconds. Then every arm paired with random search on the seeds both ran
(Wilcoxon signed-rank on real simulated seconds, an unsolved seed at what it spent;
McNemar's exact test on success; the ratio of the solved medians).

    python benchmarks/forward_eval_table.py generic-gains=fgg30-r1 generic-gains=fgg30-r2 \
        structured=fs30-r1 structured=fs30-r2 pgpe-robust=fp30-r1 pgpe-robust=fp30-r2
"""

from __future__ import annotations

import csv
import sys

import numpy as np
from scipy.stats import wilcoxon

from striatal.experiments import stats

Runs = dict[tuple[str, str], dict[str, str]]


def read(args: list[str]) -> dict[str, Runs]:
    """Every arm's runs, keyed by (root, seed), in the order the arms are first met."""
    rows: dict[str, Runs] = {}
    for arg in args:
        label, _, folder = arg.rpartition("=")
        label = label or "learner"
        root = folder.rstrip("/")[-1]
        with open(f"{folder}/runs.csv", encoding="utf-8") as f:
            for r in csv.DictReader(f):
                arm = {"learner": label, "control": f"{label} control"}.get(r["arm"], r["arm"])
                rows.setdefault(arm, {})[(root, r["seed"])] = r
    return rows


def solved_seconds(runs: Runs) -> list[float]:
    return [float(r["simulated_seconds"]) for r in runs.values() if r["success"] == "1"]


def arm_line(arm: str, runs: Runs, rng: np.random.Generator) -> str:
    ok = [r for r in runs.values() if r["success"] == "1"]
    w = stats.wilson_interval(len(ok), len(runs))
    band = "-" if w.low is None or w.high is None else f"{100 * w.low:.0f} %, {100 * w.high:.0f} %"
    secs = solved_seconds(runs)
    iv = stats.bootstrap_interval(secs, stats.median, rng) if len(secs) > 1 else None
    ci = "-" if iv is None or iv.low is None else f"[{iv.low:,.0f}, {iv.high:,.0f}]"
    med = f"{np.median(secs):,.0f} {ci}" if secs else "-"
    trials = f"{np.median([int(r['trials']) for r in ok]):.0f}" if ok else "-"
    im = [int(r["imagined_simulations"]) for r in runs.values()]
    ims = [float(r["imagined_seconds"]) for r in runs.values()]
    wall = [float(r["wall_seconds"]) for r in runs.values()]
    return (
        f"| {arm} | {len(ok)}/{len(runs)} [{band}] "
        f"| {med} | {trials} | {np.median(im):,.0f} ({sum(im):,}) | {np.median(ims):,.0f} "
        f"| {np.median(wall):.1f} ({max(wall):.0f}) |"
    )


def root_text(runs: Runs, root: str) -> str:
    mine = {k: r for k, r in runs.items() if k[0] == root}
    secs = solved_seconds(mine)
    median = f"{np.median(secs):,.0f}" if secs else "-"
    return f"root {root} {len(secs)}/{len(mine)}, median {median}"


def paired_line(arm: str, runs: Runs, rand: Runs) -> str:
    keys = sorted(set(runs) & set(rand))
    a = [float(runs[k]["simulated_seconds"]) for k in keys]
    b = [float(rand[k]["simulated_seconds"]) for k in keys]
    mc = stats.mcnemar_test(
        {i: runs[k]["success"] == "1" for i, k in enumerate(keys)},
        {i: rand[k]["success"] == "1" for i, k in enumerate(keys)},
    )
    mine = solved_seconds({k: runs[k] for k in keys})
    theirs = solved_seconds({k: rand[k] for k in keys})
    ratio = np.median(mine) / np.median(theirs) if mine and theirs else float("nan")
    return (
        f"{arm} vs random search, {len(keys)} seeds: fewer real s on "
        f"{sum(x < y for x, y in zip(a, b, strict=True))} "
        f"(Wilcoxon p = {wilcoxon(a, b).pvalue:.2g}); "
        f"solved by it only {mc.only_a}, by random search only {mc.only_b} (McNemar p = "
        f"{mc.p_value:.2g}); ratio of the solved medians {ratio:.2f}; "
        f"solved within 900 s: {sum(v <= 900 for v in mine)} of {len(keys)}"
    )


def main(args: list[str]) -> None:
    rows = read(args)
    rng = np.random.default_rng(0)
    print(
        "| arm | robust within the real-trial budget [95% CI] | real simulated s to success, "
        "solved: median [95% CI] | real trials, solved: median | imagined simulations per "
        "run: median (total) | imagined simulated s per run: median | wall s per run: "
        "median (max) |"
    )
    print("|---|---|---|---|---|---|---|")
    for arm, runs in rows.items():
        print(arm_line(arm, runs, rng))
    for arm, runs in rows.items():
        roots = sorted({k[0] for k in runs})
        print(f"    {arm}: " + "; ".join(root_text(runs, root) for root in roots))
    rand = rows.get("random")
    if rand is None:
        return
    for arm, runs in rows.items():
        if arm != "random" and not arm.endswith(" control"):
            print(paired_line(arm, runs, rand))


if __name__ == "__main__":
    main(sys.argv[1:])
