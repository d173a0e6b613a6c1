"""The benchmark runs and reports finite rates; the batched kernel equals the scalar one.

The harness is the package :mod:`striatal.bench`; it runs from an installed package,
with no benchmarks/ folder beside it.

No speed thresholds here: timings depend on the machine (docs/performance.md has them).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numba
import numpy as np
import pytest

import striatal
from striatal.bench import QUICK, BenchConfig, Timing, anchors
from striatal.bench.measure import run_sweep
from striatal.bench.timing import linear_fit
from striatal.cli import main
from striatal.errors import ParameterError
from striatal.params import CHAPTER_FINAL_W, CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.sim import bench, kernel
from striatal.sim.rollout import Protocol, TrialRequest, batch_args

SIM = Simulation(duration=35.0)  # past the 30-s check of eq 24
PROTOCOL = Protocol()


def _positive_finite(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) and x > 0


def _request(state0: np.ndarray, W: np.ndarray, theta_c: float) -> TrialRequest:
    controller = Controller(theta_c=float(theta_c))
    return TrialRequest(Plant(), controller, SIM, PROTOCOL, gains=W, state0=state0, gamma=0.999)


def _scalar(
    state0: np.ndarray, W: np.ndarray, theta_c: float, noise: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    args = _request(state0, W, theta_c).args(noise)
    kernel.run_trial(*args)
    return args[-1].out, args[-2].trace


def _batch(
    states0: np.ndarray, W: np.ndarray, theta_c: np.ndarray, noise: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    args = batch_args([_request(states0[b], W[b], theta_c[b]) for b in range(len(W))], noise)
    kernel.run_trials_batch(*args)
    return args[-1], args[-2].trace


def _mixed_rows(rng: np.random.Generator, B: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows that succeed, fail at the check, and fault (RK4 unstable, or NaN from sqrt(W1 g))."""
    W = np.empty((B, 6))
    W[:] = CHAPTER_FINAL_W
    W[1::4] = CHAPTER_INITIAL_W
    W[2::4, 4] = 1.0e4  # swing-up cart gain far beyond RK4's stability at dt = 0.01 s
    W[3::4, 0] = -1.0  # sqrt of a negative W1 g once balancing: a NaN state
    W += rng.normal(0.0, 0.01, W.shape) * (np.abs(W) < 100)
    theta_c = rng.uniform(0.5, 1.0, B)
    states0 = np.tile(SIM.initial_state, (B, 1))
    states0[:, 2] += rng.uniform(-0.05, 0.05, B)
    return states0, W, theta_c


def test_mixed_batch_equals_scalar_kernel_bit_for_bit() -> None:
    rng = np.random.default_rng(2024)
    B = 8
    states0, W, theta_c = _mixed_rows(rng, B)
    noise = np.random.default_rng(7).standard_normal((B, SIM.n_steps))
    outs, traces = _batch(states0, W, theta_c, noise)
    for b in range(B):
        out, trace = _scalar(states0[b], W[b], theta_c[b], noise[b])
        np.testing.assert_array_equal(outs[b], out)
        np.testing.assert_array_equal(traces[b], trace)
    faults = outs[:, kernel.OUT_FAULT]
    # the batch really is mixed: faulting rows beside rows that ran to an end
    assert faults[2::4].all() and faults[3::4].all()
    assert not faults[0::4].any()
    assert set(np.unique(outs[:, kernel.OUT_REWARD])) <= {10.0, -5.0}


