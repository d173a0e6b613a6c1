"""The plant: energy, force of eq 12, the kernel against plain NumPy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from striatal.params import Controller, Plant, Simulation
from striatal.sim import dynamics, kernel
from striatal.sim.rollout import NO_PROTOCOL, simulate


def test_free_pendulum_conserves_energy(plant: Plant) -> None:
    """With u = 0 the pendulum energy (eq 15) is conserved to 1e-6 of m g l over 10 s."""
    s = np.array([0.0, 0.0, 2.0, 0.5])
    e0 = float(dynamics.pendulum_energy(s, plant))
    p = plant.as_array()
    worst = 0.0
    for _ in range(1000):
        s = np.array(kernel.rk4_step(*s, 0.0, 0.01, p, p, False))
        worst = max(worst, abs(float(dynamics.pendulum_energy(s, plant)) - e0))
    assert worst / plant.target_energy < 1e-6
    assert s[1] == 0.0 and s[0] == 0.0  # x_ddot = u = 0: the cart does not move


def test_force_of_eq12_reproduces_commanded_acceleration(plant: Plant) -> None:
    """Feeding f of eq 12 to the force-level eqs 8-9 gives x_ddot = u and eq 14's theta_ddot."""
    rng = np.random.default_rng(0)
    states = rng.uniform(-3, 3, size=(200, 4))
    u = rng.uniform(-20, 20, size=200)
    f = dynamics.force(states, u, plant)
    acc = dynamics.force_level_accelerations(states, f, plant)
    np.testing.assert_allclose(acc[:, 0], u, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(acc[:, 1], dynamics.accelerations(states, u, plant)[:, 1], atol=1e-9)


def test_kernel_force_and_energy_match_numpy(plant: Plant) -> None:
    p = plant.as_array()
    rng = np.random.default_rng(1)
    for s in rng.uniform(-4, 4, size=(50, 4)):
        u = float(rng.uniform(-10, 10))
        assert kernel.force(s[2], s[3], u, p) == pytest.approx(
            float(dynamics.force(s, u, plant)), rel=1e-12
        )
        assert kernel.energy_error(s[2], s[3], p) == pytest.approx(
            float(dynamics.energy_error(s, plant)), rel=1e-12, abs=1e-14
        )


def test_kernel_rk4_equals_numpy_rk4(plant: Plant) -> None:
    p = plant.as_array()
    s = np.array([0.3, -0.2, 2.5, 1.0])
    for u in (0.0, 3.0, -7.5):
        got = np.array(kernel.rk4_step(*s, u, 0.01, p, p, False))
        np.testing.assert_allclose(
            got, dynamics.rk4_step(s, u, 0.01, plant), rtol=1e-13, atol=1e-15
        )


def test_mismatch_path_equals_exact_linearization_when_model_is_true(plant: Plant) -> None:
    """The force-level plant driven by eq 12 with the true parameters is the PFL plant."""
    p = plant.as_array()
    s = np.array([0.1, 0.4, 2.0, -1.0])
    a = np.array(kernel.rk4_step(*s, 4.0, 0.01, p, p, False))
    b = np.array(kernel.rk4_step(*s, 4.0, 0.01, p, p.copy(), True))
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)


@given(st.floats(-50, 50, allow_nan=False))
def test_wrap_angle_range(theta: float) -> None:
    w = kernel.wrap_angle(theta)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(theta), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(theta), abs_tol=1e-9)
    # the wrapped angle differs from theta by a whole number of turns
    turns = (theta - w) / (2.0 * math.pi)
    assert abs(turns - round(turns)) < 1e-12


def test_wrap_angle_boundaries() -> None:
    assert kernel.wrap_angle(math.pi) == math.pi
    assert kernel.wrap_angle(-math.pi) == math.pi
    assert kernel.wrap_angle(3.0 * math.pi) == math.pi
    assert kernel.wrap_angle(0.0) == 0.0


@njit
def _wrap_formula(theta: float) -> float:
    return theta - kernel.TWO_PI * math.ceil((theta - math.pi) / kernel.TWO_PI)


def test_wrap_angle_is_the_formula_bit_for_bit() -> None:
    """The kernel's shortcut for |theta| < 3 returns exactly what the compiled formula gives.

    (Compiled, the formula keeps -0.0 and contracts to a fused multiply-add, so NumPy's
    evaluation of it differs at -0.0 and for |theta| ~ 1e300: the reference is compiled.)
    """
    rng = np.random.default_rng(0)
    edges = [0.0, -0.0, 3.0, -3.0, math.pi, -math.pi, 5e-324, -5e-324, 1e300, -1e300]
    edges += [float(np.nextafter(v, d)) for v in (3.0, -3.0, math.pi, -math.pi) for d in (0, 9)]
    th = np.concatenate([rng.uniform(-10.0, 10.0, 20000), rng.uniform(-3.2, 3.2, 20000), edges])
    formula = np.array([_wrap_formula(float(t)) for t in th])
    got = np.array([kernel.wrap_angle(float(t)) for t in th])
    np.testing.assert_array_equal(got.view(np.int64), formula.view(np.int64))
    with np.errstate(invalid="ignore"):  # NumPy flags the compiled loop at |theta| = 1e300
        arr = dynamics.wrap_angle(th)
    np.testing.assert_array_equal(arr.view(np.int64), formula.view(np.int64))


def test_array_wrap_keeps_shape_and_ends() -> None:
    """dynamics.wrap_angle (kernel.wrap_angles) on arrays: shapes kept, (-pi, pi] endpoints."""
    th = np.array([[-math.pi, math.pi], [-3.0 * math.pi, 7.0]])
    w = dynamics.wrap_angle(th)
    assert w.shape == (2, 2)
    np.testing.assert_array_equal(w[0], [math.pi, math.pi])
    assert w[1, 0] == math.pi
    assert w[1, 1] == pytest.approx(7.0 - 2.0 * math.pi, abs=1e-15)
    assert isinstance(dynamics.wrap_angle(1.0), float)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.3, 3.0), st.floats(0.05, 2.0), st.floats(0.3, 3.0), st.floats(-3.0, 3.0))
def test_closed_loop_reflection_symmetry(M: float, m: float, l: float, theta0: float) -> None:
    """(x, theta) -> (-x, -theta) maps closed-loop trajectories onto each other (eqs 13-23)."""
    plant = Plant(cart_mass=M, pole_mass=m, length=l)
    c = Controller()
    a = simulate(plant, c, Simulation(theta0=theta0, x0=0.2, duration=5.0), protocol=NO_PROTOCOL)
    b = simulate(plant, c, Simulation(theta0=-theta0, x0=-0.2, duration=5.0), protocol=NO_PROTOCOL)
    np.testing.assert_allclose(a.states, -b.states, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(a.column("u"), -b.column("u"), rtol=1e-9, atol=1e-9)
