"""Baselines on the learner's plant, protocol and success test (docs/results.md).

Every baseline is judged like the learner: one evaluation of a candidate
(W1..W6, theta_c) is one 60-s trial of the chapter's :class:`~striatal.sim.rollout.Protocol`
(:func:`striatal.sim.rollout.run_trial`), and the trial passes with the same reading
``success_on`` as the learner: "noisy" (the chapter) judges the noisy trial
(policy noise sigma(W6), eqs 22-23) drawn from the seed's generator; "mean" a
noise-free trial of the mean policy. Each baseline reports the trials (60-s
episodes) to its first success, at most ``max_trials``.

lqr
    The linear-quadratic regulator of the upright linearization (eq 18,
    :func:`striatal.sim.dynamics.linearization`), Q = diag(1, 1, 1, 1), R = 1,
    K = R^-1 B^T P with P from the continuous algebraic Riccati equation
    (:func:`scipy.linalg.solve_continuous_are`). The kernel only runs the chapter's
    balancing law mu_1 = -K_W s with K_W = [W2, W3, -(1 + W1 l) g, -2 l sqrt(W1 g)]
    (eq 22, :func:`striatal.sim.control.balancing_gain_matrix`): three gains for four
    coefficients. So the arm runs the least-squares fit of W1..W3 to K (W2, W3 match
    K exactly; W1 fits the two theta coefficients), with the chapter's learned swing-up
    W4, W5, noise W6 and theta_c. :func:`lqr_fit` reports K, the fitted K_W and the
    closed-loop eigenvalues of both; the pure LQR law itself is not run.
hand
    The chapter's learned gains W and theta_c (params.CHAPTER_FINAL_W/THETA_C), fixed.
random
    Every trial draws (W1..W6, theta_c) uniformly from :data:`RANDOM_BOX`; no learning.
cmaes
    CMA-ES (``cma``, Hansen) over the same 7 numbers from (W(0), theta_c(0)) with step
    size 1, bounded to W1 >= W1_FLOOR and theta_c in [0.2, 1.4], minimising minus the
    dense score :func:`striatal.learners.common.shaped_reward` of each candidate's trial (the
    sparse +10/-5 reward of eqs 24-25 is almost flat for a black-box search). Success
    when a candidate's trial passes the success test. Population: cma's default
    4 + floor(3 ln 7) = 9 candidates per generation. Restarts: IPOP-CMA-ES (Auger and
    Hansen 2005), the rule of ``cma.fmin(..., restarts=, incpopsize=2)``: whenever cma's
    own termination criteria fire (``es.stop()``), a new run starts from (W(0),
    theta_c(0)) with step size 1 and twice the population, until ``max_trials``
    candidates were tried. It is written as an ask/tell loop rather than through
    ``cma.fmin`` so that the first passing candidate ends the search and every
    candidate is one counted trial (BIPOP is not used: cma draws its population
    sizes from NumPy's global generator, which the seed does not govern).

Every search takes a :class:`Budget` (its arm's config gives it: :meth:`Budget.of`): at
most ``max_trials`` candidates, the reading ``success_on`` and the stop rule. A candidate
meets the learner's success test, its checks named by
:func:`striatal.learners.loop.success_checks` (:attr:`Budget.checks`: the candidate's own
trial, with ``robust`` the robustness set). Each search is written as
:data:`striatal.sim.batch.Steps` (``fixed_controller_steps``, ``random_search_steps``,
``cmaes_steps``): it yields its trials, so the batch engines batch them with the other
runs'; ``fixed_controller``, ``random_search`` and ``cmaes`` run them on the scalar kernel.

Robust (``Budget.robust``, ``sweep --baselines random,cmaes --robust``): the protocol of
the learner's robust stop rule. Every trial holds the motor force of eq 12
(``striatal.sim.robust.ROBUST_HARDWARE``; ``Budget.hardware``: with a force limit or a
track, as ``LearnerConfig.hardware`` gives them), and a candidate whose trial passes the
success test is run through the robustness set (:func:`striatal.sim.robust.stop_check`,
up to the first failing case; the nominal case is the trial itself for a noise-free
60-s trial from the chapter's start); only a robust candidate ends the search. Each of
those runs is counted in ``simulations`` and ``simulated_seconds``; ``trials`` counts
candidates.
CMA-ES still minimises minus the shaped reward of the candidate's own trial: the search
sees what the learner sees.

Spent: every baseline reports ``simulations`` (every trial it ran, one per
candidate; a fixed controller's mean-policy verdict is one) and
``simulated_seconds`` (their simulated time, each trial ending at T_f or when it
fails early).

For the fixed controllers (lqr, hand) with the "noisy" reading, the seed's generator
draws a new noisy trial each time until one passes; with "mean" the one noise-free
trial decides (a fixed mean policy gives the same trial every time), and a failure
is reported as unsolved at ``max_trials``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.common import shaped_reward
from striatal.learners.config import W1_FLOOR, LearnerConfig, SuccessOn
from striatal.learners.loop import nominal_checked, success_checks
from striatal.learners.pgpe import THETA_C_LEARNED_RANGE
from striatal.learners.rule import Judging
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_HARDWARE,
    N_GAINS,
    Controller,
    Hardware,
    Plant,
    Simulation,
)
from striatal.sim.batch import Steps, driven
from striatal.sim.control import balancing_gain_matrix
from striatal.sim.dynamics import linearization
from striatal.sim.robust import nominal_is_the_case, robust_hardware, stop_check_steps
from striatal.sim.rollout import Protocol, TrialRequest

__all__ = [
    "BASELINES",
    "LQR_Q",
    "LQR_R",
    "RANDOM_BOX",
    "SEARCHES",
    "Budget",
    "LqrFit",
    "cmaes",
    "cmaes_steps",
    "fixed_controller",
    "fixed_controller_steps",
    "lqr_controller",
    "lqr_fit",
    "lqr_gain",
    "random_search",
    "random_search_steps",
]


#: A baseline's candidate is judged on its own trial (noise-free with success_on "mean").
JUDGING = Judging("candidate")

#: LQR weights on (x, x_dot, theta, theta_dot) and on u.
LQR_Q = np.eye(4)
LQR_R = np.eye(1)

#: (low, high) of (W1..W6, theta_c) for random search [-, rad].
RANDOM_BOX = (
    np.array([W1_FLOOR, -3.0, -3.0, -3.0, -3.0, -3.0, THETA_C_LEARNED_RANGE[0]]),
    np.array([3.0, 3.0, 3.0, 3.0, 3.0, 3.0, THETA_C_LEARNED_RANGE[1]]),
)


def lqr_gain(
    plant: Plant, Q: np.ndarray = LQR_Q, R: np.ndarray = LQR_R
) -> tuple[np.ndarray, np.ndarray]:
    """(K (1, 4), P (4, 4)): u = -K s minimises int s'Qs + u'Ru on the eq-18 linearization."""
    from scipy.linalg import solve_continuous_are

    A, B = linearization(plant)
    P = solve_continuous_are(A, B, Q, R)
    K = np.linalg.solve(R, B.T @ P)
    return K, P


@dataclass(frozen=True)
class LqrFit:
    """The LQR gain and the balancing-law gains W1..W3 closest to it (least squares)."""

    K: tuple[float, ...]
    W123: tuple[float, float, float]
    K_fit: tuple[float, ...]
    residual: float
    eig_lqr: tuple[complex, ...]
    eig_fit: tuple[complex, ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "Q": LQR_Q.diagonal().tolist(),
            "R": float(LQR_R[0, 0]),
            "K": list(self.K),
            "W123": list(self.W123),
            "K_fit": list(self.K_fit),
            "residual": self.residual,
            "eig_lqr_real": [z.real for z in self.eig_lqr],
            "eig_fit_real": [z.real for z in self.eig_fit],
        }


def lqr_fit(plant: Plant, Q: np.ndarray = LQR_Q, R: np.ndarray = LQR_R) -> LqrFit:
    """Least-squares W1..W3 with K_W(W) (eq 22, corrected sign) closest to the LQR K.

    W2 = K[0], W3 = K[1] exactly; W1 >= W1_FLOOR minimises the squared error of the
    theta and theta_dot coefficients, -(1 + W1 l) g and -2 l sqrt(W1 g).
    """
    from scipy.optimize import minimize_scalar

    K, _ = lqr_gain(plant, Q, R)
    k = K[0]

    def err(w1: float) -> float:
        kw = balancing_gain_matrix(np.array([w1, k[0], k[1]]), plant)[0]
        return float(np.sum((kw[2:] - k[2:]) ** 2))

    res = minimize_scalar(err, bounds=(W1_FLOOR, 100.0), method="bounded", options={"xatol": 1e-10})
    W123 = (float(res.x), float(k[0]), float(k[1]))
    K_fit = balancing_gain_matrix(np.array(W123), plant)[0]
    A, B = linearization(plant)
    return LqrFit(
        K=tuple(float(v) for v in k),
        W123=W123,
        K_fit=tuple(float(v) for v in K_fit),
        residual=float(math.sqrt(err(res.x))),
        eig_lqr=tuple(complex(z) for z in np.linalg.eigvals(A - B @ K)),
        eig_fit=tuple(complex(z) for z in np.linalg.eigvals(A - B @ K_fit[None, :])),
    )


def lqr_controller(plant: Plant) -> tuple[tuple[float, ...], float]:
    """(W, theta_c) of the lqr arm: fitted W1..W3, the chapter's learned W4..W6 and theta_c."""
    fit = lqr_fit(plant)
    return (*fit.W123, *CHAPTER_FINAL_W[3:]), CHAPTER_FINAL_THETA_C


