"""The ``striatal bench`` harness: each figure measured beside its reference in one process.

What is measured (``striatal bench``; the table is docs/performance.md):

1. ``scalar_vs_gymnasium``: single-core env-steps per second of one chapter trial
   (:func:`striatal.sim.kernel.run_trial`: RK4, switching controller, Gaussian policy
   noise, eligibility trace), *including* drawing its standard-normal noise from a
   ``np.random.Generator`` each trial, against Gymnasium's ``CartPole-v1`` step loop
   (``gymnasium.make("CartPole-v1").unwrapped``: Euler physics only, a fixed action,
   reset on termination).
2. ``batch_vs_gymnasium_vector``: :func:`striatal.sim.kernel.run_trials_lockstep` (blocks
   of 64 trials advancing in lockstep, vectorised over trials, blocks over all cores)
   against Gymnasium's ``CartPoleVectorEnv`` (NumPy over the batch, autoreset) at the
   same batch size, and against :func:`striatal.sim.kernel.run_trials_batch` (``prange``
   over scalar trials). Steps are env-steps summed over the batch. The kernel does
   four derivative evaluations per step (RK4), the reference one (Euler).
3. ``train``: wall seconds of ``striatal train --init chapter`` (a fresh process).
4. ``scaling``: seconds per trial against n_steps = duration / dt, with a least-squares
   line (slope [s/step], intercept [s], R^2).
5. ``compile``: the first call of each kernel function in this process (cache load, or
   compilation when the on-disk cache missed) and in a second, fresh process.

Timing: ``time.perf_counter``; warm-up calls excluded; the two sides of a ratio are
timed alternately, repeat by repeat, and the ratio uses the best repeat of each (the
median ratio is reported too).
"""

from __future__ import annotations

import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.params import Simulation
from striatal.sim import kernel, noise
from striatal.sim.bench import (
    TrialSetup,
    cache_misses,
    calibrate,
    run_batch_trials,
    run_scalar_trial,
    timed,
)

#: This folder: the subprocess scripts first_call.py and peak_rss.py live here.
HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class BenchConfig:
    """How long and how big the measurements are.

    ``seconds``: rough wall budget of one timed repeat of one side [s];
    ``repeats``: timed repeats per side (best and median reported);
    ``batch_size``: B of the batched comparison; ``duration``: trial length [s];
    ``train``: also time ``striatal train --init chapter`` (``train_max_trials`` caps it,
    None for the command's own default); ``scaling_durations``: trial lengths [s] of the
    cost-growth fit; ``cold_compile``: also time a fresh process compiling the kernels
    into an empty Numba cache folder; ``sweep_seeds``: seeds of the timed
    ``striatal sweep`` on 1 and on all workers (0: skip; ``sweep_max_trials`` caps each
    run); ``memory_runs``: runs of the sweep whose peak memory is measured (0: skip),
    capped at ``memory_max_trials``.
    """

    seconds: float = 0.5
    repeats: int = 5
    batch_size: int = 256
    duration: float = 60.0
    dt: float = 0.01
    train: bool = True
    train_max_trials: int | None = None
    scaling_durations: tuple[float, ...] = (7.5, 15.0, 30.0, 60.0, 120.0, 240.0)
    cold_compile: bool = True
    sweep_seeds: int = 0
    sweep_max_trials: int | None = None
    memory_runs: int = 0
    memory_max_trials: int = 20
    anchors: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ParameterError(f"seconds must be a finite number > 0, got {self.seconds}")
        if self.repeats < 1:
            raise ParameterError(f"repeats must be >= 1, got {self.repeats}")
        if self.batch_size < 1:
            raise ParameterError(f"batch size must be >= 1, got {self.batch_size}")
        Simulation(duration=self.duration, dt=self.dt)  # validates duration and dt
        if len(self.scaling_durations) < 2:
            raise ParameterError("the scaling fit needs at least two durations")
        for d in self.scaling_durations:
            Simulation(duration=d, dt=self.dt)
        if self.sweep_seeds < 0 or self.memory_runs < 0:
            raise ParameterError("sweep seeds and memory runs must be >= 0")
        if self.train_max_trials is not None and self.train_max_trials < 1:
            raise ParameterError(f"train max trials must be >= 1, got {self.train_max_trials}")


QUICK = BenchConfig(
    seconds=0.05,
    repeats=2,
    batch_size=32,
    duration=10.0,
    train_max_trials=20,
    scaling_durations=(2.5, 5.0, 10.0),
    cold_compile=False,
)


