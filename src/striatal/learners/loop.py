"""The one trial loop every learning rule shares.

:func:`learning_step`: restore the generator, let the rule plan the trial, run
it (recorded when the reward is the shaped one), score it (eqs 24-25 or the
shaped reward), apply the success test (on the noisy trial or on a mean-policy
rerun, eqs 22-23; on the jitter corners too: the named checks of :func:`success_checks`),
let the rule update, record the
history row and build the next state. Every simulated trial is counted in
``LearnerState.simulations`` (and its simulated time in ``simulated_seconds``):
the learning trial and each success check that needs a trial of its own. A rule
that judges its candidate (``Rule.judging``: pgpe, forward) is judged on the controller
its trial ran; when that trial already was the noise-free run on the nominal plant, it is the check.
With ``config.robust`` (any rule) every trial and check holds the motor force
(``striatal.sim.robust.ROBUST_HARDWARE``), the jitter corners are not checked, and a
controller that passes the success test must also pass the robustness set
(:func:`striatal.sim.robust.stop_check`, each of its runs counted; the nominal case is
not rerun when the success test's noise-free nominal run already was it); with
``config.stop_margin`` it must first pass the four plant corners of a wider box too
(:func:`striatal.sim.robust.corners_check_steps`, counted the same way); with
``config.margin_after_success`` as well, the run succeeds at the first controller that
passes the test without the margin (:class:`striatal.learners.state.FirstSuccess`), its
wider corners then run (counted), and the run learns on, the margin in its test, until
one passes it or the budget ends (:func:`finished`, :func:`delivered`). With a
jittered plant, a rule judged on its noise-free candidate is first filtered by its
own trial on that plant (no nominal rerun); the set then decides. ac's online trial
(``striatal.sim.online``) runs with u held even then; its success checks and the set
hold the force. ``config.max_force``
and ``config.track`` (:attr:`LearnerConfig.hardware`) apply to every trial, check and
case of the set.
:func:`learn` repeats it until success or ``max_trials``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.ac import AC
from striatal.learners.chapter import CHAPTER
from striatal.learners.common import initial_state, jitter_corners
from striatal.learners.common import shaped_reward as shaped_reward
from striatal.learners.config import LearnerConfig
from striatal.learners.pgpe import PGPE
from striatal.learners.rpe import RPE
from striatal.learners.rule import Judging, Rule, Trial, TrialContext, Update
from striatal.learners.state import FirstSuccess, LearnerState, TrialRecord
from striatal.params import Controller, Plant, Simulation
from striatal.sim.batch import Steps, drive, driven
from striatal.sim.robust import (
    ROBUST_BOX,
    StopCheck,
    corners_check_steps,
    nominal_is_the_case,
    stop_check_steps,
)
from striatal.sim.rollout import Protocol, TrialRequest

__all__ = [
    "RULES",
    "check_config",
    "control_config",
    "default_config",
    "delivered",
    "finished",
    "learn",
    "learn_steps",
    "learning_step",
    "learning_steps",
    "nominal_checked",
    "register",
    "rule_of",
    "run_context",
    "success_checks",
]

#: The registry: learner name -> rule (docs/architecture.md). The rules below the loop
#: are registered here; a rule that builds on the loop registers in
#: :mod:`striatal.learners` with :func:`register`.
RULES: dict[str, Rule] = {}


def register(rule: Rule) -> Rule:
    """Add ``rule`` to :data:`RULES` under its name (ParameterError if the name is taken)."""
    if rule.name in RULES:
        raise ParameterError(f"a learner named {rule.name!r} is registered already")
    RULES[rule.name] = rule
    return rule


for _rule in (CHAPTER, RPE, PGPE, AC):
    register(_rule)


def rule_of(config: LearnerConfig | str) -> Rule:
    """The rule named by ``config.learner`` (or by the name itself); ParameterError if none."""
    name = config.learner if isinstance(config, LearnerConfig) else config
    try:
        return RULES[name]
    except (KeyError, TypeError):
        raise ParameterError(f"learner must be one of {', '.join(RULES)}, got {name!r}") from None


def default_config(learner: str = "chapter", **changes: Any) -> LearnerConfig:
    """The learner's tuned preset with ``changes`` applied, checked by its rule.

    ``default_config("pgpe")`` is what ``striatal train --learner pgpe`` runs;
    ``default_config("chapter")`` is the chapter's learner exactly. With
    ``robust=True`` the rule's robust preset (``Rule.robust_preset_of(changes)``) is
    applied over its preset first (pgpe: plant_jitter 0.2, alpha 0.5; forward with the
    structured, generic-gains or sparse-gains model: imagine_margin 0.1).
    """
    rule = rule_of(learner)
    robust = dict(rule.robust_preset_of(changes)) if changes.get("robust") is True else {}
    try:
        config = replace(LearnerConfig(learner=learner, **rule.preset), **{**robust, **changes})
    except TypeError as exc:
        raise ParameterError(f"unknown learner option: {exc}") from None
    return check_config(config)


def control_config(config: LearnerConfig) -> LearnerConfig:
    """``config``'s no-learning control (its rule's ``control``: alpha 0 for chapter and
    rpe, the same exploration without update for pgpe)."""
    return rule_of(config).control_config(config)


def check_config(config: LearnerConfig) -> LearnerConfig:
    """``config`` if its rule accepts it (ParameterError otherwise)."""
    rule_of(config).check(config)
    return config


def _finite(update: Update, state: LearnerState) -> Update:
    """``update``, or the parts of ``state`` it would replace by a non-finite number.

    The rules keep non-finite numbers out themselves; this is the loop's backstop, so a
    numerical fault never reaches a checkpoint, a history row or a result.
    """
    finite = _all_finite
    if (
        finite(update.W)
        and math.isfinite(update.theta_c)
        and all(finite(v) for _, v in update.memory)
    ):
        return update
    W = update.W if finite(update.W) else state.W
    theta_c = update.theta_c if math.isfinite(update.theta_c) else state.theta_c
    old = dict(state.memory)
    memory = tuple((k, v if finite(v) else old.get(k, ())) for k, v in update.memory)
    return Update(W=W, theta_c=theta_c, memory=memory, extra=update.extra)


def _all_finite(values: tuple[float, ...]) -> bool:
    """Whether every one of ``values`` is finite."""
    return all(map(math.isfinite, values))


#: The checks of the success test, by name: what each runs. :func:`success_checks` says
#: which a config applies, in order; the first that fails ends the test (docs/architecture.md).
CHECKS: dict[str, str] = {
    "trial": "the trial itself: the noisy trial (success_on noisy), or the noise-free run "
    "of the candidate a rule that judges its candidate ran (its own plant)",
    "rerun": "a noise-free run of the judged controller on the nominal plant",
    "jitter corners": "noise-free runs on the four corners of plant_jitter (pole mass and "
    "length scaled by 1 +- plant_jitter), the controller believing in the nominal plant",
    "margin corners": "with stop_margin M: noise-free runs on the four plant corners at "
    "pole mass and length x(1 +- (0.2 + M)) (the motor force held, 60 s), the controller "
    "believing in the nominal plant, up to the first that fails",
    "robustness set": "the robustness set of striatal.sim.robust (9 noise-free cases, the "
    "motor force held), up to the first that fails; its nominal case is not rerun when a "
    "check already ran it",
}


def success_checks(config: LearnerConfig, judging: Judging | None = None) -> tuple[str, ...]:
    """The names of the checks (:data:`CHECKS`) the success test of ``config`` applies,
    judging as ``judging`` says (default: ``config``'s rule; a baseline judges each
    candidate on its own trial, ``Judging("candidate")``)."""
    judging = rule_of(config).judging if judging is None else judging
    if config.success_on == "noisy":
        checks: tuple[str, ...] = ("trial",)
    elif judging.candidate and (config.plant_jitter == 0.0 or config.robust):
        # its trial is the noise-free run of the judged controller (on a jittered plant
        # with robust: a first filter, the robustness set decides)
        checks = ("trial",)
    else:
        checks = ("rerun",)
    if config.success_on == "mean" and config.plant_jitter > 0.0 and not config.robust:
        checks += ("jitter corners",)
    if config.robust:
        checks += ("margin corners",) * (config.stop_margin > 0.0) + ("robustness set",)
    return checks


def nominal_checked(config: LearnerConfig, judging: Judging | None = None) -> bool:
    """Whether a check before the robustness set ran the judged controller noise-free on
    the nominal plant (then the set need not rerun its nominal case)."""
    checks = success_checks(config, judging)
    return "rerun" in checks or (
        config.success_on == "mean" and checks[0] == "trial" and config.plant_jitter == 0.0
    )


def run_context(
    plant: Plant, template: Controller, sim: Simulation, protocol: Protocol, config: LearnerConfig
) -> TrialContext:
    """The :class:`TrialContext` of a run's trials: its plant, readings, simulation,
    protocol, and ``config``'s hardware and action rate."""
    return TrialContext(plant, template, sim, protocol, config.hardware, config.action_every)


