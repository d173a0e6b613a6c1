"""Robustness of learned controllers: mismatch plumbing, determinism, files, CLI."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.experiments.robustness import CONDITIONS, controller_groups, evaluate
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim.robust import Perturbation
from striatal.sim.rollout import (
    Protocol,
    SensorNoise,
    TrialOutcome,
    TrialRequest,
    run_trial,
    simulate,
)

FINAL = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)


def mean_policy_trial(
    plant: Plant,
    model: Plant,
    controller: Controller,
    sim: Simulation,
    protocol: Protocol,
    sensor: SensorNoise,
    rng: np.random.Generator | None,
) -> TrialOutcome:
    """The trial robustness.evaluate runs: the rollout's mean-policy trial, no wrapper."""
    return run_trial(
        TrialRequest(
            plant,
            controller,
            sim,
            protocol=protocol,
            trace=np.zeros(6),
            gamma=0.0,
            rng=rng,
            model=model,
            sensor=sensor,
            mean_policy=True,
        )
    )


def test_nominal_run_equals_simulate() -> None:
    sim, protocol = Simulation(), Protocol()
    o = mean_policy_trial(Plant(), Plant(), FINAL, sim, protocol, SensorNoise(), None)
    assert o == simulate(Plant(), FINAL, sim, protocol=protocol).outcome
    assert o.success


def test_the_plant_changes_but_the_model_stays_nominal() -> None:
    sim, protocol = Simulation(duration=5.0), Protocol()
    heavy = Plant().scaled(pole_mass=1.2, length=1.2)
    mismatched = mean_policy_trial(heavy, Plant(), FINAL, sim, protocol, SensorNoise(), None)
    believed = mean_policy_trial(heavy, heavy, FINAL, sim, protocol, SensorNoise(), None)
    expected = simulate(heavy, FINAL, sim, protocol=protocol, model=Plant()).outcome
    assert mismatched == expected
    assert mismatched.final_state != believed.final_state


def test_sensor_noise_is_seeded_and_matters() -> None:
    cond = Perturbation("noisy", x_std=0.05, theta_std=0.05)
    a = evaluate([FINAL], cond, repeats=3, seed=1)
    assert a == evaluate([FINAL], cond, repeats=3, seed=1)
    assert a["runs"] == 3
    assert evaluate([FINAL], CONDITIONS[0])["success"] == 1.0
    # noise of 0.01 rad/m leaves the pole balanced but breaks the 0.005/s rest test
    r = evaluate([FINAL], Perturbation("n", x_std=0.01, theta_std=0.01), repeats=3)
    assert r["balanced"] == 1.0 and r["success"] < 1.0


def test_controller_groups_from_result_and_ablation_files() -> None:
    result = {"W": list(CHAPTER_FINAL_W), "theta_c": 0.9, "settings": {"controller": {}}}
    ((name, ctrls),) = controller_groups(result)
    assert name == "learned" and ctrls[0].gains == CHAPTER_FINAL_W
    runs = [
        {"success": True, "W": list(CHAPTER_FINAL_W), "theta_c": 0.9},
        {"success": False, "W": [1, 0, 0, 0, 0, 0], "theta_c": 0.6},
    ]
    ablation = {"pgpe": {"runs": runs}, "chapter": {"runs": runs[:1]}, "x": {"runs": runs[1:]}}
    groups = controller_groups(ablation)
    assert [(n, len(c)) for n, c in groups] == [("pgpe", 1), ("chapter", 1)]
    assert [n for n, _ in controller_groups(ablation, variants=["chapter"])] == ["chapter"]
    assert controller_groups(ablation, variants=["nope"]) == []
    with pytest.raises(ParameterError):
        controller_groups([1, 2])


