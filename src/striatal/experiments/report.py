"""summary.json and its markdown table: the statistics of a sweep's rows, per arm.

Each (arm, init) gets its success rate with a Wilson interval and, over its solved
seeds, medians and IQMs of the cost with seeded bootstrap intervals
(:mod:`striatal.experiments.stats`); each learner arm is tested against its control
(Fisher's exact test, McNemar's on the shared seeds). The summary is computed from the
rows sorted by (arm, init, seed), so it does not depend on completion order; its
bootstrap intervals are seeded by the arm and init.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.experiments import stats
from striatal.experiments.runner import NOTE_BUDGET, control_note
from striatal.experiments.runs_csv import sort_rows


def _quantile(values: Sequence[float], q: float) -> float:
    return float(np.quantile(np.asarray(values, dtype=float), q)) if values else math.nan


def _finite_mean(values: Iterable[float]) -> float:
    x = [float(v) for v in values if math.isfinite(float(v))]
    return float(np.mean(x)) if x else math.nan


def bootstrap_rng(arm: str, init: str) -> np.random.Generator:
    """The generator of an arm's bootstrap intervals: seeded by its name and init only."""
    return np.random.default_rng(zlib.crc32(f"{arm}|{init}".encode()))


def arm_statistics(
    rows: Sequence[dict[str, Any]], max_trials: int, rng: np.random.Generator | None = None
) -> dict[str, Any]:
    """The statistics of one arm's rows (one per seed).

    From :func:`striatal.experiments.stats.arm_summary`: ``success_rate`` with its Wilson interval
    ``success_rate_ci``, and over the solved seeds the median and IQM of
    ``simulations``, ``simulated_seconds`` and ``trials`` with seeded bootstrap
    intervals (``simulations_median_ci``, ``simulations_iqm_ci``, ...). Besides:
    quartiles of trials to success, ``trials_median_all`` (unsolved runs counted as
    ``max_trials``, a lower bound), the share whose final gains pass a noise-free
    re-simulation, budget and evaluation totals, and the mean pass probabilities of
    W(0) and of the final gains (over runs that estimated them).
    """
    n = len(rows)
    solved = [float(r["trials"]) for r in rows if r["success"]]
    every = [float(r["trials"]) if r["success"] else float(max_trials) for r in rows]
    wall = [float(r["wall_seconds"]) for r in rows]
    gen = rng if rng is not None else np.random.default_rng(0)
    out = stats.arm_summary(rows, rng=gen)
    out.update(
        {
            "unsolved_share": (n - len(solved)) / n if n else math.nan,
            "trials_q1": _quantile(solved, 0.25),
            "trials_q3": _quantile(solved, 0.75),
            "trials_median_all": _quantile(every, 0.5),
            "mean_policy_success_rate": (
                sum(bool(r["mean_policy_success"]) for r in rows) / n if n else math.nan
            ),
            "robust_rate": _finite_mean(r.get("robust", math.nan) for r in rows),
            "simulations_total": int(sum(int(r["simulations"]) for r in rows)),
            "simulated_seconds_total": float(sum(float(r["simulated_seconds"]) for r in rows)),
            "trials_total": int(sum(int(r["trials"]) for r in rows)),
            "eval_simulations_total": int(sum(int(r["eval_simulations"]) for r in rows)),
            "imagined_simulations_total": int(
                sum(int(r.get("imagined_simulations", 0)) for r in rows)
            ),
            "imagined_seconds_total": float(
                sum(float(r.get("imagined_seconds", 0.0)) for r in rows)
            ),
            "margin_reached_total": int(
                sum(r.get("margin_reached", math.nan) == 1.0 for r in rows)
            ),
            "seconds_after_first_success_total": float(
                sum(float(r["simulated_seconds"]) - _first_seconds(r) for r in rows if r["success"])
            ),
            "first_success_seconds_median": _quantile(
                [_first_seconds(r) for r in rows if r["success"]], 0.5
            ),
            "pass_rate_W0_mean": _finite_mean(r["pass_rate_W0"] for r in rows),
            "pass_rate_mean": _finite_mean(r["pass_rate"] for r in rows),
            "wall_seconds_total": float(sum(wall)),
            "wall_seconds_median": _quantile(wall, 0.5),
        }
    )
    spent = [float(r["simulated_seconds"]) for r in rows]
    mean_all = (
        stats.bootstrap_interval(spent, stats.mean, rng or np.random.default_rng(0)) if n else None
    )
    out.update(
        {
            "simulated_seconds_restricted_mean": float(np.mean(spent)) if n else math.nan,
            "simulated_seconds_restricted_mean_ci": mean_all.bounds if mean_all else None,
            "restricted_mean_note": "mean simulated seconds over every seed, an unsolved "
            "seed counted at what it spent (its budget): the restricted mean, "
            "percentile bootstrap interval",
        }
    )
    if out["trials_median"] is None:
        out["trials_median"] = math.nan
    return out


