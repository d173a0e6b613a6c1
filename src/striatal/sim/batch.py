"""Trials as requests: code that needs trials yields them, a driver runs them.

A learning step (with a rule's own simulations), a success check, a baseline's search,
a pass-probability estimate or a whole sweep run is written once, as a generator that
yields lists of :class:`~striatal.sim.rollout.TrialRequest` and receives their
:class:`~striatal.sim.rollout.TrialOutcome` in the same order (:data:`Steps`). Two
drivers run such a generator:

- :func:`drive`: one generator, each request run on the scalar kernel
  (:meth:`~striatal.sim.rollout.TrialRequest.run`: what ``striatal train`` and the
  process engine of ``striatal sweep`` do);
- :class:`Lockstep`: many generators side by side; the requests they have pending are
  grouped by what a kernel call shares (plant, readings, protocol, action rate, trace
  decay, motor, online learning) and each group is one call of a batch kernel
  (:func:`striatal.sim.kernel.run_trials_batch`, the SIMD
  :func:`striatal.sim.kernel.run_trials_lockstep`, the online
  :func:`striatal.sim.kernel.run_online_trials_batch`, or, on a learned plant, one
  model's :func:`striatal.sim.kernel.run_learned_trials_batch`).

Each request draws its noise from its own generator exactly as ``TrialRequest.run`` does,
in the order the requests were yielded, and ``run_trials_batch`` equals the scalar
kernel bit for bit, so both drivers give the same outcomes (the SIMD kernel: within
round-off). The rules, the loop and the evaluation therefore exist once, whichever
driver runs them.
"""

from __future__ import annotations

import contextlib
import functools
import queue
import sys
import threading
import time
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, ParamSpec, TypeVar

import numba
import numpy as np

from striatal.errors import ParameterError
from striatal.params import CHAPTER_HARDWARE
from striatal.sim import kernel
from striatal.sim.learned import LearnedPlant
from striatal.sim.noise import standard_normal_rows, standard_normals
from striatal.sim.rollout import (
    TrialOutcome,
    TrialRequest,
    action_draws,
    batch_args,
)

__all__ = [
    "BATCH_ENGINES",
    "SWITCH_INTERVAL",
    "WORKERS",
    "Calls",
    "KernelCall",
    "Lockstep",
    "NoiseBuffer",
    "Steps",
    "TrialRequest",
    "drive",
    "driven",
    "lane_threads",
    "prepare",
    "run_requests",
]

T = TypeVar("T")
P = ParamSpec("P")
#: A computation that needs trials: it yields requests, is sent their outcomes, returns T.
Steps = Generator[list["TrialRequest"], list[TrialOutcome], T]
#: The kernels :class:`Lockstep` can batch on, by the name of ``striatal sweep --engine``:
#: "batch" the exact one (:func:`striatal.sim.kernel.run_trials_batch`), "simd" the SIMD one.
BATCH_ENGINES: tuple[str, ...] = ("batch", "simd")
#: Trials a kernel thread takes at a time (numba.set_parallel_chunksize): dynamic chunks,
#: so a thread the OS takes away, or that gets the long trials, does not hold up the rest.
CHUNK = 2
#: From this many normals in one round, generators fill their rows on threads.
PARALLEL_NORMALS = 50_000
#: Python's switch interval while :class:`Lockstep` runs [s] (its default is 5 ms): a lane
#: takes the GIL back after each call that releases it (the draws, the kernels), and while
#: the other lane runs its Python it waited up to the interval for it each time
#: (benchmarks/gil_wait.py).
SWITCH_INTERVAL = 1e-4
#: The lanes :class:`Lockstep` drives side by side, at most, each on a thread of its own
#: with its share of Numba's threads (:func:`lane_threads`): one a core on two cores, as
#: the process engine's ``--workers 2``. Each further lane's thread would take a core
#: from the others: the lanes' Python overlaps the other lanes' kernels already.
WORKERS = 2


