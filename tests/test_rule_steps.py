"""Rules that need simulations of their own yield them (``yield from``), so every engine
runs and batches them: ac's online trial, forward's imagined learning, and a rule written
here that looks ahead on a model of its own before each update."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
import pytest

from striatal import learners
from striatal.experiments import pool, runs_csv, sweeps
from striatal.experiments.lockstep_sweep import execute_batch
from striatal.experiments.spec import RunSpec, spawn_seeds
from striatal.learners import LearnerConfig, default_config
from striatal.learners.config import pick
from striatal.learners.rule import Rule, Trial, TrialContext, TrialPlan, Update
from striatal.learners.state import LearnerState
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    N_GAINS,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import kernel
from striatal.sim.batch import WORKERS, Lockstep, Steps

SHORT = Simulation(duration=20.0)
SEEDS = spawn_seeds(0, 3)


@dataclass(frozen=True)
class LookaheadConfig:
    alpha: float
    explore: float


class LookaheadRule(Rule):
    """Before each update, try W + eps and W - eps (mean policy) on a model of the plant
    (the pole 10 % longer) and keep the better; the model's trials are counted apart
    (memory "imagined"), as forward counts its imagination."""

    name = "lookahead"
    summary = "try W +- eps on a model of the plant, keep the better"
    config_type = LookaheadConfig
    preset = MappingProxyType({"alpha": 1.0, "explore": 0.2, "success_on": "mean"})
    control = MappingProxyType({"alpha": 0.0})
    memory_names = ("imagined",)
    history_columns = ("margin",)

    def plan(
        self,
        state: LearnerState,
        config: LearnerConfig,
        rng: np.random.Generator,
        context: TrialContext,
    ) -> TrialPlan:
        eps = np.zeros(N_GAINS)
        eps[1:5] = pick(LookaheadConfig, config).explore * rng.standard_normal(4)
        return TrialPlan(
            W=np.array(state.W),
            theta_c=state.theta_c,
            trace=np.zeros(N_GAINS),
            gamma=0.0,
            rng=None,
            scratch={"eps": eps},
        )

    def update_steps(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Steps[Update]:
        plan = trial.plan
        done = state.get("imagined") or (0.0, 0.0)
        W, margin = state.W, 0.0
        if not trial.success:
            model = context.plant.scaled(length=1.1)
            candidates = [plan.W + plan.scratch["eps"], plan.W - plan.scratch["eps"]]
            outcomes = yield [
                context.request(
                    TrialPlan(w, plan.theta_c, np.zeros(N_GAINS), 0.0, None, plant=model)
                )
                for w in candidates
            ]
            scores = [o.ended_at + o.reward for o in outcomes]
            best = int(np.argmax(scores))
            step = pick(LookaheadConfig, config).alpha * (candidates[best] - plan.W)
            W, margin = tuple(float(w) for w in plan.W + step), scores[0] - scores[1]
            done = (done[0] + 2, done[1] + sum(o.ended_at for o in outcomes))
        return Update(
            W=W,
            theta_c=state.theta_c,
            memory=(("imagined", (float(done[0]), float(done[1]))),),
            extra=(("margin", float(margin)),),
        )

    def imagined(self, state: LearnerState) -> tuple[int, float]:
        done = state.get("imagined") or (0.0, 0.0)
        return int(done[0]), float(done[1])


@pytest.fixture
def lookahead(monkeypatch: pytest.MonkeyPatch) -> Iterator[Rule]:
    rule = LookaheadRule()
    monkeypatch.setitem(learners.RULES, rule.name, rule)
    yield rule


def _specs(config: LearnerConfig, eval_draws: int = 2) -> list[RunSpec]:
    specs, _ = sweeps.build_specs(
        config=config,
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=SHORT,
        seeds=SEEDS,
        inits=("chapter", "random"),
        eval_draws=eval_draws,
    )
    return specs


def _no_wall(row: dict[str, Any]) -> dict[str, Any]:
    return {
        k: (None if isinstance(v, float) and math.isnan(v) else v)
        for k, v in row.items()
        if k != "wall_seconds"
    }


class KernelCalls:
    """The batch size of every call of the batched kernels."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.sizes: dict[str, list[int]] = {}
        for name in (
            "run_trials_batch",
            "run_trials_lockstep",
            "run_online_trials_batch",
            "run_learned_trials_batch",
        ):
            real = getattr(kernel, name)

            def noting(*args: Any, _real: Any = real, _name: str = name) -> None:
                # the learned batch kernel takes its model first
                first = args[1] if _name == "run_learned_trials_batch" else args[0]
                self.sizes.setdefault(_name, []).append(first.shape[0])
                _real(*args)

            monkeypatch.setattr(kernel, name, noting)


