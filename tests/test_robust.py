"""The robustness set of issue 15 (:mod:`striatal.sim.robust`) and ``--robust`` on the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from striatal.cli import main
from striatal.experiments.baselines import lqr_controller
from striatal.params import Controller, Hardware, Plant, Simulation
from striatal.sim.robust import ROBUST_CASES, check_robust, run_case
from striatal.sim.rollout import simulate

CORNER = "pole mass x1.2, length x0.8"


@pytest.fixture(scope="module")
def chapter_report():  # type: ignore[no-untyped-def]
    return check_robust(Controller())


def test_the_set_has_nine_cases_as_the_issue_lists() -> None:
    names = [c.name for c in ROBUST_CASES]
    assert len(names) == len(set(names)) == 9
    corners = {(c.pole_mass, c.length) for c in ROBUST_CASES if c.pole_mass != 1.0}
    assert corners == {(0.8, 0.8), (0.8, 1.2), (1.2, 0.8), (1.2, 1.2)}
    starts = {(c.theta0, c.x0) for c in ROBUST_CASES if c.pole_mass == 1.0 and c.length == 1.0}
    assert starts == {
        (3.12, 0.0),
        (math.pi - 0.3, 0.0),
        (math.pi + 0.3, 0.0),
        (3.12, -0.5),
        (3.12, 0.5),
    }


def test_chapter_final_fails_only_the_heavy_short_corner(chapter_report) -> None:  # type: ignore[no-untyped-def]
    """Issue 15: the chapter's final W fails one corner, pole mass x1.2 and length x0.8."""
    assert chapter_report.simulations == 9
    assert not chapter_report.robust
    assert chapter_report.failed == (CORNER,)
    nominal = chapter_report.cases[0]
    assert nominal.case.name == "nominal" and nominal.success
    assert nominal.max_abs_x == pytest.approx(8.66, abs=0.01)  # force held (paper-notes 9)


def test_a_case_is_the_force_hold_run_with_the_nominal_model() -> None:
    """run_case equals simulate with the scaled true plant, the nominal model, force held."""
    case = next(c for c in ROBUST_CASES if c.name == CORNER)
    r = run_case(Controller(), case)
    traj = simulate(
        Plant().scaled(pole_mass=1.2, length=0.8),
        Controller(),
        Simulation(),
        model=Plant(),
        hardware=Hardware(hold="force"),
    )
    assert r.final_state == traj.outcome.final_state
    assert r.max_abs_x == traj.outcome.max_abs_x and not r.success
    # the controller keeps its model: with the model = the true plant the run differs
    own = simulate(
        Plant().scaled(pole_mass=1.2, length=0.8),
        Controller(),
        Simulation(),
        hardware=Hardware(hold="force"),
    )
    assert own.outcome.final_state != traj.outcome.final_state


def test_mirror_starts_give_mirror_runs(chapter_report) -> None:  # type: ignore[no-untyped-def]
    """theta0 = pi -/+ 0.3 are mirror images; the odd controller gives mirrored runs."""
    a, b = (c for c in chapter_report.cases if c.case.name.startswith("theta0"))
    assert a.max_abs_x == pytest.approx(b.max_abs_x, rel=1e-9)
    np.testing.assert_allclose(a.final_state, -np.array(b.final_state), atol=1e-9)


def test_a_track_and_a_force_limit_apply_to_every_case() -> None:
    report = check_robust(Controller(), track=5.0)
    assert report.hardware == Hardware(hold="force", track=5.0)
    for c in report.cases:
        assert c.max_abs_x <= 5.0 or c.end_reason == "track"
    assert any(c.end_reason == "track" for c in report.cases)
    limited = check_robust(Controller(), max_force=5.0)
    assert all(c.max_abs_force <= 5.0 for c in limited.cases)


#: docs/results.md, "Robust from any start": the lqr column, (passes, max |x| [m],
#: max |force| [N]) per case, force held.
LQR_VERDICTS = {
    "nominal": (True, 4.59, 29.6),
    "pole mass x0.8, length x0.8": (True, 4.03, 27.9),
    "pole mass x0.8, length x1.2": (True, 1.60, 15.4),
    "pole mass x1.2, length x0.8": (False, 0.174, 2.95),
    "pole mass x1.2, length x1.2": (True, 1.95, 16.9),
    "theta0 = pi - 0.3": (True, 2.34, 19.5),
    "theta0 = pi + 0.3": (True, 2.34, 19.5),
    "x0 = -0.5 m": (True, 3.78, 26.0),
    "x0 = +0.5 m": (True, 2.32, 18.5),
}


