"""The one trial loop every learning rule shares.

:func:`learning_step`: restore the generator, let the rule plan the trial, run
it (recorded when the reward is the shaped one), score it (eqs 24-25 or the
shaped reward), apply the success test (on the noisy trial or on a mean-policy
rerun, eqs 22-23; on the jitter corners too), let the rule update, record the
history row and build the next state. :func:`learn` repeats it until success or
``max_trials``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.chapter import CHAPTER
from striatal.learners.common import initial_state, jitter_corners, mean_policy_success
from striatal.learners.common import shaped_reward as shaped_reward
from striatal.learners.config import LearnerConfig
from striatal.learners.pgpe import PGPE
from striatal.learners.rpe import RPE
from striatal.learners.rule import Rule, Update
from striatal.learners.state import LearnerState, TrainResult, TrialRecord
from striatal.params import Controller, Plant, Simulation
from striatal.rollout import Protocol, recorded_trial, run_trial

__all__ = ["LEARNERS", "RULES", "check_config", "learn", "learning_step", "rule_of"]

#: The registry: learner name -> rule. Add a rule here (docs/architecture.md).
RULES: dict[str, Rule] = {r.name: r for r in (CHAPTER, RPE, PGPE)}
#: The learner names, in the registry's order.
LEARNERS: tuple[str, ...] = tuple(RULES)


def rule_of(config: LearnerConfig | str) -> Rule:
    """The rule named by ``config.learner`` (or by the name itself); ParameterError if none."""
    name = config if isinstance(config, str) else config.learner
    try:
        return RULES[name]
    except (KeyError, TypeError):
        raise ParameterError(
            f"learner must be one of {', '.join(LEARNERS)}, got {name!r}"
        ) from None


def check_config(config: LearnerConfig) -> LearnerConfig:
    """``config`` if its rule accepts it (ParameterError otherwise)."""
    rule_of(config).check(config)
    return config


def _finite(update: Update, state: LearnerState) -> Update:
    """``update``, or the parts of ``state`` it would replace by a non-finite number.

    The rules keep non-finite numbers out themselves; this is the loop's backstop, so a
    numerical fault never reaches a checkpoint, a history row or a result.
    """
    W = update.W if all(math.isfinite(w) for w in update.W) else state.W
    theta_c = update.theta_c if math.isfinite(update.theta_c) else state.theta_c
    old = dict(state.memory)
    memory = tuple(
        (k, v if all(math.isfinite(x) for x in v) else old.get(k, ())) for k, v in update.memory
    )
    return Update(W=W, theta_c=theta_c, memory=memory)


def learning_step(
    state: LearnerState,
    plant: Plant,
    template: Controller,
    sim: Simulation,
    protocol: Protocol,
    config: LearnerConfig,
) -> tuple[LearnerState, TrialRecord]:
    """One trial with (W, theta_c) of ``state``, the success test, then the rule's update.

    Pure: the same state gives the same result. ``template`` carries the readings
    (balance sign, switch, inhibition); its gains are replaced by the state's.
    """
    rule = rule_of(config)
    rng = np.random.default_rng()
    rng.bit_generator.state = state.rng_state
    plan = rule.plan(state, config, rng, plant)
    true_plant = plan.plant or plant
    model = plant if plan.plant is not None else None
    trial_controller = replace(template, theta_c=plan.theta_c)
    kwargs = dict(
        plant=true_plant,
        controller=trial_controller,
        sim=sim,
        protocol=protocol,
        gains=plan.W,
        rng=plan.rng,
        trace=plan.trace,
        gamma=plan.gamma,
        action_every=config.action_every,
        chapter_eligibility=plan.eligibility == "chapter",
        model=model,
    )
    if config.reward == "shaped":
        outcome, data = recorded_trial(**kwargs)  # type: ignore[arg-type]
        reward = shaped_reward(data, outcome, true_plant, sim, protocol)
    else:
        outcome = run_trial(**kwargs)  # type: ignore[arg-type]
        reward = outcome.reward
    W = np.array(state.W, dtype=float)
    controller = replace(template, theta_c=state.theta_c)
    if config.success_on == "noisy":
        success = outcome.success
    else:
        success = mean_policy_success(plant, controller, sim, protocol, W, config.action_every)
        if success and config.plant_jitter > 0.0:
            success = all(
                mean_policy_success(
                    corner, controller, sim, protocol, W, config.action_every, model=plant
                )
                for corner in jitter_corners(plant, config.plant_jitter)
            )
    update = _finite(rule.update(state, config, plan, outcome, reward, success), state)
    record = TrialRecord(
        trial=state.trials_done + 1,
        reward=reward,
        W=state.W,
        theta_c=state.theta_c,
        min_abs_theta_swingup=outcome.min_abs_theta_swingup,
        ended_at=outcome.ended_at,
        success=success,
        fault=outcome.fault,
        early=outcome.early,
        extra=rule.extra(state, plan),
    )
    new_state = LearnerState(
        trials_done=state.trials_done + 1,
        W=update.W,
        theta_c=update.theta_c,
        rng_state=dict(rng.bit_generator.state),
        success=success,
        n_positive=state.n_positive + int(outcome.reward > 0),
        memory=update.memory,
    )
    return new_state, record


def learn(
    plant: Plant,
    template: Controller,
    config: LearnerConfig,
    seed: int,
    *,
    sim: Simulation | None = None,
    protocol: Protocol | None = None,
    state: LearnerState | None = None,
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
) -> TrainResult:
    """Learn from ``template``'s gains and theta_c (or continue from ``state``).

    Stops at the first trial that passes the success test (its W and theta_c are
    the result, as in the chapter) or after ``config.max_trials`` trials.
    ``on_trial`` is called after every trial (history, checkpoints, progress).
    A KeyboardInterrupt stops the run; the result then has ``interrupted=True``.
    """
    check_config(config)
    sim = sim or Simulation()
    protocol = protocol or Protocol()
    if state is None:
        state = initial_state(template.gains, template.theta_c, seed)
    t0 = time.perf_counter()
    interrupted = False
    try:
        while not state.success and state.trials_done < config.max_trials:
            state, record = learning_step(state, plant, template, sim, protocol, config)
            if on_trial is not None:
                on_trial(state, record)
    except KeyboardInterrupt:
        interrupted = True
    return TrainResult(
        success=state.success,
        trials=state.trials_done,
        W=state.W,
        theta_c=state.theta_c,
        seed=seed,
        wall_seconds=time.perf_counter() - t0,
        state=state,
        learner=config.learner,
        interrupted=interrupted,
        settings={"learner": config.learner, "seed": seed, "config": config.to_dict()},
    )
