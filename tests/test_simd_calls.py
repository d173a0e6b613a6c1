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
from striatal.sim.rollout import Protocol, SensorNoise, TrialRequest

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
