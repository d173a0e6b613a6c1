"""The robust stop rule of issue 15: learners and searches that wait for robustness.

Every simulation the rule runs is counted (kernel calls counted by monkeypatching the
kernel), a controller that passes the nominal test but not the set does not stop a
run, the nominal case is not rerun only when the success test's run already was it,
a robust run resumes to the uninterrupted one, and ``sweep --robust`` writes its fields.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import KernelCounter

import striatal
from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments import baselines
from striatal.learners import default_config, learn
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim.robust import (
    ROBUST_CASES,
    ROBUST_HARDWARE,
    STOP_ORDER,
    check_robust,
    nominal_is_the_case,
    run_case,
    stop_check,
)
from striatal.sim.rollout import Protocol, TrialRequest, run_trial

DT = 0.01
#: A controller pgpe learned with ``--robust`` (train --learner pgpe --robust --init
#: random --seed 0): robust.
ROBUST_W = (
    2.1263782943804586,
    -0.23835975856782232,
    -0.7555898236586254,
    3.8082899510490504,
    4.5445603658432345,
    -0.5271986094008383,
)
ROBUST_THETA_C = 1.0087997898263552


def _controllers() -> list[Controller]:
    return [
        Controller(),  # the chapter's final W: fails one corner
        Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C),  # robust
        Controller(gains=(0.5, -0.3, -1.0, 0.2, 0.1, 0.0), theta_c=0.6),  # fails at once
    ]


def test_the_stop_order_runs_every_case_once() -> None:
    assert sorted(STOP_ORDER) == list(range(len(ROBUST_CASES)))
    assert STOP_ORDER[-1] == 0  # nominal last


@pytest.mark.parametrize("index", range(3))
def test_stop_check_gives_check_robusts_verdict_and_counts_its_runs(
    index: int, counted: KernelCounter
) -> None:
    c = _controllers()[index]
    report = check_robust(c)
    counted.calls = counted.steps = 0
    verdict = stop_check(c, Plant(), DT)
    assert verdict.robust == report.robust
    assert verdict.simulations == counted.calls
    assert verdict.simulated_seconds == pytest.approx(counted.seconds())
    if report.robust:
        assert verdict.simulations == 9 and verdict.failed is None
        assert verdict.simulated_seconds == pytest.approx(9 * 60.0)
    else:
        # it stops at the first failing case of STOP_ORDER
        first = next(i for i in STOP_ORDER if not report.cases[i].success)
        assert verdict.failed == ROBUST_CASES[first].name
        assert verdict.simulations == STOP_ORDER.index(first) + 1
    skipped = stop_check(c, Plant(), DT, nominal_passed=True)
    if report.robust:
        assert skipped.robust and skipped.simulations == 8


def test_the_robust_controller_is_robust_and_the_chapters_is_not() -> None:
    assert check_robust(Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)).robust
    assert not stop_check(Controller(), Plant(), DT).robust


@pytest.mark.parametrize("index", range(3))
def test_a_passing_protocol_trial_with_the_force_held_is_the_nominal_case(index: int) -> None:
    """Why the nominal case is not rerun: the eq-24 check only ends a trial early, so a
    trial that passes under it ends exactly where the case (no check) ends."""
    c = _controllers()[index]
    trial = run_trial(
        TrialRequest(
            Plant(),
            c,
            Simulation(),
            protocol=Protocol(),
            trace=np.zeros(6),
            gamma=0.0,
            rng=None,
            hardware=ROBUST_HARDWARE,
        )
    )
    case = run_case(c, ROBUST_CASES[0])
    if trial.success:
        assert case.success and case.final_state == trial.final_state
    assert nominal_is_the_case(Simulation())
    assert not nominal_is_the_case(Simulation(duration=30.0))
    assert not nominal_is_the_case(Simulation(theta0=3.0))
    assert not nominal_is_the_case(Simulation(), action_every=2)


def test_learn_counts_every_kernel_call_of_the_robust_stop_rule(counted: KernelCounter) -> None:
    config = default_config("pgpe", robust=True, max_trials=40)
    template = Controller(gains=(0.6, -0.4, -0.9, 0.9, 0.1, -1.2), theta_c=0.6)
    result = learn(Plant(), template, config, seed=3)
    assert result.simulations == counted.calls
    assert result.simulated_seconds == pytest.approx(counted.seconds())
    # the candidates that passed the nominal test were checked: more runs than trials
    assert counted.calls >= result.trials_done


def test_a_candidate_that_passes_the_nominal_test_but_not_the_set_does_not_stop_the_run(
    counted: KernelCounter,
) -> None:
    """The chapter's final W never changes (alpha 0, theta_c fixed): it passes the
    nominal test every trial (force held) and fails the heavy short corner, STOP_ORDER's
    first case. Without --robust it stops at trial 1; with it, it runs to max_trials,
    each trial costing the trial, the mean-policy rerun and the one failing case."""
    template = Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
    changes = dict(alpha=0.0, theta_c_rule="fixed", success_on="mean", max_trials=4)
    plain = learn(Plant(), template, default_config("chapter", **changes), seed=1)
    assert plain.success and plain.trials_done == 1
    counted.calls = 0
    robust = learn(Plant(), template, default_config("chapter", robust=True, **changes), seed=1)
    assert not robust.success and robust.trials_done == 4
    assert robust.simulations == counted.calls == 4 * 3
    assert ROBUST_CASES[STOP_ORDER[0]].name == "pole mass x1.2, length x0.8"


def test_a_robust_candidate_stops_the_run_with_the_robust_controller(
    counted: KernelCounter,
) -> None:
    template = Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)
    changes = dict(alpha=0.0, theta_c_rule="fixed", success_on="mean", max_trials=4)
    r = learn(Plant(), template, default_config("chapter", robust=True, **changes), seed=1)
    # trial 1 (noisy), its mean-policy rerun = the nominal case, then the other 8 cases
    assert r.success and r.trials_done == 1
    assert r.simulations == counted.calls == 1 + 1 + 8
    assert r.W == ROBUST_W


def test_robust_is_stored_in_the_settings_and_changes_the_run_id(tmp_path: Path) -> None:
    kw = dict(learner="pgpe", init="random", seed=0, max_trials=2)
    plain = striatal.train(**kw)  # type: ignore[arg-type]
    robust = striatal.train(robust=True, **kw)  # type: ignore[arg-type]
    assert "robust" not in plain.settings["config"]  # runs without it keep their ids
    assert robust.settings["config"]["robust"] is True
    assert "force" in robust.settings["integrator"]
    assert robust.run_id != plain.run_id
    assert robust.to_dict()["robust"]["simulations"] == 9
    assert "robust" not in plain.to_dict()


def test_resume_of_a_robust_run_equals_the_uninterrupted_run(tmp_path: Path) -> None:
    kw = dict(learner="pgpe", init="random", seed=5, robust=True)
    whole = striatal.train(max_trials=30, **kw)  # type: ignore[arg-type]
    first = striatal.train(out=tmp_path, max_trials=12, checkpoint_every=4, **kw)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="--robust"):
        striatal.train(out=tmp_path, resume=True, robust=False)
    resumed = striatal.train(out=tmp_path, resume=True, max_trials=30)
    assert resumed.settings["config"]["robust"] is True
    assert resumed.state == whole.state
    assert resumed.history == whole.history
    assert resumed.run_id == first.run_id  # the run id is of the run's starting settings
    assert json.loads((tmp_path / "result.json").read_text())["simulations"] == (
        whole.state.simulations
    )


def test_train_robust_from_w1_below_zero_gives_a_controller_simulate_robust_passes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 15: from any starting gains, W1 <= 0 included; the learned controller passes
    ``striatal simulate --robust`` again."""
    start = ["-0.5", "0.3", "-0.2", "0.8", "-0.6", "0.1"]
    options = "--learner pgpe --robust --seed 2 --max-trials 300 --json --no-progress"
    code = main(["train", *options.split(), "--init-gains", *start])
    assert code == 0
    result = json.loads(capsys.readouterr().out)
    assert result["success"] and result["robust"]["robust"]
    assert result["settings"]["w1_floored_from"] == -0.5
    gains = [str(w) for w in result["W"]]
    code = main(["simulate", "--robust", "--gains", *gains, "--theta-c", str(result["theta_c"])])
    assert code == 0
    assert "robust: yes" in capsys.readouterr().out


