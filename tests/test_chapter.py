"""The chapter's learner: determinism, alpha = 0, eq 21, guards, checkpoint/resume."""

from __future__ import annotations

import ast
import json
import math
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import cli_process
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from striatal.errors import ParameterError
from striatal.learners import (
    LearnerConfig,
    initial_state,
    learning_step,
    theta_c_rule,
)
from striatal.learners import learn as train
from striatal.learners.chapter import gain_update
from striatal.params import CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.sim.rollout import Protocol, TrialOutcome

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
    expected = cfg.alpha * (1 - cfg.gamma) * rec.reward * np.array(new.get("trace"))
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
    new = gain_update(
        W,
        np.array([-1e9, 1e9, 0, 0, 0, 0]),
        10.0,
        alpha=cfg.alpha,
        gamma=cfg.gamma,
        baseline=0.0,
        max_step=cfg.max_step,
        w1_floor=cfg.w1_floor,
    )
    assert new[0] == cfg.w1_floor
    assert new[1] == pytest.approx(0.5)


@settings(max_examples=200, deadline=None)
@given(
    W=arrays(np.float64, 6, elements=st.floats(-1e3, 1e3)),
    trace=arrays(np.float64, 6, elements=st.floats(-1e6, 1e6)),
    reward=st.floats(-10.0, 10.0),
    alpha=st.floats(0.0, 1e3),
    max_step=st.floats(1e-3, 1e3) | st.just(math.inf),
)
def test_gain_update_equals_numpy_reference(W, trace, reward, alpha, max_step) -> None:
    """Eqs 3-4 on Python's floats give NumPy's elementwise result bit for bit."""
    gamma, baseline, floor = 0.999, 0.25, 1e-3
    step = np.minimum(
        np.maximum(alpha * (1.0 - gamma) * (reward - baseline) * trace, -max_step), max_step
    )
    expected = W + step
    expected[0] = max(expected[0], floor)
    new = gain_update(
        W,
        trace,
        reward,
        alpha=alpha,
        gamma=gamma,
        baseline=baseline,
        max_step=max_step,
        w1_floor=floor,
    )
    np.testing.assert_array_equal(new, expected)
    assert new.dtype == np.float64 and new.shape == (6,)


def test_non_finite_trace_never_reaches_w() -> None:
    W = np.array(CHAPTER_INITIAL_W)
    for bad in (np.nan, np.inf, -np.inf):
        trace = np.array([1.0, bad, 0, 0, 0, 0])
        new = gain_update(
            W, trace, -5.0, alpha=5.0, gamma=0.999, baseline=0.0, max_step=1.0, w1_floor=1e-3
        )
        np.testing.assert_array_equal(new, W)


def test_absurd_alpha_stays_finite() -> None:
    r = train(Plant(), START, LearnerConfig(alpha=1e3, max_trials=40, max_step=math.inf), seed=0)
    assert all(math.isfinite(w) for w in r.W) and r.W[0] > 0
    assert math.isfinite(r.theta_c)


def test_resume_from_state_equals_uninterrupted_run() -> None:
    cfg = LearnerConfig(max_trials=40)
    full = train(Plant(), START, cfg, seed=5)
    half = train(Plant(), START, replace(cfg, max_trials=17), seed=5)
    resumed = train(Plant(), START, cfg, seed=5, state=half)
    assert resumed.W == full.W and resumed.theta_c == full.theta_c
    assert resumed.trials_done == full.trials_done


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


