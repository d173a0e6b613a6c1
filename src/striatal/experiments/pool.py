"""Where the runs of a sweep execute: a local process pool or a Ray cluster.

:func:`execute` yields one row per spec (:func:`striatal.experiments.runner.run_one`),
in completion order. Locally, the runs that evaluate the same W(0) with the same noise
(a learner and its control on one seed: :func:`striatal.experiments.runner.shared_w0`)
share one evaluation, made first as a task of its own; each row still counts its
trials. Local workers die with the sweep that started them (Linux's
PR_SET_PDEATHSIG, and a watchdog thread where that is missing); the Ray backend waits
for its address to answer a whole connection first (:func:`check_cluster`).
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import math
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any, Literal

from striatal.arguments import CONNECT_TIMEOUT
from striatal.errors import ParameterError
from striatal.experiments.evaluate import PassProbability
from striatal.experiments.runner import W0Key, evaluate_w0, run_one, shared_w0
from striatal.experiments.spec import RunSpec
from striatal.learners.config import require_count

Backend = Literal["local", "ray"]


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


#: The most local worker processes a sweep starts (each holds a Numba runtime, ~100 MB).
MAX_WORKERS = 256


def check_workers(workers: object) -> None:
    """ParameterError unless ``workers`` is a whole number in [1, :data:`MAX_WORKERS`]."""
    require_count("--workers", workers)
    if workers > MAX_WORKERS:  # type: ignore[operator]
        raise ParameterError(f"--workers must be <= {MAX_WORKERS}, got {workers}")


def check_backend(
    backend: object, workers: object, address: str | None, connect_timeout: object
) -> None:
    """ParameterError unless the backend options of a sweep make sense: ``workers`` (see
    :func:`check_workers`), an ``address`` for Ray, a finite ``connect_timeout`` > 0 [s]."""
    if backend not in ("local", "ray"):
        raise ParameterError(f"backend must be 'local' or 'ray', got {backend!r}")
    check_workers(workers)
    if backend == "ray" and not address:
        raise ParameterError("--backend ray needs --address HOST:PORT of a running Ray cluster")
    real = isinstance(connect_timeout, int | float) and not isinstance(connect_timeout, bool)
    if not (real and 0 < connect_timeout < math.inf):  # type: ignore[operator]
        raise ParameterError(
            f"--connect-timeout must be a finite number of seconds > 0, got {connect_timeout!r}"
        )


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
    processes, never more than there are specs (module-level worker, safe under spawn
    and forkserver; each worker exits when its parent dies). The runs of a
    :func:`~striatal.experiments.runner.shared_w0` group get W(0)'s evaluation from one
    task made before them (:func:`~striatal.experiments.runner.evaluate_w0`), and each
    row's ``wall_seconds`` an even share of its time. ray: tasks on the existing Ray
    cluster at ``address`` (extra [cluster]), given up after ``connect_timeout`` seconds
    if the address does not accept a connection; every run evaluates its own W(0).
    """
    check_backend(backend, workers, address, connect_timeout)
    if backend == "ray":
        yield from _execute_ray(specs, address, connect_timeout)
        return
    groups = shared_w0(specs)
    group_of = {i: key for key, members in groups.items() for i in members}
    if workers == 1 or len(specs) <= 1:
        made: dict[W0Key, tuple[PassProbability, float]] = {}
        for i, spec in enumerate(specs):
            key = group_of.get(i)
            if key is None:
                yield run_one(spec)
                continue
            if key not in made:
                made[key] = _timed_w0(spec)
            result, seconds = made[key]
            yield _with_share(run_one(spec, result), seconds / len(groups[key]))
        return
    pool = ProcessPoolExecutor(
        max_workers=min(workers, len(specs)), initializer=_worker_init, initargs=(os.getpid(),)
    )
    try:
        # the shared evaluations first (the pool serves its queue in order), then the
        # runs; a group's runs are queued when its evaluation is there
        evaluations = {pool.submit(_timed_w0, specs[g[0]]): key for key, g in groups.items()}
        # each run's share of its group's evaluation time [s]
        runs = {pool.submit(run_one, s): 0.0 for i, s in enumerate(specs) if i not in group_of}
        pending: set[Future[Any]] = {*evaluations, *runs}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                if fut in runs:
                    yield _with_share(fut.result(), runs.pop(fut))
                    continue
                key = evaluations.pop(fut)
                result, seconds = fut.result()
                for i in groups[key]:
                    run = pool.submit(run_one, specs[i], result)
                    runs[run] = seconds / len(groups[key])
                    pending.add(run)
    except BaseException:
        _stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def _timed_w0(spec: RunSpec) -> tuple[PassProbability, float]:
    """W(0)'s evaluation of ``spec`` (:func:`striatal.experiments.runner.evaluate_w0`) and
    the wall time it took [s]."""
    t0 = time.perf_counter()
    result = evaluate_w0(spec)
    return result, time.perf_counter() - t0


def _with_share(row: dict[str, Any], seconds: float) -> dict[str, Any]:
    """``row`` with ``seconds`` (its share of a shared evaluation) added to its wall time."""
    return {**row, "wall_seconds": row["wall_seconds"] + seconds} if seconds else row


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


#: Ray addresses that answered a whole connection in this process (:func:`check_cluster`).
_ANSWERED: set[str] = set()


def check_cluster(address: str, connect_timeout: float) -> None:
    """ParameterError (one line) unless Ray's [cluster] extra loads and the cluster at
    ``address`` answers a whole connection (TCP, then Ray's handshake in a child
    process) within ``connect_timeout`` s. A sweep calls it before it writes a file;
    an address that answered is not probed again in this process."""
    if address in _ANSWERED:
        return
    if importlib.util.find_spec("ray") is None:
        raise ParameterError(
            "--backend ray needs the [cluster] extra: pip install 'striatal[cluster]'"
        )
    started = time.monotonic()
    wait_for_address(address, connect_timeout)
    left = connect_timeout - (time.monotonic() - started)
    _probe_ray(address, max(left, 1.0), connect_timeout)
    _ANSWERED.add(address)


def _execute_ray(
    specs: Sequence[RunSpec], address: str | None, connect_timeout: float
) -> Iterator[dict[str, Any]]:
    if not address:  # narrowed for the type checker; check_backend refused it already
        raise ParameterError("--backend ray needs --address HOST:PORT of a running Ray cluster")
    # the whole connection, the TCP check and Ray's handshake, within connect_timeout
    check_cluster(address, connect_timeout)
    try:
        import ray
    except ImportError:
        raise ParameterError(
            "--backend ray needs the [cluster] extra: pip install 'striatal[cluster]'"
        ) from None
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
