"""Sweeps in lockstep (--engine batch): the process engine's rows, resume, refusals."""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import KernelCounter

from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments import pool, runner, runs_csv, sweeps
from striatal.experiments.lockstep_sweep import execute_batch
from striatal.experiments.spec import RunSpec, spawn_seeds
from striatal.learners import LearnerConfig, default_config
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import kernel
from striatal.sim.batch import Lockstep, Steps, drive, lane_threads

SHORT = Simulation(duration=20.0)
SEEDS = spawn_seeds(0, 4)


def _specs(
    config: LearnerConfig,
    seeds: tuple[int, ...] = SEEDS,
    methods: tuple[str, ...] = (),
    eval_draws: int = 3,
) -> list[RunSpec]:
    specs, _ = sweeps.build_specs(
        config=config,
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=SHORT,
        seeds=seeds,
        inits=("chapter", "random"),
        methods=methods,
        eval_draws=eval_draws,
    )
    return specs


def _no_wall(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _no_wall(v) for k, v in obj.items() if not k.startswith("wall_seconds")}
    if isinstance(obj, list):
        return [_no_wall(v) for v in obj]
    if isinstance(obj, float) and math.isnan(obj):
        return None  # NaN != NaN: compare "not estimated" as None
    return obj


CASES = {
    # the chapter's rule and its alpha = 0 control; seed 3 (random W(0)) succeeds at trial 5
    "chapter": default_config("chapter", max_trials=15),
    # the mean-policy check, the trace carried over, the printed e1, held actions, eq 21
    # over the whole trial
    "chapter-variants": default_config(
        "chapter",
        max_trials=10,
        success_on="mean",
        reset_trace=False,
        eligibility="chapter",
        action_every=2,
        theta_c_rule="trial",
    ),
    # the prediction error (normalised), decay and a mean-policy check; one run succeeds
    "rpe": default_config("rpe", max_trials=15, decay=0.1, success_on="mean"),
    # parameter exploration with theta_c learned and the spreads adapted; its control
    # (alpha = 0, sigma_rate = 0) is in the same batch
    "pgpe": default_config("pgpe", max_trials=10, reward="sparse", sigma_rate=0.5),
    "pgpe-eq21": default_config(
        "pgpe", max_trials=8, reward="sparse", theta_c_rule="swingup", action_every=3
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_batch_rows_equal_the_process_rows(case: str) -> None:
    """Every column but wall_seconds, bit for bit, for learner and control on both inits."""
    specs = _specs(CASES[case])
    serial = runs_csv.sort_rows(pool.execute(specs))
    batch = runs_csv.sort_rows(execute_batch(specs))
    assert len(batch) == len(specs) == 16
    for a, b in zip(serial, batch, strict=True):
        assert _no_wall(b) == _no_wall(a), (a["arm"], a["init"], a["seed"])
    # the runs differ among themselves, so equal rows are not equal by accident
    assert len({(r["W1"], r["theta_c"], r["simulated_seconds"]) for r in batch}) > 4
    assert any(r["W1"] != r["W0_1"] for r in batch if r["arm"] == "learner")
    if case in ("chapter", "rpe"):
        assert any(r["success"] for r in batch)  # the success branch of the update ran


def test_rows_come_as_runs_finish_and_share_the_wall_time() -> None:
    specs = _specs(CASES["chapter"], eval_draws=2)
    t0 = time.perf_counter()
    rows = list(execute_batch(specs))
    elapsed = time.perf_counter() - t0
    # a run that succeeds early is written before the runs that go on to max_trials
    assert rows[0]["success"] and rows[0]["trials"] < 15
    assert [r["trials"] for r in rows[1:]] == [15] * (len(rows) - 1)
    wall = sum(r["wall_seconds"] for r in rows)
    assert all(r["wall_seconds"] > 0 for r in rows)
    # the lanes overlap, each round counted once, so the sum lies between half the wall
    # time and the lanes times it
    assert 0.5 * elapsed < wall <= Lockstep([], "batch").lanes * elapsed


def test_the_batch_sweep_resumes_a_cut_sweep_of_either_engine(tmp_path: Path) -> None:
    specs = _specs(default_config("chapter", max_trials=6), seeds=SEEDS[:3], eval_draws=2)
    settings = {"test": "resume"}
    full = sweeps.run_sweep(specs, settings, out=tmp_path / "p", max_trials=6)
    for engine in ("batch", "processes"):
        out = tmp_path / engine
        out.mkdir()
        for name in ("sweep.json", "runs.csv"):
            (out / name).write_text((tmp_path / "p" / name).read_text())
        runs = out / "runs.csv"
        lines = runs.read_text().splitlines(keepends=True)
        # the header, 5 rows and a line a SIGKILL cut short
        runs.write_text("".join(lines[:6]) + lines[6][: len(lines[6]) // 2])
        again = sweeps.run_sweep(specs, settings, out=out, max_trials=6, engine="batch")
        assert (again.skipped, again.ran) == (5, len(specs) - 5)
        assert _no_wall(again.summary) == _no_wall(full.summary)
        assert len(runs_csv.read_runs(runs)[0]) == len(specs)
        nothing = sweeps.run_sweep(specs, settings, out=out, max_trials=6, engine="batch")
        assert nothing.ran == 0


#: What the batch engine once refused: each now runs through the same run_steps, the
#: trials that need more than a kernel summary inside their run.
EVERY_KIND = {
    "baselines": (default_config("chapter", max_trials=3), ("lqr", "hand", "random", "cmaes")),
    "shaped": (default_config("pgpe", max_trials=3), ()),
    "jitter": (default_config("pgpe", max_trials=3, reward="sparse", plant_jitter=0.1), ()),
    "track": (default_config("chapter", max_trials=3, track=2.0, max_force=20.0), ()),
    "robust": (default_config("pgpe", max_trials=3, robust=True), ()),
    "symmetric": (default_config("pgpe", max_trials=3, symmetric=True), ()),
    "ac": (default_config("ac", max_trials=2), ()),
}


@pytest.mark.parametrize("kind", list(EVERY_KIND))
def test_every_arm_runs_in_lockstep_with_the_process_rows(kind: str) -> None:
    config, methods = EVERY_KIND[kind]
    specs = _specs(config, seeds=SEEDS[:1], methods=methods, eval_draws=2)
    serial = runs_csv.sort_rows(pool.execute(specs))
    batch = runs_csv.sort_rows(execute_batch(specs))
    assert len(batch) == len(specs)
    assert _no_wall(batch) == _no_wall(serial)
    with pytest.raises(ParameterError, match="engine must be"):
        sweeps.run_sweep(specs, {}, out=None, max_trials=3, engine="threads")  # type: ignore[arg-type]


def test_trials_of_different_runs_share_kernel_calls(monkeypatch: pytest.MonkeyPatch) -> None:
    """The point of the engine: the runs' trials go to the batch kernel together."""
    sizes: list[int] = []
    real = kernel.run_trials_batch

    def counting(*args: Any) -> None:
        sizes.append(args[0].shape[0])
        real(*args)

    monkeypatch.setattr(kernel, "run_trials_batch", counting)
    specs = _specs(default_config("chapter", max_trials=4), eval_draws=3)
    rows = list(execute_batch(specs))
    trials = sum(r["simulations"] + r["eval_simulations"] for r in rows)
    # every trial of the sweep went through the batch kernel, W(0)'s evaluation (the mean
    # policy and 3 draws) once for a learner and its control of one init and seed
    shared = len({(r["init"], r["seed"]) for r in rows}) * (1 + 3)
    assert sum(sizes) == trials - shared
    # trial k of every run of a lane in one call
    assert max(sizes) >= len(specs) // Lockstep([], "batch").lanes
    assert len(sizes) < trials / 4


def test_cli_engines_give_the_same_runs_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The issue's small sweep: --seeds 6 --max-trials 40 --duration 10, both engines."""
    argv = ["sweep", "--seeds", "6", "--max-trials", "40", "--duration", "10"]
    argv += ["--eval-draws", "5", "--init", "chapter,random", "--json"]
    assert main([*argv, "--out", str(tmp_path / "p"), "--workers", "2"]) == 0
    processes = json.loads(capsys.readouterr().out)
    assert main([*argv, "--out", str(tmp_path / "b"), "--engine", "batch"]) == 0
    batch = json.loads(capsys.readouterr().out)
    assert _no_wall(batch) == _no_wall(processes)
    rows = {
        name: runs_csv.sort_rows(runs_csv.read_runs(tmp_path / name / "runs.csv")[0])
        for name in ("p", "b")
    }
    assert len(rows["b"]) == 24
    assert _no_wall(rows["b"]) == _no_wall(rows["p"])


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--workers", "2"], "--workers"),
        (["--backend", "ray", "--address", "127.0.0.1:1"], "--backend ray"),
    ],
)
def test_cli_refusals_are_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], needle: str
) -> None:
    argv = ["sweep", "--seeds", "1", "--max-trials", "2", "--engine", "batch"]
    assert main([*argv, *extra, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and "\n" not in err
    assert not (tmp_path / "x" / "runs.csv").exists()  # refused before anything ran


def test_the_simd_kernel_drifts_from_round_off_but_keeps_what_is_exact() -> None:
    """``--engine simd``: the trials on the SIMD kernel, whose
    trials equal the scalar kernel's within round-off; learning amplifies the difference
    over trials (here W of one run ends far away), which is why a folder never mixes the
    two kinds and "batch" keeps the exact kernel."""
    specs = _specs(default_config("chapter", max_trials=8), seeds=SEEDS[:2], eval_draws=2)
    exact = runs_csv.sort_rows(execute_batch(specs))
    fast = runs_csv.sort_rows(execute_batch(specs, engine="simd"))
    assert [(r["arm"], r["init"], r["seed"]) for r in fast] == [
        (r["arm"], r["init"], r["seed"]) for r in exact
    ]
    assert [r["trials"] for r in fast] == [r["trials"] for r in exact]
    drift = max(
        abs(a[f"W{i}"] - b[f"W{i}"]) for a, b in zip(exact, fast, strict=True) for i in range(1, 7)
    )
    assert drift > 1e-3
    control = [(a, b) for a, b in zip(exact, fast, strict=True) if a["arm"] == "control"]
    for a, b in control:  # alpha = 0: W never moves, theta_c only through eq 21
        assert [b[f"W{i}"] for i in range(1, 7)] == [a[f"W{i}"] for i in range(1, 7)]
    # the counts are the protocol's, whatever the kernel
    for a, b in zip(exact, fast, strict=True):
        assert b["eval_simulations"] == a["eval_simulations"]
    with pytest.raises(ParameterError, match="engine must be one of batch, simd"):
        list(execute_batch(specs, engine="lockstep"))  # type: ignore[arg-type]


def test_cli_simd_engine_gives_the_same_statistics_not_the_same_rows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--engine simd beside --engine processes on a small sweep with successes: each arm's
    success rate lies in the other engine's 95 % interval, and the folder says which
    kernel ran (a sweep folder is never resumed across the two)."""
    argv = ["sweep", "--seeds", "20", "--max-trials", "100", "--eval-draws", "5"]
    argv += ["--init", "chapter", "--json"]
    assert main([*argv, "--out", str(tmp_path / "p")]) == 0
    processes = json.loads(capsys.readouterr().out)
    assert main([*argv, "--out", str(tmp_path / "s"), "--engine", "simd"]) == 0
    simd = json.loads(capsys.readouterr().out)
    arms = {a["arm"]: a for a in processes["arms"]}
    assert sum(a["successes"] for a in arms.values()) >= 5  # a comparison with successes
    for a in simd["arms"]:
        p = arms[a["arm"]]
        assert a["runs"] == p["runs"] == 20
        assert p["success_rate_ci"][0] <= a["success_rate"] <= p["success_rate_ci"][1]
        assert a["success_rate_ci"][0] <= p["success_rate"] <= a["success_rate_ci"][1]
    assert "trial_kernel" in json.loads((tmp_path / "s" / "sweep.json").read_text())
    assert "trial_kernel" not in json.loads((tmp_path / "p" / "sweep.json").read_text())
    # resuming the processes sweep on the SIMD kernel would mix two kinds of rows
    assert main([*argv, "--out", str(tmp_path / "p"), "--engine", "simd"]) == 2
    assert "other settings" in capsys.readouterr().err
    # the SIMD engine is recorded (it changes the rows), the exact ones are not
    assert simd["settings"]["options"]["engine"] == "simd"
    assert "engine" not in processes["settings"]["options"]
    assert main(["sweep", "--from-summary", str(tmp_path / "s"), "--print-config"]) == 0
    assert 'engine = "simd"' in capsys.readouterr().out
    # the Python API records it too
    specs, _ = sweeps.build_specs(
        config=default_config("chapter", max_trials=1),
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=Simulation(duration=1.0),
        seeds=SEEDS[:1],
        inits=("chapter",),
        eval_draws=0,
    )
    sweeps.run_sweep(specs, {"x": 1}, out=tmp_path / "api", max_trials=1, engine="simd")
    assert "trial_kernel" in json.loads((tmp_path / "api" / "sweep.json").read_text())


def test_a_shared_w0_evaluation_gives_the_rows_of_separate_ones(counted: KernelCounter) -> None:
    """A learner and its control of one init and seed evaluate W(0) once, in every local
    engine; each row is the row of a run that evaluates W(0) alone, counts included."""
    specs = _specs(default_config("chapter", max_trials=4), seeds=SEEDS[:2], eval_draws=3)
    alone = []
    for s in specs:  # each run alone: nothing to share with
        (row,) = pool.execute([s])
        alone.append(row)
    separate = counted.calls
    serial = list(pool.execute(specs))
    # 2 seeds x 2 inits evaluate W(0) (the mean policy and 3 draws) once, not twice
    assert separate - (counted.calls - separate) == 2 * 2 * (1 + 3)
    two = list(pool.execute(specs, workers=2))
    batch = list(execute_batch(specs))
    for rows in (serial, two, batch):
        assert _no_wall(runs_csv.sort_rows(rows)) == _no_wall(runs_csv.sort_rows(alone))
        assert all(r["wall_seconds"] > 0 for r in rows)
    assert len(runner.shared_w0(specs)) == 4
    # nothing to share without evaluation draws, or for a run alone
    assert runner.shared_w0(_specs(CASES["chapter"], eval_draws=0)) == {}
    assert runner.shared_w0(specs[:1]) == {}


def test_a_run_takes_w0_evaluation_from_its_source_or_makes_its_own() -> None:
    (spec, *_) = _specs(default_config("chapter", max_trials=2), seeds=SEEDS[:1], eval_draws=3)
    own = drive(runner.run_steps(spec))
    made = runner.evaluate_w0(spec)
    assert made.rate == own["pass_rate_W0"] and made.simulations == 4
    # not made yet: the run makes its own, with the same result
    assert _no_wall(drive(runner.run_steps(spec, w0=lambda: None))) == _no_wall(own)
    # made: taken as it is (a different rate shows it was not recomputed)
    other = replace(made, rate=0.5)
    taken = drive(runner.run_steps(spec, w0=lambda: other))
    assert taken["pass_rate_W0"] == 0.5
    assert taken["eval_simulations"] == own["eval_simulations"]


def test_requests_grouped_by_their_objects_group_as_by_their_keys() -> None:
    """prepare's grouping (each request's objects first, then one key a group of them)
    gives the groups of batch_key itself: equal but distinct objects share a call,
    another gamma, plant or readings does not, and a recorded trial runs alone."""
    import numpy as np

    from striatal.sim.batch import _groups
    from striatal.sim.rollout import Protocol, TrialRequest

    plant, other_plant = Plant(), Plant(pole_mass=0.2)
    template = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C)
    chapter_sign = replace(template, balance_sign="chapter")
    protocol = Protocol()

    def request(**changes: Any) -> TrialRequest:
        made: dict[str, Any] = {
            "plant": plant,
            "controller": template,
            "sim": SHORT,
            "protocol": protocol,
            "rng": np.random.default_rng(0),
            "gamma": 0.999,
        }
        made.update(changes)
        return TrialRequest(**made)

    requests = [
        request(),
        request(protocol=Protocol(), sim=Simulation(duration=20.0), plant=Plant()),
        request(gamma=0.9),
        request(record=True),
        request(plant=other_plant),
        request(controller=template.with_gains(CHAPTER_INITIAL_W, 0.5)),
        request(controller=chapter_sign),
        request(rng=None),
        request(),
    ]
    keys, groups = _groups(requests)
    want: dict[tuple[object, ...], list[int]] = {}
    for i, r in enumerate(requests):
        key = r.batch_key()
        assert keys[i] == key
        if key is not None:
            want.setdefault(key, []).append(i)
    assert groups == want
    assert list(groups.values()) == [[0, 1, 5, 8], [2], [4], [6], [7]]


def test_lockstep_runs_at_its_switch_interval_and_restores_python_s() -> None:
    """While Lockstep runs, Python's switch interval is SWITCH_INTERVAL (the runs see it);
    after, whatever it was, also when a run raises."""
    import sys

    from striatal.sim.batch import SWITCH_INTERVAL

    seen: list[float] = []

    def steps(fail: bool) -> Steps[int]:
        seen.append(sys.getswitchinterval())
        if fail:
            raise RuntimeError("a run failed")
        return 1
        yield []

    before = sys.getswitchinterval()
    assert before > SWITCH_INTERVAL
    assert dict(Lockstep([steps(False), steps(False)]).run()) == {0: 1, 1: 1}
    assert seen == [pytest.approx(SWITCH_INTERVAL)] * 2 and sys.getswitchinterval() == before
    with pytest.raises(RuntimeError, match="a run failed"):
        list(Lockstep([steps(True)]).run())
    assert sys.getswitchinterval() == before


def _rounds(n: int, seed: int) -> Steps[tuple[float, ...]]:
    """``n`` rounds of one noisy 2-s trial each, every round's gains from the last one's
    end state: a run whose values depend on every outcome and every draw in order."""
    from striatal.sim.rollout import Protocol, TrialRequest

    rng = np.random.default_rng(seed)
    sim, W, seen = Simulation(duration=2.0), np.array(CHAPTER_INITIAL_W), []
    template = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C)
    for _ in range(n):
        (out,) = yield [TrialRequest(Plant(), template, sim, Protocol(), rng=rng, gains=W)]
        seen.append(out.final_state[2])
        W = W + 0.01 * out.final_state[2]
    return (*seen, *W.tolist())


@pytest.mark.parametrize("lanes", [1, 2, 3, 5])
def test_any_number_of_lanes_gives_each_run_its_values_alone(lanes: int) -> None:
    """One lane, more lanes than cores (their threads share them) or fewer than runs:
    every run's values are what it gives alone on the scalar kernel, bit for bit."""
    alone = [drive(_rounds(n, seed)) for seed, n in enumerate((1, 4, 2, 6, 3, 5))]
    steps = [_rounds(n, seed) for seed, n in enumerate((1, 4, 2, 6, 3, 5))]
    together = dict(Lockstep(steps, "batch", lanes=lanes).run())
    assert [together[i] for i in range(len(alone))] == alone
    assert len({v[0] for v in alone}) > 2  # the runs differ among themselves


def _changing_rounds(seed: int) -> Steps[tuple[float, ...]]:
    """Six rounds: 3 trials of 2 s, 1 of 3 s, 1 of the mean policy (no normals), 5 of
    2 s, 2 of 1 s, 4 of 3 s, each round's gains from the last one's outcomes: a lane's
    rounds need fewer normals, none, more than any before, fewer, and more again."""
    from striatal.sim.rollout import Protocol, TrialRequest

    rng = np.random.default_rng(seed)
    W = np.array(CHAPTER_INITIAL_W)
    template = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C)
    seen: list[float] = []
    plan = [(3, 2.0, False), (1, 3.0, False), (1, 1.0, True), (5, 2.0, False), (2, 1.0, False)]
    plan += [(4, 3.0, False)]
    for n, duration, mean in plan:
        sim = Simulation(duration=duration)
        outs = yield [
            TrialRequest(Plant(), template, sim, Protocol(), rng=rng, gains=W, mean_policy=mean)
            for _ in range(n)
        ]
        seen += [out.final_state[2] for out in outs]
        W = W + 0.01 * seen[-1]
    return (*seen, *W.tolist())


