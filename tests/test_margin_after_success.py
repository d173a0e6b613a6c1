"""``margin_after_success``: a run succeeds at its first robust controller exactly as
without the stop margin, then learns on (every trial and check counted) until a
controller also passes the margin's wider corners or the budget ends, and delivers that
one, else the first robust one.

Its success, trials, simulations and seconds to success equal the run without the margin
run for run; the delivered controller is the margin one when one is found; every
simulation after the success is counted; bad mixes are refused in one line.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pytest
from conftest import KernelCounter
from test_robust_stop import ROBUST_THETA_C, ROBUST_W

import striatal
from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments import runs_csv
from striatal.experiments.spec import initial_gains, spawn_seeds
from striatal.learners import LearnerState, default_config, learn
from striatal.learners.loop import delivered, finished
from striatal.params import CHAPTER_INITIAL_THETA_C, Controller, Plant
from striatal.sim.robust import corners_check, stop_check

DT = 0.01
FIXED = dict(alpha=0.0, theta_c_rule="fixed", success_on="mean")


def test_it_is_refused_without_a_stop_margin() -> None:
    for changes in (
        dict(margin_after_success=True),
        dict(robust=True, margin_after_success=True),
        dict(robust=True, stop_margin=0.0, margin_after_success=True),
    ):
        with pytest.raises(ParameterError, match="needs --robust --stop-margin"):
            default_config("pgpe", **changes)
    for learner in ("chapter", "rpe", "pgpe", "ac", "forward"):  # any learner's loop
        config = default_config(learner, robust=True, stop_margin=0.1, margin_after_success=True)
        assert config.margin_after_success


@pytest.mark.parametrize(
    "extra", [["--robust"], ["--stop-margin", "0.1"], []], ids=["no-margin", "no-robust", "none"]
)
def test_the_cli_refuses_it_in_one_line_and_writes_nothing(
    tmp_path: Any, capsys: pytest.CaptureFixture[str], extra: list[str]
) -> None:
    out = tmp_path / "run"
    args = ["train", "--learner", "pgpe", "--margin-after-success", *extra, "--out", str(out)]
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--robust" in err
    assert not out.exists()


def test_a_fixed_robust_controller_counts_the_corners_after_its_success(
    counted: KernelCounter,
) -> None:
    """alpha 0: the controller passes the set (trial 1: its trial, the rerun, the set's
    other 8 cases) and the corners at +-25 % (4 more runs, the run ends); at +-30 % its
    first corner fails, so it learns on: each later trial is its trial, the rerun and
    that corner, until max_trials; it delivers its first robust controller."""
    template = Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)
    kw: dict[str, Any] = dict(robust=True, max_trials=3, margin_after_success=True, **FIXED)
    r = learn(Plant(), template, default_config("chapter", stop_margin=0.05, **kw), seed=1)
    assert r.success and r.margin_reached and r.trials_done == 1
    assert r.first_success is not None and r.first_success.simulations == 1 + 1 + 8
    assert r.simulations == counted.calls == 1 + 1 + 8 + 4
    assert r.simulated_seconds == pytest.approx(counted.steps * DT)
    counted.calls = counted.steps = 0
    r = learn(Plant(), template, default_config("chapter", stop_margin=0.1, **kw), seed=1)
    assert r.success and not r.margin_reached and r.trials_done == 3
    first = r.first_success
    assert first is not None and (first.trials, first.simulations) == (1, 10)
    assert r.simulations == counted.calls == 10 + 1 + 2 * (1 + 1 + 1)
    assert r.simulated_seconds == pytest.approx(counted.steps * DT)
    assert first.simulated_seconds < r.simulated_seconds
    assert tuple(ROBUST_W) == r.W and r.theta_c == ROBUST_THETA_C


@pytest.mark.parametrize("margin", [0.05, 0.1])
def test_pgpe_succeeds_exactly_as_without_the_margin_and_delivers_the_margin_controller(
    counted: KernelCounter, margin: float
) -> None:
    """Root-0 seeds of ``sweep --init random --seed 0``: the first success is the plain
    run's (trial, simulations, seconds, controller); the run's totals count every
    simulation; the delivered controller passes the wider corners and the set when the
    margin was reached, else it is the plain run's."""
    reached = 0
    for seed in spawn_seeds(0, 3):
        template = Controller(gains=initial_gains("random", seed), theta_c=CHAPTER_INITIAL_THETA_C)
        plain = learn(Plant(), template, default_config("pgpe", robust=True, max_trials=120), seed)
        counted.calls = counted.steps = 0
        config = default_config(
            "pgpe", robust=True, stop_margin=margin, margin_after_success=True, max_trials=120
        )
        r = learn(Plant(), template, config, seed)
        assert r.simulations == counted.calls
        assert r.simulated_seconds == pytest.approx(counted.steps * DT)
        assert r.success == plain.success
        if not plain.success:
            assert r.first_success is None and not r.margin_reached
            continue
        first = r.first_success
        assert first is not None
        assert (first.trials, first.simulations) == (plain.trials_done, plain.simulations)
        assert first.simulated_seconds == pytest.approx(plain.simulated_seconds, abs=1e-9)
        assert (first.W, first.theta_c) == (plain.W, plain.theta_c)
        assert r.simulated_seconds > first.simulated_seconds  # the corners, at least
        if r.margin_reached:
            reached += 1
            found = Controller(gains=r.W, theta_c=r.theta_c)
            assert corners_check(found, Plant(), DT, 0.2 + margin).robust
            assert stop_check(found, Plant(), DT).robust
        else:
            assert r.trials_done == 120 and (r.W, r.theta_c) == (plain.W, plain.theta_c)
    assert reached >= 1  # the margin is found on some of these seeds


