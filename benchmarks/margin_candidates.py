"""A margin candidate beside the arm it changes and random search, from sweeps' runs.csv.

Each argument is NAME=SWEEP: a sweep folder run with ``--baselines random`` on the same
seeds as the others (its random-search rows are the same run for run); a NAME given
more than once pools its sweeps (e.g. one per evaluation root). A sweep's other arms
(its control, CMA-ES) enter the margin tables as "NAME control", "NAME cmaes". For
each NAME the learner arm's row, then random search's:

1. cost: robust runs [Wilson 95 %], real simulated seconds of the solved runs (median
   and its percentile-bootstrap interval, ``np.random.default_rng(0)``), real trials,
   imagined simulations (not counted), paired with random search on every seed
   (Wilcoxon signed-rank on real simulated seconds, an unsolved seed at what it spent);
2. the margin set (``striatal robustness --margin``'s table, the 40 conditions), and the
   same on the conditions outside a +-30 % box of pole mass and length (a factor
   outside [0.7, 1.3], or the cart mass or the start changed): what a learner that
   trained or checked at +-30 % corners did not see;
3. the margin set again, each candidate paired with the first NAME's learner (the arm
   it changes) on the seeds both solved;
4. the share of runs passing each group of conditions.

    python benchmarks/margin_candidates.py pgpe=pr-r0 pgpe-m10=pr-m10-r0
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import wilcoxon

from striatal.experiments import stats
from striatal.experiments.robustness import MARGIN_CONDITIONS, margin_table, sweep_controllers
from striatal.experiments.runs_csv import read_runs
from striatal.params import Controller
from striatal.sim.robust import Perturbation

#: The half-width of the box whose conditions the second margin table leaves out.
BOX = 0.3
NOMINAL = Perturbation("nominal")


def outside(c: Perturbation, box: float = BOX) -> bool:
    """Whether condition ``c`` lies outside the box of plant corners at x(1 +- box)."""
    inside = all(1 - box - 1e-9 <= f <= 1 + box + 1e-9 for f in (c.pole_mass, c.length))
    plant_only = (c.cart_mass, c.theta0, c.x0) == (1.0, NOMINAL.theta0, NOMINAL.x0)
    return not (inside and plant_only)


def group(c: Perturbation) -> str:
    if c.cart_mass != 1.0:
        return "cart mass (2)"
    if (c.theta0, c.x0) != (NOMINAL.theta0, NOMINAL.x0):
        return "starts (4)"
    return "draws (20)" if c.name.startswith("draw") else "length scan (14)"


def arm_key(name: str, arm: str) -> str:
    """The margin tables' row of sweep arm ``arm`` given as NAME ``name``: the learner is
    NAME, random search is one row (the same in every sweep, checked in :func:`main`), and
    another arm (a control, CMA-ES) is NAME's own, since it shares NAME's options (a
    control under ``--stop-margin`` stops on the wider corners too)."""
    if arm == "learner":
        return name
    return arm if arm == "random" else f"{name} {arm}"


def paired(a: np.ndarray, b: np.ndarray) -> str:
    """Seeds where ``a`` spent fewer / more than ``b`` and the Wilcoxon signed-rank p."""
    p = float(wilcoxon(a, b).pvalue) if np.any(a != b) else 1.0
    return f"fewer on {int((a < b).sum())} / more on {int((a > b).sum())}, p = {p:.2g}"


def spent(runs: dict[int, dict[str, Any]], seeds: list[int]) -> np.ndarray:
    return np.array([float(runs[s]["simulated_seconds"]) for s in seeds])


def cost_rows(
    name: str,
    rows: Sequence[dict[str, Any]],
    rng: np.random.Generator,
    first: dict[int, dict[str, Any]] | None,
) -> tuple[list[str], dict[int, dict[str, Any]]]:
    """The learner's row (paired with random search and with ``first``, the first
    argument's learner), and random search's when ``first`` is None; the learner's runs."""
    by: dict[str, dict[int, dict[str, Any]]] = {}
    for r in rows:
        by.setdefault(r["arm"], {})[int(r["seed"])] = r
    out = []
    ref = by["random"]
    for arm in ("learner", "random") if first is None else ("learner",):
        runs = by[arm]
        ok = [r for r in runs.values() if str(r["success"]) in ("1", "True")]
        w = stats.wilson_interval(len(ok), len(runs))
        secs = [float(r["simulated_seconds"]) for r in ok]
        iv = stats.bootstrap_interval(secs, stats.median, rng) if len(secs) > 1 else None
        ci = "" if iv is None or iv.low is None else f" [{iv.low:,.0f}, {iv.high:,.0f}]"
        imagined = [float(r.get("imagined_simulations") or 0) for r in runs.values()]
        against_random = against_first = "-"
        if arm != "random":
            shared = sorted(set(runs) & set(ref))
            against_random = paired(spent(runs, shared), spent(ref, shared))
            if first is not None:
                shared = sorted(set(runs) & set(first))
                against_first = paired(spent(runs, shared), spent(first, shared))
        label = name if arm == "learner" else "random search"
        trials = np.median([int(r["trials"]) for r in ok]) if ok else float("nan")
        out.append(
            f"| {label} | {len(ok)}/{len(runs)} [{100 * w.low:.0f} %, {100 * w.high:.0f} %] | "
            f"{np.median(secs) if secs else float('nan'):,.0f}{ci} | {trials:.0f} | "
            f"{np.median(imagined):,.0f} | {against_random} | {against_first} |"
        )
    return out, by["learner"]


