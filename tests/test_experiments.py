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

from striatal import experiments
from striatal.cli import main
from striatal.errors import DataFileError, ParameterError
from striatal.learn import LearnerConfig, random_initial_gains, train
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
) -> list[experiments.RunSpec]:
    specs, _ = experiments.build_specs(
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
    return obj


def test_spawn_seeds_follow_seed_sequence() -> None:
    seeds = experiments.spawn_seeds(7, 5)
    children = np.random.SeedSequence(7).spawn(5)
    assert seeds == tuple(int(c.generate_state(1)[0]) for c in children)
    assert len(set(seeds)) == 5
    assert experiments.spawn_seeds(7, 3) == seeds[:3]
    with pytest.raises(ParameterError):
        experiments.spawn_seeds(0, 0)


def test_row_is_the_train_run_of_its_seed() -> None:
    """A row with seed S is exactly `striatal train --seed S --init random`."""
    spec = next(s for s in _specs((12345,)) if s.arm == "learner" and s.init == "random")
    row = experiments.run_one(spec)
    W0 = random_initial_gains(np.random.default_rng([12345, 1]))
    result = train(Plant(), Controller(W0, CHAPTER_INITIAL_THETA_C), spec.config, 12345, sim=SHORT)
    assert row["trials"] == result.trials and row["success"] == result.success
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
        if spec.arm == experiments.CONTROL_ARM:
            row = experiments.run_one(spec)
            assert [row[f"W{i}"] for i in range(1, 7)] == [row[f"W0_{i}"] for i in range(1, 7)]
            assert row["alpha"] == 0.0


def test_arm_statistics_on_handmade_rows() -> None:
    rows = [
        {"success": True, "trials": t, "mean_policy_success": t < 30, "wall_seconds": 1.0}
        for t in (10, 20, 30, 40)
    ] + [{"success": False, "trials": 100, "mean_policy_success": False, "wall_seconds": 2.0}]
    s = experiments.arm_statistics(rows, max_trials=100)
    assert s["runs"] == 5 and s["successes"] == 4
    assert s["success_rate"] == pytest.approx(0.8)
    assert s["unsolved_share"] == pytest.approx(0.2)
    assert s["trials_median"] == pytest.approx(25.0)
    assert s["trials_q1"] == pytest.approx(17.5)
    assert s["trials_q3"] == pytest.approx(32.5)
    assert s["trials_median_all"] == pytest.approx(30.0)
    assert s["mean_policy_success_rate"] == pytest.approx(0.4)
    assert s["wall_seconds_total"] == pytest.approx(6.0)
    empty = experiments.arm_statistics(
        [{"success": False, "trials": 9, "mean_policy_success": False, "wall_seconds": 0.0}], 9
    )
    assert math.isnan(empty["trials_median"]) and empty["unsolved_share"] == 1.0


def test_summary_does_not_depend_on_completion_order() -> None:
    rows = [
        {
            "arm": arm,
            "method": "learn",
            "init": "chapter",
            "seed": seed,
            "success": seed % 2 == 0,
            "trials": seed,
            "mean_policy_success": True,
            "wall_seconds": 0.5,
        }
        for arm in ("learner", "control")
        for seed in range(1, 9)
    ]
    a = experiments.summarise(rows, 10, {"x": 1})
    shuffled = rows[:]
    random.Random(0).shuffle(shuffled)
    assert experiments.summarise(shuffled, 10, {"x": 1}) == a
    assert [x["arm"] for x in a["arms"]] == ["control", "learner"]
    assert a["learner_vs_control"][0]["success_rate"] == 0.5
    assert "theta_c still follows eq 21" in a["notes"][0]


def test_resume_skips_finished_runs_and_gives_the_same_summary(tmp_path: Path) -> None:
    specs = _specs((1, 2, 3), methods=("hand",))
    settings = {"test": "resume"}
    full = experiments.sweep(specs, settings, out=tmp_path / "a", max_trials=15)
    assert full.ran == len(specs) and full.skipped == 0
    runs = tmp_path / "a" / "runs.csv"
    lines = runs.read_text().splitlines(keepends=True)
    # keep the header and 4 rows, then a line a SIGKILL cut short
    runs.write_text("".join(lines[:5]) + lines[5][: len(lines[5]) // 2])
    (tmp_path / "a" / "summary.json").unlink()
    again = experiments.sweep(specs, settings, out=tmp_path / "a", max_trials=15)
    assert again.skipped == 4 and again.ran == len(specs) - 4
    assert _no_wall(again.summary) == _no_wall(full.summary)
    assert _no_wall(again.rows) == _no_wall(full.rows)
    stored = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert _no_wall(stored) == _no_wall(experiments.json_roundtrip(full.summary))
    rows, _ = experiments.read_runs(runs)
    assert len(rows) == len(specs)
    nothing = experiments.sweep(specs, settings, out=tmp_path / "a", max_trials=15)
    assert nothing.ran == 0
    with pytest.raises(ParameterError, match="other settings"):
        experiments.sweep(specs, {"test": "other"}, out=tmp_path / "a", max_trials=15)


def test_read_runs_rejects_a_bad_middle_line(tmp_path: Path) -> None:
    path = tmp_path / "runs.csv"
    specs = _specs((1,), max_trials=3)[:2]
    body = "".join(experiments.row_text(experiments.run_one(s)) for s in specs)
    header = ",".join(experiments.RUN_COLUMNS) + "\n"
    path.write_text(header + "garbage,1\n" + body)
    with pytest.raises(DataFileError, match="line 2"):
        experiments.read_runs(path)
    path.write_text(header + body + "learner,learn,chapter,xx\n")
    assert len(experiments.read_runs(path)[0]) == 2
    path.write_text("something,else\n")
    with pytest.raises(DataFileError, match="header"):
        experiments.read_runs(path)


def test_local_pool_gives_the_serial_rows() -> None:
    specs = _specs((5, 6), max_trials=10, methods=("random",))
    serial = experiments.sort_rows(experiments.execute(specs, workers=1))
    pooled = experiments.sort_rows(experiments.execute(specs, workers=2))
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
    assert seeds == list(experiments.spawn_seeds(0, 2))
    assert main(["compare", str(out), "--out", str(tmp_path / "cmp.json")]) == 0
    table = capsys.readouterr().out
    assert table.startswith("| arm | init |") and "| control | chapter | 2 |" in table
    assert len(json.loads((tmp_path / "cmp.json").read_text())["arms"]) == 4
    assert main(["sweep", "--seeds", "0"]) == 2
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
    assert main(["compare", str(tmp_path / "b")]) == 0  # one learner: plain names
    assert "| learner | chapter | 2 |" in capsys.readouterr().out


def test_sweep_passes_learner_options_through(tmp_path: Path) -> None:
    from striatal.cli import build_parser
    from striatal.cli.sweep import prepare

    args = build_parser().parse_args(
        ["sweep", "--seeds", "1", "--learner", "rpe", "--max-trials", "7", "--no-control"]
    )
    specs, settings, max_trials = prepare(args)
    assert max_trials == 7
    assert {s.config.learner for s in specs} == {"rpe"}
    assert settings["arms"]["learner"]["config"]["normalise"] is True


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
        local = experiments.sort_rows(experiments.execute(specs))
        ray_rows = experiments.sort_rows(
            experiments.execute(specs, backend="ray", address=f"127.0.0.1:{port}")
        )
        assert _no_wall(ray_rows) == _no_wall(local)
    finally:
        subprocess.run([ray_bin, "stop", "--force"], env=env, capture_output=True, timeout=60)