def test_finished_and_delivered() -> None:
    config = default_config("pgpe", robust=True, stop_margin=0.1, margin_after_success=True)
    start = LearnerState(trials_done=0, W=(1.0,) * 6, theta_c=0.6, rng_state={})
    first = striatal.learners.state.FirstSuccess(
        trials=2, simulations=5, simulated_seconds=30.0, W=(2.0,) * 6, theta_c=0.9
    )
    robust = replace(start, trials_done=4, success=True, first_success=first, simulations=9)
    assert not finished(start, config) and not finished(robust, config)
    assert finished(robust, replace(config, margin_after_success=False))
    assert finished(replace(robust, margin_reached=True), config)
    assert delivered(robust).W == first.W and delivered(robust).theta_c == 0.9
    assert delivered(robust).simulations == 9  # the totals stay
    kept = replace(robust, margin_reached=True)
    assert delivered(kept) is kept and delivered(start) is start


def test_the_state_round_trips_and_refuses_a_first_success_beyond_the_run() -> None:
    template = Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)
    kw: dict[str, Any] = dict(robust=True, max_trials=2, margin_after_success=True, **FIXED)
    r = learn(Plant(), template, default_config("chapter", stop_margin=0.1, **kw), seed=1)
    assert LearnerState.from_dict(r.to_dict()) == r
    bad = r.to_dict()
    bad["first_success"]["trials"] = 3
    with pytest.raises(ParameterError, match="first success"):
        LearnerState.from_dict(bad)


def test_runs_csv_carries_the_first_success_and_the_margin(tmp_path: Any) -> None:
    """A 2-seed sweep with and without the option: the learner rows' first-success
    columns equal the plain sweep's totals; the totals count what came after; the
    settings (and run ids) differ; an older runs.csv reads with its totals."""
    kw: dict[str, Any] = dict(
        learner="pgpe",
        seeds=2,
        init="random",
        robust=True,
        max_trials=100,
        eval_draws=0,
        control=False,
    )
    plain = striatal.sweep(out=tmp_path / "plain", **kw)
    after = striatal.sweep(out=tmp_path / "after", stop_margin=0.1, margin_after_success=True, **kw)
    assert sum(r["success"] for r in plain.runs) == 2  # root 0's first two seeds: 93, 55
    for p, a in zip(plain.runs, after.runs, strict=True):
        assert p["seed"] == a["seed"] and p["success"] == a["success"]
        assert math.isnan(p["margin_reached"]) and a["margin_reached"] in (0.0, 1.0)
        if not p["success"]:
            assert math.isnan(a["first_success_trials"])
            continue
        assert a["first_success_trials"] == p["trials"] == p["first_success_trials"]
        assert a["first_success_simulations"] == p["simulations"]
        assert a["first_success_seconds"] == pytest.approx(p["simulated_seconds"])
        assert a["simulated_seconds"] > a["first_success_seconds"]  # the corners, at least
        assert a["trials"] >= a["first_success_trials"]
    assert plain.summary["arms"] != after.summary["arms"]
    reached = sum(r["margin_reached"] == 1.0 for r in after.runs if r["arm"] == "learner")
    learner = next(a for a in after.summary["arms"] if a["arm"] == "learner")
    assert learner["margin_reached_total"] == reached
    assert learner["seconds_after_first_success_total"] > 0.0
    assert f"learner {reached}" in after.summary["notes"][-1]
    assert not any("margin_after_success" in n for n in plain.summary["notes"])
    header = ",".join(runs_csv.RUN_COLUMNS)
    old = (tmp_path / "plain" / "runs.csv").read_text().splitlines()
    cut = [",".join(line.split(",")[:-4]) for line in old[1:]]
    older = tmp_path / "older.csv"
    older.write_text("\n".join([",".join(runs_csv.COLUMNS_BEFORE_FIRST_SUCCESS), *cut]) + "\n")
    rows, text = runs_csv.read_runs(older)
    assert text.splitlines()[0] == header
    assert len(rows) == len(plain.runs)
    for row in rows:
        assert math.isnan(row["margin_reached"])
        if row["success"]:
            assert row["first_success_seconds"] == pytest.approx(row["simulated_seconds"])
            assert row["first_success_trials"] == row["trials"]
