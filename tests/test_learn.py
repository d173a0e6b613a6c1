"""The chapter's learner: determinism, alpha = 0, eq 21, guards, checkpoint/resume."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.learn import (
    LearnerConfig,
    gain_update,
    initial_state,
    learning_step,
    theta_c_rule,
    train,
)
from striatal.params import CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.rollout import Protocol, TrialOutcome

START = Controller(CHAPTER_INITIAL_W, 0.6)


def outcome(min_swing: float, min_all: float = 0.0) -> TrialOutcome:
    return TrialOutcome(
        reward=-5.0,
        ended_at=60.0,
        final_state=(0.0, 0.0, 0.0, 0.0),
        min_abs_theta_swingup=min_swing,
        min_abs_theta=min_all,
        fault=False,
        early=False,
        n_switches=0,
        max_abs_x=0.0,
        max_abs_force=0.0,
        success=False,
    )


def test_same_seed_same_history() -> None:
    cfg = LearnerConfig(max_trials=15)
    runs = []
    for _ in range(2):
        rows: list[list[object]] = []
        r = train(
            Plant(), START, cfg, seed=3, on_trial=lambda s, rec, rows=rows: rows.append(rec.row())
        )
        runs.append((r.W, r.theta_c, rows))
    assert runs[0] == runs[1]
    other: list[list[object]] = []
    train(Plant(), START, cfg, seed=4, on_trial=lambda s, rec: other.append(rec.row()))
    assert other != runs[0][2]


def test_alpha_zero_leaves_gains_unchanged() -> None:
    r = train(Plant(), START, LearnerConfig(alpha=0.0, max_trials=30), seed=1)
    assert START.gains == r.W


def test_learning_changes_gains_in_the_direction_of_the_rewarded_trace() -> None:
    cfg = LearnerConfig(alpha=1.0, max_trials=1, max_step=math.inf)
    state = initial_state(START.gains, 0.6, seed=2)
    new, rec = learning_step(state, Plant(), START, Simulation(), Protocol(), cfg)
    step = np.array(new.W) - np.array(state.W)
    expected = cfg.alpha * (1 - cfg.gamma) * rec.reward * np.array(new.trace)
    np.testing.assert_allclose(step, expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    ("min_swing", "rule", "theta_c", "expected"),
    [
        (0.91, "swingup", 0.6, 0.91),
        (1.39, "swingup", 0.8, 1.39),
        (1.41, "swingup", 0.8, 0.6),
        (math.inf, "swingup", 0.8, 0.6),
        (0.91, "fixed", 0.7, 0.7),
    ],
)
def test_theta_c_rule_eq21(min_swing: float, rule: str, theta_c: float, expected: float) -> None:
    assert theta_c_rule(outcome(min_swing), theta_c, rule) == pytest.approx(expected)  # type: ignore[arg-type]


def test_theta_c_rule_whole_trial_is_floored() -> None:
    assert theta_c_rule(outcome(1.0, 1e-9), 0.6, "trial") == pytest.approx(0.01)


def test_w1_floor_and_update_bound() -> None:
    cfg = LearnerConfig(alpha=1e3, max_step=0.5)
    W = np.array([0.01, 0, 0, 0, 0, 0], dtype=float)
    new = gain_update(W, np.array([-1e9, 1e9, 0, 0, 0, 0]), 10.0, cfg)
    assert new[0] == cfg.w1_floor
    assert new[1] == pytest.approx(0.5)


def test_non_finite_trace_never_reaches_w() -> None:
    W = np.array(CHAPTER_INITIAL_W)
    for bad in (np.nan, np.inf, -np.inf):
        trace = np.array([1.0, bad, 0, 0, 0, 0])
        np.testing.assert_array_equal(gain_update(W, trace, -5.0, LearnerConfig()), W)


def test_absurd_alpha_stays_finite() -> None:
    r = train(Plant(), START, LearnerConfig(alpha=1e3, max_trials=40, max_step=math.inf), seed=0)
    assert all(math.isfinite(w) for w in r.W) and r.W[0] > 0
    assert math.isfinite(r.theta_c)


def test_resume_from_state_equals_uninterrupted_run() -> None:
    cfg = LearnerConfig(max_trials=40)
    full = train(Plant(), START, cfg, seed=5)
    half = train(Plant(), START, replace(cfg, max_trials=17), seed=5)
    resumed = train(Plant(), START, cfg, seed=5, state=half.state)
    assert resumed.W == full.W and resumed.theta_c == full.theta_c
    assert resumed.trials == full.trials


def test_invalid_configs_raise() -> None:
    for kw in (
        {"alpha": -1.0},
        {"gamma": 1.0},
        {"gamma": math.nan},
        {"max_trials": 0},
        {"action_every": 0},
        {"max_step": 0.0},
        {"success_on": "x"},
    ):
        with pytest.raises(ParameterError):
            LearnerConfig(**kw)  # type: ignore[arg-type]


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "striatal", *args], capture_output=True, text=True, timeout=300
    )


def test_train_cli_writes_result_history_and_resumes(tmp_path: Path) -> None:
    out = tmp_path / "run"
    r = cli(
        "train",
        "--seed",
        "1",
        "--max-trials",
        "30",
        "--checkpoint-every",
        "7",
        "--out",
        str(out),
        "--json",
    )
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result == json.loads((out / "result.json").read_text())
    for key in ("success", "trials", "W", "theta_c", "seed", "wall_seconds", "settings"):
        assert key in result
    assert result["settings"]["config"]["eligibility"] == "score"
    lines = (out / "history.csv").read_text().splitlines()
    assert lines[0].startswith("trial,reward,W1,W2,W3,W4,W5,W6,theta_c,sigma")
    assert len(lines) == 1 + result["trials"]
    # resuming a finished run changes nothing
    again = cli("train", "--resume", "--out", str(out), "--json")
    assert again.returncode == 0, again.stderr
    assert json.loads(again.stdout)["W"] == result["W"]
    assert (out / "history.csv").read_text().splitlines() == lines


def test_train_cli_truncated_checkpoint_is_a_clear_error(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert cli("train", "--max-trials", "5", "--out", str(out)).returncode == 0
    ck = out / "checkpoint.json"
    ck.write_text(ck.read_text()[:40])
    r = cli("train", "--resume", "--out", str(out))
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "checkpoint" in r.stderr
