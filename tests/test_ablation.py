"""The ablation runner: its options reproduce its configs, its runs reproduce ``train``."""

from __future__ import annotations

import argparse
import json
import math
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from striatal.cli.learner_options import add_learner_arguments, learner_config_from
from striatal.errors import ParameterError
from striatal.experiments import baselines, runner
from striatal.experiments.ablation import (
    VARIANTS,
    build,
    markdown_table,
    runs_of,
    seeds_of,
    summary,
    variant,
)
from striatal.experiments.spec import spawn_seeds
from striatal.learners import random_initial_gains
from striatal.params import Controller, Plant, Simulation

LEARNER_VARIANTS = [v for v in VARIANTS if v.kind == "learner"]


def run_seed(name: str, seed: int, max_trials: int) -> dict[str, object]:
    """One run of variant ``name`` through the sweep's runner, as ablation.json holds it."""
    specs, _ = build([variant(name)], [seed], max_trials)
    (spec,) = specs
    return runs_of([runner.run_one(spec)])[0]


@pytest.mark.parametrize("v", LEARNER_VARIANTS, ids=[v.name for v in LEARNER_VARIANTS])
def test_printed_options_select_the_same_config(v: object) -> None:
    parser = argparse.ArgumentParser()
    add_learner_arguments(parser)
    args = parser.parse_args([*shlex.split(v.options), "--max-trials", "300"])  # type: ignore[attr-defined]
    assert learner_config_from(args) == v.config(300)  # type: ignore[attr-defined]


def test_run_seed_equals_train_from_the_command_line() -> None:
    v = variant("pgpe")
    row = run_seed("pgpe", 2, 40)
    cmd = [sys.executable, "-m", "striatal", "train", "--init", "random", "--seed", "2"]
    cmd += [*shlex.split(v.options), "--max-trials", "40", "--json"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert (out["success"], out["trials"], out["W"], out["theta_c"]) == (
        row["success"],
        row["trials"],
        row["W"],
        row["theta_c"],
    )
    assert row["success"] and row["resimulated"]


@pytest.mark.parametrize("name", ["random-search", "cma-es"])
def test_search_rows_are_seeded_count_trials_and_resimulate(name: str) -> None:
    """The ablation's search rows run the sweep's baselines, judged on the mean policy."""
    a = run_seed(name, 3, 12)
    assert a == run_seed(name, 3, 12)
    assert 1 <= a["trials"] <= 12  # type: ignore[operator]
    assert a["simulations"] == a["trials"]  # one trial per candidate, nothing else
    assert a["resimulated"] == a["success"]
    assert a["W0"] == list(random_initial_gains(np.random.default_rng([3, 1])))


def test_random_search_row_is_the_sweep_baseline() -> None:
    W0 = random_initial_gains(np.random.default_rng([5, 1]))
    row = run_seed("random-search", 5, 20)
    direct = baselines.random_search(
        Plant(), Controller(W0, 0.6), Simulation(), 5, baselines.Budget(20, "mean")
    )
    assert (row["success"], row["trials"], row["theta_c"]) == (
        direct["success"],
        direct["trials"],
        direct["theta_c"],
    )


def test_summary_and_table() -> None:
    runs = [
        {"success": True, "trials": 10, "resimulated": True},
        {"success": True, "trials": 30, "resimulated": True},
        {"success": False, "trials": 300, "resimulated": False},
    ]
    s = summary(runs)
    assert (s["successes"], s["median_trials"], s["resimulated"]) == (2, 20.0, 2)
    none = summary(runs[2:])
    assert none["successes"] == 0 and math.isnan(none["median_trials"])
    table = markdown_table([(variant("pgpe"), s), (variant("chapter"), none)])
    assert "| 2/3 | - | 20 |" in table and "| 0/1 | - | - | - |" in table
    with pytest.raises(ParameterError):
        variant("nope")


def test_ablation_cli_writes_table_and_runs(tmp_path: Path) -> None:
    out = tmp_path / "abl"
    cmd = [sys.executable, "-m", "striatal", "ablation", "--seeds", "2", "--seed", "3"]
    cmd += ["--max-trials", "20", "--variants", "pgpe,random-search", "--workers", "1"]
    r = subprocess.run([*cmd, "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    runs = json.loads((out / "ablation.json").read_text())
    # the run seeds of root 3, as `striatal sweep --seed 3 --seeds 2` spawns them
    assert tuple(row["seed"] for row in runs["pgpe"]["runs"]) == spawn_seeds(3, 2)
    settings = json.loads((out / "sweep.json").read_text())
    assert (settings["root_seed"], settings["seeds"]) == (3, 2)
    assert settings["run_seeds"] == list(spawn_seeds(3, 2))
    assert r.stdout == (out / "ablation.md").read_text()
    assert r.stdout.count("\n") == 4
    assert "| 2/2 |" in r.stdout or "/2 | [" in r.stdout  # successes with their interval
    summary_json = json.loads((out / "summary.json").read_text())
    assert {a["arm"] for a in summary_json["arms"]} == {"pgpe", "random-search"}
    assert all("success_rate_ci" in a for a in summary_json["arms"])
    # a rerun resumes: every run is already in runs.csv
    again = subprocess.run([*cmd, "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and again.stdout == r.stdout
    bad = subprocess.run([*cmd[:4], "--variants", "nope"], capture_output=True, text=True)
    assert bad.returncode == 2 and "nope" in bad.stderr


def test_ablation_seeds_are_the_sweep_s_seeds_of_the_same_root() -> None:
    """One meaning of --seed: ablation and sweep spawn their runs' seeds from the root
    alike (SeedSequence(root).spawn(n)), so root R's rows of the two share seeds."""
    from striatal.experiments import sweeps

    for root in (0, 1, 7):
        sweep_plan = sweeps.plan("pgpe", seeds=3, seed=root, init="random", control=False)
        assert tuple(sweep_plan.settings["run_seeds"]) == seeds_of(root, 3)
    assert seeds_of(1, 5)[:3] == seeds_of(1, 3)  # a longer run extends a shorter one


@pytest.mark.parametrize("value", ["", "100"])
def test_ablation_refuses_first_seed_naming_seed(value: str) -> None:
    """The old --first-seed S (seeds S..S+N-1) is refused in one line naming --seed."""
    cmd = [sys.executable, "-m", "striatal", "ablation", "--first-seed"]
    r = subprocess.run([*cmd, *([value] if value else [])], capture_output=True, text=True)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "--seed R" in r.stderr and r.stdout == ""


@pytest.mark.parametrize("names", ["", " , ", "pgpe,pgpe"])
def test_ablation_refuses_an_empty_or_repeated_variant_list(names: str) -> None:
    """Issue 16 item 21: --variants "" ran nothing and exited 0."""
    cmd = [sys.executable, "-m", "striatal", "ablation", "--seeds", "1", "--variants", names]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert r.stdout == ""


def test_control_variants_are_their_learners_declared_control() -> None:
    from striatal.learners import control_config, default_config

    for name, learner in (("chapter-control", "chapter"), ("pgpe-control", "pgpe")):
        v = variant(name)
        cfg = default_config(learner, max_trials=50, success_on="mean")
        assert v.config(50) == control_config(cfg)
        assert v.role == "control"
    assert variant("pgpe-control").config(50).sigma_rate == 0.0
