"""Plant equations in plain NumPy (vectorised over leading axes): eqs 7-14.

The compiled kernel (:mod:`striatal.sim.kernel`) is what runs; these are the
readable reference forms, the linearization and the energy used by tests,
baselines and figures. ``state``: (..., 4) [m, m/s, rad, rad/s].
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from striatal.params import Plant
from striatal.sim import kernel

__all__ = [
    "accelerations",
    "derivative",
    "energy_error",
    "force",
    "force_level_accelerations",
    "linearization",
    "pendulum_energy",
    "rk4_force_step",
    "rk4_step",
    "wrap_angle",
]


def accelerations(state: np.ndarray, u: np.ndarray | float, plant: Plant) -> np.ndarray:
    """(..., 2) [x_ddot, theta_ddot] under partial feedback linearization, eqs 13-14."""
    s = np.asarray(state, dtype=float)
    th = s[..., 2]
    x_ddot = np.broadcast_to(np.asarray(u, dtype=float), th.shape)
    theta_ddot = (plant.gravity * np.sin(th) - x_ddot * np.cos(th)) / plant.length
    return np.stack([x_ddot, theta_ddot], axis=-1)


def force_level_accelerations(state: np.ndarray, f: np.ndarray | float, plant: Plant) -> np.ndarray:
    """(..., 2) [x_ddot, theta_ddot] for a cart force f [N], solving eqs 8-9 (eq 10)."""
    s = np.asarray(state, dtype=float)
    th, thd = s[..., 2], s[..., 3]
    m, M, l, g = plant.pole_mass, plant.cart_mass, plant.length, plant.gravity
    c, sn = np.cos(th), np.sin(th)
    # Mass matrix of eq 10, [[m + M, m l c], [m l c, m l^2]].
    det = (m + M) * m * l**2 - (m * l * c) ** 2
    rhs1 = np.asarray(f, dtype=float) + m * l * thd**2 * sn
    rhs2 = m * g * l * sn
    x_ddot = (m * l**2 * rhs1 - m * l * c * rhs2) / det
    theta_ddot = ((m + M) * rhs2 - m * l * c * rhs1) / det
    return np.stack([x_ddot, theta_ddot], axis=-1)


def force(state: np.ndarray, u: np.ndarray | float, plant: Plant) -> np.ndarray:
    """Cart force [N] that realises x_ddot = u, eq 12."""
    s = np.asarray(state, dtype=float)
    th, thd = s[..., 2], s[..., 3]
    m = plant.pole_mass
    return (
        (plant.cart_mass + m - m * np.cos(th) ** 2) * u
        + m * plant.gravity * np.cos(th) * np.sin(th)
        - m * plant.length * thd**2 * np.sin(th)
    )


def derivative(state: np.ndarray, u: np.ndarray | float, plant: Plant) -> np.ndarray:
    """d state / dt, (..., 4)."""
    s = np.asarray(state, dtype=float)
    acc = accelerations(s, u, plant)
    return np.stack([s[..., 1], acc[..., 0], s[..., 3], acc[..., 1]], axis=-1)


def _rk4(d: Callable[[np.ndarray], np.ndarray], state: np.ndarray, dt: float) -> np.ndarray:
    """One classical RK4 step of d state / dt = d(state)."""
    k1 = d(state)
    k2 = d(state + 0.5 * dt * k1)
    k3 = d(state + 0.5 * dt * k2)
    k4 = d(state + dt * k3)
    out: np.ndarray = state + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return out


def rk4_step(state: np.ndarray, u: np.ndarray | float, dt: float, plant: Plant) -> np.ndarray:
    """One classical RK4 step with u held."""
    return _rk4(lambda s: derivative(s, u, plant), state, dt)


def rk4_force_step(
    state: np.ndarray, f: np.ndarray | float, dt: float, plant: Plant, friction: float = 0.0
) -> np.ndarray:
    """One RK4 step of eqs 8-10 with the cart force f [N] held (``Hardware(hold="force")``),
    a viscous cart friction -friction * x_dot [N] added to it (0: the kernel's plant)."""

    def d(s: np.ndarray) -> np.ndarray:
        acc = force_level_accelerations(s, f - friction * s[..., 1], plant)
        return np.stack([s[..., 1], acc[..., 0], s[..., 3], acc[..., 1]], axis=-1)

    return _rk4(d, np.asarray(state, dtype=float), dt)


def pendulum_energy(state: np.ndarray, plant: Plant) -> np.ndarray:
    """E_p = 1/2 m l^2 theta_dot^2 + m g l cos theta, eq 15 [J]."""
    s = np.asarray(state, dtype=float)
    m, l, g = plant.pole_mass, plant.length, plant.gravity
    return 0.5 * m * l**2 * s[..., 3] ** 2 + m * g * l * np.cos(s[..., 2])


def energy_error(state: np.ndarray, plant: Plant) -> np.ndarray:
    """E~ = E_p - E_d with E_d = m g l, eqs 15-16 [J]."""
    return pendulum_energy(state, plant) - plant.target_energy


def wrap_angle(theta: np.ndarray | float) -> np.ndarray:
    """Angle wrapped to (-pi, pi]: :func:`striatal.sim.kernel.wrap_angle` over any shape."""
    result: np.ndarray = kernel.wrap_angles(np.asarray(theta, dtype=float))
    return result


def linearization(plant: Plant) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the upright linearization, eq 18: x_ddot = u, theta_ddot = (g theta - u) / l."""
    l, g = plant.length, plant.gravity
    A = np.array(
        [[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, g / l, 0.0]]
    )
    B = np.array([[0.0], [1.0], [0.0], [-1.0 / l]])
    return A, B