def test_train_cli_writes_result_history_and_resumes(tmp_path: Path) -> None:
    out = tmp_path / "run"
    r = cli_process(
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
    assert r.rc == 0, r.err
    result = json.loads(r.out)
    assert result == json.loads((out / "result.json").read_text())
    for key in ("success", "trials", "W", "theta_c", "seed", "wall_seconds", "settings"):
        assert key in result
    assert result["settings"]["config"]["eligibility"] == "score"
    lines = (out / "history.csv").read_text().splitlines()
    assert lines[0].startswith("trial,reward,W1,W2,W3,W4,W5,W6,theta_c,sigma")
    assert len(lines) == 1 + result["trials"]
    # resuming a finished run changes nothing
    again = cli_process("train", "--resume", "--out", str(out), "--json")
    assert again.rc == 0, again.err
    assert json.loads(again.out)["W"] == result["W"]
    assert (out / "history.csv").read_text().splitlines() == lines


def test_train_cli_truncated_checkpoint_is_a_clear_error(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert cli_process("train", "--max-trials", "5", "--out", str(out)).rc == 0
    ck = out / "checkpoint.json"
    ck.write_text(ck.read_text()[:40])
    r = cli_process("train", "--resume", "--out", str(out))
    assert r.rc == 2
    assert len(r.err.strip().splitlines()) == 1 and "checkpoint" in r.err


# --------------------------------------------------------------------------- Python API

ROOT = Path(__file__).resolve().parents[1]


def without_wall(d: dict[str, object]) -> dict[str, object]:
    return {k: v for k, v in d.items() if k != "wall_seconds"}


def test_python_api_gives_exactly_what_the_cli_gives(tmp_path: Path) -> None:
    """striatal.train(...) == striatal train ... --json: same result, same history rows."""
    code = (
        "import striatal; r = striatal.train(learner='pgpe', init='random', seed=0, "
        "max_trials=300); print(r.trials, r.success)"
    )
    printed = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300
    )
    assert printed.returncode == 0, printed.stderr
    out = tmp_path / "cli"
    r = cli_process(
        *("train", "--learner", "pgpe", "--init", "random", "--seed", "0"),
        *("--max-trials", "300", "--json", "--out", str(out)),
    )
    assert r.rc == 0, r.err
    want = json.loads(r.out)
    assert printed.stdout.split() == [str(want["trials"]), str(want["success"])]
    import striatal

    run = striatal.train(learner="pgpe", init="random", seed=0, max_trials=300)
    assert without_wall(json.loads(json.dumps(run.to_dict()))) == without_wall(want)
    assert run.learner == want["learner"] == want["settings"]["learner"] == "pgpe"
    assert run.settings == want["settings"]
    from_file = striatal.read_history(out / "history.csv")
    assert run.history.columns == from_file.columns
    np.testing.assert_array_equal(run.history.data, from_file.data)
    assert len(run.history) == run.trials


def test_python_api_resumes_a_stopped_run_to_the_uninterrupted_result(tmp_path: Path) -> None:
    import striatal

    full = striatal.train(seed=4, max_trials=25, out=tmp_path / "full", checkpoint_every=3)
    n = {"trials": 0}

    def stop() -> bool:
        n["trials"] += 1
        return n["trials"] == 11

    cut = striatal.train(
        seed=4, max_trials=25, out=tmp_path / "cut", checkpoint_every=3, should_stop=stop
    )
    assert cut.interrupted and cut.trials == 11
    resumed = striatal.train(out=tmp_path / "cut", resume=True)
    assert without_wall(resumed.to_dict()) == without_wall(full.to_dict())
    assert resumed.history == full.history
    assert (tmp_path / "cut" / "history.csv").read_bytes() == (
        tmp_path / "full" / "history.csv"
    ).read_bytes()


def test_learn_returns_its_last_state_and_lets_an_interrupt_through() -> None:
    from striatal.learners import LearnerState, default_config, learn

    seen: list[LearnerState] = []
    config = default_config("pgpe", max_trials=3)
    r = learn(Plant(), START, config, seed=0, on_trial=lambda s, rec: seen.append(s))
    assert isinstance(r, LearnerState) and r == seen[-1] and r.trials_done == len(seen) == 3

    def stop(s: LearnerState, rec: object) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        learn(Plant(), START, config, seed=0, on_trial=stop)


def test_simulate_defaults_are_the_cli_defaults() -> None:
    import striatal

    r = cli_process("simulate", "--json")
    assert r.rc == 0, r.err
    traj = striatal.simulate()
    summary = json.loads(r.out)
    assert summary["success"] is traj.outcome.success is True
    assert summary["final_state"] == list(traj.outcome.final_state)


def test_example_script_trains_and_plots(tmp_path: Path) -> None:
    env = {**os.environ, "STRIATAL_EXAMPLE_TRIALS": "3", "MPLBACKEND": "Agg"}
    r = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "train_pgpe.py"), str(tmp_path / "ex")],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert r.returncode == 0, r.stderr
    assert "explore" in r.stdout and "sigma" not in r.stdout
    for name in ("curves.png", "figure5.png", "history.csv", "result.json"):
        assert (tmp_path / "ex" / name).stat().st_size > 0


