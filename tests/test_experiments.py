"""Sweeps: seeds, the worker, the control arm, resume, statistics, backends."""

from __future__ import annotations

import json
import math
import os
import random
import shutil
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from striatal.cli import main
from striatal.errors import DataFileError, ParameterError
from striatal.experiments import pool, report, runner, runs_csv, sweeps
from striatal.experiments.spec import RunSpec, initial_gains, spawn_seeds
from striatal.learners import LearnerConfig, random_initial_gains
from striatal.learners import learn as train
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)

SHORT = Simulation(duration=20.0)


def _specs(
    seeds: tuple[int, ...], max_trials: int = 15, methods: tuple[str, ...] = ()
) -> list[RunSpec]:
    specs, _ = sweeps.build_specs(
        config=LearnerConfig(max_trials=max_trials),
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=SHORT,
        seeds=seeds,
        inits=("chapter", "random"),
        methods=methods,
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


def test_spawn_seeds_follow_seed_sequence() -> None:
    seeds = spawn_seeds(7, 5)
    children = np.random.SeedSequence(7).spawn(5)
    assert seeds == tuple(int(c.generate_state(1)[0]) for c in children)
    assert len(set(seeds)) == 5
    assert spawn_seeds(7, 3) == seeds[:3]
    with pytest.raises(ParameterError):
        spawn_seeds(0, 0)


def test_row_is_the_train_run_of_its_seed() -> None:
    """A row with seed S is exactly `striatal train --seed S --init random`."""
    spec = next(s for s in _specs((12345,)) if s.arm == "learner" and s.init == "random")
    row = runner.run_one(spec)
    W0 = random_initial_gains(np.random.default_rng([12345, 1]))
    result = train(Plant(), Controller(W0, CHAPTER_INITIAL_THETA_C), spec.config, 12345, sim=SHORT)
    assert row["trials"] == result.trials_done and row["success"] == result.success
    assert [row[f"W{i}"] for i in range(1, 7)] == list(result.W)
    assert row["theta_c"] == result.theta_c
    assert [row[f"W0_{i}"] for i in range(1, 7)] == list(W0)


def test_control_arm_never_changes_W_but_theta_c_follows_eq21() -> None:
    config = LearnerConfig(alpha=0.0, max_trials=40)
    template = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C)
    seen_W: list[tuple[float, ...]] = []
    seen_theta_c: list[float] = []

    def on_trial(state: Any, record: Any) -> None:
        seen_W.append(state.W)
        seen_theta_c.append(state.theta_c)

    train(Plant(), template, config, 3, sim=SHORT, on_trial=on_trial)
    assert len(seen_W) == 40
    assert all(w == CHAPTER_INITIAL_W for w in seen_W)
    assert len(set(seen_theta_c)) > 1  # eq 21 still moves theta_c
    for spec in _specs((1, 2)):
        if spec.arm == runner.CONTROL_ARM:
            row = runner.run_one(spec)
            assert [row[f"W{i}"] for i in range(1, 7)] == [row[f"W0_{i}"] for i in range(1, 7)]
            assert row["alpha"] == 0.0


def _row(**kw: Any) -> dict[str, Any]:
    base = {
        "simulations": 2 * kw["trials"],
        "simulated_seconds": 60.0 * kw["trials"],
        "eval_simulations": 1,
        "pass_rate_W0": math.nan,
        "pass_rate": math.nan,
        "mean_policy_success": True,
        "wall_seconds": 0.5,
        "role": "learner",
        "learner": "chapter",
        "method": "learn",
    }
    return {**base, **kw}