def driven(steps: Callable[P, Steps[T]]) -> Callable[P, T]:
    """The function that runs ``steps``'s generator to its end with :func:`drive`."""

    @functools.wraps(steps)
    def run(*args: P.args, **kwargs: P.kwargs) -> T:
        return drive(steps(*args, **kwargs))

    return run


def drive(steps: Steps[T]) -> T:
    """Run ``steps`` to its end, each request on the scalar kernel; its return value."""
    try:
        requests = next(steps)
        while True:
            requests = steps.send([r.run() for r in requests])
    except StopIteration as stop:
        return stop.value  # type: ignore[no-any-return]


def run_requests(
    requests: Sequence[TrialRequest],
    engine: Literal["batch", "simd"] = "batch",
) -> list[TrialOutcome]:
    """The outcomes of ``requests``, in their order, from as few batched kernel calls as
    their :meth:`TrialRequest.batch_key` allow.

    The action noise of each request is drawn from its generator in the order of
    ``requests`` (what :func:`drive` would draw); traces are updated in place. "simd" runs a
    group on the SIMD kernel unless its motor or track needs the exact one; trials on a
    learned plant always run on the exact learned batch kernel. The three
    stages, :func:`prepare`, :meth:`Calls.run` and :meth:`Calls.outcomes`, can run on
    different threads (:class:`Lockstep`).
    """
    calls = prepare(requests, engine)
    calls.run()
    return calls.outcomes()


class NoiseBuffer:
    """The action normals of a lane's rounds (:class:`Lockstep`): one buffer, reused
    round after round, grown when a round needs more.

    A round's blocks (:func:`prepare`) are views of the buffer's first values; the
    lane draws into them and its kernels read them (:meth:`Calls.run`);
    :meth:`Calls.outcomes` copies out what the round returns (the summary rows' values,
    the traces) and gives the buffer back. The next round takes it only then:
    :meth:`take` refuses a buffer whose last round has not been read, and
    :meth:`Calls.run` refuses to run a round that gave it back. A fresh buffer each
    round (megabytes: tens of trials x 6000 normals) is mapped anew by the C library,
    and each of its pages faults when first written; a lane's own buffer faults once.
    """

    def __init__(self) -> None:
        self._data = np.empty(0)
        self._lent: np.ndarray | None = None

    def take(self, size: int) -> np.ndarray:
        """The buffer's first ``size`` values for one round, until :meth:`give_back`."""
        if self._lent is not None:
            raise RuntimeError("a lane's noise buffer is still held by a round not yet read")
        if size > self._data.size:
            self._data = np.empty(size)
        self._lent = self._data[:size]
        return self._lent

    def lends(self, normals: np.ndarray) -> bool:
        """Whether ``normals`` (from :meth:`take`) is still the round's that holds it."""
        return self._lent is normals

    def give_back(self, normals: np.ndarray) -> None:
        """End the round that took ``normals`` (nothing if it ended already)."""
        if self._lent is normals:
            self._lent = None


@dataclass(frozen=True)
class KernelCall:
    """One batched kernel call: the indices of its requests, its arguments, and the
    online trials' stacked critics (None: not online)."""

    members: list[int]
    args: kernel.BatchArgs
    critic: kernel.CriticArgs | None