@pytest.mark.parametrize("engine", ["batch", "simd"])
def test_lanes_reusing_their_noise_buffers_give_each_run_its_values(
    monkeypatch: pytest.MonkeyPatch, engine: str
) -> None:
    """Each lane's rounds, larger and smaller, draw into the lane's one buffer (grown
    only when a round needs more), and every run's values are those of fresh buffers
    (run_requests round by round): on the exact engine, the scalar kernel's (drive)."""
    from striatal.sim import batch

    def fresh(steps: Steps[tuple[float, ...]]) -> tuple[float, ...]:
        try:
            requests = next(steps)
            while True:
                requests = steps.send(batch.run_requests(requests, engine))  # type: ignore[arg-type]
        except StopIteration as stop:
            return stop.value  # type: ignore[no-any-return]

    takes: list[tuple[int, int, bool]] = []  # (buffer, normals, grown) of each round
    take = batch.NoiseBuffer.take

    def counted(self: batch.NoiseBuffer, size: int) -> np.ndarray:
        before = self._data
        normals = take(self, size)
        takes.append((id(self), size, self._data is not before))
        return normals

    monkeypatch.setattr(batch.NoiseBuffer, "take", counted)
    seeds = range(5)
    want = [fresh(_changing_rounds(seed)) for seed in seeds]
    if engine == "batch":
        assert want == [drive(_changing_rounds(seed)) for seed in seeds]
    assert not takes  # run_requests: a fresh buffer each round
    together = dict(Lockstep([_changing_rounds(seed) for seed in seeds], engine, 2).run())  # type: ignore[arg-type]
    assert [together[i] for i in seeds] == want
    assert len(takes) == 2 * 6 and len({lane for lane, _, _ in takes}) == 2
    for lane in {lane for lane, _, _ in takes}:
        sizes = [size for mine, size, _ in takes if mine == lane]
        grown = [g for mine, _, g in takes if mine == lane]
        assert sizes[2] == 0 and sizes[4] < sizes[1] < sizes[0] < sizes[3] < sizes[5]
        # grown only for a round that needs more than any before it
        assert grown == [True, False, False, True, False, True]