@pytest.mark.parametrize("method", ["random", "cmaes"])
def test_the_searches_count_every_run_of_the_robust_stop_rule(
    method: str, counted: KernelCounter
) -> None:
    template = Controller(gains=(0.6, -0.4, -0.9, 0.9, 0.1, -1.2), theta_c=0.6)
    budget = baselines.Budget(60, "mean", robust=True)
    if method == "random":
        out = baselines.random_search(Plant(), template, Simulation(), 7, budget)
    else:
        out = baselines.cmaes(Plant(), template, Simulation(), template.gains, 0.6, 7, budget)
    assert out["simulations"] == counted.calls
    assert out["simulated_seconds"] == pytest.approx(counted.seconds())
    assert out["trials"] <= out["simulations"]
    if out["success"]:
        found = Controller(gains=out["W"], theta_c=out["theta_c"])
        assert check_robust(found).robust


def test_a_fixed_controller_that_is_not_robust_is_unsolved_after_one_check() -> None:
    template = Controller()
    out = baselines.fixed_controller(
        Plant(),
        template,
        Simulation(),
        CHAPTER_FINAL_W,
        CHAPTER_FINAL_THETA_C,
        0,
        baselines.Budget(50, "mean", robust=True),
    )
    assert not out["success"] and out["trials"] == 50 and out["simulations"] == 2
    plain = baselines.fixed_controller(
        Plant(),
        template,
        Simulation(),
        CHAPTER_FINAL_W,
        CHAPTER_FINAL_THETA_C,
        0,
        baselines.Budget(50, "mean"),
    )
    assert plain["success"] and plain["simulations"] == 1