#: The note of a sweep whose learner learned on after its success (margin_after_success).
NOTE_MARGIN_AFTER_SUCCESS = (
    "margin_after_success: success is the first robust controller, as without the "
    "margin (runs.csv first_success_trials, first_success_simulations, "
    "first_success_seconds; summary first_success_seconds_median); trials, simulations "
    "and simulated seconds count every run to the delivered controller (the margin one, "
    "else the first robust one; seconds_after_first_success_total); margin reached "
    "(margin_reached_total): "
)


def _first_seconds(row: dict[str, Any]) -> float:
    """Simulated seconds to a solved run's first success (its total for a row without
    the column: every such run stopped at its success)."""
    return float(row.get("first_success_seconds", row["simulated_seconds"]))


def _control_of(a: dict[str, Any], arms: Sequence[dict[str, Any]]) -> dict[str, Any] | None:
    """The control arm of learner arm ``a``: its learner's, on its init (None if none ran)."""
    return next(
        (
            c
            for c in arms
            if c["role"] == "control" and c["init"] == a["init"] and c["learner"] == a["learner"]
        ),
        None,
    )


def _paired(
    a: dict[str, Any],
    b: dict[str, Any],
    groups: dict[tuple[str, str], list[dict[str, Any]]],
    other: str,
) -> dict[str, Any]:
    """Learner arm ``a`` against arm ``b`` (its ``other``: "control" or "baseline") on the
    same init: both rates, costs over solved seeds and restricted means, and both tests
    (McNemar's on the shared seeds)."""
    solved = {
        arm["arm"]: {int(r["seed"]): bool(r["success"]) for r in groups[(arm["arm"], a["init"])]}
        for arm in (a, b)
    }
    keys = (
        "success_rate",
        "success_rate_ci",
        "simulations_median",
        "trials_median",
        "simulated_seconds_restricted_mean",
    )
    return {
        "init": a["init"],
        "arm": a["arm"],
        other: b["arm"],
        "learner": a["learner"],
        **{k: a[k] for k in keys},
        **{f"{other}_{k}": b[k] for k in keys},
        **stats.compare_arms(solved[a["arm"]], solved[b["arm"]]),
    }


def summarise(
    rows: Sequence[dict[str, Any]], max_trials: int, settings: dict[str, Any]
) -> dict[str, Any]:
    """summary.json: statistics per (arm, init) in sorted order, each learner arm against
    its control and against each baseline (Fisher's exact test, and McNemar's on the
    shared seeds), settings.

    Rows must have distinct (arm, init, seed): a duplicate would count one run twice
    (ParameterError).
    """
    ordered = sort_rows(rows)
    keys = [(r["arm"], r["init"], int(r["seed"])) for r in ordered]
    if len(set(keys)) != len(keys):
        dup = next(k for i, k in enumerate(keys) if k in keys[:i])
        raise ParameterError(f"run {dup} appears twice: a run is counted once")
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in ordered:
        groups.setdefault((r["arm"], r["init"]), []).append(r)
    arms = [
        {
            "arm": arm,
            "init": init,
            "role": g[0]["role"],
            "method": g[0]["method"],
            "learner": g[0]["learner"],
            **arm_statistics(g, max_trials, bootstrap_rng(arm, init)),
        }
        for (arm, init), g in groups.items()
    ]
    side_by_side = []
    for a in arms:
        control = _control_of(a, arms) if a["role"] == "learner" else None
        if control is not None:
            side_by_side.append(_paired(a, control, groups, "control"))
    against_baselines = [
        _paired(a, b, groups, "baseline")
        for a in arms
        if a["role"] == "learner"
        for b in arms
        if b["role"] == "baseline" and b["init"] == a["init"]
    ]
    learners = sorted({a["learner"] for a in arms} - {"-"})
    margin = [
        f"{a['arm']} {a['margin_reached_total']}"
        for a in arms
        if any(
            math.isfinite(r.get("margin_reached", math.nan)) for r in groups[a["arm"], a["init"]]
        )
    ]
    return {
        "arms": arms,
        "learner_vs_control": side_by_side,
        "learner_vs_baselines": against_baselines,
        "notes": [
            *(control_note(x) for x in learners),
            NOTE_BUDGET,
            *([NOTE_MARGIN_AFTER_SUCCESS + ", ".join(margin)] if margin else []),
        ],
        "settings": settings,
    }


def _num(v: Any, fmt: str = "g") -> str:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        return "-"
    return format(v, fmt)


def _ci(v: Any, fmt: str = "g") -> str:
    if not isinstance(v, list | tuple) or len(v) != 2:
        return ""
    return f" [{_num(v[0], fmt)}, {_num(v[1], fmt)}]"


