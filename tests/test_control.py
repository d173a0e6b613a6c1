"""The controllers: closed-loop eigenvalues, the chapter's runs, hard vs soft switch."""

from __future__ import annotations

import numpy as np
import pytest

from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import control, kernel
from striatal.sim.dynamics import linearization
from striatal.sim.rollout import simulate


def closed_loop_eigenvalues(sign: float, plant: Plant) -> np.ndarray:
    A, B = linearization(plant)
    K = control.balancing_gain_matrix(np.array(CHAPTER_FINAL_W), plant, sign)
    return np.linalg.eigvals(A - B @ K)


def test_corrected_balancing_law_is_stable(plant: Plant) -> None:
    """docs/paper-notes.md section 1: -3.05, -2.08, -0.43 +- 0.54j with the chapter's final W.

    The pendulum loop alone is critically damped with a double root at
    -sqrt(W1 g) = -3.39; the cart terms W2, W3 couple in and split it.
    """
    ev = closed_loop_eigenvalues(+1.0, plant)
    assert np.all(ev.real < 0)
    expected = np.array([-3.05, -2.08, -0.43 + 0.54j, -0.43 - 0.54j])
    for e in expected:
        assert np.min(np.abs(ev - e)) < 0.005 * np.sqrt(2)
    # python-control closes the loop u = -K s on the open-loop system on its own
    ct = pytest.importorskip("control")
    A, B = linearization(plant)
    K = control.balancing_gain_matrix(np.array(CHAPTER_FINAL_W), plant, 1.0)
    loop = ct.feedback(ct.ss(A, B, np.eye(4), np.zeros((4, 1))), ct.ss([], [], [], K))
    assert np.sort_complex(ct.poles(loop)) == pytest.approx(np.sort_complex(ev), abs=1e-9)


def test_printed_balancing_law_has_two_unstable_eigenvalues(plant: Plant) -> None:
    """docs/paper-notes.md section 1: +10.50 and +0.43 (and -3.14, -0.21), all real."""
    ev = np.sort_complex(closed_loop_eigenvalues(-1.0, plant))
    assert np.abs(ev.imag).max() < 1e-9
    assert ev.real == pytest.approx([-3.135, -0.213, 0.432, 10.502], abs=0.001)
    assert np.sum(ev.real > 0) == 2


def test_pendulum_closed_loop_is_critically_damped(plant: Plant) -> None:
    """Eq 19 (corrected): theta_ddot + 2 sqrt(k_p) theta_dot + k_p theta = 0, k_p = W1 g."""
    W = np.array(CHAPTER_FINAL_W)
    K = control.balancing_gain_matrix(W, plant, 1.0)
    k_p = W[0] * plant.gravity
    # theta row of A - B K with the cart terms removed
    assert plant.gravity / plant.length + K[0, 2] / plant.length == pytest.approx(-k_p)
    assert K[0, 3] / plant.length == pytest.approx(-2 * np.sqrt(k_p))


def test_chapter_final_gains_swing_up_and_pass_success_test(
    plant: Plant, sim60: Simulation
) -> None:
    traj = simulate(plant, Controller(), sim60)
    o = traj.outcome
    assert o.success and not o.fault
    assert len(traj.switch_times) == 1
    assert 10.0 < traj.switch_times[0] < 30.0  # "in about 25 seconds"
    assert 4.0 < o.max_abs_x < 8.0  # docs/paper-notes.md section 5: the cart travels about 6 m


def test_printed_sign_fails(plant: Plant, sim60: Simulation) -> None:
    o = simulate(plant, Controller(balance_sign="chapter"), sim60).outcome
    assert not o.success


def test_chapter_initial_gains_pass_under_mean_policy(plant: Plant, sim60: Simulation) -> None:
    """A finding recorded in docs/paper-notes.md: W(0) already succeeds without noise."""
    assert simulate(plant, Controller(CHAPTER_INITIAL_W, 0.6), sim60).outcome.success


def test_kernel_mean_equals_numpy_mean(plant: Plant) -> None:
    rng = np.random.default_rng(3)
    p = plant.as_array()
    grad = np.empty(5)
    for soft in (False, True):
        for sign in ("corrected", "chapter"):
            c = Controller(
                CHAPTER_FINAL_W,
                CHAPTER_FINAL_THETA_C,
                balance_sign=sign,
                switch="soft" if soft else "hard",
                inhibition=5.0,
            )
            for s in rng.uniform([-2, -2, -4, -4], [2, 2, 4, 4], size=(100, 4)):
                W = np.array(c.gains)
                k = kernel.policy_mean(
                    *s, W, c.theta_c, c.sign, c.soft, c.inhibition, p, False, grad
                )
                assert k == pytest.approx(
                    float(control.mean_action(s, c, plant)), rel=1e-12, abs=1e-12
                )


def test_large_inhibition_soft_switch_reproduces_hard_switch(plant: Plant) -> None:
    sim = Simulation(duration=60.0)
    hard = simulate(plant, Controller(), sim)
    soft = simulate(plant, Controller(switch="soft", inhibition=1e9), sim)
    np.testing.assert_allclose(soft.states, hard.states, atol=1e-6)
    assert soft.outcome.success


def test_soft_switch_weights() -> None:
    wb, ws = control.switch_weights(np.array([0.0, 0.5, 0.9, 1.0, 2.0]), 0.9, True, 10.0)
    np.testing.assert_allclose(wb, [1.0, 1.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(ws, [0.0, 0.0, 0.0, 1.0, 1.0])
    wb, ws = control.switch_weights(np.array([0.85, 0.95]), 0.9, True, 10.0)
    np.testing.assert_allclose(wb, [0.5, 0.0])
    np.testing.assert_allclose(ws, [0.0, 0.5])
