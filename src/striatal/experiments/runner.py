"""The one experiment runner: run specs, a pure worker, backends, resume, statistics.

A sweep is a list of :class:`RunSpec` (frozen, picklable), one per (arm, init, seed);
an arm is a learner's settings (``method`` "learn"), its no-learning control or a
baseline (``method`` lqr, hand, random, cmaes). :func:`run_one` turns one spec into
one row of ``runs.csv`` and depends on nothing else, so the local process pool and a
Ray cluster give the same rows for the same specs. ``striatal sweep`` and
``striatal ablation`` (whose variants are arms) both run through :func:`sweep`.

Robust (``LearnerConfig.robust``, ``sweep --robust``): every arm stops only on a
controller that passes the robustness set (:func:`striatal.sim.robust.stop_check`), and
the row's ``robust`` column re-checks the final gains with
:func:`striatal.sim.robust.check_robust` (all nine cases, counted in ``eval_simulations``;
empty in a sweep without ``--robust``).

Budget: every row counts every simulated trial its arm ran to learn or search,
the success checks included (``simulations``, ``simulated_seconds``, beside the
learning ``trials``). What the sweep runs afterwards to evaluate the result, the
re-simulation of the final gains and the pass probabilities, is counted apart in
``eval_simulations``.

Seeds: run i of a sweep with root seed R has the integer seed
``SeedSequence(R).spawn(N)[i].generate_state(1)[0]`` (:func:`spawn_seeds`). Every arm
uses the same seeds, and a learner row with seed S is exactly
``striatal train --seed S --init <init> <the same learner options>`` (random W(0) is
drawn as train draws it, from ``default_rng([S, 1])``).

The control arm is the learner's declared no-learning control (the rule's
``control``, :func:`striatal.learners.control_config`): for chapter and rpe alpha = 0
(W never changes, theta_c still follows eq 21); for pgpe alpha = 0 and
sigma_rate = 0, the same perturbations around W(0) with the same spreads and no
update, judged like pgpe on the candidate each trial ran.

Resume: rows are appended and flushed to runs.csv as runs finish; a rerun with the
same output folder reads the rows back (dropping a last line a kill cut short) and
runs only the missing (arm, init, seed); a row whose (arm, init, seed) is already
there is dropped, never counted twice. The output folder is locked
(:meth:`striatal.io.rundir.RunDir.lock`) while a sweep runs in it. The summary is
computed from the rows sorted by (arm, init, seed), so it does not depend on
completion order; its bootstrap intervals are seeded by the arm and init.
"""

from __future__ import annotations

import contextlib
import csv
import io
import logging
import math
import os
import signal
import socket
import sys
import threading
import time
import zlib
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, TextIO

import numpy as np

