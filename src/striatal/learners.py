"""Learners beyond the chapter: a dopamine-like prediction error and per-trial exploration.

Both keep the chapter's structure: the two controllers and the switch (eqs 20-23),
a stochastic policy, an eligibility and a three-factor update
W <- W + rate * factor * eligibility applied once per trial at the reward event.
They differ from the chapter's rule (:mod:`striatal.learn`) in what plays each part.

"rpe"
    The chapter's per-step Gaussian policy and eligibility trace D (eqs 3-5), but the
    factor is a reward prediction error delta = r - b with a baseline that tracks the
    expected reward, b <- b + beta (r - b) (dopamine as RPE), optionally divided by
    the running root mean square of delta (``normalise``).
"pgpe"
    Exploration in parameter space, once per trial (parameter-exploring policy
    gradients, Sehnke et al. 2010): the policy over the parameters
    p = (W1..W5, theta_c) is Gaussian, p' = p + eps, eps ~ N(0, diag(s^2)), and the
    trial runs the mean action of eqs 22-23 with p'. Eligibility = eps, factor =
    delta / rms(delta) with the tracked baseline, p <- p + alpha * factor * eps
    - alpha * decay * p (the decay on W1..W5 only). With ``plant_jitter`` the trial's
    plant is randomised and success must hold on the corner plants too.
    With ``sigma_rate`` > 0 the exploration adapts, s <- s exp(sigma_rate * factor *
    (z^2 - 1)) with z = eps / s (the same three factors on the score of s).
    W6 (the per-step sigma) is not used: the trial acts with the mean policy.

The ``shaped`` reward (:func:`shaped_reward`) replaces the sparse +10 / -5 of
eqs 24-25 by a dense score of the recorded trial. The first trial of a run sets
the baseline b to its own reward (a prediction error of zero: only the decay acts).
Measurements of every option: docs/ablation.md.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from striatal.dynamics import energy_error, wrap_angle
from striatal.kernel import sigma_of
from striatal.learn import (
    LearnerConfig,
    LearnerState,
    TrialRecord,
    mean_policy_success,
    theta_c_rule,
    trial_record,
)
from striatal.params import N_GAINS, Controller, Plant, Simulation
from striatal.rollout import (
    Protocol,
    TrialOutcome,
    recorded_trial,
    run_trial,
)

#: Exploration std of theta_c relative to that of the gains (theta_c is in rad, ~0.6).
THETA_C_EXPLORE = 0.3
#: Range of a learned theta_c [rad]: a floor keeps the balancing region from vanishing;
#: eq 21 resets anything above 1.4.
THETA_C_LEARNED_RANGE = (0.2, 1.4)
#: Adapted exploration stays within these multiples of its initial value.
EXPLORE_RANGE = (0.1, 3.0)
#: Weights of the shaped reward's terms: energy, cart near centre, final state,
#: convergence while upright (measured in docs/ablation.md).
SHAPED_WEIGHTS = (1.0, 1.0, 1.0, 2.0)
#: Decades of distance to the success box over which the closeness terms fall from 1 to 0.
CLOSENESS_DECADES = 4.0


def _closeness(states: np.ndarray, sim: Simulation) -> np.ndarray:
    """Per row of ``states`` (n, 4) [x, x_dot, theta (wrapped), theta_dot]: closeness to the box.

    1 inside the success test's box, falling linearly with log10 of the distance
    to 0 at CLOSENESS_DECADES decades out; mean over the four components, (n,).
    """
    box = np.array([sim.success.x, sim.success.x_dot, sim.success.theta, sim.success.theta_dot])
    decades = np.log10(np.maximum(np.abs(states) / box, 1.0))
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
    upright = float(np.sum(_closeness(states, sim) * near)) / n
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


def initial_explore(config: LearnerConfig) -> np.ndarray:
    """Exploration std (6,) of (W1..W5, theta_c) at the start of a "pgpe" run."""
    s = np.full(6, config.explore)
    s[5] *= THETA_C_EXPLORE
    return s


def adapt_explore(s: np.ndarray, z: np.ndarray, factor: float, config: LearnerConfig) -> np.ndarray:
    """s exp(sigma_rate * factor * (z^2 - 1)), kept within EXPLORE_RANGE of its start.

    z^2 - 1 is s times d ln N(eps; 0, s^2) / d s at eps = z s: more exploration
    after a better-than-expected perturbation far from the mean, less otherwise.
    """
    if config.sigma_rate == 0.0 or not math.isfinite(factor):
        return s.copy()
    s0 = initial_explore(config)
    new = s * np.exp(np.clip(config.sigma_rate * factor * (z * z - 1.0), -1.0, 1.0))
    return np.clip(new, EXPLORE_RANGE[0] * s0, EXPLORE_RANGE[1] * s0)


def _clamp_params(p: np.ndarray, config: LearnerConfig) -> np.ndarray:
    out = p.copy()
    out[0] = max(out[0], config.w1_floor)
    out[5] = min(max(out[5], THETA_C_LEARNED_RANGE[0]), THETA_C_LEARNED_RANGE[1])
    return out


def _reward(
    outcome: TrialOutcome,
    data: np.ndarray | None,
    plant: Plant,
    sim: Simulation,
    protocol: Protocol,
) -> float:
    if data is None:
        return outcome.reward
    return shaped_reward(data, outcome, plant, sim, protocol)


def jitter_corners(plant: Plant, jitter: float) -> list[Plant]:
    """The four plants with pole mass and length scaled by 1 - jitter or 1 + jitter."""
    return [
        plant.scaled(pole_mass=a, length=b)
        for a in (1.0 - jitter, 1.0 + jitter)
        for b in (1.0 - jitter, 1.0 + jitter)
    ]


def _prediction_error(
    state: LearnerState, reward: float, config: LearnerConfig
) -> tuple[float, float, float]:
    """(factor, new baseline b, new mean square) for one trial's reward."""
    b = reward if state.trials_done == 0 else state.reward_mean
    factor, square = prediction_error_factor(
        reward - b, state.rpe_square, config.rpe_rate, config.normalise
    )
    return factor, tracked_baseline(b, reward, config.rpe_rate), square


