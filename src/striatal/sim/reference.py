"""A plain-NumPy, step-by-step reference of :func:`striatal.sim.kernel.run_trial`.

Slow and readable; the tests check that the compiled kernel equals it under the
same noise. It supports the exact-linearization plant without sensor noise.
"""

from __future__ import annotations

import numpy as np

from striatal.params import Controller, Plant, Simulation
from striatal.sim.control import mean_action
from striatal.sim.dynamics import force, rk4_step, wrap_angle
from striatal.sim.policy import eligibilities, sigma
from striatal.sim.rollout import Protocol

__all__ = [
    "reference_trial",
]


def reference_trial(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    protocol: Protocol,
    noise: np.ndarray,
    gamma: float,
    trace: np.ndarray,
    action_every: int = 1,
    chapter_form: bool = False,
) -> tuple[float, int, np.ndarray, float, np.ndarray]:
    """(reward, end_step, final state (theta wrapped), min |theta| under swing-up, trace)."""
    W = np.asarray(controller.gains, dtype=float)
    s = sim.initial_state.copy()
    D = trace.astype(float).copy()
    sig = float(sigma(W[5]))
    check = protocol.check_step(sim.dt)
    min_swing = np.inf
    a = 0.0
    draw = 0
    for k in range(sim.n_steps):
        th_w = float(wrap_angle(s[2]))
        if k == check and (abs(s[0]) > protocol.check_x or abs(th_w) > protocol.check_theta):
            return protocol.reward_failure, k, _wrapped(s), min_swing, D
        if abs(th_w) >= controller.theta_c:
            min_swing = min(min_swing, abs(th_w))
        if k % action_every == 0:
            mu = float(mean_action(s, controller, plant, W=W))
            if noise.size:
                a = mu + sig * noise[draw]
                D = eligibilities(a, s, W, controller, plant, chapter_form) + gamma * D
            else:
                a = mu
            draw += 1
        _ = force(s, a, plant)
        s = rk4_step(s, a, sim.dt, plant)
        if not np.all(np.abs(s) < 1e8):
            return protocol.reward_failure, k + 1, _wrapped(s), min_swing, D
    th_w = float(wrap_angle(s[2]))
    ok = abs(s[0]) < protocol.goal_x and abs(th_w) < protocol.goal_theta
    reward = protocol.reward_success if ok else protocol.reward_failure
    return reward, sim.n_steps, _wrapped(s), min_swing, D


def _wrapped(s: np.ndarray) -> np.ndarray:
    out = s.copy()
    out[2] = wrap_angle(s[2])
    return out
