"""Eligibilities against finite differences of ln pi; the kernel against the NumPy reference."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from striatal.params import CHAPTER_FINAL_W, CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.policy import eligibilities, log_prob_of, rescaling
from striatal.sim.reference import reference_trial
from striatal.sim.rollout import Protocol, TrialRequest, run_trial


def fd_score(
    a: float, s: np.ndarray, W: np.ndarray, c: Controller, plant: Plant, h: float = 1e-6
) -> np.ndarray:
    g = np.empty(6)
    for i in range(6):
        wp, wm = W.copy(), W.copy()
        wp[i] += h
        wm[i] -= h
        g[i] = (log_prob_of(a, s, wp, c, plant) - log_prob_of(a, s, wm, c, plant)) / (2 * h)
    return g


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-3, 3), min_size=4, max_size=4),
    st.floats(-2, 2),
    st.sampled_from(["corrected", "chapter"]),
    st.sampled_from(["hard", "soft"]),
)
def test_eligibilities_equal_rescaled_finite_difference_score(
    state: list[float], noise: float, sign: str, switch: str
) -> None:
    plant = Plant()
    c = Controller(CHAPTER_FINAL_W, 0.9, balance_sign=sign, switch=switch, inhibition=3.0)
    s = np.array(state)
    W = np.array(c.gains)
    from striatal.sim.control import mean_action
    from striatal.sim.policy import sigma

    a = float(mean_action(s, c, plant)) + float(sigma(W[5])) * noise
    e = eligibilities(a, s, W, c, plant)
    fd = fd_score(a, s, W, c, plant) * rescaling(W)
    np.testing.assert_allclose(e, fd, rtol=1e-5, atol=1e-6)


def test_chapter_printed_e1_differs_from_the_score(plant: Plant) -> None:
    """The printed e1 is the derivative of neither sign of the mean.

    Reading: docs/paper-notes.md section 2.
    """
    c = Controller()
    s = np.array([0.1, 0.2, 0.3, 0.4])
    W = np.array(c.gains)
    a = 1.0
    printed = eligibilities(a, s, W, c, plant, chapter_form=True)
    score = eligibilities(a, s, W, c, plant)
    assert printed[0] != pytest.approx(score[0])
    np.testing.assert_allclose(printed[1:], score[1:])


def test_kernel_eligibility_trace_equals_reference(plant: Plant) -> None:
    c = Controller(CHAPTER_INITIAL_W, 0.6)
    sim = Simulation(duration=40.0)
    rng = np.random.default_rng(7)
    noise = rng.standard_normal(sim.n_steps)
    for chapter_form in (False, True):
        trace0 = np.array([0.1, -0.2, 0.0, 0.3, 0.0, 0.05])
        ref = reference_trial(
            plant, c, sim, Protocol(), noise, 0.995, trace0, chapter_form=chapter_form
        )
        trace = trace0.copy()
        args = TrialRequest(
            plant, c, sim, Protocol(), chapter_eligibility=chapter_form, gamma=0.995, trace=trace
        ).args(noise)
        kernel.run_trial(*args)
        out = args[-1].out
        assert out[kernel.OUT_REWARD] == ref[0]
        assert int(out[kernel.OUT_END_STEP]) == ref[1]
        np.testing.assert_allclose(
            out[kernel.OUT_X : kernel.OUT_THETA_DOT + 1], ref[2], rtol=1e-8, atol=1e-9
        )
        np.testing.assert_allclose(trace, ref[4], rtol=1e-7, atol=1e-9)


def test_same_noise_same_trial(plant: Plant) -> None:
    c = Controller()
    sim = Simulation()
    results = []
    for _ in range(2):
        trace = np.zeros(6)
        o = run_trial(
            TrialRequest(
                plant,
                c,
                sim,
                protocol=Protocol(),
                trace=trace,
                gamma=0.99,
                rng=np.random.default_rng(11),
            )
        )
        results.append((o, trace.copy()))
    assert results[0][0] == results[1][0]
    np.testing.assert_array_equal(results[0][1], results[1][1])


def test_kernel_policy_with_w1_zero_raises_only_where_the_balancing_law_acts() -> None:
    """W1 = 0 has no balancing law (eq 22): the kernel raises there, not in swing-up."""
    model = np.array([1.0, 0.1, 0.5, 9.81])
    W = np.array(CHAPTER_INITIAL_W, dtype=float)
    W[0] = 0.0
    grad = np.empty(5)
    mu = kernel.policy_mean(0.1, 0.0, 2.0, 0.3, W, 0.6, 1.0, False, 50.0, model, False, grad)
    assert np.isfinite(mu) and grad[0] == 0.0 and grad[3] != 0.0
    with pytest.raises(ZeroDivisionError):
        kernel.policy_mean(0.1, 0.0, 0.1, 0.3, W, 0.6, 1.0, False, 50.0, model, False, grad)


def test_kernel_policy_mean_needs_no_sigma_gain() -> None:
    """policy_mean reads W1..W5 only: five gains give the mean of six."""
    model = np.array([1.0, 0.1, 0.5, 9.81])
    W = np.array(CHAPTER_FINAL_W, dtype=float)
    g6, g5 = np.empty(5), np.empty(5)
    for theta in (0.1, 2.0):
        mu6 = kernel.policy_mean(0.1, 0.2, theta, 0.3, W, 0.6, 1.0, True, 20.0, model, True, g6)
        mu5 = kernel.policy_mean(0.1, 0.2, theta, 0.3, W[:5], 0.6, 1.0, True, 20.0, model, True, g5)
        assert mu5 == mu6 and np.array_equal(g5, g6)