@pytest.mark.parametrize("chunk", [0, 2])
def test_parallel_batch_rows_equal_serial_rows(chunk: int) -> None:
    """The batch kernel's rows do not depend on its threads: one thread (serial), two,
    static (chunk 0) or dynamic chunks (the engines' CHUNK), and the scalar kernel."""
    rng = np.random.default_rng(11)
    B = 12
    states0, W, theta_c = _mixed_rows(rng, B)
    noise = np.random.default_rng(5).standard_normal((B, SIM.n_steps))
    threads, old = numba.get_num_threads(), numba.set_parallel_chunksize(chunk)
    rows = []
    try:
        for n in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            numba.set_num_threads(n)
            rows.append(_batch(states0, W, theta_c, noise))
    finally:
        numba.set_num_threads(threads)
        numba.set_parallel_chunksize(old)
    for outs, traces in rows[1:]:
        np.testing.assert_array_equal(outs, rows[0][0])
        np.testing.assert_array_equal(traces, rows[0][1])
    for b in range(B):
        out, trace = _scalar(states0[b], W[b], theta_c[b], noise[b])
        np.testing.assert_array_equal(rows[0][0][b], out)
        np.testing.assert_array_equal(rows[0][1][b], trace)


def test_mean_policy_batch_equals_scalar_kernel() -> None:
    rng = np.random.default_rng(99)
    B = 4
    states0, W, theta_c = _mixed_rows(rng, B)
    outs, traces = _batch(states0, W, theta_c, np.empty((B, 0)))
    for b in range(B):
        out, trace = _scalar(states0[b], W[b], theta_c[b], np.empty(0))
        np.testing.assert_array_equal(outs[b], out)
        np.testing.assert_array_equal(trace, np.zeros(6))
    np.testing.assert_array_equal(traces, np.zeros((B, 6)))


def test_same_seed_same_benchmark_trial() -> None:
    setup = bench.TrialSetup.chapter(35.0, 0.01)
    a = np.empty(kernel.N_OUT)
    b = np.empty(kernel.N_OUT)
    bench.run_scalar_trial(setup, np.random.default_rng(3), a)
    bench.run_scalar_trial(setup, np.random.default_rng(3), b)
    np.testing.assert_array_equal(a, b)
    # the benchmark's trial runs its whole length, so its steps per second count all steps
    assert a[kernel.OUT_END_STEP] == setup.n_steps


def test_linear_fit_recovers_a_line() -> None:
    x = np.array([1.0, 2.0, 4.0, 8.0])
    fit = linear_fit(x, 3.0 + 0.5 * x)
    assert fit["slope"] == pytest.approx(0.5)
    assert fit["intercept"] == pytest.approx(3.0)
    assert fit["r2"] == pytest.approx(1.0)


def test_timing_rates() -> None:
    t = Timing("x", (100, 100, 100), (1.0, 0.5, 2.0))
    assert t.best_steps_per_second == 200.0
    assert t.median_steps_per_second == 100.0


@pytest.mark.parametrize(
    "kwargs", [{"seconds": 0.0}, {"repeats": 0}, {"batch_size": 0}, {"dt": 0.5}]
)
def test_bad_config_raises(kwargs: dict[str, float]) -> None:
    with pytest.raises(ParameterError):
        BenchConfig(**kwargs)