from striatal.errors import DataFileError, ParameterError
from striatal.experiments import baselines, stats
from striatal.experiments.evaluate import pass_probability
from striatal.experiments.spec import Init, RunSpec, initial_gains, spawn_seeds
from striatal.io.files import atomic_write_text, csv_text, read_text
from striatal.io.rundir import RunDir
from striatal.learners import LearnerConfig, learn, rule_of
from striatal.params import (
    N_GAINS,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim.robust import check_robust
from striatal.sim.rollout import Protocol, simulate

__all__ = [
    "CONNECT_TIMEOUT",
    "CONTROL_ARM",
    "ENGINES",
    "EVAL_DRAWS",
    "METHODS",
    "NOTE_BUDGET",
    "NOTE_CONTROL",
    "NOTE_ROBUST",
    "NOTE_SIMD",
    "ROLES",
    "RUN_COLUMNS",
    "WATCHDOG_SECONDS",
    "Arm",
    "Backend",
    "Engine",
    "Init",
    "RunSpec",
    "SweepResult",
    "arm_label",
    "arm_statistics",
    "bootstrap_rng",
    "build_specs",
    "control_note",
    "execute",
    "initial_gains",
    "json_roundtrip",
    "learning_run",
    "markdown_table",
    "read_runs",
    "row_text",
    "run_one",
    "search",
    "sort_rows",
    "spawn_seeds",
    "specs_of",
    "summarise",
    "sweep",
    "wait_for_address",
]

Backend = Literal["local", "ray"]
Engine = Literal["processes", "batch", "simd"]
#: How a sweep runs its specs: one learning loop per run, or the runs of an arm in lockstep
#: on the exact batch kernel ("batch") or on the SIMD lockstep kernel ("simd").
ENGINES: tuple[str, ...] = ("processes", "batch", "simd")
METHODS: tuple[str, ...] = ("learn", *baselines.BASELINES)
CONTROL_ARM = "control"
ROLES = ("learner", "control", "baseline")
#: Default noise draws of each pass-probability estimate (0: none).
EVAL_DRAWS = 200
#: Seconds to wait for a Ray cluster's address to accept a connection.
CONNECT_TIMEOUT = 30.0

RUN_COLUMNS: tuple[str, ...] = (
    "arm",
    "role",
    "method",
    "learner",
    "init",
    "seed",
    "alpha",
    "gamma",
    "success",
    "trials",
    *(f"W{i}" for i in range(1, N_GAINS + 1)),
    "theta_c",
    *(f"W0_{i}" for i in range(1, N_GAINS + 1)),
    "theta_c0",
    "mean_policy_success",
    "robust",
    "simulations",
    "simulated_seconds",
    "eval_simulations",
    "pass_rate_W0",
    "pass_rate",
    "wall_seconds",
)
_INT_COLUMNS = ("seed", "trials", "simulations", "eval_simulations")
_BOOL_COLUMNS = ("success", "mean_policy_success")
_STR_COLUMNS = ("arm", "role", "method", "learner", "init")

NOTE_BUDGET = (
    "simulations: every simulated trial an arm ran to learn or search, success checks "
    "included (a mean-policy rerun, the jitter corners); trials: learning trials only; "
    "eval_simulations (not in the budget): the re-simulation of the final gains and the "
    "pass-probability draws"
)

NOTE_ROBUST = (
    "robust stop rule: every arm's trials hold the motor force of eq 12; a controller "
    "that passes the success test must also pass the robustness set (striatal.sim.robust, "
    "9 mean-policy runs of 60 s, run up to the first failing case, each counted in "
    "simulations) for the run to stop; the robust column re-checks the final gains on "
    "all 9 cases (eval_simulations)"
)
NOTE_SIMD = (
    "--engine simd: every trial on kernel.run_trials_lockstep (polynomial sin/cos, within "
    "1 ulp of libm's), not on the exact scalar kernel; a trial equals the scalar kernel's "
    "within round-off, which a chaotic swing-up and learning over many trials amplify, "
    "so a run's row differs from --engine processes/batch; where measured, the arms' "
    "success rates agreed within their 95 % intervals (docs/performance.md)"
)


def control_note(learner: str) -> str:
    """What the control arm of ``learner`` is (from the rule's declared ``control``)."""
    rule = rule_of(learner)
    changes = ", ".join(f"{k} = {v:g}" for k, v in rule.control.items())
    if rule.control_text:
        return f"control arm ({learner}): {changes}: {rule.control_text}"
    also = f"; {rule.control_also}" if rule.control_also else ""
    return (
        f"control arm ({learner}): {changes}, so the gains W never change; theta_c still "
        "follows eq 21 (the threshold rule does not involve alpha), as in the learner arm" + also
    )


NOTE_CONTROL = control_note("chapter")


def learning_run(
    plant: Plant, template: Controller, config: LearnerConfig, seed: int, sim: Simulation
) -> dict[str, Any]:
    """success, trials, W, theta_c, simulations and simulated_seconds of one finished
    :func:`striatal.learners.learn` run.

    train turns Ctrl-C into a partial result; a cut run must never be recorded as
    finished, so it is raised again here as KeyboardInterrupt.
    """
    result = learn(plant, template, config, seed, sim=sim)
    if result.interrupted:
        raise KeyboardInterrupt
    return {
        "success": result.success,
        "trials": result.trials,
        "W": result.W,
        "theta_c": result.theta_c,
        "simulations": result.state.simulations,
        "simulated_seconds": result.state.simulated_seconds,
    }


def search(spec: RunSpec, W0: tuple[float, ...]) -> dict[str, Any]:
    """What the arm of ``spec`` finds from W(0) = ``W0``: a learning run or a baseline."""
    template = spec.template.with_gains(W0, spec.template.theta_c)
    cfg = spec.config
    if spec.method == "learn":
        return learning_run(spec.plant, template, cfg, spec.seed, spec.sim)
    if spec.method in ("lqr", "hand"):
        if spec.method == "lqr":
            W, theta_c = baselines.lqr_controller(spec.plant)
        else:
            W, theta_c = baselines.CHAPTER_FINAL_W, baselines.CHAPTER_FINAL_THETA_C
        return baselines.fixed_controller(
            spec.plant,
            template,
            spec.sim,
            W,
            theta_c,
            spec.seed,
            cfg.max_trials,
            cfg.success_on,
            robust=cfg.robust,
            hardware=cfg.hardware,
        )
    if spec.method == "random":
        return baselines.random_search(
            spec.plant,
            template,
            spec.sim,
            spec.seed,
            cfg.max_trials,
            cfg.success_on,
            robust=cfg.robust,
            hardware=cfg.hardware,
        )
    if spec.method == "cmaes":
        return baselines.cmaes(
            spec.plant,
            template,
            spec.sim,
            W0,
            spec.template.theta_c,
            spec.seed,
            cfg.max_trials,
            cfg.success_on,
            robust=cfg.robust,
            hardware=cfg.hardware,
        )
    raise ParameterError(f"unknown method {spec.method!r}; choose from {', '.join(METHODS)}")


def run_one(spec: RunSpec) -> dict[str, Any]:
    """One run -> one row (RUN_COLUMNS). Pure: the same spec gives the same row
    (except wall_seconds).

    After the search: one noise-free re-simulation of the final gains
    (``mean_policy_success``) and, with ``spec.eval_draws`` > 0, the pass probability
    (:func:`striatal.experiments.evaluate.pass_probability`, noise from ``default_rng(seed)``) of
    W(0) and of the final gains; their trials are ``eval_simulations``, apart from the
    arm's budget ``simulations``.
    """
    t0 = time.perf_counter()
    W0 = initial_gains(spec.init, spec.seed)
    theta_c0 = spec.template.theta_c
    template = spec.template.with_gains(W0, theta_c0)
    cfg = spec.config
    out = search(spec, W0)
    final = template.with_gains(out["W"], out["theta_c"]) if out["W"][0] > 0 else None
    mean_ok = (
        final is not None
        and simulate(
            spec.plant,
            final,
            spec.sim,
            protocol=Protocol(),
            hardware=cfg.hardware,
        ).outcome.success
    )
    evals = 1 if final is not None else 0
    robust = math.nan
    if cfg.robust and final is not None:
        report = check_robust(final, plant=spec.plant, max_force=cfg.max_force, track=cfg.track)
        robust, evals = float(report.robust), evals + report.simulations
    rate0 = rate = math.nan
    if spec.eval_draws > 0:
        before = pass_probability(
            spec.plant, template, spec.sim, Protocol(), spec.eval_draws, spec.seed
        )
        rate0, evals = before.rate, evals + before.simulations
        if final is not None:
            after = pass_probability(
                spec.plant, final, spec.sim, Protocol(), spec.eval_draws, spec.seed
            )
            rate, evals = after.rate, evals + after.simulations
    row: dict[str, Any] = {
        "arm": spec.arm,
        "role": spec.role,
        "method": spec.method,
        "learner": cfg.learner if spec.method == "learn" else "-",
        "init": spec.init,
        "seed": spec.seed,
        "alpha": cfg.alpha,
        "gamma": cfg.gamma,
        "success": bool(out["success"]),
        "trials": int(out["trials"]),
    }
    row.update({f"W{i + 1}": float(w) for i, w in enumerate(out["W"])})
    row["theta_c"] = float(out["theta_c"])
    row.update({f"W0_{i + 1}": float(w) for i, w in enumerate(W0)})
    row["theta_c0"] = float(theta_c0)
    row["mean_policy_success"] = bool(mean_ok)
    row["robust"] = robust
    row["simulations"] = int(out["simulations"])
    row["simulated_seconds"] = float(out["simulated_seconds"])
    row["eval_simulations"] = evals
    row["pass_rate_W0"] = rate0
    row["pass_rate"] = rate
    row["wall_seconds"] = time.perf_counter() - t0
    return row


def _ray_worker(spec: RunSpec) -> dict[str, Any]:
    return run_one(spec)


#: How often a local worker checks that the sweep that started it is still there [s].
WATCHDOG_SECONDS = 0.5
#: prctl(2) option: the signal the kernel sends this process when its parent dies (Linux).
_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies; False where unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _watch_parent(parent: int, ppid: int) -> None:
    while True:
        if os.getppid() != ppid or not _alive(parent):
            os._exit(1)  # the sweep is gone (even SIGKILLed): stop its run at once
        time.sleep(WATCHDOG_SECONDS)


def _worker_init(parent: int) -> None:
    """Initializer of every local worker: it ends when the sweep ``parent`` (its pid) dies.

    On Linux the kernel kills it as soon as its parent process dies (prctl
    PR_SET_PDEATHSIG); everywhere a daemon thread also ends it within about
    WATCHDOG_SECONDS once its parent changes (it was re-parented) or the sweep's
    pid is gone, so a SIGKILLed sweep leaves no worker behind.
    Under the fork and spawn start methods the parent is the sweep; under
    forkserver it is the server, which exits with the sweep.
    """
    _die_with_parent()
    ppid = os.getppid()
    if not _alive(parent):
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent, ppid), daemon=True).start()


