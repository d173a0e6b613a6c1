"""Intervals and tests for comparing learning arms over seeds.

Pure functions on plain numbers; every result is a frozen dataclass with
``to_dict()`` that holds only JSON-ready values (an interval that cannot be
computed is None, with the reason under ``note``, never NaN).

- a success rate with its Wilson 95 % interval (:func:`wilson_interval`);
- the median and the interquartile mean (IQM, the 25 % trimmed mean) of a cost
  such as simulations-to-success, each with a seeded percentile-bootstrap 95 %
  interval (:func:`bootstrap_interval`);
- Fisher's exact test between two arms run on different seeds
  (:func:`fisher_test`) and McNemar's exact test between two arms run on the
  same seeds (:func:`mcnemar_test`);
- :func:`arm_summary`, the block of ``summary.json`` for one arm.

The per-arm costs are taken over the solved seeds only: an unsolved seed has no
simulations-to-success, only a lower bound (its budget). The share of unsolved
seeds is in the success rate beside them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import stats as sps

from striatal.errors import ParameterError

__all__ = [
    "CONFIDENCE",
    "COSTS",
    "N_RESAMPLES",
    "FisherResult",
    "Interval",
    "McNemarResult",
    "SeedRecord",
    "arm_summary",
    "bootstrap_interval",
    "compare_arms",
    "cost_summary",
    "fisher_test",
    "iqm",
    "mcnemar_test",
    "mean",
    "median",
    "wilson_interval",
]

CONFIDENCE = 0.95
#: Resamples of every bootstrap interval; 9999 is scipy's default.
N_RESAMPLES = 9999
#: The costs :func:`arm_summary` reports, each a field of :class:`SeedRecord`.
COSTS: tuple[str, ...] = ("simulations", "simulated_seconds", "trials")


@dataclass(frozen=True)
class Interval:
    """A two-sided 95 % interval ``[low, high]``, or None with the reason in ``note``."""

    low: float | None
    high: float | None
    note: str = ""

    @property
    def bounds(self) -> list[float] | None:
        """``[low, high]``, or None when the interval could not be computed."""
        if self.low is None or self.high is None:
            return None
        return [self.low, self.high]


def wilson_interval(successes: int, n: int, confidence: float = CONFIDENCE) -> Interval:
    """Wilson score interval of a binomial rate ``successes / n`` (no continuity correction).

    Uses ``scipy.stats.binomtest(...).proportion_ci(method="wilson")``. With
    ``n = 0`` there is no rate: both bounds are None.
    """
    k, total = _count("successes", successes), _count("n", n)
    if k > total:
        raise ParameterError(f"successes ({k}) cannot exceed n ({total})")
    if total == 0:
        return Interval(None, None, "no runs")
    ci = sps.binomtest(k, total).proportion_ci(confidence_level=confidence, method="wilson")
    return Interval(float(ci.low), float(ci.high))


def iqm(values: np.ndarray, axis: int = -1) -> np.ndarray:
    """Interquartile mean: the mean of the middle 50 % (``scipy.stats.trim_mean(x, 0.25)``)."""
    return np.asarray(sps.trim_mean(values, 0.25, axis=axis))


def mean(values: np.ndarray, axis: int = -1) -> np.ndarray:
    """The mean along ``axis`` (vectorised for :func:`scipy.stats.bootstrap`)."""
    return np.asarray(np.mean(values, axis=axis))


def median(values: np.ndarray, axis: int = -1) -> np.ndarray:
    """The median along ``axis`` (vectorised for :func:`scipy.stats.bootstrap`)."""
    return np.asarray(np.median(values, axis=axis))


def bootstrap_interval(
    values: Sequence[float] | np.ndarray,
    statistic: Callable[..., np.ndarray],
    rng: np.random.Generator,
    *,
    n_resamples: int = N_RESAMPLES,
    confidence: float = CONFIDENCE,
) -> Interval:
    """Percentile-bootstrap interval of ``statistic`` over ``values`` (``scipy.stats.bootstrap``).

    The percentile method is used because it stays inside the range of the data
    for the median of integer counts, where BCa degenerates on ties. With fewer
    than two values, or all values equal, the bootstrap distribution is a single
    point and the interval is None with that reason.
    """
    x = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(x)):
        raise ParameterError("bootstrap values must be finite numbers")
    if x.size < 2:
        return Interval(None, None, f"{x.size} value(s): a bootstrap needs at least 2")
    if np.all(x == x[0]):
        return Interval(None, None, "all values equal: the bootstrap distribution is one point")
    res = sps.bootstrap(
        (x,),
        statistic,
        n_resamples=_count("n_resamples", n_resamples, minimum=1),
        confidence_level=confidence,
        method="percentile",
        vectorized=True,
        rng=rng,
    )
    return Interval(float(res.confidence_interval.low), float(res.confidence_interval.high))


@dataclass(frozen=True)
class FisherResult:
    """Fisher's exact test (two-sided) between two arms run on different seeds."""

    successes_a: int
    n_a: int
    successes_b: int
    n_b: int
    odds_ratio: float | None
    p_value: float
    test: str = "Fisher's exact test, two-sided (scipy.stats.fisher_exact)"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def fisher_test(successes_a: int, n_a: int, successes_b: int, n_b: int) -> FisherResult:
    """Do arms A and B succeed at the same rate? Two-sided Fisher exact test on the 2x2 table.

    The odds ratio (sample, as scipy reports it) is None when it is infinite or
    undefined (a zero cell).
    """
    ka, na, kb, nb = (
        _count("successes_a", successes_a),
        _count("n_a", n_a),
        _count("successes_b", successes_b),
        _count("n_b", n_b),
    )
    if ka > na or kb > nb:
        raise ParameterError("successes cannot exceed the number of runs")
    if na == 0 or nb == 0:
        raise ParameterError("each arm needs at least one run")
    res = sps.fisher_exact([[ka, na - ka], [kb, nb - kb]])
    ratio = float(res.statistic)
    return FisherResult(
        successes_a=ka,
        n_a=na,
        successes_b=kb,
        n_b=nb,
        odds_ratio=ratio if math.isfinite(ratio) else None,
        p_value=float(res.pvalue),
    )