@dataclass(frozen=True)
class Timing:
    """Repeated timings of one side: env-steps and seconds of each repeat."""

    name: str
    steps: tuple[int, ...]
    seconds: tuple[float, ...]

    @property
    def rates(self) -> list[float]:
        """Env-steps per second of each repeat."""
        return [n / t for n, t in zip(self.steps, self.seconds, strict=True)]

    @property
    def best_steps_per_second(self) -> float:
        return max(self.rates)

    @property
    def median_steps_per_second(self) -> float:
        return statistics.median(self.rates)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "repeat_steps": list(self.steps),
            "repeat_seconds": list(self.seconds),
            "best_steps_per_second": self.best_steps_per_second,
            "median_steps_per_second": self.median_steps_per_second,
        }


@dataclass(frozen=True)
class Comparison:
    """One kernel figure and its reference; ``ratio`` = best kernel / best reference."""

    kernel: Timing
    reference: Timing
    target_ratio: float
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ratio(self) -> float:
        return self.kernel.best_steps_per_second / self.reference.best_steps_per_second

    @property
    def median_ratio(self) -> float:
        return self.kernel.median_steps_per_second / self.reference.median_steps_per_second

    def to_dict(self) -> dict[str, Any]:
        return {
            "kernel": self.kernel.to_dict(),
            "reference": self.reference.to_dict(),
            "ratio": self.ratio,
            "median_ratio": self.median_ratio,
            "target_ratio": self.target_ratio,
            "meets_target": self.ratio >= self.target_ratio,
            "notes": self.notes,
            **self.extra,
        }


# ------------------------------------------------------------------------ Gymnasium side


def _gymnasium() -> Any:
    try:
        import gymnasium
    except ImportError as exc:  # a core dependency, but say what is missing
        raise ParameterError(f"the benchmark needs gymnasium ({exc})") from None
    return gymnasium


def gymnasium_steps(env: Any, n: int) -> int:
    """``n`` steps of an unwrapped ``CartPole-v1`` with action 1, reset on termination."""
    for _ in range(n):
        _, _, terminated, _, _ = env.step(1)
        if terminated:
            env.reset()
    return n


def gymnasium_vector_steps(env: Any, actions: np.ndarray, n: int) -> int:
    """``n`` steps of ``CartPoleVectorEnv`` (autoreset); returns env-steps over the batch."""
    for _ in range(n):
        env.step(actions)
    return n * int(actions.shape[0])


def compare(
    kernel_name: str,
    kernel_run: Callable[[], int],
    reference_name: str,
    reference_run: Callable[[], int],
    config: BenchConfig,
) -> tuple[Timing, Timing]:
    """Time both sides alternately (warm-up excluded), ``config.repeats`` repeats each.

    Each ``run`` returns the env-steps it actually performed (a trial that ends early
    counts only its steps).
    """
    kc = calibrate(kernel_run, config.seconds)
    rc = calibrate(reference_run, config.seconds)
    kn: list[int] = []
    ks: list[float] = []
    rn: list[int] = []
    rs: list[float] = []
    for _ in range(config.repeats):
        n, t = timed(kernel_run, kc)
        kn.append(n)
        ks.append(t)
        n, t = timed(reference_run, rc)
        rn.append(n)
        rs.append(t)
    return (
        Timing(kernel_name, tuple(kn), tuple(ks)),
        Timing(reference_name, tuple(rn), tuple(rs)),
    )


def scalar_vs_gymnasium(config: BenchConfig, rng: np.random.Generator) -> Comparison:
    """Item 1: one trial on one core (noise generation included) vs CartPole-v1."""
    setup = TrialSetup.chapter(config.duration, config.dt)
    out = np.empty(kernel.N_OUT)
    env = _gymnasium().make("CartPole-v1").unwrapped
    env.reset(seed=0)
    # a block of ~ one trial's steps per call keeps the per-call overhead alike
    block = setup.n_steps
    k, r = compare(
        "kernel.run_trial + rng.standard_normal",
        lambda: run_scalar_trial(setup, rng, out),
        "gymnasium CartPole-v1 unwrapped step loop",
        lambda: gymnasium_steps(env, block),
        config,
    )
    env.close()
    return Comparison(
        kernel=k,
        reference=r,
        target_ratio=75.0,
        notes=(
            f"one {config.duration:g}-s trial = {setup.n_steps} RK4 steps per call, chapter final "
            "W and theta_c, stochastic policy; drawing its noise from np.random.Generator is "
            "timed; one thread; reference: Euler, action 1, reset on termination"
        ),
        extra={"steps_per_trial": setup.n_steps},
    )