@dataclass(frozen=True)
class Budget:
    """What a baseline's search may spend and when it stops: at most ``max_trials``
    candidates, each trial judged by ``success_on`` ("noisy" or "mean", module
    docstring), with ``robust`` the robust stop rule. ``hardware``: the motor and track
    of every trial and of the stop rule's runs (None: the force held with ``robust``,
    the chapter's idealisation otherwise; no limit, no track)."""

    max_trials: int
    success_on: SuccessOn
    robust: bool = False
    hardware: Hardware | None = None

    @classmethod
    def of(cls, config: LearnerConfig) -> Budget:
        """The budget and stop rule of an arm's config."""
        return cls(config.max_trials, config.success_on, config.robust, config.hardware)

    @functools.cached_property
    def test(self) -> LearnerConfig:
        """The success test a candidate meets, as the learner's loop states it (its
        reading and stop rule; the baselines' trials run on the nominal plant)."""
        return LearnerConfig(success_on=self.success_on, robust=self.robust)

    @functools.cached_property
    def checks(self) -> tuple[str, ...]:
        """The checks of that test (:func:`striatal.learners.loop.success_checks`) for a
        candidate judged on its own trial: the trial, and with ``robust`` the
        robustness set."""
        return success_checks(self.test, JUDGING)


def _trial(
    plant: Plant,
    template: Controller,
    sim: Simulation,
    p: np.ndarray,
    budget: Budget,
    rng: np.random.Generator,
    shaped: bool = False,
) -> Steps[tuple[bool, float, float, int]]:
    """(success, shaped score or nan, simulated seconds, simulations) of one 60-s trial
    of p, yielded; with ``budget.robust`` the force held and, when the trial passes, the
    robust stop rule's runs (module docstring) added to the seconds and simulations."""
    hardware = budget.hardware
    if hardware is None:
        hardware = robust_hardware() if budget.robust else CHAPTER_HARDWARE
    controller = template.with_gains(template.gains, float(p[6]))
    W = np.array(p[:N_GAINS], dtype=float)
    (outcome,) = yield [
        TrialRequest(
            plant,
            controller,
            sim,
            Protocol(),
            rng=rng if budget.success_on == "noisy" else None,
            gains=W,
            hardware=hardware,
            record=shaped,
        )
    ]
    score = math.nan
    if shaped:
        assert outcome.rows is not None
        score = shaped_reward(outcome.rows, outcome, plant, sim, Protocol())
    ok, seconds, runs = True, outcome.ended_at, 1
    for check in budget.checks:
        if not ok:
            break
        if check == "trial":
            ok = outcome.success
        elif check == "robustness set":
            nominal = nominal_checked(budget.test, JUDGING) and nominal_is_the_case(sim)
            verdict = yield from stop_check_steps(
                controller,
                plant,
                sim.dt,
                gains=W,
                nominal_passed=nominal,
                hardware=hardware,
            )
            ok, seconds = verdict.robust, seconds + verdict.simulated_seconds
            runs += verdict.simulations
        else:
            raise ParameterError(f"a baseline's candidate cannot take the check {check!r}")
    return ok, score, seconds, runs