def test_arm_statistics_on_handmade_rows() -> None:
    rows = [
        _row(success=True, trials=t, mean_policy_success=t < 30, wall_seconds=1.0)
        for t in (10, 20, 30, 40)
    ] + [_row(success=False, trials=100, mean_policy_success=False, wall_seconds=2.0)]
    s = report.arm_statistics(rows, max_trials=100)
    assert s["runs"] == 5 and s["successes"] == 4
    assert s["success_rate"] == pytest.approx(0.8)
    assert s["unsolved_share"] == pytest.approx(0.2)
    assert s["trials_median"] == pytest.approx(25.0)
    assert s["trials_q1"] == pytest.approx(17.5)
    assert s["trials_q3"] == pytest.approx(32.5)
    assert s["trials_median_all"] == pytest.approx(30.0)
    assert s["mean_policy_success_rate"] == pytest.approx(0.4)
    assert s["wall_seconds_total"] == pytest.approx(6.0)
    # the stats of issue 14: Wilson interval, medians over solved runs with bootstrap intervals
    lo, hi = s["success_rate_ci"]
    assert lo == pytest.approx(0.3755, abs=1e-3) and hi == pytest.approx(0.9638, abs=1e-3)
    assert s["simulations_median"] == 50.0 and s["simulations_iqm"] == pytest.approx(50.0)
    assert s["simulations_median_ci"][0] <= 50.0 <= s["simulations_median_ci"][1]
    assert s["simulations_total"] == 2 * (10 + 20 + 30 + 40 + 100)
    empty = report.arm_statistics(
        [_row(success=False, trials=9, mean_policy_success=False, wall_seconds=0.0)], 9
    )
    assert math.isnan(empty["trials_median"]) and empty["unsolved_share"] == 1.0
    assert empty["simulations_median"] is None


def test_summary_does_not_depend_on_completion_order() -> None:
    rows = [
        _row(
            arm=arm,
            role=arm,
            init="chapter",
            seed=seed,
            success=seed % 2 == 0 or (arm == "learner" and seed == 1),
            trials=seed,
        )
        for arm in ("learner", "control")
        for seed in range(1, 9)
    ]
    a = report.summarise(rows, 10, {"x": 1})
    shuffled = rows[:]
    random.Random(0).shuffle(shuffled)
    assert report.summarise(shuffled, 10, {"x": 1}) == a
    assert [x["arm"] for x in a["arms"]] == ["control", "learner"]
    pair = a["learner_vs_control"][0]
    assert pair["success_rate"] == 5 / 8 and pair["control_success_rate"] == 0.5
    assert pair["mcnemar"]["only_a"] == 1 and pair["mcnemar"]["only_b"] == 0
    assert pair["mcnemar"]["p_value"] == 1.0 and pair["same_seeds"]
    assert 0.0 < pair["fisher"]["p_value"] <= 1.0
    assert "theta_c still follows eq 21" in a["notes"][0]


def test_each_learner_is_paired_with_each_baseline_on_its_seeds() -> None:
    """learner_vs_baselines: McNemar's test on the seeds both ran, and the restricted mean
    (unsolved seeds counted at what they spent) beside the rates."""
    solved = {"learner": {1, 2, 3}, "random": {2, 3, 4, 5}, "lqr": set()}
    rows = [
        _row(
            arm=arm,
            role="learner" if arm == "learner" else "baseline",
            method="learn" if arm == "learner" else arm,
            init=init,
            seed=seed,
            success=seed in solved[arm],
            trials=seed if seed in solved[arm] else 10,
        )
        for arm in solved
        for init in ("chapter", "random")
        for seed in range(1, 7)
    ]
    s = report.summarise(rows, 10, {"x": 1})
    pairs = {(p["baseline"], p["init"]): p for p in s["learner_vs_baselines"]}
    assert set(pairs) == {(b, i) for b in ("random", "lqr") for i in ("chapter", "random")}
    mc = pairs[("random", "chapter")]["mcnemar"]
    assert (mc["both"], mc["only_a"], mc["only_b"], mc["neither"]) == (2, 1, 2, 1)
    assert pairs[("lqr", "random")]["mcnemar"]["only_a"] == 3
    learner = next(a for a in s["arms"] if a["arm"] == "learner" and a["init"] == "chapter")
    spent = [60.0 * t for t in (1, 2, 3, 10, 10, 10)]
    assert learner["simulated_seconds_restricted_mean"] == pytest.approx(sum(spent) / 6)
    lo, hi = learner["simulated_seconds_restricted_mean_ci"]
    assert min(spent) <= lo <= sum(spent) / 6 <= hi <= max(spent)
    # over solved seeds only, the median hides the unsolved ones: 120 s against ~ 360 s
    assert learner["simulated_seconds_median"] == 120.0
    table = report.markdown_table(s)
    assert "| learner | random | chapter | 50% [19%, 81%] | 67% [30%, 90%] | 360 / 340 |" in table


