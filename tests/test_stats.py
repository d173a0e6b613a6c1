"""Intervals and tests of striatal.experiments.stats against textbook values and edge cases."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.experiments import stats


def test_wilson_textbook_value() -> None:
    ci = stats.wilson_interval(72, 100)
    assert ci.bounds is not None
    assert [round(v, 3) for v in ci.bounds] == [0.625, 0.799]
    # closed form: (p + z^2/2n +- z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)
    z, n, p = 1.959963984540054, 100, 0.72
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    assert ci.bounds == pytest.approx([centre - half, centre + half], abs=1e-12)


def test_wilson_at_the_edges() -> None:
    zero = stats.wilson_interval(0, 20)
    assert zero.low == 0.0 and zero.high == pytest.approx(3.8415 / (20 + 3.8415), abs=1e-4)
    full = stats.wilson_interval(20, 20)
    assert full.high == pytest.approx(1.0)
    assert full.low == pytest.approx(20 / (20 + 3.8415), abs=1e-4)
    empty = stats.wilson_interval(0, 0)
    assert empty.bounds is None and empty.note


@pytest.mark.parametrize("bad", [(-1, 10), (11, 10), (1.5, 10), (True, 10)])
def test_wilson_refuses_bad_counts(bad: tuple[object, object]) -> None:
    with pytest.raises(ParameterError):
        stats.wilson_interval(*bad)  # type: ignore[arg-type]


def test_bootstrap_interval_contains_the_statistic_and_is_seeded() -> None:
    data = np.random.default_rng(1).integers(50, 900, size=40)
    for fn in (stats.median, stats.iqm):
        a = stats.bootstrap_interval(data, fn, np.random.default_rng(7), n_resamples=2000)
        b = stats.bootstrap_interval(data, fn, np.random.default_rng(7), n_resamples=2000)
        c = stats.bootstrap_interval(data, fn, np.random.default_rng(8), n_resamples=2000)
        assert a == b
        assert a != c
        assert a.low is not None and a.high is not None
        assert a.low <= float(fn(data)) <= a.high
        assert a.low < a.high


def test_iqm_is_the_mean_of_the_middle_half() -> None:
    x = np.arange(1.0, 9.0)  # 1..8: the middle half is 3, 4, 5, 6
    assert float(stats.iqm(x)) == pytest.approx(4.5)


@pytest.mark.parametrize("values", [[], [5.0], [3.0, 3.0, 3.0]])
def test_bootstrap_degenerate_gives_none_with_a_reason(values: list[float]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ci = stats.bootstrap_interval(values, stats.median, np.random.default_rng(0))
    assert ci.bounds is None and ci.note


def test_fisher_on_the_chapter_rule_seed_blocks() -> None:
    # the chapter rule solved 36/100 on seeds 0-99 and 14/100 on seeds 100-199
    res = stats.fisher_test(36, 100, 14, 100)
    assert res.p_value == pytest.approx(5e-4, rel=0.2)
    assert res.p_value < 1e-3
    assert res.odds_ratio == pytest.approx((36 * 86) / (64 * 14))
    same = stats.fisher_test(20, 100, 20, 100)
    assert same.p_value == pytest.approx(1.0)
    json.dumps(res.to_dict())


def test_fisher_zero_cell_odds_ratio_is_none() -> None:
    res = stats.fisher_test(0, 10, 5, 10)
    assert res.odds_ratio == 0.0
    assert stats.fisher_test(10, 10, 5, 10).odds_ratio is None


def test_mcnemar_on_a_constructed_example() -> None:
    # 20 shared seeds: 5 both, 6 neither, 8 only A, 1 only B; seed 99 is not shared
    a = {s: s < 13 for s in range(20)}
    b = {s: (s < 5) or s == 19 for s in range(20)}
    a[99] = True
    res = stats.mcnemar_test(a, b)
    assert (res.shared_seeds, res.both, res.neither, res.only_a, res.only_b) == (20, 5, 6, 8, 1)
    # exact two-sided binomial: 2 * P(X <= 1 | n = 9, p = 1/2) = 2 * 10 / 512
    assert res.p_value == pytest.approx(20 / 512)
    tied = stats.mcnemar_test({0: True, 1: False}, {0: True, 1: False})
    assert tied.p_value == 1.0
    with pytest.raises(ParameterError):
        stats.mcnemar_test({0: True}, {1: True})


def _records(sims: list[int], solved: list[bool]) -> list[stats.SeedRecord]:
    return [
        stats.SeedRecord(success=ok, simulations=s, simulated_seconds=60.0 * s, trials=s)
        for s, ok in zip(sims, solved, strict=True)
    ]


def test_arm_summary_keys_and_values() -> None:
    sims = [10, 20, 30, 40, 50, 60, 70, 80, 1000, 1000]
    solved = [True] * 8 + [False] * 2
    out = stats.arm_summary(_records(sims, solved), rng=np.random.default_rng(0), n_resamples=999)
    assert out["success_rate"] == 0.8
    assert out["success_rate_ci"] == pytest.approx(stats.wilson_interval(8, 10).bounds)
    assert out["simulations_median"] == 45.0  # over the 8 solved seeds only
    assert out["simulations_iqm"] == pytest.approx(45.0)
    assert out["simulated_seconds_median"] == 45.0 * 60.0
    lo, hi = out["simulations_median_ci"]
    assert lo <= 45.0 <= hi
    text = json.dumps(out, allow_nan=False)
    assert "NaN" not in text


@pytest.mark.parametrize(
    ("sims", "solved"),
    [
        ([5, 6, 7], [False] * 3),
        ([5, 6, 7], [True, False, False]),
        ([4, 4, 4], [True] * 3),
        ([], []),
    ],
)
def test_arm_summary_edge_cases_are_json_without_warnings(
    sims: list[int], solved: list[bool]
) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = stats.arm_summary(_records(sims, solved), rng=np.random.default_rng(0))
    json.dumps(out, allow_nan=False)
    assert out["simulations_median_ci"] is None and out["simulations_note"]
    if any(solved):
        assert out["simulations_median"] == sims[0]
    else:
        assert out["simulations_median"] is None
    if not sims:
        assert out["success_rate"] is None and out["success_rate_ci"] is None


def test_arm_summary_reads_mappings_and_refuses_missing_fields() -> None:
    row = {"success": True, "simulations": 3, "simulated_seconds": 180.0, "trials": 3}
    out = stats.arm_summary([row, row], rng=np.random.default_rng(0))
    assert out["successes"] == 2
    with pytest.raises(ParameterError):
        stats.arm_summary([{"success": True}], rng=np.random.default_rng(0))
    # a row of today's runs.csv: trials only
    old = stats.arm_summary(
        [{"success": True, "trials": 3}, {"success": True, "trials": 5}],
        rng=np.random.default_rng(0),
    )
    assert old["trials_median"] == 4.0 and old["trials_median_ci"] == [3.0, 5.0]
    assert old["simulations_median"] is None and "not recorded" in old["simulations_note"]


def test_compare_arms_pairs_shared_seeds_only() -> None:
    a = {s: s < 13 for s in range(20)}
    b = {s: (s < 5) or s == 19 for s in range(20)}
    out = stats.compare_arms(a, b)
    assert out["same_seeds"] is True
    assert out["fisher"]["successes_a"] == 13 and out["fisher"]["successes_b"] == 6
    assert out["mcnemar"]["only_a"] == 8 and out["mcnemar"]["only_b"] == 1
    # the pairing matters: the paired test sees 8 vs 1 discordant seeds
    assert out["mcnemar"]["p_value"] < out["fisher"]["p_value"]
    apart = stats.compare_arms({0: True, 1: False}, {2: True, 3: True})
    assert apart["mcnemar"] is None and apart["same_seeds"] is False
    json.dumps(out, allow_nan=False)
    with pytest.raises(ParameterError):
        stats.compare_arms({}, b)