@pytest.mark.parametrize(
    "config",
    [
        default_config("ac", max_trials=4),
        default_config("forward", max_trials=3, imagine_trials=12),
        default_config(
            "forward", max_trials=2, imagine_trials=12, robust=True, forward_model="generic"
        ),
    ],
    ids=["ac", "forward", "forward-generic"],
)
def test_rules_with_their_own_simulations_give_the_process_rows_under_batch(
    config: LearnerConfig, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ac (its online trial) and forward (its recorded real trial, its imagined learning
    on the fitted model, the family check) under --engine batch: the process rows, and
    their trials share kernel calls across runs."""
    specs = _specs(config)
    serial = runs_csv.sort_rows(pool.execute(specs))
    calls = KernelCalls(monkeypatch)
    batch = runs_csv.sort_rows(execute_batch(specs))
    assert len(batch) == len(specs) == 12
    for a, b in zip(serial, batch, strict=True):
        assert _no_wall(b) == _no_wall(a), (a["arm"], a["init"], a["seed"])
    assert any(r["W1"] != r["W0_1"] for r in batch if r["arm"] == "learner")
    if config.learner == "ac":
        # the online trials of several runs in one call
        assert max(calls.sizes["run_online_trials_batch"]) >= len(specs) // (
            2 * Lockstep([], "batch").lanes
        )
    elif config.forward_model == "generic":
        # imagined trials on learned plants, counted apart: the rows (their simulations
        # included) are the process engine's, and the physical batch kernel ran no more
        # trials than the rows count (real trials, checks and evaluations)
        assert any(r["imagined_simulations"] > 0 for r in batch)
        real = sum(r["simulations"] + r["eval_simulations"] for r in batch)
        assert 0 < sum(calls.sizes["run_trials_batch"]) <= real
    else:
        assert any(r["imagined_simulations"] > 0 for r in batch)
        # the imagined trials of the runs share kernel calls
        assert max(calls.sizes["run_trials_batch"]) > 1


def test_a_rule_that_yields_its_own_simulations_runs_on_every_engine(
    lookahead: Rule, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = default_config("lookahead", max_trials=5)
    specs = _specs(config)
    serial = runs_csv.sort_rows(pool.execute(specs))
    calls = KernelCalls(monkeypatch)
    batch = runs_csv.sort_rows(execute_batch(specs, engine="batch"))
    simd = runs_csv.sort_rows(execute_batch(specs, engine="simd"))
    for a, b in zip(serial, batch, strict=True):
        assert _no_wall(b) == _no_wall(a), (a["arm"], a["init"], a["seed"])
    learner = [r for r in serial if r["arm"] == "learner"]
    # the model's trials ran and were counted apart, two per failed trial
    assert all(r["imagined_simulations"] == 2 * (r["trials"] - r["success"]) for r in learner)
    assert any(r["W2"] != r["W0_2"] for r in learner)
    # the look-ahead pairs of the runs of a lane went to the kernels together
    lanes = Lockstep([], "batch").lanes
    assert max(calls.sizes["run_trials_batch"]) >= len(specs) // lanes
    assert max(calls.sizes["run_trials_lockstep"]) >= len(specs) // lanes
    # simd: the same experiment, each run's trials counted the same way
    assert len(simd) == len(serial)
    for a, s in zip(serial, simd, strict=True):
        assert (s["arm"], s["init"], s["seed"]) == (a["arm"], a["init"], a["seed"])
        if s["arm"] == "learner":
            assert s["imagined_simulations"] == 2 * (s["trials"] - s["success"])


def test_lane_threads_share_numbas_threads_out() -> None:
    """Each worker gets its share of Numba's threads (never more in all), one worker with
    every thread under the workqueue layer, which takes no concurrent calls."""
    import numba

    from striatal.sim.batch import lane_threads

    workers, each = lane_threads()
    threads = numba.get_num_threads()
    assert workers in (1, WORKERS) and each >= 1
    assert workers * each <= max(threads, 1)
    if numba.threading_layer() == "workqueue" or threads < WORKERS:
        assert (workers, each) == (1, threads)
    else:
        assert (workers, each) == (WORKERS, threads // WORKERS)
