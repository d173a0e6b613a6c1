"""Pieces every learning rule may use: eq 21, the success test, rewards, three-factor updates.

The dense ``shaped`` reward replaces the sparse +10 / -5 of eqs 24-25 by a score of
the recorded trial (measured in docs/ablation.md).
"""

from __future__ import annotations

import math

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.config import W1_FLOOR, ThetaCRule
from striatal.learners.state import LearnerState
from striatal.params import (
    N_GAINS,
    Plant,
    Simulation,
    check_gains,
    check_seed,
    check_theta_c,
)
from striatal.sim import kernel
from striatal.sim.dynamics import energy_error, wrap_angle
from striatal.sim.rollout import Protocol, TrialOutcome

__all__ = [
    "CLOSENESS_DECADES",
    "SHAPED_WEIGHTS",
    "THETA_C_FLOOR",
    "THETA_C_RESET_ABOVE",
    "THETA_C_RESET_TO",
    "baseline_memory",
    "check_decay",
    "initial_state",
    "jitter_corners",
    "prediction_error",
    "prediction_error_factor",
    "random_initial_gains",
    "shaped_reward",
    "theta_c_rule",
    "three_factor_update",
    "tracked_baseline",
]

#: Smallest theta_c the rule of eq 21 may set (only reachable with theta_c_rule "trial").
THETA_C_FLOOR = 0.01
#: Eq 21's thresholds: min|theta| below 1.4 becomes theta_c, otherwise theta_c resets to 0.6.
THETA_C_RESET_ABOVE = 1.4
THETA_C_RESET_TO = 0.6
#: Weights of the shaped reward's terms: energy, cart near centre, final state,
#: convergence while upright (measured in docs/ablation.md).
SHAPED_WEIGHTS = (1.0, 1.0, 1.0, 2.0)
#: Decades of distance to the success box over which the closeness terms fall from 1 to 0.
CLOSENESS_DECADES = 4.0


def initial_state(W0: object, theta_c0: float, seed: int) -> LearnerState:
    """The state before trial 1: gains, threshold and a fresh PCG64 stream seeded by ``seed``."""
    gains = check_gains(W0)
    check_theta_c(theta_c0)
    rng = np.random.default_rng(check_seed(seed))
    return LearnerState(
        trials_done=0, W=gains, theta_c=float(theta_c0), rng_state=dict(rng.bit_generator.state)
    )


def random_initial_gains(rng: np.random.Generator) -> tuple[float, ...]:
    """W(0) uniform in [-1, 1]^6 (the chapter: "randomly initialized"), W1 floored at W1_FLOOR."""
    W = rng.uniform(-1.0, 1.0, size=N_GAINS)
    W[0] = max(W[0], W1_FLOOR)
    return tuple(float(w) for w in W)


def theta_c_rule(outcome: TrialOutcome, theta_c: float, rule: ThetaCRule) -> float:
    """Eq 21: theta_c = min|theta| if it is < 1.4, else 0.6 (docs/paper-notes.md, section 6).

    min|theta| [rad] is read under the swing-up ("swingup": never below the theta_c the
    trial ran with, so theta_c only rises until it resets, a ratchet) or over the whole
    trial ("trial": once the balancing law holds the pole, about 0, so theta_c falls to
    THETA_C_FLOOR). "clamped" reads it over the whole trial, held at or above the reset
    value 0.6: theta_c rises to the closest approach of a trial that never came within
    0.6 rad and falls back when a trial comes closer than it, so it neither ratchets
    nor collapses.
    """
    if rule in ("fixed", "learned"):
        return theta_c
    m = outcome.min_abs_theta_swingup if rule == "swingup" else outcome.min_abs_theta
    if not math.isfinite(m) or m > THETA_C_RESET_ABOVE:
        return THETA_C_RESET_TO
    if rule == "clamped":
        return max(m, THETA_C_RESET_TO)
    return max(m, THETA_C_FLOOR)


def _closeness(states: np.ndarray, sim: Simulation) -> np.ndarray:
    """Per row of ``states`` (n, 4) [x, x_dot, theta (wrapped), theta_dot]: closeness to the box.

    1 inside the success test's box, falling linearly with log10 of the distance
    to 0 at CLOSENESS_DECADES decades out; mean over the four components, (n,).
    """
    box = np.array([sim.success.x, sim.success.x_dot, sim.success.theta, sim.success.theta_dot])
    decades = kernel.log10_libm(np.maximum(np.abs(states) / box, 1.0))
    return np.mean(1.0 - np.minimum(decades / CLOSENESS_DECADES, 1.0), axis=-1)