def main(args: list[str]) -> None:
    arms: dict[str, dict[int, Controller]] = {}
    lines = [
        "| arm | robust within the budget [95% CI] | real simulated s, solved: median [95% CI] "
        "| real trials, solved: median | imagined simulations: median | real s paired with "
        "random search (every seed): Wilcoxon | real s paired with the first arm |",
        "|---|---|---|---|---|---|---|",
    ]
    rng = np.random.default_rng(0)
    given: dict[str, list[dict[str, Any]]] = {}
    for arg in args:
        name, _, folder = arg.partition("=")
        rows, _ = read_runs(Path(folder) / "runs.csv")
        given.setdefault(name, []).extend(rows)
    first_random: dict[int, Controller] | None = None
    first: dict[int, dict[str, Any]] | None = None
    for name, rows in given.items():
        found = sweep_controllers(rows)
        more, learner = cost_rows(name, rows, rng, first)
        lines += more
        first = learner if first is None else first
        if first_random is None:
            first_random = found.get("random", {})
        elif found.get("random", {}) != first_random:
            lines.append(f"| (random search in {name}'s sweeps differs from the first's) |")
        for arm, by_seed in found.items():
            arms.setdefault(arm_key(name, arm), {}).update(by_seed)
    print("\n".join(lines) + "\n")
    print("The margin set, 40 conditions:\n")
    table, found = margin_table(arms)
    print(table)
    beyond = tuple(c for c in MARGIN_CONDITIONS if outside(c))
    print(f"Its {len(beyond)} conditions outside the +-{BOX:.0%} box of pole mass and length:\n")
    print(margin_table(arms, conditions=beyond)[0])
    names_given = list(given)
    mine = {k: v for k, v in arms.items() if k in names_given}
    print(f"The 40 conditions, each arm paired with {names_given[0]} (the arm it changes):\n")
    print(margin_table(mine, reference=names_given[0])[0])
    kinds = {c.name: group(c) for c in MARGIN_CONDITIONS}
    names = list(dict.fromkeys(kinds.values()))
    print("| arm | controllers | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names))
    for arm in arms:
        share = {
            k: np.mean(
                [r["success"] for r in found if r["arm"] == arm and kinds[r["condition"]] == k]
            )
            for k in names
        }
        cells = " | ".join(f"{100 * share[k]:.0f} %" for k in names)
        print(f"| {arm} | {len(arms[arm])} | {cells} |")


if __name__ == "__main__":
    main(sys.argv[1:])