def test_the_engines_lanes_and_a_bad_lane_count() -> None:
    # a lane a worker of lane_threads: two on two cores, as the process engine's workers
    assert Lockstep([], "batch").lanes == Lockstep([], "simd").lanes == lane_threads()[0]
    with pytest.raises(ParameterError, match="lanes must be at least 1"):
        Lockstep([], "batch", lanes=0)


def test_a_lane_takes_every_thread_only_when_it_is_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each call gets its share of Numba's threads among the lanes still driving runs
    (three here: the first call of the long run, while the two short runs wait for it),
    and every thread once its lane is the only one left (its last round waits for the
    other lanes' threads to end)."""
    import threading

    import numba

    from striatal.sim import batch

    long_started = threading.Event()
    given: list[tuple[int, int]] = []  # (rounds of the long run so far, threads) of its calls

    def short(seed: int) -> Steps[tuple[float, ...]]:
        value = yield from _rounds(1, seed)
        assert long_started.wait(timeout=60)  # the long run's first call made with 3 lanes
        return value

    def long(n: int) -> Steps[tuple[float, ...]]:
        steps, outcomes, k = _rounds(n, 2), None, 0
        try:
            while True:
                requests = next(steps) if outcomes is None else steps.send(outcomes)
                if k == n - 1:  # the last round: after the other lanes' threads ended
                    for t in threading.enumerate():
                        if t.name in ("lockstep_0", "lockstep_1"):
                            t.join(timeout=60)
                outcomes, k = (yield requests), k + 1
        except StopIteration as stop:
            return stop.value  # type: ignore[no-any-return]

    real = batch._timed

    def timed(calls: batch.Calls, threads: int) -> float:
        if threading.current_thread().name == "lockstep_2":
            given.append((len(given), threads))
            long_started.set()
        return real(calls, threads)

    monkeypatch.setattr(batch, "_timed", timed)
    every = numba.get_num_threads()
    values = dict(Lockstep([short(0), short(1), long(8)], lanes=3).run())
    assert values[2] == drive(_rounds(8, 2)) and values[0] == drive(_rounds(1, 0))
    assert len(given) == 8
    assert given[0] == (0, max(1, every // 3))  # three lanes live
    assert given[-1] == (7, every)  # the long run's last round: its lane alone


@pytest.mark.parametrize("engine", ["batch", "simd"])
def test_a_lane_that_raises_stops_the_others_and_reaches_the_caller(engine: str) -> None:
    """A run that raises in one lane: the caller gets its exception, and the other lane
    stops after its round under way instead of running its long run to the end."""
    import threading

    rounds = [0]

    def failing() -> Steps[tuple[float, ...]]:
        yield from _rounds(2, 0)
        raise RuntimeError("a run failed")

    def long() -> Steps[tuple[float, ...]]:
        steps, outcomes = _rounds(400, 1), None
        try:
            while True:
                requests = next(steps) if outcomes is None else steps.send(outcomes)
                rounds[0] += 1
                outcomes = yield requests
        except StopIteration as stop:
            return stop.value  # type: ignore[no-any-return]

    with pytest.raises(RuntimeError, match="a run failed"):
        list(Lockstep([failing(), long()], engine, lanes=2).run())  # type: ignore[arg-type]
    assert 0 < rounds[0] < 400
    assert not [t for t in threading.enumerate() if t.name.startswith("lockstep_")]


def test_lanes_take_turns_when_numbas_layer_takes_one_call_at_a_time(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Under a layer that takes one parallel call at a time (workqueue; lane_threads says
    one worker), two lanes still drive their runs side by side, their calls one after
    the other: every run's values are its own, bit for bit."""
    import threading

    import numba

    from striatal.sim import batch

    running, most = [0], [0]
    guard = threading.Lock()
    real = batch._timed

    def timed(calls: batch.Calls, threads: int) -> float:
        with guard:
            running[0] += 1
            most[0] = max(most[0], running[0])
        try:
            return real(calls, threads)
        finally:
            with guard:
                running[0] -= 1

    monkeypatch.setattr(batch, "lane_threads", lambda: (1, numba.get_num_threads()))
    monkeypatch.setattr(batch, "_timed", timed)
    alone = [drive(_rounds(n, seed)) for seed, n in enumerate((3, 5, 2, 4))]
    together = dict(Lockstep([_rounds(n, s) for s, n in enumerate((3, 5, 2, 4))], lanes=2).run())
    assert [together[i] for i in range(4)] == alone
    assert most[0] == 1
