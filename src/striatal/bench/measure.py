"""The measurements of ``striatal bench``, each a function returning its part of the report.

Items 1 and 2 time a kernel figure beside its Gymnasium reference in this process;
item 3 (``train``, the sweeps) times a ``striatal`` command in a fresh process; item 5
starts a fresh interpreter on :mod:`striatal.bench.first_call`; the sweeps' peak memory
is read by :mod:`striatal.bench.peak_rss`. Both scripts are files of this package, run
with ``python -P`` (their folder is not put on ``sys.path``).
"""

from __future__ import annotations

import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from striatal.bench.timing import BenchConfig, Comparison, compare, linear_fit
from striatal.errors import ParameterError
from striatal.sim import kernel
from striatal.sim.bench import (
    TrialSetup,
    cache_misses,
    calibrate,
    run_batch_trials,
    run_scalar_trial,
    timed,
)

#: This package's folder: the subprocess scripts first_call.py and peak_rss.py.
HERE = Path(__file__).resolve().parent


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
            "timed (bench.batch_normals: one child generator per Numba thread, drawn on "
            "Numba's threads in one compiled call); kernel blocks of 64 trials parallel over "
            f"{numba.get_num_threads()} Numba threads"
        ),
        extra={
            "batch_size": B,
            "numba_threads": numba.get_num_threads(),
            "lockstep_vs_prange": versus_prange.to_dict(),
        },
    )


# ------------------------------------------------------------------------ scaling


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
        [sys.executable, "-P", str(HERE / "first_call.py")],
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

    The process is started by :mod:`striatal.bench.peak_rss`, which reports the peak resident set
    (``ru_maxrss`` of its one child; with workers > 1 the largest single process).
    """
    cmd = _sweep_command(seeds, workers, max_trials)
    full = [sys.executable, "-m", "striatal", *cmd]
    proc = subprocess.run(
        [sys.executable, "-P", str(HERE / "peak_rss.py"), *full],
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