def test_cli_table_and_clear_error(tmp_path: Path) -> None:
    f = tmp_path / "result.json"
    f.write_text(json.dumps({"W": list(CHAPTER_FINAL_W), "theta_c": CHAPTER_FINAL_THETA_C}))
    cmd = [sys.executable, "-m", "striatal", "robustness", str(f), "--repeats", "2", "--json"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert {row["group"] for row in rows} == {"learned", "chapter's final gains", "LQR baseline"}
    assert len(rows) == 3 * len(CONDITIONS)
    assert np.isclose(rows[0]["success"], 1.0)
    lqr_nominal = [r for r in rows if r["group"] == "LQR baseline" and r["condition"] == "nominal"]
    assert lqr_nominal[0]["success"] == 1.0  # the LQR-fitted law passes on the nominal plant
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    r = subprocess.run(
        [sys.executable, "-m", "striatal", "robustness", str(bad)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_evaluate_is_the_rollout_mean_policy_trial() -> None:
    """evaluate's verdict on a mismatched plant equals the rollout's own mean-policy trial."""
    heavy = Perturbation("heavy", pole_mass=1.2, length=1.2)
    plant = Plant().scaled(pole_mass=1.2, length=1.2)
    o = mean_policy_trial(plant, Plant(), FINAL, Simulation(), Protocol(), SensorNoise(), None)
    assert evaluate([FINAL], heavy)["success"] == float(o.success)


@pytest.mark.parametrize("runs", ['"x"', "[5]", '[{"success": true, "W": "x", "theta_c": 1}]'])
def test_cli_refuses_an_ablation_json_with_malformed_runs(tmp_path: Path, runs: str) -> None:
    """Issue 16 item 10: one line on stderr and exit 2, not an AttributeError."""
    bad = tmp_path / "ablation.json"
    bad.write_text('{"pgpe": {"runs": ' + runs + "}}")
    r = subprocess.run(
        [sys.executable, "-m", "striatal", "robustness", str(bad)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr


def test_the_margin_set_lies_outside_the_robustness_set_and_is_refused_by_nothing() -> None:
    """Every margin condition is a plant or start that none of the nine robust cases is;
    each runs for every controller (none refused, sensor noise in none), one simulation
    each, counted in the table beside the others."""
    from striatal.experiments.robustness import (
        MARGIN_CONDITIONS,
        MARGIN_DRAWS,
        margin_passes,
        margin_table,
    )
    from striatal.sim.robust import ROBUST_CASES

    def key(c: Perturbation) -> tuple[float, ...]:
        return (c.pole_mass, c.length, c.cart_mass, c.theta0, c.x0)

    assert not {key(c) for c in MARGIN_CONDITIONS} & {key(c) for c in ROBUST_CASES}
    assert len({c.name for c in MARGIN_CONDITIONS}) == len(MARGIN_CONDITIONS)
    assert not any(c.sensor.active for c in MARGIN_CONDITIONS)
    assert sum(c.name.startswith("draw ") for c in MARGIN_CONDITIONS) == MARGIN_DRAWS
    assert {c.cart_mass for c in MARGIN_CONDITIONS} == {0.7, 1.0, 1.3}
    assert Perturbation("c", cart_mass=1.3).plant(Plant()).cart_mass == pytest.approx(1.3)
    chapter = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    bad = Controller((0.001, 0.0, 0.0, 0.0, 0.0, 1.0), 0.6)
    passes = margin_passes([chapter, bad])
    assert passes.shape == (2, len(MARGIN_CONDITIONS))
    assert passes[0].any() and not passes[1].any()  # it can fail, and it can pass
    table, rows = margin_table({"random": {1: chapter, 2: bad}, "other": {1: chapter}})
    assert "| random | 2 |" in table and f"| {2 * len(MARGIN_CONDITIONS)} |" in table
    assert "n = 1" in table  # "other" paired with random on the seed both solved
    assert len(rows) == 2 * len(MARGIN_CONDITIONS)


def test_the_margin_command_reads_sweeps_and_refuses_a_missing_one(tmp_path: Path) -> None:
    """``striatal robustness --margin NAME=SWEEP``: the learner arm under NAME, the rest
    under their names; a path with no runs.csv is one line on stderr and exit 2."""
    from conftest import cli_in_process

    ran = cli_in_process("robustness", "--margin", str(tmp_path / "none"))
    assert ran.rc == 2 and ran.err.count("\n") == 1 and "no such sweep runs.csv" in ran.err
    out = tmp_path / "sweep"
    ran = cli_in_process(
        "sweep",
        "--init",
        "chapter",
        "--seeds",
        "1",
        "--max-trials",
        "1",
        "--learner",
        "forward",
        "--baselines",
        "random",
        "--eval-draws",
        "0",
        "--no-progress",
        "--out",
        str(out),
    )
    assert ran.rc == 0, ran.err
    ran = cli_in_process("robustness", "--margin", f"fwd={out}", "--json")
    assert ran.rc == 0, ran.err
    arms = {row["arm"] for row in json.loads(ran.out)}
    assert arms <= {"fwd", "fwd control", "random"}