def test_a_runs_file_from_before_the_imagined_columns_resumes(tmp_path: Path) -> None:
    """Its rows read with 0 imagined trials, and the folder is rewritten with today's
    columns, so the rows appended next line up."""
    specs = _specs((11, 12), max_trials=3)
    out = tmp_path / "old"
    full = sweeps.run_sweep(specs, {"x": 1}, out=out, max_trials=3)
    path = out / "runs.csv"
    old_columns = runs_csv.COLUMNS_BEFORE_IMAGINED
    old = [{k: r[k] for k in old_columns} for r in full.rows[:2]]
    from striatal.io.files import csv_text

    cells = [[int(r[c]) if isinstance(r[c], bool) else r[c] for c in old_columns] for r in old]
    path.write_text(csv_text(old_columns, cells), encoding="utf-8")
    rows, clean = runs_csv.read_runs(path)
    assert [r["imagined_simulations"] for r in rows] == [0, 0]
    assert clean.splitlines()[0] == ",".join(runs_csv.RUN_COLUMNS)
    again = sweeps.run_sweep(specs, {"x": 1}, out=out, max_trials=3)
    assert (again.skipped, again.ran) == (2, len(specs) - 2)
    assert len(runs_csv.read_runs(path)[0]) == len(specs)
    assert _no_wall(again.summary) == _no_wall(full.summary)


def test_duplicate_runs_are_dropped_on_read_and_refused_by_the_summary(tmp_path: Path) -> None:
    """Issue 16 item 4: a duplicated (arm, init, seed) line was counted twice."""
    rows = [_row(arm="learner", init="chapter", seed=s, success=True, trials=3) for s in (1, 2)]
    with pytest.raises(ParameterError, match="twice"):
        report.summarise([*rows, rows[0]], 10, {})
    path = tmp_path / "runs.csv"
    spec = _specs((1,), max_trials=2)[0]
    line = runs_csv.row_text({**runner.run_one(spec), "settings_id": sweeps.settings_id(spec)})
    header = ",".join(runs_csv.RUN_COLUMNS) + "\n"
    path.write_text(header + line + line)
    read, clean = runs_csv.read_runs(path)
    assert len(read) == 1 and clean == header + line
    summary = sweeps.run_sweep([spec], {"t": 1}, out=tmp_path, max_trials=2)
    assert summary.ran == 0 and summary.summary["arms"][0]["runs"] == 1
    assert (tmp_path / "runs.csv").read_text() == header + line