@dataclass(frozen=True)
class McNemarResult:
    """McNemar's exact test between two arms on shared seeds.

    ``only_a``: seeds solved by A and not by B; ``only_b`` the reverse. The test
    is a two-sided binomial test of ``only_a`` out of ``only_a + only_b`` at 1/2.
    """

    shared_seeds: int
    both: int
    neither: int
    only_a: int
    only_b: int
    p_value: float
    test: str = "McNemar's exact test: scipy.stats.binomtest on the discordant seeds"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def mcnemar_test(a: Mapping[int, bool], b: Mapping[int, bool]) -> McNemarResult:
    """Paired comparison of two arms on the seeds both ran (``seed -> solved``).

    With no discordant seed the arms cannot be told apart: p = 1.
    """
    shared = sorted(set(a) & set(b))
    if not shared:
        raise ParameterError("the two arms share no seed: use fisher_test for unpaired arms")
    pairs = [(bool(a[s]), bool(b[s])) for s in shared]
    only_a = sum(x and not y for x, y in pairs)
    only_b = sum(y and not x for x, y in pairs)
    discordant = only_a + only_b
    p = 1.0 if discordant == 0 else float(sps.binomtest(only_a, discordant, 0.5).pvalue)
    return McNemarResult(
        shared_seeds=len(shared),
        both=sum(x and y for x, y in pairs),
        neither=sum(not x and not y for x, y in pairs),
        only_a=only_a,
        only_b=only_b,
        p_value=p,
    )