# --------------------------------------------------------------------------- layering


def _imports(path: Path) -> set[str]:
    """Every striatal module ``path`` imports, at module level or inside functions."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found |= {f"{node.module}.{a.name}" for a in node.names}
    return {m for m in found if m.split(".")[0] == "striatal"}


def _module_graph() -> dict[str, set[str]]:
    src = ROOT / "src"
    modules = {
        ".".join(p.relative_to(src).with_suffix("").parts).removesuffix(".__init__"): p
        for p in (src / "striatal").rglob("*.py")
    }
    return {m: {i for i in _imports(p) if i in modules and i != m} for m, p in modules.items()}


def test_library_never_imports_the_cli() -> None:
    graph = _module_graph()
    bad = {
        m: sorted(i for i in deps if i.startswith("striatal.cli"))
        for m, deps in graph.items()
        if not m.startswith("striatal.cli") and m != "striatal.__main__"
    }
    assert {m: d for m, d in bad.items() if d} == {}


def test_learner_layer_has_no_import_cycle() -> None:
    """No cycle through learn, learners.*, rundir or training (function-level imports too)."""
    graph = _module_graph()
    ours = [m for m in graph if m.startswith(("striatal.learn", "striatal.io.rundir"))]
    ours.append("striatal.experiments.training")

    def reaches(start: str, goal: str) -> bool:
        seen, todo = set(), [start]
        while todo:
            m = todo.pop()
            for d in graph.get(m, ()):
                if d == goal:
                    return True
                if d not in seen and d != "striatal":
                    seen.add(d)
                    todo.append(d)
        return False

    cycles = [m for m in ours if reaches(m, m)]
    assert cycles == []


# --------------------------------------------------------------------------- run folders


def test_resume_refuses_changed_settings_but_extends_max_trials(tmp_path: Path) -> None:
    import striatal
    from striatal.errors import DataFileError

    out = tmp_path / "run"
    first = striatal.train(seed=1, max_trials=20, out=out)
    assert first.trials == 20 and not first.success
    with pytest.raises(
        ParameterError, match=r"--seed \(the run has 1\), --alpha \(the run has 5.0\)"
    ):
        striatal.train(out=out, resume=True, alpha=3.0, seed=4)
    with pytest.raises(ParameterError, match="may only raise --max-trials"):
        striatal.train(out=out, resume=True, max_trials=10)
    with pytest.raises(ParameterError, match="checkpoint-every"):
        striatal.train(out=out, resume=True, checkpoint_every=0)
    longer = striatal.train(out=out, resume=True, seed=1, max_trials=40)
    assert (longer.trials, longer.success) == (32, True)  # README: seed 1 succeeds after 32
    assert longer.run_id == first.run_id == json.loads((out / "result.json").read_text())["run_id"]
    with striatal.io.rundir.RunDir(out).lock(), pytest.raises(DataFileError, match="in use"):
        striatal.train(out=out, resume=True)


def test_fresh_start_replaces_the_old_runs_files(tmp_path: Path) -> None:
    import striatal

    out = tmp_path / "run"
    striatal.train(seed=1, max_trials=5, out=out)
    old = (out / "result.json").read_text()
    r = striatal.train(seed=2, max_trials=3, out=out, checkpoint_every=100)
    assert (out / "result.json").read_text() != old
    ck = json.loads((out / "checkpoint.json").read_text())
    assert ck["run_id"] == r.run_id and ck["state"]["trials_done"] == 3
    assert r.run_id != json.loads(old)["run_id"]


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_written_files_follow_the_umask(tmp_path: Path, mask: int) -> None:
    from striatal.io.files import write_json

    old = os.umask(mask)
    try:
        write_json(tmp_path / "a.json", {"x": 1})
    finally:
        os.umask(old)
    assert (tmp_path / "a.json").stat().st_mode & 0o777 == 0o666 & ~mask