def test_resume_skips_finished_runs_and_gives_the_same_summary(tmp_path: Path) -> None:
    specs = _specs((1, 2, 3), methods=("hand",))
    settings = {"test": "resume"}
    full = sweeps.run_sweep(specs, settings, out=tmp_path / "a", max_trials=15)
    assert full.ran == len(specs) and full.skipped == 0
    runs = tmp_path / "a" / "runs.csv"
    lines = runs.read_text().splitlines(keepends=True)
    # keep the header and 4 rows, then a line a SIGKILL cut short
    runs.write_text("".join(lines[:5]) + lines[5][: len(lines[5]) // 2])
    (tmp_path / "a" / "summary.json").unlink()
    again = sweeps.run_sweep(specs, settings, out=tmp_path / "a", max_trials=15)
    assert again.skipped == 4 and again.ran == len(specs) - 4
    assert _no_wall(again.summary) == _no_wall(full.summary)
    assert _no_wall(again.rows) == _no_wall(full.rows)
    stored = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert _no_wall(stored) == _no_wall(sweeps.json_roundtrip(full.summary))
    rows, _ = runs_csv.read_runs(runs)
    assert len(rows) == len(specs)
    nothing = sweeps.run_sweep(specs, settings, out=tmp_path / "a", max_trials=15)
    assert nothing.ran == 0
    with pytest.raises(ParameterError, match="other settings"):
        sweeps.run_sweep(specs, {"test": "other"}, out=tmp_path / "a", max_trials=15)


def test_read_runs_rejects_a_bad_middle_line(tmp_path: Path) -> None:
    path = tmp_path / "runs.csv"
    specs = _specs((1,), max_trials=3)[:2]
    body = "".join(runs_csv.row_text(runner.run_one(s)) for s in specs)
    header = ",".join(runs_csv.RUN_COLUMNS) + "\n"
    path.write_text(header + "garbage,1\n" + body)
    with pytest.raises(DataFileError, match="line 2"):
        runs_csv.read_runs(path)
    path.write_text(header + body + "learner,learn,chapter,xx\n")
    assert len(runs_csv.read_runs(path)[0]) == 2
    path.write_text("something,else\n")
    with pytest.raises(DataFileError, match="header"):
        runs_csv.read_runs(path)


def test_local_pool_gives_the_serial_rows() -> None:
    specs = _specs((5, 6), max_trials=10, methods=("random",))
    serial = runs_csv.sort_rows(pool.execute(specs, workers=1))
    pooled = runs_csv.sort_rows(pool.execute(specs, workers=2))
    assert _no_wall(serial) == _no_wall(pooled)


def test_sweep_and_compare_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s"
    argv = ["sweep", "--seeds", "2", "--max-trials", "5", "--duration", "20", "--out", str(out)]
    assert main([*argv, "--json", "--baselines", "lqr", "--alpha-grid", "2,5"]) == 0
    summary = json.loads(capsys.readouterr().out)
    arms = {a["arm"] for a in summary["arms"]}
    assert arms == {"learner a=2 g=0.999", "learner a=5 g=0.999", "control", "lqr"}
    assert summary["settings"]["arms"]["control"]["config"]["alpha"] == 0.0
    seeds = summary["settings"]["run_seeds"]
    assert seeds == list(spawn_seeds(0, 2))
    assert main(["compare", str(out), "--out", str(tmp_path / "cmp.json")]) == 0
    table = capsys.readouterr().out
    assert table.startswith("| arm | init |") and "| control | chapter | 2 |" in table
    assert len(json.loads((tmp_path / "cmp.json").read_text())["arms"]) == 4
    with pytest.raises(SystemExit) as refused:  # refused by the parser, from the option table
        main(["sweep", "--seeds", "0"])
    assert refused.value.code == 2
    assert main(["sweep", "--backend", "ray"]) == 2
    assert main(["sweep", "--baselines", "nope"]) == 2
    assert main(["compare", str(tmp_path / "missing")]) == 2
    assert "error" in capsys.readouterr().err.lower()


def test_compare_names_the_learner_when_sweeps_mix_learners(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["sweep", "--seeds", "2", "--max-trials", "3", "--duration", "20", "--json"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    assert main([*argv, "--out", str(tmp_path / "b"), "--learner", "pgpe"]) == 0
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    table = capsys.readouterr().out
    for name in ("learner (chapter)", "control (chapter)", "learner (pgpe)", "control (pgpe)"):
        assert f"| {name} | chapter | 2 |" in table
    for learner in ("chapter", "pgpe"):  # the learner-against-control rows too
        assert f"| learner ({learner}) | control ({learner}) | chapter |" in table
    assert main(["compare", str(tmp_path / "b")]) == 0  # one learner: plain names
    assert "| learner | chapter | 2 |" in capsys.readouterr().out


def test_sweep_passes_learner_options_through(tmp_path: Path) -> None:
    from striatal.cli import build_parser
    from striatal.cli.sweep import prepare

    args = build_parser().parse_args(
        ["sweep", "--seeds", "1", "--learner", "rpe", "--max-trials", "7", "--no-control"]
    )
    plan = prepare(args)
    assert plan.max_trials == 7
    assert {s.config.learner for s in plan.specs} == {"rpe"}
    assert plan.settings["arms"]["learner"]["config"]["normalise"] is True


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.cluster
def test_ray_backend_gives_the_local_rows(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the Ray path needs the [cluster] extra (ray)")
    bindir = Path(sys.executable).parent
    ray_bin = shutil.which("ray", path=str(bindir)) or shutil.which("ray")
    if ray_bin is None:
        pytest.skip("the ray command is not installed next to this Python")
    port = _free_port()
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    start = [
        ray_bin,
        "start",
        "--head",
        f"--port={port}",
        "--node-ip-address=127.0.0.1",
        "--num-cpus=2",
        "--include-dashboard=false",
        "--disable-usage-stats",
    ]
    subprocess.run(start, check=True, env=env, capture_output=True, timeout=90)
    try:
        specs = _specs((11, 12), max_trials=8, methods=("cmaes",))
        local = runs_csv.sort_rows(pool.execute(specs))
        ray_rows = runs_csv.sort_rows(
            pool.execute(specs, backend="ray", address=f"127.0.0.1:{port}")
        )
        assert _no_wall(ray_rows) == _no_wall(local)
    finally:
        subprocess.run([ray_bin, "stop", "--force"], env=env, capture_output=True, timeout=60)


class KernelCalls:
    """Counts the calls of the kernel's trial entry (every simulated trial goes through it)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        from striatal.sim import kernel

        self.n = 0
        real = kernel.run_trial

        def counted(*args: Any) -> Any:
            self.n += 1
            return real(*args)

        monkeypatch.setattr(kernel, "run_trial", counted)


@pytest.mark.parametrize(
    ("method", "learner"), [("learn", "chapter"), ("learn", "pgpe"), ("random", ""), ("cmaes", "")]
)
def test_simulations_equal_the_kernel_calls(
    monkeypatch: pytest.MonkeyPatch, method: str, learner: str
) -> None:
    """Issue 14: every simulated trial is counted, the mean-policy checks included."""
    from striatal.learners import default_config
    from striatal.sim.batch import drive

    config = default_config(learner or "chapter", max_trials=12, success_on="mean")
    arm = sweeps.Arm("a", method, config, "learner" if method == "learn" else "baseline")
    (spec,), _ = sweeps.specs_of(
        [arm],
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=SHORT,
        seeds=(4,),
        inits=("random",),
        eval_draws=3,
    )
    calls = KernelCalls(monkeypatch)
    found = drive(runner.search(spec, initial_gains("random", 4)))
    assert found["simulations"] == calls.n
    if learner == "chapter":  # a noisy trial plus a mean-policy check per trial
        assert found["simulations"] == 2 * found["trials"]
    elif learner == "pgpe":  # its trial is the check of the candidate: nothing more
        assert found["simulations"] == found["trials"]
    else:
        assert found["simulations"] == found["trials"]
    assert 0 < found["simulated_seconds"] <= SHORT.duration * found["simulations"] + 1e-9
    calls.n = 0
    row = runner.run_one(spec)
    assert row["simulations"] + row["eval_simulations"] == calls.n
    assert row["simulations"] == found["simulations"]
    assert row["eval_simulations"] == 1 + 2 * (3 + 1)  # re-simulation, two pass probabilities
    assert 0.0 <= row["pass_rate_W0"] <= 1.0 and 0.0 <= row["pass_rate"] <= 1.0


def test_pgpe_control_draws_the_learners_perturbations(monkeypatch: pytest.MonkeyPatch) -> None:
    """The exploration-only control draws the same perturbations as pgpe under one seed:
    the same p' until the first update, the same z every trial, and never moves p."""
    from striatal.learners import control_config, default_config, learning_step
    from striatal.learners.common import initial_state
    from striatal.learners.pgpe import PgpeRule
    from striatal.sim.rollout import Protocol

    seen: dict[str, list[dict[str, Any]]] = {"learner": [], "control": []}
    real = PgpeRule.plan
    who = ["learner"]

    def plan(self: Any, *args: Any) -> Any:
        p = real(self, *args)
        seen[who[0]].append({k: np.array(v) for k, v in p.scratch.items()} | {"W": p.W})
        return p

    monkeypatch.setattr(PgpeRule, "plan", plan)
    learner = default_config("pgpe", max_trials=6)
    control = control_config(learner)
    assert (control.alpha, control.sigma_rate) == (0.0, 0.0)
    W0 = random_initial_gains(np.random.default_rng([8, 1]))
    template = Controller(W0, CHAPTER_INITIAL_THETA_C)
    for name, cfg in (("learner", learner), ("control", control)):
        who[0] = name
        state = initial_state(W0, CHAPTER_INITIAL_THETA_C, 8)
        for _ in range(6):
            state, _ = learning_step(state, Plant(), template, SHORT, Protocol(), cfg)
            if state.success:
                break
    a, b = seen["learner"], seen["control"]
    n = min(len(a), len(b))
    assert n >= 2
    np.testing.assert_array_equal(a[0]["W"], b[0]["W"])  # trial 1: the same candidate p'
    np.testing.assert_array_equal(a[0]["eps"], b[0]["eps"])
    for x, y in zip(a[:n], b[:n], strict=True):
        np.testing.assert_array_equal(x["z"], y["z"])  # the same draws every trial
    p0 = np.array([*W0[:5], CHAPTER_INITIAL_THETA_C])
    for y in b:
        np.testing.assert_array_equal(y["p"], p0)  # the control never moves p
    assert not np.array_equal(a[1]["p"], p0)  # the learner has updated


def test_a_second_sweep_on_a_locked_out_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 16 item 2: one line, exit 2, nothing written."""
    from striatal.io.rundir import RunDir

    out = tmp_path / "s"
    with RunDir(out).lock():
        code = main(["sweep", "--seeds", "1", "--max-trials", "1", "--out", str(out)])
        code_ablation = main(["ablation", "--seeds", "1", "--variants", "pgpe", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and code_ablation == 2
    assert len(err) == 2 and all("in use by another striatal process" in e for e in err)
    assert sorted(p.name for p in out.iterdir()) == []


WATCHED = """
import os, sys, time
from concurrent.futures import ProcessPoolExecutor
from striatal.experiments import pool, report, runner, runs_csv, sweeps
from striatal.experiments.spec import RunSpec, initial_gains, spawn_seeds
pool = ProcessPoolExecutor(
    max_workers=2, initializer=pool._worker_init, initargs=(os.getpid(),)
)
futures = [pool.submit(time.sleep, 120) for _ in range(2)]
time.sleep(1.0)
print(" ".join(str(p) for p in pool._processes), flush=True)
time.sleep(120)
"""


def _alive(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_exit_soon_after_their_parent_is_killed() -> None:
    """Issue 16 item 6: sweep workers outlived a SIGKILLed parent by minutes."""
    import signal
    import time

    parent = subprocess.Popen(
        [sys.executable, "-c", WATCHED], stdout=subprocess.PIPE, text=True, env=os.environ
    )
    try:
        assert parent.stdout is not None
        pids = [int(p) for p in parent.stdout.readline().split()]
        assert len(pids) == 2 and all(_alive(p) for p in pids)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.1)
        assert not any(_alive(p) for p in pids)
    finally:
        if parent.poll() is None:
            parent.kill()


def test_ray_address_that_never_answers_is_given_up_on() -> None:
    """Issue 16 item 7: one line and exit 2 after --connect-timeout, not ten minutes."""
    pytest.importorskip("ray", reason="the Ray path needs the [cluster] extra (ray)")
    import time

    cmd = [sys.executable, "-m", "striatal", "sweep", "--seeds", "1", "--backend", "ray"]
    cmd += ["--address", "127.0.0.1:1", "--connect-timeout", "2", "--no-progress"]
    t0 = time.monotonic()
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2, r.stderr
    assert time.monotonic() - t0 < 30
    assert len(r.stderr.strip().splitlines()) == 1 and "127.0.0.1:1" in r.stderr
    with pytest.raises(SystemExit) as refused:
        main(["sweep", "--backend", "ray", "--address", "x:1", "--connect-timeout", "0"])
    assert refused.value.code == 2


@pytest.mark.parametrize(
    ("field", "value"),
    [("success_rate", "x"), ("arm", 5), ("wall_seconds_total", {}), ("success_rate_ci", [1])],
)
def test_compare_refuses_arm_fields_of_the_wrong_type(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], field: str, value: Any
) -> None:
    """Issue 16 item 9: one line and exit 2, not a TypeError."""
    arm = {
        "arm": "learner",
        "init": "chapter",
        "method": "learn",
        "runs": 2,
        "success_rate": 0.5,
        "unsolved_share": 0.5,
        "trials_median": 3.0,
        "wall_seconds_total": 1.0,
    }
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"arms": [arm]}))
    assert main(["compare", str(path)]) == 0
    capsys.readouterr()
    path.write_text(json.dumps({"arms": [{**arm, field: value}]}))
    assert main(["compare", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0]