@dataclass(frozen=True)
class SeedRecord:
    """What one seed of an arm reports: solved or not, and what it cost.

    ``simulations``: every simulated trial the arm ran for this seed (learning
    trials, mean-policy reruns, evaluations); ``simulated_seconds``: their total
    simulated time [s]; ``trials``: learning trials.
    """

    success: bool
    simulations: int | None
    simulated_seconds: float | None
    trials: int

    @classmethod
    def from_mapping(cls, row: Mapping[str, Any]) -> SeedRecord:
        """A record from a dict (a parsed runs.csv row).

        ``success`` and ``trials`` are required; ``simulations`` and
        ``simulated_seconds`` may be missing (sweeps from before they were
        recorded): their statistics are then None with a note.
        """
        try:
            sims, secs = row.get("simulations"), row.get("simulated_seconds")
            return cls(
                success=bool(row["success"]),
                simulations=None if sims is None else int(sims),
                simulated_seconds=None if secs is None else float(secs),
                trials=int(row["trials"]),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ParameterError(f"a seed record needs success and trials: {exc!r}") from None


def cost_summary(
    values: Sequence[float], name: str, rng: np.random.Generator, n_resamples: int = N_RESAMPLES
) -> dict[str, Any]:
    """``{name}_median``, ``{name}_median_ci``, ``{name}_iqm``, ``{name}_iqm_ci`` of ``values``.

    Empty ``values`` give None everywhere; reasons for a None interval go under
    ``{name}_note``.
    """
    x = np.asarray(values, dtype=float)
    out: dict[str, Any] = {}
    notes: list[str] = []
    for stat_name, fn in (("median", median), ("iqm", iqm)):
        if x.size == 0:
            out[f"{name}_{stat_name}"] = None
            out[f"{name}_{stat_name}_ci"] = None
            continue
        out[f"{name}_{stat_name}"] = float(fn(x))
        ci = bootstrap_interval(x, fn, rng, n_resamples=n_resamples)
        out[f"{name}_{stat_name}_ci"] = ci.bounds
        if ci.note:
            notes.append(f"{stat_name} interval: {ci.note}")
    if x.size == 0:
        notes.append("no solved seed")
    out[f"{name}_note"] = "; ".join(dict.fromkeys(notes))
    return out


def arm_summary(
    records: Sequence[SeedRecord | Mapping[str, Any]],
    *,
    rng: np.random.Generator,
    n_resamples: int = N_RESAMPLES,
) -> dict[str, Any]:
    """The ``summary.json`` block of one arm from its per-seed records.

    Keys: ``runs``, ``successes``, ``success_rate`` with ``success_rate_ci``
    (Wilson), and for each of simulations, simulated_seconds and trials the
    median and IQM over the *solved* seeds with seeded percentile-bootstrap
    intervals (``simulations_median``, ``simulations_median_ci``,
    ``simulations_iqm``, ``simulations_iqm_ci``, ``simulations_note``...).
    Anything that cannot be computed is None, with the reason in its note.
    """
    recs = [r if isinstance(r, SeedRecord) else SeedRecord.from_mapping(r) for r in records]
    n = len(recs)
    solved = [r for r in recs if r.success]
    ci = wilson_interval(len(solved), n)
    out: dict[str, Any] = {
        "runs": n,
        "successes": len(solved),
        "success_rate": len(solved) / n if n else None,
        "success_rate_ci": ci.bounds,
        "success_rate_note": ci.note,
        "costs_over": "solved seeds only (an unsolved seed has only a lower bound, its budget)",
        "interval_method": f"Wilson for the rate; percentile bootstrap ({n_resamples} "
        "resamples, scipy.stats.bootstrap) for the median and the IQM "
        "(scipy.stats.trim_mean(x, 0.25))",
    }
    for cost in COSTS:
        values = [getattr(r, cost) for r in solved]
        if any(v is None for v in values):
            out.update(cost_summary([], cost, rng, n_resamples))
            out[f"{cost}_note"] = f"{cost} not recorded for every solved seed"
        else:
            out.update(cost_summary(values, cost, rng, n_resamples))
    return out


def _count(name: str, value: object, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise ParameterError(f"{name} must be a whole number >= {minimum}, got {value!r}")
    return int(value)


def compare_arms(a: Mapping[int, bool], b: Mapping[int, bool]) -> dict[str, Any]:
    """Both tests of arm A against arm B from ``seed -> solved`` maps, for summary.json.

    ``fisher``: every seed of each arm, as independent samples. ``mcnemar``: the
    seeds both arms ran, paired (None when they share none). When the arms ran
    the same seeds (a learner and its control), the paired test is the one to
    quote: it removes the seed-to-seed variation the two arms share.
    """
    if not a or not b:
        raise ParameterError("each arm needs at least one seed")
    shared = set(a) & set(b)
    return {
        "fisher": fisher_test(
            sum(map(bool, a.values())), len(a), sum(map(bool, b.values())), len(b)
        ).to_dict(),
        "mcnemar": mcnemar_test(a, b).to_dict() if shared else None,
        "same_seeds": set(a) == set(b),
    }