@dataclass(frozen=True)
class Calls:
    """The kernel calls of a list of requests (:func:`prepare`); ``done`` holds the
    outcomes of the requests that ran alone, by index."""

    requests: Sequence[TrialRequest]
    engine: Literal["batch", "simd"]
    calls: list[KernelCall]
    done: dict[int, TrialOutcome]
    #: Draws the calls' action normals into their blocks, on as many of Numba's threads
    #: as it is given (None: drawn already).
    draw: Callable[[int], None] | None = None
    #: The lane's buffer whose first values, ``normals``, hold the calls' blocks until
    #: :meth:`outcomes` (None: ``normals`` is the calls' own).
    noise: NoiseBuffer | None = None
    normals: np.ndarray = field(default_factory=lambda: np.empty(0))

    def run(self, threads: int | None = None) -> None:
        """Draw the calls' noise (:attr:`draw`) and make the kernel calls: the draws and
        the kernels release the GIL, so this can run on a thread of its own while
        Python runs elsewhere.

        ``threads``: run on that many of Numba's threads, on a thread that runs only
        :class:`Lockstep`'s calls (a lane's): Numba's thread count and chunk size are then
        set for the thread only when they change (each setting is a call through ctypes
        that hands the GIL back, and taking it back can wait for another thread's
        Python), and left set. None: the calling thread's thread count, its chunk size
        restored after."""
        if threads is not None:
            _thread_settings(threads)
            self._run(threads)
            return
        old = numba.set_parallel_chunksize(CHUNK)
        try:
            self._run(numba.get_num_threads())
        finally:
            numba.set_parallel_chunksize(old)

    def _run(self, threads: int) -> None:
        if self.noise is not None and not self.noise.lends(self.normals):
            raise RuntimeError("these calls' outcomes were read: their noise buffer is not theirs")
        if self.draw is not None:
            self.draw(threads)
        for call in self.calls:
            args, critic = call.args, call.critic
            first = self.requests[call.members[0]]
            if critic is not None:
                kernel.run_online_trials_batch(*args[:7], critic, args.outs)
            elif isinstance(first.plant, LearnedPlant):
                assert first.plant.dynamics is not None
                kernel.run_learned_trials_batch(first.plant.dynamics.args, *args)
            elif self.engine == "simd" and first.hardware == CHAPTER_HARDWARE:
                # a block per thread when the trials are few
                block = -(-len(call.members) // threads)
                kernel.run_trials_lockstep(*args, block)
            else:
                kernel.run_trials_batch(*args)

    def outcomes(self) -> list[TrialOutcome]:
        """The outcomes in the requests' order, after :meth:`run`; the traces (and an
        online trial's critic) written back to each request's arrays. The lane's noise
        buffer is given back: nothing returned refers to it."""
        outcomes = dict(self.done)
        for call in self.calls:
            args, critic = call.args, call.critic
            sim = self.requests[call.members[0]].sim
            values = args.outs.tolist()
            for j, i in enumerate(call.members):
                r = self.requests[i]
                r.trace[:] = args.learning.trace[j]
                if critic is not None and r.online is not None:
                    o = r.online
                    for mine, rows in (
                        (o.critic, critic.weights),
                        (o.critic_trace, critic.trace),
                        (o.stats, critic.stats),
                        (o.square, critic.square),
                        (o.gains_end, critic.gains_end),
                    ):
                        mine[:] = rows[j]
                outcomes[i] = TrialOutcome.from_values(values[j], sim)
        if self.noise is not None:
            self.noise.give_back(self.normals)
        return [outcomes[i] for i in range(len(self.requests))]


def prepare(
    requests: Sequence[TrialRequest],
    engine: Literal["batch", "simd"] = "batch",
    noise: NoiseBuffer | None = None,
) -> Calls:
    """The batched kernel calls of ``requests`` (:func:`run_requests`): grouped by
    :meth:`TrialRequest.batch_key`, their arguments built. A request that
    :attr:`~TrialRequest.runs_alone` runs here, on the scalar kernel, in its order.

    A group's action normals go straight into the rows of its (B, n) block, the kernel's
    argument: each request's row from its own generator, in request order. They are
    drawn by :meth:`Calls.run`, on the thread that runs the kernels, unless a request
    runs alone (then here, in request order, as it draws). The blocks lie in ``noise``,
    a lane's buffer held until :meth:`Calls.outcomes` (None: a fresh array)."""
    if engine not in BATCH_ENGINES:
        raise ParameterError(f"engine must be one of {', '.join(BATCH_ENGINES)}, got {engine!r}")
    keys, groups = _groups(requests)
    # the round's normals in one buffer: each group's (B, n) block a part of it, request
    # i's row at rows[i] = (start, size)
    draws = [_draws(requests[members[0]]) for members in groups.values()]
    total = sum(len(m) * n for m, n in zip(groups.values(), draws, strict=True))
    normals = np.empty(total) if noise is None else noise.take(total)
    try:
        rows: dict[int, tuple[int, int]] = {}
        blocks: list[np.ndarray | None] = []
        at = 0
        for members, n in zip(groups.values(), draws, strict=True):
            if not n:
                blocks.append(None)
                continue
            blocks.append(normals[at : at + len(members) * n].reshape(len(members), n))
            rows.update((i, (at + j * n, n)) for j, i in enumerate(members))
            at += len(members) * n
        done: dict[int, TrialOutcome] = {}
        draw = None
        if any(key is None for key in keys):
            # a trial that runs alone draws as it runs: keep every draw in request order
            for i, (r, key) in enumerate(zip(requests, keys, strict=True)):
                if key is None:
                    done[i] = r.run()
                elif i in rows:
                    assert r.rng is not None
                    start, size = rows[i]
                    standard_normals(r.rng, normals[start : start + size])
        elif rows:
            draw = functools.partial(_draw_noise, requests, rows, normals)
        calls = []
        for members, block in zip(groups.values(), blocks, strict=True):
            group = [requests[i] for i in members]
            critic = None if group[0].online is None else _critics(group)
            calls.append(KernelCall(members, batch_args(group, block), critic))
    except BaseException:
        if noise is not None:  # the round never ran: the lane's next may take its buffer
            noise.give_back(normals)
        raise
    return Calls(requests, engine, calls, done, draw, noise, normals)


def _groups(
    requests: Sequence[TrialRequest],
) -> tuple[list[tuple[object, ...] | None], dict[tuple[object, ...], list[int]]]:
    """Each request's :meth:`TrialRequest.batch_key`, and the indices of the requests
    that share a key, by key, in request order.

    Requests that hold the same objects (a run's plant, readings, simulation, protocol,
    hardware: the same for all its trials) share a key, so it is made and hashed once for
    them (each key hashes those frozen dataclasses, a few microseconds a request)."""
    by_objects: dict[tuple[object, ...], list[int]] = {}
    for i, r in enumerate(requests):
        by_objects.setdefault(r.batch_objects(), []).append(i)
    keys: list[tuple[object, ...] | None] = [None] * len(requests)
    groups: dict[tuple[object, ...], list[int]] = {}
    for members in by_objects.values():
        key = requests[members[0]].batch_key()
        for i in members:
            keys[i] = key
        if key is not None:
            groups.setdefault(key, []).extend(members)
    if len(groups) < len(by_objects):
        for members in groups.values():
            members.sort()
    return keys, groups


def _critics(group: Sequence[TrialRequest]) -> kernel.CriticArgs:
    """The critics of a group of online trials (shared rates), stacked (B, ...)."""
    learnings = [r.online for r in group if r.online is not None]
    first = learnings[0]
    return first.args(group[0].protocol.check_x)._replace(
        weights=np.array([o.critic for o in learnings]),
        trace=np.array([o.critic_trace for o in learnings]),
        stats=np.array([o.stats for o in learnings]),
        square=np.array([o.square for o in learnings]),
        gains_end=np.array([o.gains_end for o in learnings]),
    )


def _draws(request: TrialRequest) -> int:
    """The action normals ``request``'s trial draws (0: none, the mean policy)."""
    return action_draws(request.sim, request.action_every) if request.draws_actions else 0


def _draw_noise(
    requests: Sequence[TrialRequest],
    rows: dict[int, tuple[int, int]],
    normals: np.ndarray,
    threads: int = 1,
) -> None:
    """Fill request i's row, ``normals[start:start + size]`` for ``rows[i]`` = (start,
    size), with its action normals: each generator's requests in their order (what
    run_trial draws), in one compiled call with the GIL released
    (:func:`striatal.sim.noise.standard_normal_rows`), different generators on
    ``threads`` of Numba's once there are enough normals to pay."""
    order = sorted(rows)
    rngs = [requests[i].rng for i in order]
    assert all(rng is not None for rng in rngs)
    spans = [rows[i] for i in order]
    standard_normal_rows(
        rngs,  # type: ignore[arg-type]
        normals,
        [start for start, _ in spans],
        [size for _, size in spans],
        threads if normals.size >= PARALLEL_NORMALS else 1,
    )


class Lockstep:
    """Many :data:`Steps` advanced together: each round, the requests of every unfinished
    one run in batched kernel calls (:func:`run_requests`).

    The generators are split into ``lanes`` groups (default: one per worker of
    :func:`lane_threads`, two on two cores), and each lane is driven by a thread of its
    own, as a worker process drives its runs in the process engine: it advances its
    generators with the outcomes of their last calls (their Python: the rules' plans and
    updates, the success tests), prepares their next calls (:func:`prepare`: grouping,
    arguments), runs them (:meth:`Calls.run`: the noise and the kernels, with the GIL
    released) and reads their outcomes, round after round. While one lane's kernels run,
    the other's Python runs: two threads on two cores, which take turns only for the
    GIL, and only when both are in Python at once. A lane's calls take Numba's threads
    shared among the lanes whose runs are not all finished (a lane left alone takes
    every thread); under Numba's workqueue layer, which takes one parallel call at a
    time, the lanes' calls take turns. A generator is always in the same lane, so its
    trials, and the order in which its generator draws their noise, are what they would
    be alone.

    Each lane keeps one :class:`NoiseBuffer` for its rounds' normals: a round takes it
    when prepared and gives it back when its outcomes are read, and the lane's next
    round is prepared only then, so the buffer is written and read by one round at a
    time and faulted in once.

    While it runs, Python's switch interval is :data:`SWITCH_INTERVAL` (restored after),
    so that a lane waiting for the GIL behind the other's Python gets it within 0.1 ms
    rather than 5.

    :meth:`run`, on the calling thread, yields ``(index, value)`` as each finishes,
    ``value`` its return value (the lanes finish their runs in their own time, so the
    order of two lanes' values can vary from run to run, as the process engine's rows
    do; the values cannot). An exception in a lane reaches the caller there, and the
    other lanes stop after their round under way; so do they when the caller stops
    (an interrupt, or closing the generator). ``seconds[i]``: the wall time spent on
    generator i, its own Python plus an even share of each round it was in (the
    lanes overlap, so the sum over the generators can exceed the wall time of
    :meth:`run`, about ``lanes`` times at most).
    """

    def __init__(
        self,
        steps: Sequence[Steps[T]],
        engine: Literal["batch", "simd"] = "batch",
        lanes: int | None = None,
    ) -> None:
        self.steps = list(steps)
        self.engine = engine
        self.lanes = lane_threads()[0] if lanes is None else lanes
        if self.lanes < 1:
            raise ParameterError(f"lanes must be at least 1, got {self.lanes}")
        self.seconds = np.zeros(len(self.steps))

    def _advance(self, i: int, outcomes: list[TrialOutcome] | None) -> list[TrialRequest]:
        t0 = time.perf_counter()
        try:
            step = self.steps[i]
            return next(step) if outcomes is None else step.send(outcomes)
        finally:
            self.seconds[i] += time.perf_counter() - t0

    def _prepare(self, pending: dict[int, list[TrialRequest]], noise: NoiseBuffer) -> _Round:
        """The kernel calls of ``pending``'s requests (:func:`prepare`), on this thread,
        their blocks in the lane's ``noise`` buffer."""
        order = list(pending)
        t0 = time.perf_counter()
        calls = prepare([r for i in order for r in pending[i]], self.engine, noise)
        return order, [len(pending[i]) for i in order], calls, time.perf_counter() - t0

    def _outcomes(self, lane: _Round, seconds: float) -> dict[int, list[TrialOutcome]]:
        """The outcomes of a lane's calls by generator, each generator's share of their
        time (``seconds`` and this thread's preparing and reading) added; the lane's
        noise buffer given back (:meth:`Calls.outcomes`)."""
        order, counts, calls, prepared = lane
        t0 = time.perf_counter()
        outcomes = calls.outcomes()
        spent = prepared + seconds + time.perf_counter() - t0
        share = spent / max(len(outcomes), 1)
        out: dict[int, list[TrialOutcome]] = {}
        at = 0
        for i, n in zip(order, counts, strict=True):
            self.seconds[i] += share * n
            out[i], at = outcomes[at : at + n], at + n
        return out

    def run(self) -> Generator[tuple[int, Any], None, None]:
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, SWITCH_INTERVAL))
        try:
            yield from self._run()
        finally:
            sys.setswitchinterval(switch)

    def _run(self) -> Generator[tuple[int, Any], None, None]:
        workers, _ = lane_threads()
        every = numba.get_num_threads()
        values: queue.SimpleQueue[tuple[int, Any] | BaseException | None] = queue.SimpleQueue()
        stop = threading.Event()
        count = min(self.lanes, max(len(self.steps), 1))
        # the lanes whose runs are not all finished (changed under ``lock``), and the
        # lanes' calls taking turns when Numba's layer takes one call at a time
        live = [count]
        lock = threading.Lock()
        turns = threading.Lock() if workers == 1 else contextlib.nullcontext()

        def drive(g: int) -> None:
            """Lane g's generators (i = g mod lanes), round after round, to their end."""
            noise = NoiseBuffer()
            pending: dict[int, list[TrialRequest]] = {}
            try:
                for i in range(g, len(self.steps), self.lanes):
                    try:
                        pending[i] = self._advance(i, None)
                    except StopIteration as done:
                        values.put((i, done.value))
                while pending and not stop.is_set():
                    # a round takes the lane's noise buffer, given back when its outcomes
                    # are read, before the next round is prepared
                    prepared = self._prepare(pending, noise)
                    with turns:
                        seconds = _timed(prepared[2], max(1, every // live[0]))
                    outcomes = self._outcomes(prepared, seconds)
                    pending = {}
                    for i, mine in outcomes.items():
                        try:
                            pending[i] = self._advance(i, mine)
                        except StopIteration as done:
                            values.put((i, done.value))
            except BaseException as exc:  # to the caller, in run()
                values.put(exc)
            finally:
                with lock:
                    live[0] -= 1
                values.put(None)

        lanes = [
            threading.Thread(target=drive, args=(g,), name=f"lockstep_{g}", daemon=True)
            for g in range(count)
        ]
        for lane in lanes:
            lane.start()
        try:
            ended = 0
            while ended < len(lanes):
                value = values.get()
                if value is None:
                    ended += 1
                elif isinstance(value, BaseException):
                    raise value
                else:
                    yield value
        finally:
            stop.set()
            for lane in lanes:
                lane.join()


def lane_threads() -> tuple[int, int]:
    """(the lanes :class:`Lockstep` drives by default, Numba threads each): :data:`WORKERS`
    lanes, each with its share of Numba's threads, so that two lanes' kernel calls run at
    once and a lane with few trials left does not hold a core it cannot use (a lane left
    alone takes every thread); one lane with all of Numba's threads under the workqueue
    layer (it takes no concurrent calls) or with fewer threads than lanes."""
    threads = numba.get_num_threads()  # launches Numba's threading layer
    if threads < WORKERS or numba.threading_layer() == "workqueue":
        return 1, threads
    return WORKERS, threads // WORKERS


def _timed(calls: Calls, threads: int) -> float:
    """Run ``calls``' noise and kernels on the lane's thread with ``threads`` of Numba's
    threads: the wall time they took [s]."""
    t0 = time.perf_counter()
    calls.run(threads)
    return time.perf_counter() - t0


#: Numba's settings of this thread as :func:`_thread_settings` last made them.
_SETTINGS = threading.local()


def _thread_settings(threads: int) -> None:
    """Numba's thread count ``threads`` and chunk size :data:`CHUNK` on this thread,
    each set only when it differs from what this function last set here."""
    if getattr(_SETTINGS, "threads", None) != threads:
        numba.set_num_threads(threads)
        _SETTINGS.threads = threads
    if getattr(_SETTINGS, "chunk", None) != CHUNK:
        numba.set_parallel_chunksize(CHUNK)
        _SETTINGS.chunk = CHUNK


#: A lane's prepared round: its generators in order, their request counts, the kernel
#: calls, and the seconds spent preparing them.
_Round = tuple[list[int], list[int], Calls, float]