#: What a baseline's search returns (success, trials, W, theta_c, simulations, ...).
Found = dict[str, Any]


def _result(
    ok: bool, trials: int, p: np.ndarray, seconds: float, runs: int, **extra: Any
) -> dict[str, Any]:
    """A baseline's outcome: ``trials`` candidates tried, ``runs`` simulations made."""
    return {
        "success": ok,
        "trials": trials,
        "W": tuple(float(v) for v in p[:N_GAINS]),
        "theta_c": float(p[N_GAINS]),
        "simulations": runs,
        "simulated_seconds": seconds,
        **extra,
    }


def fixed_controller_steps(
    plant: Plant,
    template: Controller,
    sim: Simulation,
    W: tuple[float, ...],
    theta_c: float,
    seed: int,
    budget: Budget,
) -> Steps[Found]:
    """Trials of a fixed (W, theta_c) until one passes (lqr, hand)."""
    p = np.array([*W, theta_c])
    rng = np.random.default_rng(seed)
    tries = budget.max_trials if budget.success_on == "noisy" else 1
    seconds, runs = 0.0, 0
    for trial in range(1, tries + 1):
        ok, _, t, n = yield from _trial(plant, template, sim, p, budget, rng)
        seconds, runs = seconds + t, runs + n
        if ok:
            return _result(True, trial, p, seconds, runs)
        if n > 1:
            break  # the robust check of the fixed mean policy failed: it always will
    # "mean": the one noise-free trial decided (unsolved at max_trials)
    return _result(False, budget.max_trials, p, seconds, runs)


