"""Baselines: the LQR gain and its fit to the balancing law, and the searches."""

from __future__ import annotations

import numpy as np
import pytest

from striatal.experiments import baselines
from striatal.experiments.baselines import Budget
from striatal.learners import LearnerConfig
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_HARDWARE,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Hardware,
    Plant,
    Simulation,
)
from striatal.sim.control import balancing_gain_matrix
from striatal.sim.dynamics import linearization

TEMPLATE = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C)


def test_lqr_gain_solves_the_riccati_equation(plant: Plant) -> None:
    K, P = baselines.lqr_gain(plant)
    A, B = linearization(plant)
    Q, R = baselines.LQR_Q, baselines.LQR_R
    residual = A.T @ P + P @ A - P @ B @ np.linalg.solve(R, B.T @ P) + Q
    assert np.allclose(residual, 0.0, atol=1e-9)
    assert np.allclose(P, P.T) and np.all(np.linalg.eigvalsh(P) > 0)
    assert np.all(np.linalg.eigvals(A - B @ K).real < 0)


def test_lqr_gain_matches_python_control(plant: Plant) -> None:
    control = pytest.importorskip("control", reason="python-control is in the [dev] extra")
    A, B = linearization(plant)
    K_ref, _, _ = control.lqr(A, B, baselines.LQR_Q, baselines.LQR_R)
    K, _ = baselines.lqr_gain(plant)
    assert np.allclose(K, np.asarray(K_ref), rtol=1e-8, atol=1e-10)


def test_lqr_fit_matches_the_cart_terms_and_stabilises(plant: Plant) -> None:
    fit = baselines.lqr_fit(plant)
    assert fit.W123[1] == pytest.approx(fit.K[0]) and fit.W123[2] == pytest.approx(fit.K[1])
    K_fit = balancing_gain_matrix(np.array(fit.W123), plant)[0]
    assert np.allclose(K_fit, fit.K_fit)

    # W1 is the least-squares optimum of the two theta coefficients
    def err(w1: float) -> float:
        kw = balancing_gain_matrix(np.array([w1, *fit.W123[1:]]), plant)[0]
        return float(np.sum((kw[2:] - np.array(fit.K[2:])) ** 2))

    assert err(fit.W123[0]) <= min(err(fit.W123[0] * 0.99), err(fit.W123[0] * 1.01))
    assert fit.residual == pytest.approx(np.sqrt(err(fit.W123[0])))
    assert all(z.real < 0 for z in fit.eig_fit) and all(z.real < 0 for z in fit.eig_lqr)
    W, theta_c = baselines.lqr_controller(plant)
    assert W[3:] == CHAPTER_FINAL_W[3:] and theta_c == CHAPTER_FINAL_THETA_C


def test_chapter_final_gains_pass_on_the_mean_policy(plant: Plant, sim60: Simulation) -> None:
    out = baselines.fixed_controller(
        plant, TEMPLATE, sim60, CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C, 0, Budget(50, "mean")
    )
    assert out["success"] and out["trials"] == 1


def test_searches_are_deterministic_and_within_budget(plant: Plant) -> None:
    sim = Simulation(duration=20.0)
    a = baselines.random_search(plant, TEMPLATE, sim, 4, Budget(12, "noisy"))
    assert a == baselines.random_search(plant, TEMPLATE, sim, 4, Budget(12, "noisy"))
    assert 1 <= a["trials"] <= 12
    low, high = baselines.RANDOM_BOX
    p = np.array([*a["W"], a["theta_c"]])
    assert np.all(p >= low) and np.all(p <= high)
    b = baselines.cmaes(plant, TEMPLATE, sim, CHAPTER_INITIAL_W, 0.6, 4, Budget(15, "mean"))
    assert b == baselines.cmaes(plant, TEMPLATE, sim, CHAPTER_INITIAL_W, 0.6, 4, Budget(15, "mean"))
    assert 1 <= b["trials"] <= 15 and b["W"][0] > 0
    assert low[6] <= b["theta_c"] <= high[6]


def test_cmaes_restarts_with_twice_the_population_when_cma_stops(
    plant: Plant, monkeypatch: pytest.MonkeyPatch
) -> None:
    """IPOP: whenever cma's termination criteria fire, a new run with a doubled population
    starts from (W(0), theta_c(0)); every candidate is one counted trial."""
    import cma

    sim = Simulation(duration=5.0)  # too short to pass: the budget is spent
    plain = baselines.cmaes(plant, TEMPLATE, sim, CHAPTER_INITIAL_W, 0.6, 2, Budget(20, "mean"))
    assert plain["restarts"] == 0 and plain["popsize"] == 4 + int(3 * np.log(7))
    assert plain["simulations"] == plain["trials"] == 20
    real_stop = cma.CMAEvolutionStrategy.stop

    def stop_after_one_generation(self: cma.CMAEvolutionStrategy, *a: object, **k: object):  # type: ignore[no-untyped-def]
        return {"test": 1} if self.countiter >= 1 else real_stop(self, *a, **k)

    monkeypatch.setattr(cma.CMAEvolutionStrategy, "stop", stop_after_one_generation)
    out = baselines.cmaes(plant, TEMPLATE, sim, CHAPTER_INITIAL_W, 0.6, 2, Budget(60, "mean"))
    # runs of 9, 18 and (33 of) 36 candidates: two restarts
    assert out["restarts"] == 2 and out["popsize"] == 36
    assert out["simulations"] == out["trials"] == 60 and not out["success"]
    assert 0 < out["simulated_seconds"] <= 60 * 5.0


def test_budget_of_an_arm_takes_its_config_budget_and_stop_rule() -> None:
    config = LearnerConfig(max_trials=7, success_on="mean", robust=True, max_force=20.0)
    budget = Budget.of(config)
    assert budget == Budget(7, "mean", robust=True, hardware=config.hardware)
    assert budget.hardware == Hardware(hold="force", max_force=20.0)
    assert Budget.of(LearnerConfig()) == Budget(2000, "noisy", False, CHAPTER_HARDWARE)