def execute(
    specs: Sequence[RunSpec],
    *,
    backend: Backend = "local",
    workers: int = 1,
    address: str | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
) -> Iterator[dict[str, Any]]:
    """Rows of ``specs`` in completion order.

    local: in this process (workers 1) or a ProcessPoolExecutor of ``workers``
    processes (module-level worker, safe under spawn and forkserver; each worker
    exits when its parent dies). ray: tasks on the existing Ray cluster at
    ``address`` (extra [cluster]), given up after ``connect_timeout`` seconds if the
    address does not accept a connection.
    """
    if workers < 1:
        raise ParameterError(f"--workers must be >= 1, got {workers}")
    if backend == "ray":
        yield from _execute_ray(specs, address, connect_timeout)
        return
    if backend != "local":
        raise ParameterError(f"backend must be 'local' or 'ray', got {backend!r}")
    if workers == 1 or len(specs) <= 1:
        for spec in specs:
            yield run_one(spec)
        return
    pool = ProcessPoolExecutor(
        max_workers=workers, initializer=_worker_init, initargs=(os.getpid(),)
    )
    try:
        pending = {pool.submit(run_one, s) for s in specs}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                yield fut.result()
    except BaseException:
        _stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """End ``pool`` now: queued runs cancelled, running ones (never recorded) killed.

    A plain ``shutdown`` waits for the running runs, and a second Ctrl-C inside it
    leaves workers waiting for work that never comes, which the interpreter then
    joins at exit for ever. SIGINT is blocked meanwhile (a pending one is raised
    afterwards).
    """
    main = threading.current_thread() is threading.main_thread()
    if main:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        workers = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for worker in workers:
            with contextlib.suppress(OSError, ValueError):
                worker.kill()
        for worker in workers:
            with contextlib.suppress(OSError, ValueError, AssertionError):
                worker.join(timeout=5)
    finally:
        if main:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def wait_for_address(address: str, timeout: float) -> None:
    """Return once HOST:PORT accepts a TCP connection; ParameterError after ``timeout`` s.

    Addresses that are not HOST:PORT (``auto``, ``ray://...``) are left to Ray.
    """
    if not math.isfinite(timeout) or timeout <= 0:
        raise ParameterError(f"--connect-timeout must be > 0 seconds, got {timeout}")
    host, sep, port_text = address.rpartition(":")
    if not sep or not host or "/" in address or not port_text.isdigit():
        return
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        try:
            with socket.create_connection((host, int(port_text)), timeout=max(min(left, 5.0), 0.1)):
                return
        except OSError as exc:
            if time.monotonic() + 0.5 >= deadline:
                raise ParameterError(
                    f"no Ray cluster answers at {address} within {timeout:g} s "
                    f"({exc.strerror or exc})"
                ) from None
            time.sleep(0.5)