def _robust_cell(arm: dict[str, Any]) -> str:
    """ ", robust R" (re-checked share of robust final gains) in a robust sweep."""
    rate = arm.get("robust_rate")
    return (
        f", robust {_num(rate, '.0%')}" if isinstance(rate, float) and math.isfinite(rate) else ""
    )


def _pair_cells(c: dict[str, Any], other: str) -> str:
    """The first cells of a pair's row: the arms, the init and both success rates."""
    return (
        f"| {c['arm']} | {c[other]} | {c['init']} | "
        f"{_num(c['success_rate'], '.0%')}{_ci(c.get('success_rate_ci'), '.0%')} | "
        f"{_num(c[f'{other}_success_rate'], '.0%')}"
        f"{_ci(c.get(f'{other}_success_rate_ci'), '.0%')} |"
    )


def _mcnemar_cell(c: dict[str, Any]) -> str:
    mc = c.get("mcnemar") or {}
    return f"{_num(mc.get('p_value'), '.3g')} ({mc.get('only_a', '-')} / {mc.get('only_b', '-')}) |"


def _fisher_cell(c: dict[str, Any]) -> str:
    return _num(c["fisher"]["p_value"], ".3g")


def _seconds_cell(c: dict[str, Any]) -> str:
    return (
        f"{_num(c['simulated_seconds_restricted_mean'], '.0f')} / "
        f"{_num(c['baseline_simulated_seconds_restricted_mean'], '.0f')}"
    )


def _pair_table(
    pairs: list[dict[str, Any]] | None,
    other: str,
    column: str,
    cell: Callable[[dict[str, Any]], str],
) -> list[str]:
    """The lines of a table of learner arms against their ``other`` arm ("control",
    "baseline"), after a blank line: the arms, the init, both success rates, the column
    ``column`` (each row's ``cell``) and McNemar's test; none without pairs."""
    if not pairs:
        return []
    lines = [
        "",
        f"| learner arm | {other} | init | success | {other} success | {column} | "
        f"McNemar p (only learner / only {other}) |",
        "|---|---|---|---|---|---|---|",
    ]
    return lines + [f"{_pair_cells(c, other)} {cell(c)} | {_mcnemar_cell(c)}" for c in pairs]


def markdown_table(summary: dict[str, Any]) -> str:
    """The comparison table of a summary, one line per (arm, init), then each learner
    against its control. Intervals are 95 %: Wilson for rates, bootstrap for the median
    and IQM of simulations to success (over solved runs)."""
    lines = [
        "| arm | init | runs | success [95% CI] | simulations to success: median [95% CI] | "
        "IQM [95% CI] | trials: median [q1, q3] | mean policy passes | "
        "pass rate W(0) -> final | simulations (all runs) | wall s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for a in summary["arms"]:
        lines.append(
            f"| {a['arm']} | {a['init']} | {a['runs']} | "
            f"{_num(a['success_rate'], '.0%')}{_ci(a.get('success_rate_ci'), '.0%')} | "
            f"{_num(a.get('simulations_median'))}{_ci(a.get('simulations_median_ci'))} | "
            f"{_num(a.get('simulations_iqm'), '.4g')}{_ci(a.get('simulations_iqm_ci'), '.4g')} | "
            f"{_num(a['trials_median'])} "
            f"[{_num(a.get('trials_q1'))}, {_num(a.get('trials_q3'))}] | "
            f"{_num(a.get('mean_policy_success_rate'), '.0%')}{_robust_cell(a)} | "
            f"{_num(a.get('pass_rate_W0_mean'), '.2f')} -> "
            f"{_num(a.get('pass_rate_mean'), '.2f')} | "
            f"{_num(a.get('simulations_total'))} | {_num(a.get('wall_seconds_total'), '.1f')} |"
        )
    lines = _with_source(lines, summary["arms"])
    for pairs, table in (
        (
            summary.get("learner_vs_control"),
            _pair_table(summary.get("learner_vs_control"), "control", "Fisher p", _fisher_cell),
        ),
        (
            summary.get("learner_vs_baselines"),
            _pair_table(
                summary.get("learner_vs_baselines"),
                "baseline",
                "mean simulated s, all seeds (learner / baseline)",
                _seconds_cell,
            ),
        ),
    ):
        lines += _with_source(table[:1], []) + _with_source(table[1:], pairs or [])
    return "\n".join(lines) + "\n"


def _with_source(lines: list[str], rows: list[dict[str, Any]]) -> list[str]:
    """``lines`` (a header, its rule, one line per row) with a first column naming each
    row's ``source`` (the summary it came from), when ``rows`` come from several."""
    if len({r.get("source") for r in rows}) < 2:
        return lines
    return [
        f"| source {lines[0]}",
        f"|---{lines[1]}",
        *(f"| {r['source']} {line}" for r, line in zip(rows, lines[2:], strict=True)),
    ]