def batch_vs_gymnasium_vector(config: BenchConfig, rng: np.random.Generator) -> Comparison:
    """Item 2: run_trials_lockstep vs CartPoleVectorEnv at the same batch size.

    ``extra`` also has the lockstep kernel against run_trials_batch (prange over
    scalar trials, the previous batch kernel), timed alternately in the same way.
    """
    import numba
    from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

    B = config.batch_size
    setup = TrialSetup.chapter(config.duration, config.dt)
    outs = np.empty((B, kernel.N_OUT))
    env = CartPoleVectorEnv(num_envs=B)
    env.reset(seed=0)
    actions = np.ones(B, dtype=np.int64)
    block = setup.n_steps
    k, r = compare(
        f"kernel.run_trials_lockstep (B={B}) + bench.batch_normals",
        lambda: run_batch_trials(setup, B, rng, outs),
        f"gymnasium CartPoleVectorEnv (num_envs={B})",
        lambda: gymnasium_vector_steps(env, actions, block),
        config,
    )
    env.close()
    lk, pk = compare(
        f"kernel.run_trials_lockstep (B={B}) + bench.batch_normals",
        lambda: run_batch_trials(setup, B, rng, outs),
        f"kernel.run_trials_batch (B={B}, prange over scalar trials) + bench.batch_normals",
        lambda: run_batch_trials(setup, B, rng, outs, lockstep=False),
        config,
    )
    versus_prange = Comparison(kernel=lk, reference=pk, target_ratio=3.0)
    return Comparison(
        kernel=k,
        reference=r,
        target_ratio=12.0,
        notes=(
            "steps = env-steps summed over the batch; the kernel does 4 derivative "
            "evaluations per step (RK4), the reference 1 (Euler); kernel noise generation "
            "timed (bench.batch_normals: one child generator per Numba thread, on threads "
            f"when Numba's sleep: {noise.idle_kernel_threads()}); kernel blocks of 64 "
            "trials parallel over "
            f"{numba.get_num_threads()} Numba threads"
        ),
        extra={
            "batch_size": B,
            "numba_threads": numba.get_num_threads(),
            "lockstep_vs_prange": versus_prange.to_dict(),
        },
    )


# ------------------------------------------------------------------------ scaling