def rpe_step(
    state: LearnerState,
    plant: Plant,
    template: Controller,
    sim: Simulation,
    protocol: Protocol,
    config: LearnerConfig,
) -> tuple[LearnerState, TrialRecord]:
    """One trial of the chapter's per-step policy; update alpha (1 - gamma) delta D (eqs 3-4).

    delta = r - b is the reward prediction error with the tracked baseline b
    (divided by its running rms with ``normalise``); W1 floored, each step bounded
    by max_step, theta_c by eq 21 as in the chapter.
    """
    rng = np.random.default_rng()
    rng.bit_generator.state = state.rng_state
    W = np.array(state.W, dtype=float)
    controller = replace(template, theta_c=state.theta_c)
    trace = np.zeros(N_GAINS) if config.reset_trace else np.array(state.trace, dtype=float)
    eligibility = config.eligibility == "chapter"
    if config.reward == "shaped":
        outcome, data = recorded_trial(
            plant,
            controller,
            sim,
            protocol=protocol,
            gains=W,
            rng=rng,
            trace=trace,
            gamma=config.gamma,
            action_every=config.action_every,
            chapter_eligibility=eligibility,
        )
    else:
        outcome = run_trial(
            plant,
            controller,
            sim,
            protocol=protocol,
            trace=trace,
            gamma=config.gamma,
            rng=rng,
            gains=W,
            action_every=config.action_every,
            chapter_eligibility=eligibility,
        )
        data = None
    reward = _reward(outcome, data, plant, sim, protocol)
    if config.success_on == "noisy":
        success = outcome.success
    else:
        success = mean_policy_success(plant, controller, sim, protocol, W, config.action_every)
    finite = bool(np.all(np.isfinite(trace)))
    factor, b, square = _prediction_error(state, reward, config)
    new_W, new_theta_c = W, state.theta_c
    if not success:
        if finite:
            new_W = three_factor_update(W, trace, factor, config.update_rate, config.max_step)
            new_W[:5] -= config.decay_per_update * W[:5]
            new_W[0] = max(new_W[0], config.w1_floor)
        new_theta_c = theta_c_rule(outcome, state.theta_c, config.theta_c_rule)
    if not finite:
        trace = np.zeros(N_GAINS)
    record = trial_record(
        state, outcome, reward=reward, sigma=float(sigma_of(W[5])), success=success
    )
    new_state = LearnerState(
        trials_done=state.trials_done + 1,
        W=tuple(float(w) for w in new_W),
        theta_c=float(new_theta_c),
        trace=tuple(float(v) for v in trace),
        rng_state=dict(rng.bit_generator.state),
        success=success,
        n_positive=state.n_positive + int(outcome.reward > 0),
        reward_mean=b if math.isfinite(b) else state.reward_mean,
        rpe_square=square if math.isfinite(square) else state.rpe_square,
    )
    return new_state, record


