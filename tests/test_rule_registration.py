"""A new learning rule is one file and one registry line, and runs everywhere a built-in
rule runs: ``train``, ``sweep --engine processes`` and ``sweep --engine batch``."""

from __future__ import annotations

import importlib
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import striatal
from striatal.errors import ParameterError
from striatal.experiments import runs_csv
from striatal.learners import RULES, register

#: The whole rule: random search around W, keeping a perturbation whose trial earned more.
RULE_FILE = """
from dataclasses import dataclass

import numpy as np

from striatal.learners.rule import Rule, TrialPlan, Update


@dataclass(frozen=True)
class HillConfig:
    alpha: float = 0.3


class HillRule(Rule):
    name = "hill"
    summary = "hill climbing: keep a perturbation of W whose trial earned more reward"
    config_type = HillConfig
    preset = {"alpha": 0.3}
    memory_names = ("best",)
    history_columns = ("step",)

    def plan(self, state, config, rng, context):
        step = config.alpha * rng.standard_normal(6)
        W = np.array(state.W) + step
        W[0] = max(W[0], 0.1)
        return TrialPlan(W=W, theta_c=state.theta_c, trace=np.zeros(6), gamma=0.0, rng=rng,
                         scratch={"step": step})

    def update(self, state, config, trial, context):
        plan, reward, success = trial.plan, trial.reward, trial.success
        best = dict(state.memory).get("best")
        extra = (("step", float(abs(plan.scratch["step"]).sum())),)
        if success or (best is not None and reward <= best[0]):
            return Update(W=state.W, theta_c=state.theta_c, memory=state.memory, extra=extra)
        return Update(W=tuple(float(w) for w in plan.W), theta_c=state.theta_c,
                      memory=(("best", (float(reward),)),), extra=extra)


HILL = HillRule()
"""


@pytest.fixture()
def hill(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    (tmp_path / "hill_rule.py").write_text(RULE_FILE, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("hill_rule")
    register(module.HILL)  # the one registry line
    try:
        yield module.HILL
    finally:
        del RULES["hill"]
        sys.modules.pop("hill_rule", None)


SHORT = striatal.Simulation(duration=10.0)
ARGS: dict[str, Any] = {"seeds": 3, "init": "random", "max_trials": 6, "eval_draws": 2}


def _no_wall(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows]


def test_a_new_rule_runs_through_train_and_both_sweep_engines(hill: Any) -> None:
    processes = striatal.sweep("hill", sim=SHORT, **ARGS)
    batch = striatal.sweep("hill", sim=SHORT, engine="batch", **ARGS)
    assert _no_wall(batch.rows) == _no_wall(processes.rows)
    assert {r["arm"] for r in batch.rows} == {"learner", "control"}
    learner = [r for r in batch.rows if r["arm"] == "learner"]
    assert any(r["W1"] != r["W0_1"] for r in learner)  # the rule moved W
    control = [r for r in batch.rows if r["arm"] == "control"]
    assert all(r["W1"] == r["W0_1"] for r in control)  # alpha = 0: its step is zero
    # a sweep row is the train run with its seed
    row = learner[0]
    run = striatal.train("hill", seed=row["seed"], init="random", max_trials=6, sim=SHORT)
    assert tuple(row[f"W{i}"] for i in range(1, 7)) == run.W
    assert run.trials == row["trials"] and run.success == row["success"]
    assert "step" in run.history.columns


def test_a_new_rule_runs_from_the_command_line(hill: Any, tmp_path: Path, cli: Any) -> None:
    out = tmp_path / "t"
    argv = ["--learner", "hill", "--max-trials", "3", "--duration", "10", "--no-progress"]
    assert cli("train", *argv, "--seed", "2", "--out", out)[0] == 0
    result = json.loads((out / "result.json").read_text())
    assert result["settings"]["learner"] == "hill"
    sweep = ["sweep", *argv, "--seeds", "2", "--eval-draws", "0"]
    assert cli(*sweep, "--out", tmp_path / "p")[0] == 0
    assert cli(*sweep, "--engine", "batch", "--out", tmp_path / "b")[0] == 0
    rows = {k: runs_csv.sort_rows(runs_csv.read_runs(tmp_path / k / "runs.csv")[0]) for k in "pb"}
    assert _no_wall(rows["p"]) == _no_wall(rows["b"]) and len(rows["p"]) == 4
    # an option the rule does not read is refused, naming it
    code, _, err = cli("train", *argv, "--gamma", "0.5", "--out", tmp_path / "x")
    assert code == 2 and "does not use gamma" in err


def test_a_name_is_registered_once(hill: Any) -> None:
    with pytest.raises(ParameterError, match="registered already"):
        register(hill)