def random_search_steps(
    plant: Plant,
    template: Controller,
    sim: Simulation,
    seed: int,
    budget: Budget,
) -> Steps[Found]:
    """Uniform draws of (W1..W6, theta_c) from RANDOM_BOX, one trial each."""
    draw = np.random.default_rng([seed, 3])
    rng = np.random.default_rng(seed)
    low, high = RANDOM_BOX
    p = draw.uniform(low, high)
    seconds, runs = 0.0, 0
    for trial in range(1, budget.max_trials + 1):
        if trial > 1:
            p = draw.uniform(low, high)
        ok, _, t, n = yield from _trial(plant, template, sim, p, budget, rng)
        seconds, runs = seconds + t, runs + n
        if ok:
            return _result(True, trial, p, seconds, runs)
    return _result(False, budget.max_trials, p, seconds, runs)


def cmaes_steps(
    plant: Plant,
    template: Controller,
    sim: Simulation,
    W0: tuple[float, ...],
    theta_c0: float,
    seed: int,
    budget: Budget,
    sigma0: float = 1.0,
) -> Steps[Found]:
    """IPOP-CMA-ES over (W1..W6, theta_c) from (W0, theta_c0) on minus the shaped reward.

    ``restarts`` in the result: how many times the search restarted with a doubled
    population; ``popsize``: the population of the last run.
    """
    import cma

    low, high = RANDOM_BOX
    lower = np.array([W1_FLOOR, *[-np.inf] * 5, low[6]])
    upper = np.array([*[np.inf] * 6, high[6]])
    x0 = np.clip(np.array([*W0, theta_c0]), lower + 1e-9, upper - 1e-9)
    opts: dict[str, Any] = {
        "seed": int(seed) % (2**31 - 1) + 1,
        "bounds": [[W1_FLOOR, *[None] * 5, low[6]], [*[None] * 6, high[6]]],
        "verbose": -9,
    }
    rng = np.random.default_rng(seed)
    max_trials = budget.max_trials
    trials, seconds, restarts, runs = 0, 0.0, 0, 0
    p = x0
    popsize = 0
    while trials < max_trials:
        if restarts:
            # IPOP: cma.fmin's incpopsize = 2; the seed moves on so the run differs
            opts = {**opts, "popsize": 2 * popsize, "seed": opts["seed"] + 1}
        es = cma.CMAEvolutionStrategy(x0.tolist(), sigma0, opts)
        popsize, started = int(es.popsize), trials
        while trials < max_trials and not es.stop():
            candidates = es.ask()
            losses = []
            for x in candidates:
                trials += 1
                p = np.clip(np.array(x), lower, upper)
                ok, score, t, n = yield from _trial(
                    plant, template, sim, p, budget, rng, shaped=True
                )
                seconds, runs = seconds + t, runs + n
                if ok:
                    return _result(
                        True,
                        trials,
                        p,
                        seconds,
                        runs,
                        restarts=restarts,
                        popsize=popsize,
                    )
                losses.append(-score)
                if trials >= max_trials:
                    break
            if len(losses) < len(candidates):
                break
            es.tell(candidates, losses)
        if trials == started:  # stopped before its first candidate: nothing more to try
            break
        restarts += 1
    return _result(False, max_trials, p, seconds, runs, restarts=restarts - 1, popsize=popsize)