def pgpe_step(
    state: LearnerState,
    plant: Plant,
    template: Controller,
    sim: Simulation,
    protocol: Protocol,
    config: LearnerConfig,
) -> tuple[LearnerState, TrialRecord]:
    """One trial with perturbed parameters p + eps under the mean policy, then the update.

    p = (W1..W5, theta_c); with theta_c_rule other than "learned", theta_c is not
    perturbed and follows that rule (eq 21) instead. With ``plant_jitter`` J > 0 the
    trial's true plant has pole mass and length scaled by factors drawn uniformly
    from [1 - J, 1 + J], the controller still believing the nominal ``plant``
    (learning for robustness), and the success test must then also hold on the four
    corner plants (:func:`jitter_corners`). The success test is judged on the
    unperturbed p (mean policy); if it holds p is the result and nothing changes.
    The state's ``trace`` holds the last eligibility eps.
    """
    rng = np.random.default_rng()
    rng.bit_generator.state = state.rng_state
    W = np.array(state.W, dtype=float)
    learn_theta_c = config.theta_c_rule == "learned"
    p = np.array([*W[:5], state.theta_c])
    s = np.array(state.explore) if state.explore else initial_explore(config)
    z = rng.standard_normal(6)
    if not learn_theta_c:
        z[5] = 0.0
    eps = z * s
    p_trial = _clamp_params(p + eps, config) if learn_theta_c else p + eps
    p_trial[0] = max(p_trial[0], config.w1_floor)
    eps = p_trial - p
    W_trial = np.array([*p_trial[:5], W[5]])
    trial_controller = replace(template, theta_c=float(p_trial[5]))
    true_plant = plant
    if config.plant_jitter > 0.0:
        j = config.plant_jitter
        scale = rng.uniform(1.0 - j, 1.0 + j, size=2)
        true_plant = plant.scaled(pole_mass=float(scale[0]), length=float(scale[1]))
    if config.reward == "shaped":
        outcome, data = recorded_trial(
            true_plant,
            trial_controller,
            sim,
            protocol=protocol,
            gains=W_trial,
            rng=None,
            trace=np.zeros(N_GAINS),
            gamma=0.0,
            action_every=config.action_every,
            model=plant,
        )
    else:
        outcome = run_trial(
            true_plant,
            trial_controller,
            sim,
            protocol=protocol,
            trace=np.zeros(N_GAINS),
            gamma=0.0,
            rng=None,
            gains=W_trial,
            action_every=config.action_every,
            model=plant,
        )
        data = None
    reward = _reward(outcome, data, true_plant, sim, protocol)
    controller = replace(template, theta_c=state.theta_c)
    success = mean_policy_success(plant, controller, sim, protocol, W, config.action_every)
    if success and config.plant_jitter > 0.0:
        success = all(
            mean_policy_success(
                corner, controller, sim, protocol, W, config.action_every, model=plant
            )
            for corner in jitter_corners(plant, config.plant_jitter)
        )
    factor, b, square = _prediction_error(state, reward, config)
    new_p, new_s = p, s
    if not success:
        new_p = three_factor_update(p, eps, factor, config.update_rate, config.max_step)
        new_p[:5] -= config.decay_per_update * p[:5]
        if learn_theta_c:
            new_p = _clamp_params(new_p, config)
        else:
            new_p[5] = theta_c_rule(outcome, state.theta_c, config.theta_c_rule)
        new_p[0] = max(new_p[0], config.w1_floor)
        new_s = adapt_explore(s, z, factor, config)
    record = trial_record(state, outcome, reward=reward, sigma=float(s[0]), success=success)
    new_state = LearnerState(
        trials_done=state.trials_done + 1,
        W=(*(float(v) for v in new_p[:5]), float(W[5])),
        theta_c=float(new_p[5]),
        trace=tuple(float(v) for v in eps),
        rng_state=dict(rng.bit_generator.state),
        success=success,
        n_positive=state.n_positive + int(outcome.reward > 0),
        reward_mean=b if math.isfinite(b) else state.reward_mean,
        rpe_square=square if math.isfinite(square) else state.rpe_square,
        explore=tuple(float(v) for v in new_s),
    )
    return new_state, record


def learning_step(
    state: LearnerState,
    plant: Plant,
    template: Controller,
    sim: Simulation,
    protocol: Protocol,
    config: LearnerConfig,
) -> tuple[LearnerState, TrialRecord]:
    """Dispatch to the variant named by ``config.learner`` ("rpe" or "pgpe")."""
    if config.learner == "rpe":
        return rpe_step(state, plant, template, sim, protocol, config)
    if config.learner == "pgpe":
        return pgpe_step(state, plant, template, sim, protocol, config)
    raise ValueError(f"no learner {config.learner!r} in striatal.learners")