def test_lqr_baseline_gives_the_documented_verdict_in_every_case() -> None:
    """The LQR arm (fitted W1..W3, the chapter's W4..W6 and theta_c): docs/results.md's
    verdict, max |x| and max |force| case by case; it fails only the heavy short corner."""
    W, theta_c = lqr_controller(Plant())
    report = check_robust(Controller(gains=W, theta_c=theta_c))
    assert [c.case.name for c in report.cases] == list(LQR_VERDICTS)
    for c in report.cases:
        passes, max_x, max_force = LQR_VERDICTS[c.case.name]
        assert c.success is passes, c.case.name
        assert c.max_abs_x == pytest.approx(max_x, abs=0.006), c.case.name
        assert c.max_abs_force == pytest.approx(max_force, abs=0.06), c.case.name
    assert report.failed == (CORNER,) and not report.robust


def test_simulate_robust_prints_a_table_and_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--robust"]) == 0
    out = capsys.readouterr().out
    assert "robust: no (failed: pole mass x1.2, length x0.8)" in out
    rows = [
        line for line in out.splitlines() if line.startswith(("nominal", "pole", "theta", "x0"))
    ]
    assert len(rows) == 9
    assert main(["simulate", "--robust", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["robust"] is False and data["failed"] == [CORNER]
    assert len(data["cases"]) == 9 and data["simulations"] == 9
    assert data["hardware"]["hold"] == "force"
    assert {"case", "success", "max_abs_x", "max_abs_force", "end_reason"} <= set(data["cases"][0])


def test_evaluate_robust_reports_the_verdict(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", "--robust"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("robust: no")
    assert f"cases failed: {CORNER}" in out
    assert main(["evaluate", "--robust", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["failed"] == [CORNER]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["simulate", "--robust", "--hold", "u"], "always holds the force"),
        (["simulate", "--robust", "--x0", "1"], "drop --x0"),
        (["simulate", "--robust", "--duration", "10"], "drop --duration"),
        (["simulate", "--robust", "--out", "somewhere"], "drop --out"),
        (["simulate", "--max-force", "0"], "max_force"),
        (["simulate", "--track", "-1"], "track"),
        (["evaluate", "--robust", "--theta0", "3"], "drop --theta0"),
    ],
)
def test_bad_robust_options_exit_2_with_one_line(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_simulate_hold_force_and_track_options(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--hold", "force", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["max_abs_x"] == pytest.approx(8.66, abs=0.01)
    assert data["settings"]["hardware"] == {"hold": "force", "max_force": None, "track": None}
    assert main(["simulate", "--track", "4", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["end_reason"] == "track" and data["success"] is False


def test_pass_probability_runs_its_trials_on_the_hardware_given() -> None:
    """evaluate's trials take the motor and track: a 4-m track fails the mean policy
    (final W reaches |x| = 6 m) and every noisy trial that goes as far."""
    from striatal.experiments.evaluate import pass_probability
    from striatal.sim.rollout import Protocol

    free = pass_probability(Plant(), Controller(), Simulation(), Protocol(), 5, 0)
    track = pass_probability(
        Plant(), Controller(), Simulation(), Protocol(), 5, 0, hardware=Hardware(track=4.0)
    )
    assert free.mean_policy_pass and not track.mean_policy_pass
    assert track.simulated_seconds < free.simulated_seconds


def test_evaluate_prints_the_motor(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", "--draws", "2", "--hold", "force", "--track", "20"]) == 0
    assert "motor: force held; max force: none; track: 20 m" in capsys.readouterr().out


def test_a_report_states_the_success_test_it_applied(chapter_report) -> None:  # type: ignore[no-untyped-def]
    from striatal.params import SuccessTest

    stated = chapter_report.to_dict()["success_test"]
    assert stated == "|theta|<0.05, |x|<0.05, |theta_dot|<0.005, |x_dot|<0.005 at T_f"
    assert str(SuccessTest(theta=0.1, x_dot=0.02)) == (
        "|theta|<0.1, |x|<0.05, |theta_dot|<0.005, |x_dot|<0.02 at T_f"
    )
    # the sentence is the test: a state just inside every bound passes, one outside fails
    test = SuccessTest()
    assert test.passed(np.array([0.049, 0.0049, 0.049, 0.0049]))
    assert not test.passed(np.array([0.0, 0.0051, 0.0, 0.0]))


def test_a_case_with_sensor_noise_is_refused_not_run_without_it() -> None:
    from striatal.errors import ParameterError
    from striatal.sim.robust import Perturbation

    noisy = Perturbation("noisy", x_std=0.01, theta_std=0.01)
    with pytest.raises(ParameterError, match="sensor noise"):
        run_case(Controller(), noisy)
    with pytest.raises(ParameterError, match="sensor noise"):
        check_robust(Controller(), cases=(ROBUST_CASES[0], noisy))