#: The seed of a generator whose state is set right after (not the OS's entropy: a run
#: restores its generator every trial).
_BLANK = np.random.SeedSequence(0)


def learning_steps(
    state: LearnerState,
    plant: Plant,
    template: Controller,
    sim: Simulation,
    protocol: Protocol,
    config: LearnerConfig,
    rng: np.random.Generator | None = None,
    *,
    context: TrialContext | None = None,
    rng_at_state: bool = False,
) -> Steps[tuple[LearnerState, TrialRecord]]:
    """One trial with (W, theta_c) of ``state``, the success test, then the rule's update.

    Pure: the same state gives the same result. ``template`` carries the readings
    (balance sign, switch, inhibition); its gains are replaced by the state's. ``rng``:
    a PCG64 generator to draw with, its state set to ``state.rng_state`` first (a run
    reuses one; None: a new one); ``rng_at_state``: ``rng`` is at ``state.rng_state``
    already (the state the run's last step left), so it is not set again. ``context``:
    the run's :class:`TrialContext` (None: built here from the arguments; a run builds
    it once, :func:`learn_steps`). As
    :data:`striatal.sim.batch.Steps`: every simulation is yielded as a request (the
    learning trial, the rule's own ones, the success test's trials and the robustness
    set); :func:`learning_step` runs them on the scalar kernel.
    """
    rule = rule_of(config)
    if context is None:
        context = run_context(plant, template, sim, protocol, config)
    if rng is None:
        rng = np.random.Generator(np.random.PCG64(_BLANK))
        rng_at_state = False
    if not rng_at_state:
        rng.bit_generator.state = state.rng_state
    plan = rule.plan(state, config, rng, context)
    judging = rule.judging
    if judging.candidate and plan.rng is not None:
        raise ParameterError(
            f"learner {rule.name!r} judges its candidate, so its trials must be noise-free "
            "(TrialPlan.rng None)"
        )
    shaped = config.reward == "shaped"
    if shaped and not plan.record:
        plan = replace(plan, record=True)
    outcome = yield from rule.run(config, plan, context)
    reward = outcome.reward
    if shaped:
        assert outcome.rows is not None
        reward = shaped_reward(outcome.rows, outcome, plan.plant or plant, sim, protocol)
    simulations, seconds = 1, outcome.ended_at
    if judging.candidate:
        # the controller the trial ran (e.g. pgpe's perturbed p') is the one judged
        W, theta_c = np.asarray(plan.W, dtype=float), plan.theta_c
    else:
        W, theta_c = np.array(state.W, dtype=float), state.theta_c
    success = True
    checks: tuple[tuple[tuple[float, float], np.ndarray], ...] = ()

    def margin_corners() -> Steps[StopCheck]:
        """The judged controller on the corners of the box widened by the stop margin."""
        return corners_check_steps(
            replace(template, theta_c=theta_c),
            plant,
            sim.dt,
            ROBUST_BOX + config.stop_margin,
            gains=W,
            hardware=context.hardware,
        )

    # margin_after_success: the margin's corners join the test only after the first success
    first_test = config.margin_after_success and not state.success
    tested = replace(config, stop_margin=0.0) if first_test else config
    for check in success_checks(tested):
        if not success:
            break
        if check == "trial":
            success = outcome.success
            continue
        if check == "robustness set":
            nominal = nominal_checked(config) and nominal_is_the_case(sim, config.action_every)
            verdict = yield from stop_check_steps(
                replace(template, theta_c=theta_c),
                plant,
                sim.dt,
                gains=W,
                nominal_passed=nominal,
                hardware=context.hardware,
                record=plan.record_checks,
            )
            checks = verdict.recorded
            simulations += verdict.simulations
            seconds += verdict.simulated_seconds
            success = verdict.robust
            continue
        if check == "margin corners":
            verdict = yield from margin_corners()
            simulations += verdict.simulations
            seconds += verdict.simulated_seconds
            success = verdict.robust
            continue
        runs = (
            [(plant, None)]
            if check == "rerun"
            else [(corner, plant) for corner in jitter_corners(plant, config.plant_jitter)]
        )
        for true_plant_i, model_i in runs:
            if not success:
                break
            (rerun,) = yield [
                TrialRequest(
                    true_plant_i,
                    template,
                    sim,
                    protocol,
                    gains=W,
                    action_every=config.action_every,
                    model=model_i,
                    hardware=context.hardware,
                    theta_c=theta_c,
                )
            ]
            simulations += 1
            seconds += rerun.ended_at
            success = rerun.success
    first_success, margin_reached = state.first_success, state.margin_reached
    if first_test and success:
        # the run's success, exactly as without the margin; then the wider corners on
        # the same controller, counted after it
        first_success = FirstSuccess(
            trials=state.trials_done + 1,
            simulations=state.simulations + simulations,
            simulated_seconds=state.simulated_seconds + seconds,
            W=tuple(float(w) for w in W),
            theta_c=float(theta_c),
        )
        verdict = yield from margin_corners()
        simulations += verdict.simulations
        seconds += verdict.simulated_seconds
        margin_reached = verdict.robust
    elif config.margin_after_success and success:
        margin_reached = True
    trial = Trial(plan, outcome, reward, success, checks)
    update = yield from rule.update_steps(state, config, trial, context)
    update = _finite(update, state)
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
        extra=update.extra,
    )
    new_state = LearnerState(
        trials_done=state.trials_done + 1,
        W=update.W,
        theta_c=update.theta_c,
        rng_state=dict(rng.bit_generator.state),
        success=success or state.success,
        n_positive=state.n_positive + int(outcome.reward > 0),
        memory=update.memory,
        simulations=state.simulations + simulations,
        simulated_seconds=state.simulated_seconds + seconds,
        first_success=first_success,
        margin_reached=margin_reached,
    )
    return new_state, record


