"""An anytime-margin sweep (``--stop-margin M --margin-after-success``) beside the same
sweep without the option, from their runs.csv.

Arguments: PLAIN ANYTIME [PLAIN ANYTIME ...], sweep folders on the same seeds (one pair
per root, pooled). For the learner arms: robust within the budget (McNemar's exact test
between them), on how many seeds the anytime run's first success is the plain run's
(trials, simulations, simulated seconds; its controller when the margin was not reached),
how many runs reached the margin (and at the first robust trial itself), the real
seconds after success, and the mean counted real seconds per seed (every seed at all it
spent) beside random search's in the anytime sweeps, with Wilcoxon's signed-rank test.

    python benchmarks/anytime_margin.py pr-r0 pa-m10-r0
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import wilcoxon

from striatal.experiments.runs_csv import read_runs
from striatal.experiments.stats import mcnemar_test

GAINS = (*(f"W{i}" for i in range(1, 7)), "theta_c")
Rows = dict[tuple[int, int], dict[str, Any]]


def arm(folders: list[str], name: str) -> Rows:
    return {
        (k, int(r["seed"])): r
        for k, folder in enumerate(folders)
        for r in read_runs(Path(folder) / "runs.csv")[0]
        if r["arm"] == name
    }


def same_first(p: dict[str, Any], a: dict[str, Any]) -> bool:
    """Whether anytime row ``a`` succeeded first where plain row ``p`` stopped."""
    if p["success"] != a["success"]:
        return False
    if not p["success"]:
        return True
    counts = (a["first_success_trials"], a["first_success_simulations"]) == (
        p["trials"],
        p["simulations"],
    )
    seconds = math.isclose(a["first_success_seconds"], p["simulated_seconds"], abs_tol=1e-6)
    kept = a["margin_reached"] == 1.0 or all(a[g] == p[g] for g in GAINS)
    return counts and seconds and kept


def main(args: list[str]) -> None:
    if len(args) < 2 or len(args) % 2:
        sys.exit("usage: anytime_margin.py PLAIN ANYTIME [PLAIN ANYTIME ...]")
    plain, anytime = arm(args[0::2], "learner"), arm(args[1::2], "learner")
    random = arm(args[1::2], "random")
    seeds = sorted(plain)
    if sorted(anytime) != seeds or sorted(random) != seeds:
        sys.exit("the sweeps do not hold the same seeds")
    test = mcnemar_test(
        {s: anytime[s]["success"] for s in seeds}, {s: plain[s]["success"] for s in seeds}
    )
    print(
        f"seeds {len(seeds)}; robust within the budget: plain "
        f"{sum(plain[s]['success'] for s in seeds)}, anytime "
        f"{sum(anytime[s]['success'] for s in seeds)} (only anytime / only plain "
        f"{test.only_a} / {test.only_b}, McNemar p = {test.p_value:.2g}); first success = "
        f"plain's on {sum(same_first(plain[s], anytime[s]) for s in seeds)} seeds"
    )
    solved = [s for s in seeds if anytime[s]["success"]]
    reached = [s for s in solved if anytime[s]["margin_reached"] == 1.0]
    at_once = sum(anytime[s]["trials"] == anytime[s]["first_success_trials"] for s in reached)
    print(f"margin reached on {len(reached)} of {len(solved)} robust runs ({at_once} at once)")
    after = np.array(
        [anytime[s]["simulated_seconds"] - anytime[s]["first_success_seconds"] for s in solved]
    )
    print(
        f"real s after success, robust runs: median {np.median(after):,.0f}, "
        f"mean {after.mean():,.0f}"
    )
    spent = {
        name: np.array([rows[s]["simulated_seconds"] for s in seeds])
        for name, rows in (("plain", plain), ("anytime", anytime), ("random", random))
    }
    mean = {k: float(v.mean()) for k, v in spent.items()}
    print(
        "mean counted real s per seed, every seed: "
        + ", ".join(f"{k} {v:,.0f}" for k, v in mean.items())
        + f"; anytime / plain {mean['anytime'] / mean['plain']:.2f}, "
        f"anytime / random {mean['anytime'] / mean['random']:.2f}"
    )
    for other in ("plain", "random"):
        x, y = spent["anytime"], spent[other]
        print(
            f"anytime against {other}, real s per seed: more {(x > y).sum()} fewer "
            f"{(x < y).sum()}, Wilcoxon p = {wilcoxon(x, y).pvalue:.2g}"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
