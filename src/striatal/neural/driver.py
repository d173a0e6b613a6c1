"""The project's learning loop with its trials run on the spiking network.

:func:`striatal.learners.loop.learning_steps` is the one trial protocol of every rule: a
rule plans a trial, the loop yields it as a :class:`~striatal.sim.batch.TrialRequest`,
a driver runs it, the rule updates. :func:`network_drive` is a driver that runs each
request on the network (nengo or the Brian2 program) instead of the kernel, so any rule
whose trials the loop yields (the chapter's, pgpe, ...) learns the pathway weights with
its own update; :func:`learn_with_rule` runs a learning run that way.

What the network gives the loop: the action noise drawn from the request's generator
as the kernel draws it (``rollout.noise_arrays``), so the generator's state after a
trial is the kernel's; the eligibility trace D of eq 3 from the pathways' traces
(``D <- gamma^n D + (J^T E, E_6)``, :mod:`striatal.neural.learn`); the outcome with the
reward of eq 25 at T_f. Requests the network cannot run (another plant, a model, sensor
noise, the chapter's printed eligibility, a motor limit, held actions) are refused.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import TypeVar

import numpy as np

from striatal.errors import ParameterError
from striatal.learners import default_config, rule_of
from striatal.learners.common import initial_state
from striatal.learners.config import LearnerConfig
from striatal.learners.loop import learning_steps
from striatal.learners.state import LearnerState, TrialRecord
from striatal.neural.learn import Eligibility, gain_eligibility, trial_outcome, trial_reward
from striatal.neural.network import NetworkConfig
from striatal.neural.run import Simulator, run_network
from striatal.params import CHAPTER_HARDWARE, Controller, Plant, Simulation, check_seed
from striatal.sim import kernel
from striatal.sim.batch import Steps, TrialRequest
from striatal.sim.rollout import Protocol, TrialOutcome, noise_arrays

__all__ = ["learn_with_rule", "network_drive", "run_request"]

T = TypeVar("T")


def run_request(
    r: TrialRequest, config: NetworkConfig, seed: int, simulator: Simulator, net_dt: float = 0.001
) -> TrialOutcome:
    """One requested trial on the network (network seed ``seed``); ``r.trace`` updated."""
    if (
        r.model is not None
        or r.sensor.active
        or r.chapter_eligibility
        or r.action_every != 1
        or r.hardware != CHAPTER_HARDWARE
    ):
        raise ParameterError(
            "the network runs the chapter's trial only: no model mismatch, sensor noise, "
            "printed eligibility, held actions or motor limit"
        )
    noise, _ = noise_arrays(r.sim, r.action_every, r.rng, r.sensor, r.mean_policy)
    W = np.array(r.controller.gains if r.gains is None else r.gains, dtype=float)
    controller = r.controller.with_gains(W, r.controller.theta_c)
    explores = noise.size > 0
    sigma = kernel.sigma_of(W[5]) if explores else 0.0
    every = max(1, int(round(r.sim.dt / net_dt)))
    elig = Eligibility(sigma, noise if explores else np.zeros(r.sim.n_steps), r.gamma, every)
    run = run_network(
        controller,
        r.plant,
        r.sim,
        config,
        seed,
        net_dt=net_dt,
        record_rates=False,
        exploration=elig if explores else None,
        simulator=simulator,
    )
    if explores:
        d = gain_eligibility(elig.trace, elig.sigma_trace, W, r.plant, controller.sign)
        r.trace[:] = r.gamma**r.sim.n_steps * r.trace + d
    reward = trial_reward(run, r.protocol)
    outcome = trial_outcome(run, reward, controller.theta_c)
    return outcome


def network_drive(steps: Steps[T], config: NetworkConfig, seed: int, simulator: Simulator) -> T:
    """Run ``steps`` to its end, each request on the network; its return value."""
    try:
        requests = next(steps)
        while True:
            requests = steps.send([run_request(r, config, seed, simulator) for r in requests])
    except StopIteration as stop:
        return stop.value  # type: ignore[no-any-return]


def learn_with_rule(
    learner: str,
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    *,
    trials: int,
    simulator: Simulator = "brian2",
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
    state: LearnerState | None = None,
    **options: object,
) -> LearnerState:
    """A learning run of rule ``learner`` (its preset, ``options`` over it, the sparse
    reward of eq 25) on the network from ``controller``'s W and theta_c, up to ``trials``
    trials or the first success; ``seed`` seeds the network and the rule's generator.
    ``state``: continue an earlier run (its state after its last trial)."""
    seed = check_seed(seed)
    lc: LearnerConfig = default_config(learner, reward="sparse", max_trials=trials, **options)
    rule = rule_of(lc)
    if getattr(rule, "runs_trial", False):
        raise ParameterError(f"learner {learner!r} runs its own trials: not on the network")
    protocol = Protocol()
    if 0.0 <= protocol.check_time < sim.duration or not math.isfinite(sim.duration):
        raise ParameterError(
            f"network trials must be at most {protocol.check_time:g} s, got {sim.duration:g}"
        )
    if state is None:
        state = initial_state(controller.gains, controller.theta_c, seed)
    template = replace(controller)
    while state.trials_done < trials and not state.success:
        state, record = network_drive(
            learning_steps(state, plant, template, sim, protocol, lc), config, seed, simulator
        )
        if on_trial is not None:
            on_trial(state, record)
    return state