#: Run in a child process: connect to the Ray cluster at argv[1], then disconnect.
_RAY_PROBE = (
    "import logging, sys, ray; "
    "ray.init(address=sys.argv[1], logging_level=logging.ERROR, log_to_driver=False); "
    "ray.shutdown()"
)


def _probe_ray(address: str, timeout: float, shown: float) -> None:
    """Connect to Ray at ``address`` in a child process killed after ``timeout`` s.

    Ray has no connect timeout of its own: on a port that accepts connections but is
    no Ray head it retries for minutes, logging each attempt to stderr from C++, and
    the SIGTERM handler it installs cannot run while its client waits. A child can be
    killed and its stderr kept; it dies with this process (PR_SET_PDEATHSIG on
    Linux), so SIGTERM, which keeps its default action here, ends both at once.
    ParameterError (one line) when it fails or times out.
    """
    import subprocess

    try:
        done = subprocess.run(
            [sys.executable, "-c", _RAY_PROBE, address],
            capture_output=True,
            text=True,
            timeout=timeout,
            preexec_fn=_die_with_parent,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise ParameterError(
            f"the Ray cluster at {address} did not answer within {shown:g} s "
            "(is it a Ray head's GCS port?); see --connect-timeout"
        ) from None
    if done.returncode != 0:
        lines = [ln.strip() for ln in done.stderr.splitlines() if ln.strip()]
        reason = lines[-1] if lines else f"exit {done.returncode}"
        raise ParameterError(f"cannot connect to the Ray cluster at {address}: {reason}")


def _execute_ray(
    specs: Sequence[RunSpec], address: str | None, connect_timeout: float
) -> Iterator[dict[str, Any]]:
    if not address:
        raise ParameterError("--backend ray needs --address HOST:PORT of a running Ray cluster")
    try:
        import ray
    except ImportError:
        raise ParameterError(
            "--backend ray needs the [cluster] extra: pip install 'striatal[cluster]'"
        ) from None
    # the whole connection, the TCP check and Ray's handshake, within connect_timeout
    started = time.monotonic()
    wait_for_address(address, connect_timeout)
    left = connect_timeout - (time.monotonic() - started)
    _probe_ray(address, max(left, 1.0), connect_timeout)
    ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(_ray_worker)
        pending = [remote.remote(s) for s in specs]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield ray.get(ref)
    finally:
        ray.shutdown()


def row_text(row: dict[str, Any]) -> str:
    """One CSV line (no header) of ``row`` in RUN_COLUMNS order."""
    cells = [int(row[c]) if c in _BOOL_COLUMNS else row[c] for c in RUN_COLUMNS]
    return csv_text(RUN_COLUMNS, [cells]).split("\n", 1)[1]


def _parse_row(cells: list[str]) -> dict[str, Any]:
    if len(cells) != len(RUN_COLUMNS):
        raise ValueError(f"{len(cells)} cells, expected {len(RUN_COLUMNS)}")
    row: dict[str, Any] = {}
    for name, cell in zip(RUN_COLUMNS, cells, strict=True):
        if name in _STR_COLUMNS:
            if not cell:
                raise ValueError(f"empty {name}")
            row[name] = cell
        elif name in _INT_COLUMNS:
            row[name] = int(cell)
        elif name in _BOOL_COLUMNS:
            if cell not in ("0", "1"):
                raise ValueError(f"{name} must be 0 or 1, got {cell!r}")
            row[name] = cell == "1"
        else:
            row[name] = float(cell) if cell else math.nan
    return row


def read_runs(path: Path) -> tuple[list[dict[str, Any]], str]:
    """(rows, clean text) of runs.csv; a last line that does not parse is dropped.

    A last line without its newline or that does not parse is what a kill during
    a write leaves; any other bad line raises DataFileError. A row whose (arm, init,
    seed) an earlier row already has is dropped (the first is kept), so no run is
    counted twice.
    """
    if not path.exists():
        return [], csv_text(RUN_COLUMNS, [])
    lines = read_text(path, what="runs file").splitlines(keepends=True)
    header = ",".join(RUN_COLUMNS)
    if not lines or not lines[0].endswith("\n"):
        return [], csv_text(RUN_COLUMNS, [])
    if lines[0].strip() != header:
        if lines[0].startswith("arm,"):
            raise DataFileError(
                f"runs file {path} has the columns of another striatal version (an older "
                "one, before simulations or the robust column were recorded); use another --out"
            )
        raise DataFileError(f"runs file {path} does not have the header of a striatal sweep")
    rows: list[dict[str, Any]] = []
    kept = [lines[0]]
    seen: set[tuple[str, str, int]] = set()
    for i, line in enumerate(lines[1:], start=2):
        last = i == len(lines)
        try:
            if not line.endswith("\n"):
                raise ValueError("line cut short")
            cells = next(csv.reader(io.StringIO(line)))
            row = _parse_row(cells)
        except (ValueError, StopIteration, csv.Error) as exc:
            if last:
                break
            raise DataFileError(f"runs file {path} line {i} is malformed: {exc}") from None
        key = (row["arm"], row["init"], row["seed"])
        if key in seen:
            continue
        seen.add(key)
        rows.append(row)
        kept.append(line)
    return rows, "".join(kept)


def _quantile(values: Sequence[float], q: float) -> float:
    return float(np.quantile(np.asarray(values, dtype=float), q)) if values else math.nan


def _finite_mean(values: Iterable[float]) -> float:
    x = [float(v) for v in values if math.isfinite(float(v))]
    return float(np.mean(x)) if x else math.nan


def bootstrap_rng(arm: str, init: str) -> np.random.Generator:
    """The generator of an arm's bootstrap intervals: seeded by its name and init only."""
    return np.random.default_rng(zlib.crc32(f"{arm}|{init}".encode()))


def arm_statistics(
    rows: Sequence[dict[str, Any]], max_trials: int, rng: np.random.Generator | None = None
) -> dict[str, Any]:
    """The statistics of one arm's rows (one per seed).

    From :func:`striatal.experiments.stats.arm_summary`: ``success_rate`` with its Wilson interval
    ``success_rate_ci``, and over the solved seeds the median and IQM of
    ``simulations``, ``simulated_seconds`` and ``trials`` with seeded bootstrap
    intervals (``simulations_median_ci``, ``simulations_iqm_ci``, ...). Besides:
    quartiles of trials to success, ``trials_median_all`` (unsolved runs counted as
    ``max_trials``, a lower bound), the share whose final gains pass a noise-free
    re-simulation, budget and evaluation totals, and the mean pass probabilities of
    W(0) and of the final gains (over runs that estimated them).
    """
    n = len(rows)
    solved = [float(r["trials"]) for r in rows if r["success"]]
    every = [float(r["trials"]) if r["success"] else float(max_trials) for r in rows]
    wall = [float(r["wall_seconds"]) for r in rows]
    out = stats.arm_summary(rows, rng=rng if rng is not None else np.random.default_rng(0))
    out.update(
        {
            "unsolved_share": (n - len(solved)) / n if n else math.nan,
            "trials_q1": _quantile(solved, 0.25),
            "trials_q3": _quantile(solved, 0.75),
            "trials_median_all": _quantile(every, 0.5),
            "mean_policy_success_rate": (
                sum(bool(r["mean_policy_success"]) for r in rows) / n if n else math.nan
            ),
            "robust_rate": _finite_mean(r.get("robust", math.nan) for r in rows),
            "simulations_total": int(sum(int(r["simulations"]) for r in rows)),
            "simulated_seconds_total": float(sum(float(r["simulated_seconds"]) for r in rows)),
            "trials_total": int(sum(int(r["trials"]) for r in rows)),
            "eval_simulations_total": int(sum(int(r["eval_simulations"]) for r in rows)),
            "pass_rate_W0_mean": _finite_mean(r["pass_rate_W0"] for r in rows),
            "pass_rate_mean": _finite_mean(r["pass_rate"] for r in rows),
            "wall_seconds_total": float(sum(wall)),
            "wall_seconds_median": _quantile(wall, 0.5),
        }
    )
    if out["trials_median"] is None:
        out["trials_median"] = math.nan
    return out


def sort_rows(rows: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(rows, key=lambda r: (r["arm"], r["init"], int(r["seed"])))


def summarise(
    rows: Sequence[dict[str, Any]], max_trials: int, settings: dict[str, Any]
) -> dict[str, Any]:
    """summary.json: statistics per (arm, init) in sorted order, each learner arm against
    its control (Fisher's exact test, and McNemar's on the shared seeds), settings.

    Rows must have distinct (arm, init, seed): a duplicate would count one run twice
    (ParameterError).
    """
    ordered = sort_rows(rows)
    keys = [(r["arm"], r["init"], int(r["seed"])) for r in ordered]
    if len(set(keys)) != len(keys):
        dup = next(k for i, k in enumerate(keys) if k in keys[:i])
        raise ParameterError(f"run {dup} appears twice: a run is counted once")
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in ordered:
        groups.setdefault((r["arm"], r["init"]), []).append(r)
    arms = [
        {
            "arm": arm,
            "init": init,
            "role": g[0]["role"],
            "method": g[0]["method"],
            "learner": g[0]["learner"],
            **arm_statistics(g, max_trials, bootstrap_rng(arm, init)),
        }
        for (arm, init), g in groups.items()
    ]
    side_by_side = []
    for a in arms:
        if a["role"] != "learner":
            continue
        ctrl = next(
            (
                c
                for c in arms
                if c["role"] == "control"
                and c["init"] == a["init"]
                and c["learner"] == a["learner"]
            ),
            None,
        )
        if ctrl is None:
            continue
        solved = {
            name: {int(r["seed"]): bool(r["success"]) for r in groups[(name, a["init"])]}
            for name in (a["arm"], ctrl["arm"])
        }
        side_by_side.append(
            {
                "init": a["init"],
                "arm": a["arm"],
                "control": ctrl["arm"],
                "learner": a["learner"],
                "success_rate": a["success_rate"],
                "success_rate_ci": a["success_rate_ci"],
                "control_success_rate": ctrl["success_rate"],
                "control_success_rate_ci": ctrl["success_rate_ci"],
                "simulations_median": a["simulations_median"],
                "control_simulations_median": ctrl["simulations_median"],
                "trials_median": a["trials_median"],
                "control_trials_median": ctrl["trials_median"],
                **stats.compare_arms(solved[a["arm"]], solved[ctrl["arm"]]),
            }
        )
    learners = sorted({a["learner"] for a in arms} - {"-"})
    return {
        "arms": arms,
        "learner_vs_control": side_by_side,
        "notes": [*(control_note(x) for x in learners), NOTE_BUDGET],
        "settings": settings,
    }


def _num(v: Any, fmt: str = "g") -> str:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        return "-"
    return format(v, fmt)


def _ci(v: Any, fmt: str = "g") -> str:
    if not isinstance(v, list | tuple) or len(v) != 2:
        return ""
    return f" [{_num(v[0], fmt)}, {_num(v[1], fmt)}]"


def _robust_cell(arm: dict[str, Any]) -> str:
    """ ", robust R" (re-checked share of robust final gains) in a robust sweep."""
    rate = arm.get("robust_rate")
    return (
        f", robust {_num(rate, '.0%')}" if isinstance(rate, float) and math.isfinite(rate) else ""
    )


def markdown_table(summary: dict[str, Any]) -> str:
    """The comparison table of a summary, one line per (arm, init), then each learner
    against its control. Intervals are 95 %: Wilson for rates, bootstrap for the median
    and IQM of simulations to success (over solved runs)."""
    lines = [
        "| arm | init | runs | success [95% CI] | simulations to success: median [95% CI] | "
        "IQM [95% CI] | trials: median [q1, q3] | mean policy passes | "
        "pass rate W(0) -> final | simulations (all runs) | wall s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for a in summary["arms"]:
        lines.append(
            f"| {a['arm']} | {a['init']} | {a['runs']} | "
            f"{_num(a['success_rate'], '.0%')}{_ci(a.get('success_rate_ci'), '.0%')} | "
            f"{_num(a.get('simulations_median'))}{_ci(a.get('simulations_median_ci'))} | "
            f"{_num(a.get('simulations_iqm'), '.4g')}{_ci(a.get('simulations_iqm_ci'), '.4g')} | "
            f"{_num(a['trials_median'])} "
            f"[{_num(a.get('trials_q1'))}, {_num(a.get('trials_q3'))}] | "
            f"{_num(a.get('mean_policy_success_rate'), '.0%')}{_robust_cell(a)} | "
            f"{_num(a.get('pass_rate_W0_mean'), '.2f')} -> "
            f"{_num(a.get('pass_rate_mean'), '.2f')} | "
            f"{_num(a.get('simulations_total'))} | {_num(a.get('wall_seconds_total'), '.1f')} |"
        )
    pairs = summary.get("learner_vs_control") or []
    if pairs:
        lines += [
            "",
            "| learner arm | control | init | success | control success | "
            "Fisher p | McNemar p (only learner / only control) |",
            "|---|---|---|---|---|---|---|",
        ]
        for c in pairs:
            mc = c.get("mcnemar") or {}
            lines.append(
                f"| {c['arm']} | {c['control']} | {c['init']} | "
                f"{_num(c['success_rate'], '.0%')}{_ci(c.get('success_rate_ci'), '.0%')} | "
                f"{_num(c['control_success_rate'], '.0%')}"
                f"{_ci(c.get('control_success_rate_ci'), '.0%')} | "
                f"{_num(c['fisher']['p_value'], '.3g')} | "
                f"{_num(mc.get('p_value'), '.3g')} ({mc.get('only_a', '-')} / "
                f"{mc.get('only_b', '-')}) |"
            )
    return "\n".join(lines) + "\n"


def arm_label(alpha: float, gamma: float, grid: bool) -> str:
    return f"learner a={alpha:g} g={gamma:g}" if grid else "learner"


def build_specs(
    *,
    config: LearnerConfig,
    template: Controller,
    plant: Plant,
    sim: Simulation,
    seeds: Sequence[int],
    inits: Sequence[Init],
    alphas: Sequence[float] = (),
    gammas: Sequence[float] = (),
    control: bool = True,
    methods: Sequence[str] = (),
    eval_draws: int = 0,
) -> tuple[list[RunSpec], dict[str, dict[str, Any]]]:
    """(specs, config of each arm): the grid of alpha x gamma (default: config's own),
    the learner's declared no-learning control arm, and the baselines, each for every
    init and seed."""
    alphas = tuple(alphas) or (config.alpha,)
    gammas = tuple(gammas) or (config.gamma,)
    grid = len(alphas) * len(gammas) > 1
    arms: list[Arm] = [
        Arm(arm_label(a, g, grid), "learn", replace(config, alpha=a, gamma=g))
        for a in alphas
        for g in gammas
    ]
    if control:
        arms.append(Arm(CONTROL_ARM, "learn", rule_of(config).control_config(config), "control"))
    for m in methods:
        if m not in baselines.BASELINES:
            raise ParameterError(
                f"unknown baseline {m!r}; choose from {', '.join(baselines.BASELINES)}"
            )
        arms.append(Arm(m, m, config, "baseline"))
    return specs_of(
        arms,
        template=template,
        plant=plant,
        sim=sim,
        seeds=seeds,
        inits=inits,
        eval_draws=eval_draws,
    )


@dataclass(frozen=True)
class Arm:
    """One arm of a sweep: a name, a method ("learn" or a baseline), its config, its role."""

    name: str
    method: str
    config: LearnerConfig
    role: str = "learner"

    def settings(self) -> dict[str, Any]:
        return {"method": self.method, "role": self.role, "config": self.config.to_dict()}


def specs_of(
    arms: Sequence[Arm],
    *,
    template: Controller,
    plant: Plant,
    sim: Simulation,
    seeds: Sequence[int],
    inits: Sequence[Init],
    eval_draws: int = 0,
) -> tuple[list[RunSpec], dict[str, dict[str, Any]]]:
    """(specs, settings of each arm): every arm for every init and seed."""
    names = [a.name for a in arms]
    if len(set(names)) != len(names):
        raise ParameterError("two arms of the sweep have the same name; check the grid")
    if not arms:
        raise ParameterError("the sweep has no arm to run")
    for a in arms:
        if a.role not in ROLES:
            raise ParameterError(f"arm role must be one of {', '.join(ROLES)}, got {a.role!r}")
    if eval_draws < 0:
        raise ParameterError(f"--eval-draws must be >= 0, got {eval_draws}")
    for init in inits:
        initial_gains(init, 0)
    specs = [
        RunSpec(
            a.name, a.method, init, int(seed), a.config, template, plant, sim, a.role, eval_draws
        )
        for a in arms
        for init in inits
        for seed in seeds
    ]
    return specs, {a.name: a.settings() for a in arms}


@dataclass(frozen=True)
class SweepResult:
    rows: list[dict[str, Any]]
    ran: int
    skipped: int
    summary: dict[str, Any]


def sweep(
    specs: Sequence[RunSpec],
    settings: dict[str, Any],
    *,
    out: Path | None,
    max_trials: int,
    backend: Backend = "local",
    workers: int = 1,
    address: str | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
    progress: bool = False,
    engine: Engine = "processes",
    locked: bool = False,
) -> SweepResult:
    """Run the specs not already in ``out``/runs.csv, appending each row as it finishes,
    then write ``out``/summary.json (atomically) from all rows.

    ``engine`` "processes": :func:`execute` (one learning loop per run, on ``backend``);
    "batch": :func:`striatal.experiments.lockstep_sweep.execute_batch` (the runs of an arm advance
    in lockstep in this process; the same rows but wall_seconds); "simd": the same on
    the SIMD kernel (:func:`striatal.sim.kernel.run_trials_lockstep`), rows equal only
    within round-off (docs/performance.md), so ``settings`` gets ``trial_kernel``
    (:data:`NOTE_SIMD`) and a folder is never resumed across the two kinds.

    ``settings`` is stored in ``out``/sweep.json; a rerun in the same folder must use
    the same settings (ParameterError otherwise), ``settings["options"]`` aside: the
    options as they were given, recorded for ``--print-config --from-summary``.
    ``out`` is locked for the whole sweep: a second sweep on it gets DataFileError.
    ``locked``: the caller already holds ``RunDir(out).lock()`` (to write more files
    under the same lock).
    """
    if engine not in ENGINES:
        raise ParameterError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if engine != "processes":
        from striatal.experiments.lockstep_sweep import check_specs

        check_specs(specs, engine)
    if engine == "simd":
        # its rows are not the exact kernel's: recorded, so a folder never mixes the two
        settings = {**settings, "trial_kernel": NOTE_SIMD}
    # a folder not yet locked is locked for the whole sweep
    guard = contextlib.nullcontext() if out is None or locked else RunDir(out).lock()
    with guard:
        return _sweep(
            specs,
            settings,
            out,
            max_trials,
            backend,
            workers,
            address,
            connect_timeout,
            progress,
            engine,
        )


def _sweep(
    specs: Sequence[RunSpec],
    settings: dict[str, Any],
    out: Path | None,
    max_trials: int,
    backend: Backend,
    workers: int,
    address: str | None,
    connect_timeout: float,
    progress: bool,
    engine: Engine = "processes",
) -> SweepResult:
    from tqdm import tqdm

    from striatal.io.files import read_json, write_json

    rows: list[dict[str, Any]] = []
    stream: TextIO | None = None
    wanted = {s.key for s in specs}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        spath = out / "sweep.json"
        if spath.exists():
            old = read_json(spath, what="sweep settings")
            # settings.options records how the sweep was asked for (an option left to its
            # default or given at that value), the rest what it computes: only that counts
            new = json_roundtrip(settings)
            new.pop("options", None)
            if isinstance(old, dict):
                old.pop("options", None)
            if old != new:
                raise ParameterError(
                    f"{out} holds a sweep with other settings; use another --out "
                    "or the same options to resume it"
                )
        else:
            write_json(spath, settings)
        rpath = out / "runs.csv"
        old_rows, clean = read_runs(rpath)
        rows = [r for r in old_rows if (r["arm"], r["init"], r["seed"]) in wanted]
        atomic_write_text(rpath, clean)
        stream = rpath.open("a", encoding="utf-8", newline="")
    done = {(r["arm"], r["init"], r["seed"]) for r in rows}
    todo = [s for s in specs if s.key not in done]
    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), unit="run", disable=not progress)
    try:
        if engine != "processes":
            from striatal.experiments.lockstep_sweep import execute_batch

            rows_in = execute_batch(todo, trial_kernel="lockstep" if engine == "simd" else "exact")
        else:
            rows_in = execute(
                todo,
                backend=backend,
                workers=workers,
                address=address,
                connect_timeout=connect_timeout,
            )
        for row in rows_in:
            rows.append(row)
            if stream is not None:
                stream.write(row_text(row))
                stream.flush()
            bar.update(1)
    finally:
        bar.close()
        if stream is not None:
            stream.close()
    summary = summarise(rows, max_trials, settings)
    if out is not None:
        write_json(out / "summary.json", summary)
    return SweepResult(
        rows=sort_rows(rows), ran=len(todo), skipped=len(specs) - len(todo), summary=summary
    )


def json_roundtrip(obj: Any) -> Any:
    """``obj`` as it reads back from JSON (tuples become lists, non-finite floats None)."""
    import json

    from striatal.io.files import dumps_json

    return json.loads(dumps_json(obj))