def test_sweep_robust_writes_the_fields(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sweep"
    options = "--init random --seeds 2 --learner pgpe --robust --max-trials 6"
    options += " --baselines random,cmaes --eval-draws 0 --json --no-progress"
    code = main(["sweep", *options.split(), "--out", str(out)])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert {r["arm"] for r in rows} == {"learner", "control", "random", "cmaes"}
    assert len(rows) == 8
    for r in rows:
        assert r["robust"] in ("0", "1", "0.0", "1.0")
        assert int(r["simulations"]) >= int(r["trials"])
        # the robust re-check of the final gains is evaluation: 9 runs beside the re-simulation
        assert int(r["eval_simulations"]) == 10
    settings = json.loads((out / "sweep.json").read_text())
    assert "robust" in settings
    for arm in settings["arms"].values():
        assert arm["config"]["robust"] is True
    for arm in summary["arms"]:
        assert math.isfinite(arm["robust_rate"])
    # and a sweep without it has an empty robust column and no robust setting
    plain = tmp_path / "plain"
    options = "--init random --seeds 1 --learner pgpe --max-trials 2 --eval-draws 0"
    main(
        ["sweep", *options.split(), "--no-control", "--json", "--no-progress", "--out", str(plain)]
    )
    capsys.readouterr()
    assert [r["robust"] for r in csv.DictReader((plain / "runs.csv").open())] == [""]
    assert "robust" not in json.loads((plain / "sweep.json").read_text())


def test_robust_applies_the_rules_robust_preset_under_the_options_given() -> None:
    c = default_config("pgpe", robust=True)
    assert (c.plant_jitter, c.alpha) == (0.2, 0.5)
    given = default_config("pgpe", robust=True, alpha=0.3, plant_jitter=0.0)
    assert (given.plant_jitter, given.alpha) == (0.0, 0.3)
    assert default_config("pgpe").plant_jitter == 0.0  # not without --robust
    assert default_config("chapter", robust=True) == default_config("chapter").__class__(
        **{**default_config("chapter").to_dict(), "robust": True}
    )
    # the control switches learning off and keeps the jittered plants
    from striatal.learners import control_config

    ctrl = control_config(c)
    assert (ctrl.alpha, ctrl.sigma_rate, ctrl.plant_jitter, ctrl.robust) == (0.0, 0.0, 0.2, True)


def test_a_robust_sweep_reruns_in_its_folder_and_skips_its_finished_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """sweep.json's robust entry is the rule's note (text): a rerun reads it back."""
    out = tmp_path / "sweep"
    options = "--init random --seeds 1 --learner pgpe --robust --max-trials 2 --eval-draws 0"
    argv = ["sweep", *options.split(), "--no-control", "--no-progress", "--out", str(out)]
    assert main(argv) == 0
    rows = (out / "runs.csv").read_text()
    assert isinstance(json.loads((out / "sweep.json").read_text())["robust"], str)
    capsys.readouterr()
    assert main(argv) == 0
    assert "1 already in --out" in capsys.readouterr().out
    assert (out / "runs.csv").read_text() == rows