def test_anchors_without_the_extra_is_one_clear_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """--anchors without jax/gymnax/envpool: what to install, one line, exit 2, nothing run."""
    import importlib.util

    real = importlib.util.find_spec

    def no_envpool(name: str, *args: object) -> object:
        return None if name == "envpool" else real(name, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(importlib.util, "find_spec", no_envpool)
    assert main(["bench", "--quick", "--anchors"]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and "pip install 'striatal[bench]'" in captured.err
    assert "envpool" in captured.err and captured.out == ""


def test_gymnax_missing_names_the_install_line(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without gymnax the gymnax rows are skipped, with one line saying how to add it."""
    import importlib.util

    found = object()
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *args: found)
    assert anchors.gymnax_missing() is None
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *args: None if name == "gymnax" else found
    )
    why = anchors.gymnax_missing()
    assert why is not None and "\n" not in why
    assert "gymnax not installed" in why and anchors.GYMNAX_INSTALL in why
    anchors.check_installed()  # EnvPool is found: --anchors runs, without the gymnax rows


def test_bench_extra_leaves_gymnasium_alone() -> None:
    """[bench] names no package that requires gymnasium < 1.4 (every gymnax release does)."""
    pyproject = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    bench_extra = pyproject["project"]["optional-dependencies"]["bench"]
    assert any(req.startswith("envpool") for req in bench_extra)
    assert not any(req.startswith("gymnax") for req in bench_extra)
    assert "--no-deps 'gymnax" in anchors.GYMNAX_INSTALL


@pytest.mark.parametrize("size", ["0", "100000000"])
def test_cli_bad_batch_size_exits_2(size: str, capsys: pytest.CaptureFixture[str]) -> None:
    """Refused by the parser (cli.guards), before anything is allocated."""
    with pytest.raises(SystemExit) as exc:
        main(["bench", "--quick", "--batch-size", size])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--batch-size" in err


def test_bench_quick_json_reports_positive_finite_figures(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["bench", "--quick", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    for key in ("scalar_vs_gymnasium", "batch_vs_gymnasium_vector"):
        comp = report[key]
        for value in (
            comp["ratio"],
            comp["median_ratio"],
            comp["kernel"]["best_steps_per_second"],
            comp["reference"]["best_steps_per_second"],
        ):
            assert _positive_finite(value)
    assert report["batch_vs_gymnasium_vector"]["batch_size"] == QUICK.batch_size
    fit = report["scaling"]["fit"]
    # the slope is a timing: on a loaded machine the quick durations' costs can order
    # either way, so only its being a number is the code's to keep
    assert math.isfinite(fit["slope"]) and fit["r2"] <= 1.0
    assert len(report["scaling"]["rows"]) == len(QUICK.scaling_durations)
    train = report["train"]
    assert _positive_finite(train["process_wall_seconds"])
    assert train["trials"] == QUICK.train_max_trials
    for where in ("this_process", "second_process"):
        info = report["compile"][where]
        assert _positive_finite(info["first_run_trial_seconds"])
        assert isinstance(info["compile_included"], bool)
    # this process compiled or loaded the kernels, so a fresh one loads them from disk
    assert report["compile"]["second_process"]["compile_included"] is False
    assert report["machine"]["logical_cores"] >= 1


def test_sweep_measurement_runs_learner_and_control_arm() -> None:
    info = run_sweep(1, 1, 3)
    assert info["runs"] == 2  # one seed x (learner + alpha = 0 control arm)
    assert info["command"].startswith("striatal sweep --seeds 1 --workers 1")
    assert _positive_finite(info["wall_seconds"]) and _positive_finite(info["peak_rss_mib"])


def test_bench_runs_from_a_package_without_a_checkout(tmp_path: Path) -> None:
    """``striatal bench`` from a copy of the package alone (as a wheel installs it).

    The copy keeps the source files' times, so the kernels load from the copied Numba
    cache; ``python -P`` keeps the working directory off ``sys.path``.
    """
    site = tmp_path / "site"
    shutil.copytree(Path(striatal.__file__).parent, site / "striatal")
    env = {**os.environ, "PYTHONPATH": str(site)}
    where = subprocess.run(
        [sys.executable, "-P", "-c", "import striatal; print(striatal.__file__)"],
        capture_output=True,
        text=True,
        check=True,
        env=env,
        cwd=tmp_path,
    )
    assert Path(where.stdout.strip()).parent == site / "striatal"
    assert not (site / "benchmarks").exists() and not (tmp_path / "benchmarks").exists()
    cmd = [sys.executable, "-P", "-m", "striatal", "bench", "--quick", "--no-train", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-500:]
    report = json.loads(proc.stdout)
    assert _positive_finite(report["scalar_vs_gymnasium"]["ratio"])
    assert report["compile"]["second_process"]["compile_included"] is False
    assert report["train"] is None and "train" in report["not_measured"]