def linear_fit(x: np.ndarray, y: np.ndarray) -> dict[str, float]:
    """Least-squares y = intercept + slope x and its coefficient of determination R^2."""
    slope, intercept = np.polyfit(x, y, 1)
    pred = intercept + slope * x
    ss_res = float(np.sum((y - pred) ** 2))
    ss_tot = float(np.sum((y - np.mean(y)) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    return {"slope": float(slope), "intercept": float(intercept), "r2": r2}


def scaling(config: BenchConfig, rng: np.random.Generator) -> dict[str, Any]:
    """Item 4: best seconds per trial (noise included) against n_steps = duration / dt.

    The eq-24 check is off so each trial runs all its steps.
    """
    rows = []
    out = np.empty(kernel.N_OUT)
    for duration in config.scaling_durations:
        setup = TrialSetup.chapter(duration, config.dt, check=False)

        def one(s: TrialSetup = setup) -> int:
            return run_scalar_trial(s, rng, out)

        calls = calibrate(one, config.seconds)
        best = math.inf
        for _ in range(config.repeats):
            steps, t = timed(one, calls)
            if steps != calls * setup.n_steps:
                raise ParameterError("a scaling trial ended early; its step count would be wrong")
            best = min(best, t / calls)
        rows.append({"duration": duration, "n_steps": setup.n_steps, "seconds_per_trial": best})
    fit = linear_fit(
        np.array([r["n_steps"] for r in rows], dtype=float),
        np.array([r["seconds_per_trial"] for r in rows]),
    )
    return {
        "dt": config.dt,
        "rows": rows,
        "fit": {**fit, "ns_per_step": fit["slope"] * 1e9},
        "notes": "best of repeats; kernel.run_trial with noise drawn per trial; check off",
    }


# ------------------------------------------------------------------------ compile / cache


def first_calls(rng: np.random.Generator) -> dict[str, Any]:
    """Item 5, this process: the first call of each trial kernel (load or compile)."""
    setup = TrialSetup.chapter(1.0, 0.01)
    before = cache_misses()
    t0 = time.perf_counter()
    run_scalar_trial(setup, rng, np.empty(kernel.N_OUT))
    t_scalar = time.perf_counter() - t0
    t0 = time.perf_counter()
    run_batch_trials(setup, 2, rng, np.empty((2, kernel.N_OUT)))
    t_batch = time.perf_counter() - t0
    misses = cache_misses() - before
    return {
        "first_run_trial_seconds": t_scalar,
        "first_run_trials_batch_seconds": t_batch,
        "cache_misses": misses,
        "compile_included": misses > 0,
    }


def second_process(cache_dir: str | None = None) -> dict[str, Any]:
    """Item 5, a fresh interpreter: import and first calls after this process's cache.

    With ``cache_dir`` (an empty folder) Numba caches there instead, so the fresh
    process compiles both kernels: the cold-start cost.
    """
    env = dict(os.environ)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = cache_dir
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, str(HERE / "first_call.py")],
        capture_output=True,
        text=True,
        check=False,
        env=env,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise ParameterError(f"the second-process check failed: {proc.stderr.strip()[-300:]}")
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    result["process_wall_seconds"] = wall
    result["compile_included"] = result["cache_misses"] > 0
    return result


# ------------------------------------------------------------------------ training


def train_wall(max_trials: int | None) -> dict[str, Any]:
    """Item 3: ``striatal train --init chapter`` in a fresh process, timed from outside."""
    cmd = [sys.executable, "-m", "striatal", "train", "--init", "chapter"]
    cmd += ["--no-progress", "--json"]
    if max_trials is not None:
        cmd += ["--max-trials", str(max_trials)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise ParameterError(f"striatal train failed: {proc.stderr.strip()[-300:]}")
    result = json.loads(proc.stdout)
    shown = ["striatal", *cmd[3:]]
    return {
        "command": " ".join(shown),
        "process_wall_seconds": wall,
        "learning_loop_seconds": float(result["wall_seconds"]),
        "trials": int(result["trials"]),
        "success": bool(result["success"]),
        "notes": "process wall includes interpreter start, imports and kernel cache load",
    }


# ------------------------------------------------------------------------ sweeps


def _sweep_command(seeds: int, workers: int, max_trials: int | None) -> list[str]:
    cmd = ["sweep", "--seeds", str(seeds), "--workers", str(workers)]
    cmd += ["--no-progress", "--json"]
    if max_trials is not None:
        cmd += ["--max-trials", str(max_trials)]
    return cmd


def run_sweep(seeds: int, workers: int, max_trials: int | None) -> dict[str, Any]:
    """``striatal sweep`` (learner and alpha = 0 control arm) in a fresh process.

    The process is started by benchmarks/peak_rss.py, which reports the peak resident set
    (``ru_maxrss`` of its one child; with workers > 1 the largest single process).
    """
    cmd = _sweep_command(seeds, workers, max_trials)
    full = [sys.executable, "-m", "striatal", *cmd]
    proc = subprocess.run(
        [sys.executable, str(HERE / "peak_rss.py"), *full],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        raise ParameterError(f"the sweep wrapper failed: {proc.stderr.strip()[-300:]}")
    info = json.loads(proc.stdout.strip().splitlines()[-1])
    if info["returncode"] != 0:
        raise ParameterError(f"striatal sweep failed: {info['stderr'].strip()}")
    return {
        "command": "striatal " + " ".join(cmd),
        "runs": 2 * seeds,
        "workers": workers,
        "wall_seconds": float(info["wall"]),
        "peak_rss_mib": float(info["maxrss_kib"]) / 1024.0,
    }


def sweep_scaling(seeds: int, max_trials: int | None) -> dict[str, Any]:
    """Item 3: the same sweep on 1 worker and on every core; speed-up = t1 / t_all."""
    cores = os.cpu_count() or 1
    one = run_sweep(seeds, 1, max_trials)
    every = run_sweep(seeds, cores, max_trials)
    return {
        "seeds": seeds,
        "max_trials": max_trials,
        "one_worker": one,
        "all_workers": every,
        "speedup": one["wall_seconds"] / every["wall_seconds"],
        "notes": "wall time of the whole process (interpreter start, imports, kernel load "
        "included); runs = seeds x (learner arm + alpha = 0 control arm)",
    }


def sweep_memory(runs: int, max_trials: int) -> dict[str, Any]:
    """Item 4: peak RSS of a ``runs``-run sweep on one worker beside a 10-run one."""
    small = run_sweep(5, 1, max_trials)
    big = run_sweep(runs // 2, 1, max_trials)
    return {
        "max_trials": max_trials,
        "small": small,
        "large": big,
        "notes": f"one worker, so the sweep's only process holds everything; trials capped "
        f"at {max_trials} per run to fit the run's time budget (memory grows with the "
        "rows, not with trials)",
    }


# ------------------------------------------------------------------------ machine, all


def machine() -> dict[str, Any]:
    """Cores, CPU model (/proc/cpuinfo), library versions."""
    import gymnasium
    import numba

    model = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu_model": model,
        "logical_cores": os.cpu_count(),
        "numba_threads": numba.get_num_threads(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "gymnasium": gymnasium.__version__,
        "platform": platform.platform(),
        "load_average_1_5_15_min": list(os.getloadavg()),
    }


@dataclass(frozen=True)
class BenchReport:
    """Everything ``striatal bench`` measured; ``not_measured`` names what was skipped and why."""

    config: BenchConfig
    machine: dict[str, Any]
    compile: dict[str, Any]
    scalar_vs_gymnasium: Comparison
    batch_vs_gymnasium_vector: Comparison
    scaling: dict[str, Any]
    train: dict[str, Any] | None
    sweep: dict[str, Any] | None
    sweep_memory: dict[str, Any] | None
    not_measured: dict[str, str]
    total_seconds: float
    anchors: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "config": asdict(self.config),
            "machine": self.machine,
            "compile": self.compile,
            "scalar_vs_gymnasium": self.scalar_vs_gymnasium.to_dict(),
            "batch_vs_gymnasium_vector": self.batch_vs_gymnasium_vector.to_dict(),
            "scaling": self.scaling,
            "train": self.train,
            "sweep": self.sweep,
            "sweep_memory": self.sweep_memory,
            "not_measured": self.not_measured,
            "total_seconds": self.total_seconds,
            "anchors": self.anchors,
        }


def load_anchors() -> Any:
    """benchmarks/anchors.py (gymnax and EnvPool anchors), imported from this folder."""
    import importlib.util

    name = "striatal_benchmarks_anchors"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, HERE / "anchors.py")
        if spec is None or spec.loader is None:
            raise ParameterError(f"cannot import {HERE / 'anchors.py'}")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def run_all(config: BenchConfig, seed: int = 0) -> BenchReport:
    """Every measurement in one process, in the order compile, 1, 2, 4, 3, anchors."""
    if config.anchors:
        load_anchors().check_installed()  # before anything is timed
    t_start = time.perf_counter()
    rng = np.random.default_rng(seed)
    here = first_calls(rng)
    compile_info = {"this_process": here, "second_process": second_process()}
    if config.cold_compile:
        import tempfile

        with tempfile.TemporaryDirectory(prefix="striatal-numba-") as empty:
            compile_info["cold_process"] = second_process(cache_dir=empty)
    scalar = scalar_vs_gymnasium(config, rng)
    batch = batch_vs_gymnasium_vector(config, rng)
    grow = scaling(config, rng)
    train = train_wall(config.train_max_trials) if config.train else None
    sweep = (
        sweep_scaling(config.sweep_seeds, config.sweep_max_trials) if config.sweep_seeds else None
    )
    memory = (
        sweep_memory(config.memory_runs, config.memory_max_trials) if config.memory_runs else None
    )
    anchors = load_anchors().measure(config, rng, compare, Comparison) if config.anchors else None
    not_measured: dict[str, str] = {}
    if anchors is None:
        not_measured["anchors"] = "skipped (no --anchors)"
    if train is None:
        not_measured["train"] = "skipped (--no-train)"
    if sweep is None:
        not_measured["sweep"] = "skipped (--sweep-seeds 0)"
    if memory is None:
        not_measured["sweep_memory"] = "skipped (--memory-runs 0)"
    return BenchReport(
        config=config,
        machine=machine(),
        compile=compile_info,
        scalar_vs_gymnasium=scalar,
        batch_vs_gymnasium_vector=batch,
        scaling=grow,
        train=train,
        sweep=sweep,
        sweep_memory=memory,
        not_measured=not_measured,
        total_seconds=time.perf_counter() - t_start,
        anchors=anchors,
    )


def format_report(report: BenchReport) -> str:
    """The human-readable table printed by ``striatal bench``."""
    m = report.machine
    lines = [
        f"machine: {m['cpu_model']}, {m['logical_cores']} logical cores, "
        f"{m['numba_threads']} Numba threads; numpy {m['numpy']}, numba {m['numba']}, "
        f"gymnasium {m['gymnasium']}",
    ]
    here = report.compile["this_process"]
    second = report.compile["second_process"]
    lines.append(
        "compile/warm-up (excluded from all rates): first run_trial "
        f"{here['first_run_trial_seconds']:.3f} s, first run_trials_lockstep "
        f"{here['first_run_trials_batch_seconds']:.3f} s "
        f"({'compile included' if here['compile_included'] else 'loaded from cache'}); "
        f"second process {second['first_run_trial_seconds']:.3f} s + "
        f"{second['first_run_trials_batch_seconds']:.3f} s "
        f"({'compile included' if second['compile_included'] else 'loaded from cache'})"
    )
    cold = report.compile.get("cold_process")
    if cold is not None:
        lines.append(
            "cold start (empty Numba cache, compile included): first run_trial "
            f"{cold['first_run_trial_seconds']:.2f} s, first run_trials_lockstep "
            f"{cold['first_run_trials_batch_seconds']:.2f} s"
        )
    for key, comp in (
        ("scalar_vs_gymnasium", report.scalar_vs_gymnasium),
        ("batch_vs_gymnasium_vector", report.batch_vs_gymnasium_vector),
    ):
        lines.append(
            f"{key}: {comp.kernel.best_steps_per_second:,.0f} steps/s "
            f"vs {comp.reference.best_steps_per_second:,.0f} steps/s = {comp.ratio:.1f}x "
            f"(median {comp.median_ratio:.1f}x; target >= {comp.target_ratio:g}x)"
        )
        lines.append(f"  kernel:    {comp.kernel.name}")
        lines.append(f"  reference: {comp.reference.name}")
    vp = report.batch_vs_gymnasium_vector.extra["lockstep_vs_prange"]
    lines.append(
        f"lockstep_vs_prange: {vp['kernel']['best_steps_per_second']:,.0f} steps/s vs "
        f"{vp['reference']['best_steps_per_second']:,.0f} steps/s = {vp['ratio']:.1f}x "
        f"(median {vp['median_ratio']:.1f}x; target >= {vp['target_ratio']:g}x)"
    )
    fit = report.scaling["fit"]
    lines.append(
        f"scaling: time per trial = {fit['intercept'] * 1e6:.1f} us + "
        f"{fit['ns_per_step']:.1f} ns x n_steps, R^2 = {fit['r2']:.5f}"
    )
    for row in report.scaling["rows"]:
        lines.append(
            f"  {row['duration']:>7g} s  {row['n_steps']:>7d} steps  "
            f"{row['seconds_per_trial'] * 1e3:.3f} ms/trial"
        )
    if report.train is not None:
        t = report.train
        lines.append(
            f"train: `{t['command']}` {t['process_wall_seconds']:.2f} s wall "
            f"({t['learning_loop_seconds']:.2f} s learning loop, {t['trials']} trials, "
            f"success={t['success']})"
        )
    if report.sweep is not None:
        sw = report.sweep
        for key in ("one_worker", "all_workers"):
            r = sw[key]
            lines.append(
                f"sweep: `{r['command']}` {r['runs']} runs, {r['wall_seconds']:.1f} s wall"
            )
        lines.append(f"  speed-up 1 -> all workers: {sw['speedup']:.2f}x")
    if report.sweep_memory is not None:
        for key in ("small", "large"):
            r = report.sweep_memory[key]
            lines.append(
                f"memory: `{r['command']}` {r['runs']} runs, peak RSS {r['peak_rss_mib']:.0f} MiB"
            )
    if report.anchors is not None:
        for key, comp in report.anchors.items():
            if key == "versions":
                continue
            lines.append(
                f"anchor {key}: {comp['kernel']['best_steps_per_second']:,.0f} steps/s vs "
                f"{comp['reference']['best_steps_per_second']:,.0f} steps/s = "
                f"{comp['ratio']:.1f}x (median {comp['median_ratio']:.1f}x)"
            )
            lines.append(f"  kernel:    {comp['kernel']['name']}")
            lines.append(f"  reference: {comp['reference']['name']}")
    for name, why in report.not_measured.items():
        lines.append(f"not measured: {name}: {why}")
    lines.append(f"total {report.total_seconds:.1f} s")
    return "\n".join(lines)
