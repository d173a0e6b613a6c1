"""A round's kernel calls (striatal.sim.batch.prepare, Calls.run): the noise of every
request drawn in one call, each generator's rows in request order, and a worker's Numba
settings made once."""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import replace

import numba
import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.experiments import runs_csv, sweeps
from striatal.experiments.lockstep_sweep import execute_batch
from striatal.experiments.spec import RunSpec, spawn_seeds
from striatal.learners import LearnerConfig, default_config
from striatal.params import (
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import batch
from striatal.sim.rollout import OnlineLearning, Protocol, SensorNoise, TrialRequest

SIM = Simulation(duration=12.0)


def _requests() -> list[TrialRequest]:
    """Requests of three noisy groups (action every step, every 3rd step, a shorter
    trial), three generators whose requests lie in several groups and between the
    others', and one mean-policy trial (no draws), each with a fresh generator."""
    rngs = [np.random.default_rng(s) for s in (11, 12, 13)]
    short = Simulation(duration=7.0)
    plant = Plant()
    protocol = Protocol()
    W = np.array(CHAPTER_FINAL_W)
    plan = [(0, SIM, 1), (1, SIM, 3), (0, short, 1), (2, SIM, 1), (1, SIM, 1)]
    plan += [(0, SIM, 3), (None, SIM, 1), (2, short, 1), (1, SIM, 1)]
    return [
        TrialRequest(
            plant,
            Controller(),
            sim,
            protocol,
            rng=None if g is None else rngs[g],
            gains=W + 0.01 * i,
            action_every=every,
            gamma=0.99,
        )
        for i, (g, sim, every) in enumerate(plan)
    ]


@pytest.mark.parametrize("engine", ["batch", "simd"])
def test_a_round_draws_each_request_s_noise_in_request_order(engine: str) -> None:
    """Every request's block row holds the normals its own generator gives it drawn alone,
    request after request (what the scalar trial draws), across groups of different
    sizes; the exact engine's outcomes then equal the scalar kernel's, bit for bit."""
    requests = _requests()
    calls = batch.prepare(requests, engine)  # type: ignore[arg-type]
    assert len(calls.calls) == 4 and calls.draw is not None  # the mean policy apart
    calls.run()
    rows = {
        i: block
        for call in calls.calls
        for i, block in zip(call.members, call.args.noise, strict=True)
    }
    alone = _requests()
    for i, r in enumerate(alone):
        noise, _ = r.noise()  # draws from the copy's generator, in request order
        assert np.array_equal(rows[i], noise), f"request {i}"
        assert rows[i].size == (0 if r.rng is None else -(-SIM.n_steps // r.action_every)) or (
            r.sim is not SIM
        )
    for r, mine in zip(alone, requests, strict=True):  # each generator left where it was
        if r.rng is not None:
            assert mine.rng is not None
            assert r.rng.standard_normal() == mine.rng.standard_normal()
    if engine == "batch":
        assert calls.outcomes() == [r.run() for r in _requests()]


def test_a_request_that_runs_alone_keeps_every_draw_in_request_order() -> None:
    """With a trial that runs alone (sensor noise) among them, the round's draws are made
    in request order as they come (prepare), the same numbers as one after another."""
    requests = _requests()
    requests[4] = replace(requests[4], sensor=SensorNoise(theta_std=0.01))
    calls = batch.prepare(requests, "batch")
    assert calls.draw is None and list(calls.done) == [4]
    calls.run()
    copies = _requests()
    copies[4] = replace(copies[4], sensor=SensorNoise(theta_std=0.01))
    assert calls.outcomes() == [r.run() for r in copies]


def test_a_worker_sets_numba_s_threads_once_and_runs_the_same(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Calls.run(threads) on a worker thread sets Numba's thread count and chunk size the
    first time only (each a ctypes call that hands the GIL back), and again when the
    count changes; its outcomes are those of Calls.run() on the caller's thread."""
    want = batch.prepare(_requests(), "simd")
    want.run()
    counts = {"threads": 0, "chunk": 0}
    set_threads, set_chunk = numba.set_num_threads, numba.set_parallel_chunksize

    def count_threads(n: int) -> None:
        counts["threads"] += 1
        set_threads(n)

    def count_chunk(n: int) -> int:
        counts["chunk"] += 1
        return int(set_chunk(n))

    monkeypatch.setattr(batch.numba, "set_num_threads", count_threads)
    monkeypatch.setattr(batch.numba, "set_parallel_chunksize", count_chunk)
    got: list[batch.Calls] = []

    def worker() -> None:
        for threads in (1, 1, 1, numba.config.NUMBA_NUM_THREADS):
            calls = batch.prepare(_requests(), "simd")
            calls.run(threads)
            got.append(calls)

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert len(got) == 4
    assert counts == {"threads": 1 + (numba.config.NUMBA_NUM_THREADS > 1), "chunk": 1}
    for calls in got:
        assert calls.outcomes() == want.outcomes()


def _lane_rounds() -> list[list[TrialRequest]]:
    """A lane's rounds: the nine requests of :func:`_requests`, then fewer normals (three
    of them), then more than the first (twelve: the buffer grows), then none (the
    mean-policy trial alone), then one; the generators carry over from round to round,
    as a run's do."""
    first = _requests()
    again = [replace(r, gains=r.W + 0.02) for r in first]
    return [first, first[:3], first + again[:3], [first[6]], again[4:5]]


@pytest.mark.parametrize("engine", ["batch", "simd"])
def test_a_lane_s_buffer_reused_over_rounds_gives_fresh_buffers_outcomes(engine: str) -> None:
    """Rounds through one NoiseBuffer, smaller and larger, give the outcomes, traces and
    generator states of rounds with fresh buffers (run_requests), and on the exact
    engine of the scalar kernel; the buffer grows only for the larger round, and a
    smaller round's blocks lie in the memory it already has."""
    noise = batch.NoiseBuffer()
    mine, fresh, scalar = _lane_rounds(), _lane_rounds(), _lane_rounds()
    held: list[np.ndarray] = []
    for k, (requests, theirs, alone) in enumerate(zip(mine, fresh, scalar, strict=True)):
        calls = batch.prepare(requests, engine, noise)  # type: ignore[arg-type]
        calls.run()
        got = calls.outcomes()
        assert got == batch.run_requests(theirs, engine), f"round {k}"  # type: ignore[arg-type]
        if engine == "batch":
            assert got == [r.run() for r in alone], f"round {k}"
        for a, b in zip(requests, theirs, strict=True):
            assert np.array_equal(a.trace, b.trace)
        held.append(calls.normals)
    sizes = [normals.size for normals in held]
    assert sizes[1] < sizes[0] < sizes[2] and sizes[3] == 0 < sizes[4] < sizes[1]
    # one buffer for the first two rounds, a larger one from the third on
    assert np.shares_memory(held[0], held[1]) and np.shares_memory(held[2], held[4])
    assert not np.shares_memory(held[0], held[2])
    for a, b in zip(mine[2], fresh[2], strict=True):  # each generator left where it was
        if a.rng is not None:
            assert b.rng is not None
            assert a.rng.standard_normal() == b.rng.standard_normal()


def test_a_lane_s_buffer_serves_one_round_at_a_time() -> None:
    """A round takes the buffer until its outcomes are read: the next round cannot take
    it before, and a round whose outcomes were read cannot run again into the buffer the
    next round took; a round whose preparing fails gives it back."""
    noise = batch.NoiseBuffer()
    calls = batch.prepare(_requests(), "batch", noise)
    with pytest.raises(RuntimeError, match="not yet read"):
        batch.prepare(_requests(), "batch", noise)
    calls.run()
    want = calls.outcomes()
    following = batch.prepare(_requests(), "batch", noise)
    with pytest.raises(RuntimeError, match="outcomes were read"):
        calls.run()
    following.run()
    assert following.outcomes() == want
    assert calls.outcomes() == want  # reading again: the values, not the buffer
    broken = _requests()
    broken[2] = replace(broken[2], record=True, online=_online())
    with pytest.raises(ParameterError, match="online trial"):
        batch.prepare(broken, "batch", noise)
    batch.prepare(_requests(), "batch", noise).run()


def _online() -> OnlineLearning:
    from striatal.sim import kernel

    return OnlineLearning(
        alpha=0.1,
        beta=0.1,
        discount=0.9,
        critic_decay=0.5,
        max_step=1.0,
        w1_floor=0.0,
        normalise=False,
        square_rate=0.01,
        critic=np.zeros(kernel.N_FEATURES),
        critic_trace=np.zeros(kernel.N_FEATURES),
        square=np.ones(1),
    )


def test_simd_sweep_rows_do_not_depend_on_the_workers_or_the_blocks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The simd engine's rows, every column but wall_seconds, are the same in two runs,
    with a worker per lane (each call on its share of Numba's threads) and with one
    worker whose calls take every thread (so a call's trials are cut into other blocks
    of whole vectors)."""
    specs = _specs(default_config("chapter", max_trials=6), seeds=spawn_seeds(0, 3))
    first = _rows(execute_batch(specs, engine="simd"))
    assert first == _rows(execute_batch(specs, engine="simd"))
    monkeypatch.setattr(batch, "lane_threads", lambda: (1, numba.get_num_threads()))
    assert first == _rows(execute_batch(specs, engine="simd"))
    assert len({r["W1"] for r in first}) > 3  # the runs differ among themselves


def _specs(config: LearnerConfig, seeds: tuple[int, ...]) -> list[RunSpec]:
    specs, _ = sweeps.build_specs(
        config=config,
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=SIM,
        seeds=seeds,
        inits=("chapter", "random"),
        methods=(),
        eval_draws=2,
    )
    return specs


def _rows(rows: Iterable[dict[str, object]]) -> list[dict[str, object]]:
    """The rows in order, without their wall times."""
    return [
        {k: v for k, v in r.items() if not k.startswith("wall_seconds")}
        for r in runs_csv.sort_rows(list(rows))
    ]