def shaped_reward(
    data: np.ndarray,
    outcome: TrialOutcome,
    plant: Plant,
    sim: Simulation,
    protocol: Protocol,
    weights: tuple[float, float, float, float] = SHAPED_WEIGHTS,
) -> float:
    """Dense score of one recorded trial, in [0, sum(weights)].

    ``data``: the trial's rows (n, 8), columns kernel.TRAJ_COLUMNS. Each term is a
    mean over the sim.n_steps + 1 instants of the full trial (instants after an
    early stop of eq 24 or a fault count 0):

    - energy: 1 - min(|E~| / (2 E_d), 1), E~ of eqs 15-16 (graded swing-up);
    - centre: 1 - min(|x| / check_x, 1) (the cart stays on the 3-m track of eq 24);
    - final: closeness of the final state to the success test's box (0 after an
      early stop or a fault), see :func:`_closeness`;
    - upright: closeness to the box at the instants with |theta| < goal_theta
      (eq 25's pi/9), 0 elsewhere: rewards catching the pole early and converging
      fast, and does not reward hanging still at the bottom.
    """
    if outcome.fault or not np.all(np.isfinite(data)):
        return 0.0
    n = sim.n_steps + 1
    x = data[:, 1]
    theta = wrap_angle(data[:, 3])
    states = np.stack([x, data[:, 2], theta, data[:, 4]], axis=1)
    e_tilde = energy_error(np.stack([x, data[:, 2], data[:, 3], data[:, 4]], axis=1), plant)
    energy = np.sum(1.0 - np.minimum(np.abs(e_tilde) / (2.0 * plant.target_energy), 1.0)) / n
    centre = np.sum(1.0 - np.minimum(np.abs(x) / protocol.check_x, 1.0)) / n
    final = 0.0 if outcome.early else float(_closeness(np.array(outcome.final_state), sim))
    near = np.abs(theta) < protocol.goal_theta
    # the closeness at the near instants only (the others count 0): the same sum
    close = np.zeros(len(states))
    if near.any():
        close[near] = _closeness(states[near], sim)
    upright = float(np.sum(close)) / n
    w = weights
    return float(w[0] * energy + w[1] * centre + w[2] * final + w[3] * upright)


def tracked_baseline(b: float, reward: float, rate: float) -> float:
    """The expected-reward estimate after one more reward: b + rate (r - b)."""
    return b + rate * (reward - b)


def prediction_error_factor(
    delta: float, square: float, rate: float, normalise: bool
) -> tuple[float, float]:
    """(factor, new running mean square of delta).

    The mean square starts at delta^2 (``square`` 0) and then tracks
    (1 - rate) square + rate delta^2; the factor is delta, or delta / rms with
    ``normalise`` (0 when the rms is 0).
    """
    new_square = delta * delta if square <= 0.0 else (1.0 - rate) * square + rate * delta * delta
    if not normalise:
        return delta, new_square
    if new_square <= 0.0 or not math.isfinite(new_square):
        return 0.0, new_square
    return delta / math.sqrt(new_square), new_square


def three_factor_update(
    params: np.ndarray, eligibility: np.ndarray, factor: float, rate: float, max_step: float
) -> np.ndarray:
    """params + clip(rate * factor * eligibility, +-max_step); unchanged if non-finite."""
    step = np.clip(rate * factor * eligibility, -max_step, max_step)
    new = params + step
    if not np.all(np.isfinite(new)):
        return params.copy()
    return new


def jitter_corners(plant: Plant, jitter: float) -> list[Plant]:
    """The four plants with pole mass and length scaled by 1 - jitter or 1 + jitter."""
    return [
        plant.scaled(pole_mass=a, length=b)
        for a in (1.0 - jitter, 1.0 + jitter)
        for b in (1.0 - jitter, 1.0 + jitter)
    ]


def prediction_error(
    state: LearnerState, reward: float, rate: float, normalise: bool
) -> tuple[float, float, float]:
    """(factor, new baseline b, new mean square) for one trial's reward.

    The baseline b tracks the expected reward (memory "reward_mean"); the first
    trial of a run sets b to its own reward (a prediction error of zero).
    """
    mean = state.get("reward_mean")
    square = state.get("rpe_square")
    b = reward if state.trials_done == 0 or not mean else mean[0]
    factor, new_square = prediction_error_factor(
        reward - b, square[0] if square else 0.0, rate, normalise
    )
    return factor, tracked_baseline(b, reward, rate), new_square


def baseline_memory(
    state: LearnerState, b: float, square: float
) -> tuple[tuple[str, tuple[float, ...]], ...]:
    """Memory entries "reward_mean" and "rpe_square" (the old value kept if non-finite)."""
    old_b = state.get("reward_mean") or (0.0,)
    old_sq = state.get("rpe_square") or (0.0,)
    return (
        ("reward_mean", (b,) if math.isfinite(b) else old_b),
        ("rpe_square", (square,) if math.isfinite(square) else old_sq),
    )


def check_decay(rate: float, decay: float) -> None:
    """ParameterError unless the decay per update (``rate`` x ``decay``) is below 1, so
    that -rate*decay*W never overshoots zero."""
    if rate * decay >= 1.0:
        raise ParameterError(f"the decay per update (rate x decay = {rate * decay:g}) must be < 1")