Config = LearnerConfig  # (short, so that each search's signature fits one line)


#: :func:`fixed_controller_steps` run on the scalar kernel.
fixed_controller = driven(fixed_controller_steps)
#: :func:`random_search_steps` run on the scalar kernel.
random_search = driven(random_search_steps)
#: :func:`cmaes_steps` run on the scalar kernel.
cmaes = driven(cmaes_steps)


def _lqr(plant: Plant, template: Controller, sim: Simulation, seed: int, c: Config) -> Steps[Found]:
    W, theta_c = lqr_controller(plant)
    return (yield from fixed_controller_steps(plant, template, sim, W, theta_c, seed, Budget.of(c)))


def _hand(
    plant: Plant, template: Controller, sim: Simulation, seed: int, c: Config
) -> Steps[Found]:
    W, theta_c = CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C
    return (yield from fixed_controller_steps(plant, template, sim, W, theta_c, seed, Budget.of(c)))


def _random(
    plant: Plant, template: Controller, sim: Simulation, seed: int, c: Config
) -> Steps[Found]:
    return (yield from random_search_steps(plant, template, sim, seed, Budget.of(c)))


def _cmaes(
    plant: Plant, template: Controller, sim: Simulation, seed: int, c: Config
) -> Steps[Found]:
    W0, theta_c0 = template.gains, template.theta_c
    return (yield from cmaes_steps(plant, template, sim, W0, theta_c0, seed, Budget.of(c)))


#: A baseline arm's search from ``template`` (its W(0) and theta_c(0)) under ``config``'s
#: budget and stop rule, its trials yielded: success, trials, W, theta_c, simulations,
#: simulated_seconds.
Search = Callable[[Plant, Controller, Simulation, int, LearnerConfig], Steps[Found]]
#: The baselines by name, in the order of ``--baselines``' help.
SEARCHES: dict[str, Search] = {
    "lqr": _lqr,
    "hand": _hand,
    "random": _random,
    "cmaes": _cmaes,
}
BASELINES: tuple[str, ...] = tuple(SEARCHES)
