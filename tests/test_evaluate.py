"""pass_probability and ``striatal evaluate``: the noisy success test."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments.evaluate import MAX_DRAWS, check_draws, pass_probability
from striatal.experiments.stats import wilson_interval
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim.rollout import Protocol, TrialRequest, run_trial, simulate

SHORT = Simulation(duration=40.0)


def test_counts_the_learners_success_test_on_the_same_draws(plant: Plant) -> None:
    """Same trials as a plain loop of rollout.run_trial from one seeded generator."""
    ctrl = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
    res = pass_probability(plant, ctrl, SHORT, Protocol(), 25, seed=3)
    rng = np.random.default_rng(3)
    outcomes = [
        run_trial(
            TrialRequest(
                plant, ctrl, SHORT, protocol=Protocol(), trace=np.zeros(6), gamma=0.0, rng=rng
            )
        )
        for _ in range(25)
    ]
    assert res.passes == sum(o.success for o in outcomes)
    assert res.reward_positive == sum(o.reward > 0 for o in outcomes)
    assert res.simulations == 26
    mean = simulate(plant, ctrl, SHORT, protocol=Protocol())
    assert res.simulated_seconds == pytest.approx(
        sum(o.ended_at for o in outcomes) + mean.outcome.ended_at
    )
    assert res.mean_policy_pass == mean.outcome.success
    # the noise matters: not every trial ends the same way
    assert len({o.final_state for o in outcomes}) == 25


def test_same_seed_same_result(plant: Plant) -> None:
    ctrl = Controller()
    a = pass_probability(plant, ctrl, SHORT, Protocol(), 12, seed=5)
    b = pass_probability(plant, ctrl, SHORT, Protocol(), 12, seed=5)
    assert a == b
    assert a.to_dict() == b.to_dict()


def test_printed_sign_never_passes_and_its_interval_starts_at_zero(plant: Plant) -> None:
    ctrl = Controller(balance_sign="chapter")
    res = pass_probability(plant, ctrl, SHORT, Protocol(), 10, seed=0)
    assert res.passes == 0 and not res.mean_policy_pass
    assert res.rate_ci[0] == 0.0
    assert res.rate_ci[1] == pytest.approx(wilson_interval(0, 10).high)
    # trials end early (the 30-s check or a fault): less simulated time than 11 full runs
    assert res.simulated_seconds < 11 * SHORT.duration
    json.dumps(res.to_dict(), allow_nan=False)


def test_chapter_final_mean_policy_passes(plant: Plant) -> None:
    res = pass_probability(plant, Controller(), Simulation(), Protocol(), 3, seed=0)
    assert res.mean_policy_pass
    assert 0 <= res.passes <= 3 and res.rate == res.passes / 3


@pytest.mark.parametrize("draws", [0, -1, 10**12, MAX_DRAWS + 1, 2.5, True, "10", math.nan])
def test_refuses_bad_draws(draws: object, plant: Plant) -> None:
    with pytest.raises(ParameterError, match="draws"):
        check_draws(draws)
    with pytest.raises(ParameterError):
        pass_probability(plant, Controller(), SHORT, Protocol(), draws, 0)  # type: ignore[arg-type]


def test_refuses_a_bad_seed(plant: Plant) -> None:
    with pytest.raises(ParameterError, match="seed"):
        pass_probability(plant, Controller(), SHORT, Protocol(), 1, -3)


def test_cli_json(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["evaluate", "--chapter-initial", "--draws", "4", "--seed", "2", "--duration", "35"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["draws"] == 4 and out["simulations"] == 5
    assert out["gains"] == list(CHAPTER_INITIAL_W) and out["theta_c"] == 0.6
    assert 0.0 <= out["pass_rate_ci"][0] <= out["pass_rate"] <= out["pass_rate_ci"][1] <= 1.0
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "Wilson" in text and "mean policy" in text


def test_cli_reads_a_result(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "result.json"
    path.write_text(json.dumps({"W": list(CHAPTER_INITIAL_W), "theta_c": 0.7, "settings": {}}))
    assert main(["evaluate", "--result", str(path), "--draws", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["theta_c"] == 0.7


@pytest.mark.parametrize(
    "bad",
    [
        ["--draws", "0"],
        ["--draws", "-1"],
        ["--draws", "1e12"],
        ["--draws", "2.5"],
        ["--gains", "nan", "1", "1", "1", "1", "1", "--theta-c", "0.6"],
        ["--gains", "1", "1", "1", "1", "1", "1"],
        ["--chapter-final", "--theta-c", "inf"],
        ["--seed", "-2"],
        ["--duration", "10"],
        ["--result", "/nonexistent/result.json"],
    ],
)
def test_cli_hostile_input_is_one_line_exit_2(bad: list[str]) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "striatal", "evaluate", *bad],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert len(proc.stderr.strip().splitlines()) == 1


def test_help_text_formats(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--help"])
    assert exc.value.code == 0
    assert "Wilson 95 % interval" in " ".join(capsys.readouterr().out.split())
