"""Black-box search baselines for the ablation: random search and CMA-ES over the gains.

Stand-ins measured with striatal's own loop (the sweep's baselines module may
replace them). Both search p = (W1..W5, theta_c) with W6 kept (the mean policy
does not use it) and count one 60-s trial of the mean policy per evaluated p.

random search
    Every trial draws p uniformly from :data:`RANDOM_BOX`; success when a drawn p
    passes the success test. No learning at all: how easy is the problem?
CMA-ES
    ``cma`` (Hansen) from p(0) = (W(0)[:5], 0.6) with step size ``sigma0``,
    minimising minus the shaped reward of :func:`striatal.learners.shaped_reward`
    (the reward "pgpe" learns from). Success when an evaluated candidate passes the
    success test, or the distribution mean does (checked once per generation and,
    like the learners' mean-policy check, not counted as a trial).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from striatal.learn import W1_FLOOR
from striatal.learners import THETA_C_LEARNED_RANGE, recorded_trial, shaped_reward
from striatal.params import N_GAINS, Controller, Plant, Simulation
from striatal.rollout import Protocol

#: (low, high) of W1..W5 and theta_c for random search.
RANDOM_BOX = (
    np.array([W1_FLOOR, -3.0, -3.0, -3.0, -3.0, THETA_C_LEARNED_RANGE[0]]),
    np.array([3.0, 3.0, 3.0, 3.0, 3.0, THETA_C_LEARNED_RANGE[1]]),
)


def evaluate_params(p: np.ndarray, W6: float) -> tuple[float, bool]:
    """(shaped reward, success) of one mean-policy trial with p = (W1..W5, theta_c)."""
    plant, sim, protocol = Plant(), Simulation(), Protocol()
    controller = Controller((1.0, 0.0, 0.0, 0.0, 0.0, W6), float(p[5]))
    W = np.array([*p[:5], W6])
    outcome, data = recorded_trial(
        plant,
        controller,
        sim,
        protocol=protocol,
        gains=W,
        rng=None,
        trace=np.zeros(N_GAINS),
        gamma=0.0,
    )
    return shaped_reward(data, outcome, plant, sim, protocol), outcome.success


def _row(seed: int, W0: tuple[float, ...], ok: bool, trials: int, p: np.ndarray) -> dict[str, Any]:
    return {
        "seed": seed,
        "success": ok,
        "trials": trials,
        "W0": list(W0),
        "W": [*(float(v) for v in p[:5]), W0[5]],
        "theta_c": float(p[5]),
        "resimulated": ok,
    }


def random_search_seed(seed: int, W0: tuple[float, ...], max_trials: int) -> dict[str, Any]:
    """Random search: uniform draws from RANDOM_BOX until one passes (``W0`` only gives W6)."""
    rng = np.random.default_rng([seed, 3])
    low, high = RANDOM_BOX
    p = np.array([*W0[:5], 0.6])
    for trial in range(1, max_trials + 1):
        p = rng.uniform(low, high)
        if evaluate_params(p, W0[5])[1]:
            return _row(seed, W0, True, trial, p)
    return _row(seed, W0, False, max_trials, p)


def cmaes_seed(
    seed: int, W0: tuple[float, ...], max_trials: int, sigma0: float = 1.0
) -> dict[str, Any]:
    """CMA-ES from (W0[:5], 0.6) on minus the shaped reward, at most ``max_trials`` trials."""
    import cma

    low, high = RANDOM_BOX
    opts = {
        "seed": seed + 1,
        "bounds": [[W1_FLOOR, *[None] * 4, low[5]], [*[None] * 5, high[5]]],
        "verbose": -9,
    }
    es = cma.CMAEvolutionStrategy([*W0[:5], 0.6], sigma0, opts)
    lower = np.array([W1_FLOOR, *[-np.inf] * 4, low[5]])
    upper = np.array([*[np.inf] * 5, high[5]])
    trials = 0
    while trials < max_trials:
        # cma keeps the mean itself unconstrained; evaluate its feasible projection
        mean = np.clip(np.array(es.mean), lower, upper)
        if evaluate_params(mean, W0[5])[1]:
            return _row(seed, W0, True, trials, mean)
        candidates = es.ask()[: max_trials - trials]
        losses = []
        for x in candidates:
            trials += 1
            p = np.clip(np.array(x), lower, upper)
            reward, ok = evaluate_params(p, W0[5])
            if ok:
                return _row(seed, W0, True, trials, p)
            losses.append(-reward)
        if len(losses) < es.popsize:
            break
        es.tell(candidates, losses)
    return _row(seed, W0, False, trials, np.clip(np.array(es.mean), lower, upper))