#: :func:`learning_steps` run to its end on the scalar kernel.
learning_step = driven(learning_steps)


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
) -> LearnerState:
    """Learn from ``template``'s gains and theta_c (or continue from ``state``); the
    state after the last trial.

    Stops at the first trial that passes the success test (its W and theta_c are
    the result, as in the chapter; with ``config.robust`` it must pass the robustness
    set too) or after ``config.max_trials`` trials.
    ``on_trial`` is called after every trial (history, checkpoints, progress); a
    KeyboardInterrupt it raises, or the user's, ends the loop and reaches the caller
    (:func:`striatal.train` keeps the last recorded state).
    """
    check_config(config)
    if state is None:
        state = initial_state(template.gains, template.theta_c, seed)
    return drive(
        learn_steps(
            plant,
            template,
            config,
            state,
            sim or Simulation(),
            protocol or Protocol(),
            on_trial=on_trial,
        )
    )


def learn_steps(
    plant: Plant,
    template: Controller,
    config: LearnerConfig,
    state: LearnerState,
    sim: Simulation,
    protocol: Protocol,
    *,
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
) -> Steps[LearnerState]:
    """:func:`learn`'s trials from ``state`` as :data:`striatal.sim.batch.Steps`: the
    learning steps until success or ``config.max_trials``; returns the last state. The
    steps share one generator, its state set from each step's ``rng_state``."""
    rng = np.random.Generator(np.random.PCG64(_BLANK))
    context = run_context(plant, template, sim, protocol, config)
    first = True
    while not finished(state, config) and state.trials_done < config.max_trials:
        # after the first step the generator is where the step left it: state.rng_state
        state, record = yield from learning_steps(
            state,
            plant,
            template,
            sim,
            protocol,
            config,
            rng,
            context=context,
            rng_at_state=not first,
        )
        first = False
        if on_trial is not None:
            on_trial(state, record)
    return delivered(state)


def finished(state: LearnerState, config: LearnerConfig) -> bool:
    """Whether a run in ``state`` has ended before its budget: at its success, or with
    ``config.margin_after_success`` at the first success that also passes the margin."""
    if config.margin_after_success:
        return state.margin_reached
    return state.success


def delivered(state: LearnerState) -> LearnerState:
    """``state`` holding the controller its run delivers: its own W and theta_c, or, for
    a run that learned on after its first success (``margin_after_success``) and did not
    reach the margin, the first success's. Its counts stay the run's totals."""
    first = state.first_success
    if first is None or state.margin_reached:
        return state
    return replace(state, W=first.W, theta_c=first.theta_c)
