"""One run of a sweep: a pure worker that turns a :class:`RunSpec` into a row.

An arm is a learner's settings (``method`` "learn"), its no-learning control or a
baseline (``method`` one of :data:`striatal.experiments.baselines.BASELINES`).
:func:`run_one` turns one spec into one row of ``runs.csv`` and depends on nothing
else, so the local process pool and a Ray cluster (:mod:`striatal.experiments.pool`)
give the same rows for the same specs.

Robust (``LearnerConfig.robust``, ``sweep --robust``): every arm stops only on a
controller that passes the robustness set (:func:`striatal.sim.robust.stop_check`), and
the row's ``robust`` column re-checks the final gains with
:func:`striatal.sim.robust.check_robust` (all nine cases, counted in ``eval_simulations``;
empty in a sweep without ``--robust``).

Budget: every row counts every simulated trial its arm ran to learn or search,
the success checks included (``simulations``, ``simulated_seconds``, beside the
learning ``trials``). What the sweep runs afterwards to evaluate the result, the
re-simulation of the final gains and the pass probabilities, is counted apart in
``eval_simulations``.

Seeds: run i of a sweep with root seed R has the integer seed
``SeedSequence(R).spawn(N)[i].generate_state(1)[0]`` (:func:`spawn_seeds`). Every arm
uses the same seeds, and a learner row with seed S is exactly
``striatal train --seed S --init <init> <the same learner options>`` (random W(0) is
drawn as train draws it, from ``default_rng([S, 1])``).

The control arm is the learner's declared no-learning control (the rule's
``control``, :func:`striatal.learners.control_config`): for chapter and rpe alpha = 0
(W never changes, theta_c still follows eq 21); for pgpe alpha = 0 and
sigma_rate = 0, the same perturbations around W(0) with the same spreads and no
update, judged like pgpe on the candidate each trial ran.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable, Sequence
from typing import Any

from striatal.errors import ParameterError
from striatal.experiments import baselines
from striatal.experiments.evaluate import DRAWS_AT_ONCE, PassProbability, pass_probability_steps
from striatal.experiments.runs_csv import first_success_columns
from striatal.experiments.spec import RunSpec, initial_gains
from striatal.learners import LearnerConfig, check_config, rule_of
from striatal.learners.common import initial_state
from striatal.learners.loop import learn_steps
from striatal.learners.state import LearnerState, TrialRecord
from striatal.params import Controller, Plant, Simulation
from striatal.sim.batch import Steps, TrialRequest, drive, driven
from striatal.sim.robust import check_robust
from striatal.sim.rollout import Protocol

METHODS: tuple[str, ...] = ("learn", *baselines.BASELINES)


CONTROL_ARM = "control"


ROLES = ("learner", "control", "baseline")


#: Default noise draws of each pass-probability estimate (0: none).
EVAL_DRAWS = 200


NOTE_BUDGET = (
    "simulations: every simulated trial an arm ran to learn or search, success checks "
    "included (a mean-policy rerun, the jitter corners); trials: learning trials only; "
    "eval_simulations (not in the budget): the re-simulation of the final gains and the "
    "pass-probability draws"
)


NOTE_ROBUST = (
    "robust stop rule: every arm's trials hold the motor force of eq 12; a controller "
    "that passes the success test must also pass the robustness set (striatal.sim.robust, "
    "9 mean-policy runs of 60 s, run up to the first failing case, each counted in "
    "simulations) for the run to stop; the robust column re-checks the final gains on "
    "all 9 cases (eval_simulations)"
)


NOTE_SIMD = (
    "--engine simd: the trials on kernel.run_trials_lockstep (polynomial sin/cos, within "
    "1 ulp of libm's) where the motor and track allow, not on the exact scalar kernel; "
    "a trial equals the scalar kernel's within round-off, which a chaotic swing-up and "
    "learning over many trials amplify, "
    "so a run's row differs from --engine processes/batch; where measured, the arms' "
    "success rates agreed within their 95 % intervals (docs/performance.md)"
)


def control_note(learner: str) -> str:
    """What the control arm of ``learner`` is (from the rule's declared ``control``)."""
    rule = rule_of(learner)
    changes = ", ".join(f"{k} = {v:g}" for k, v in rule.control.items())
    if rule.control_text:
        return f"control arm ({learner}): {changes}: {rule.control_text}"
    also = f"; {rule.control_also}" if rule.control_also else ""
    return (
        f"control arm ({learner}): {changes}, so the gains W never change; theta_c still "
        "follows eq 21 (the threshold rule does not involve alpha), as in the learner arm" + also
    )


NOTE_CONTROL = control_note("chapter")


#: The chapter's protocol (eqs 24-25), one object for every run's trials, so that a
#: lockstep round groups them without hashing it (:func:`striatal.sim.batch.prepare`).
PROTOCOL = Protocol()


#: Called with each learning trial of a run (its state after the trial and its record).
OnTrial = Callable[[LearnerState, TrialRecord], None]


def learning_run_steps(
    plant: Plant,
    template: Controller,
    config: LearnerConfig,
    seed: int,
    sim: Simulation,
    on_trial: OnTrial | None = None,
) -> Steps[dict[str, Any]]:
    """success, trials, W, theta_c, simulations and simulated_seconds of one learning run
    from ``template``'s gains (:func:`striatal.learners.loop.learn_steps`)."""
    start = initial_state(template.gains, template.theta_c, seed)
    check_config(config)
    state = yield from learn_steps(plant, template, config, start, sim, PROTOCOL, on_trial=on_trial)
    return {
        "success": state.success,
        "trials": state.trials_done,
        "W": state.W,
        "theta_c": state.theta_c,
        "simulations": state.simulations,
        "simulated_seconds": state.simulated_seconds,
        "imagined": rule_of(config).imagined(state),
        "first_success": state.first_success,
        "margin_reached": state.margin_reached if config.margin_after_success else None,
    }


def search(
    spec: RunSpec, W0: tuple[float, ...], on_trial: OnTrial | None = None
) -> Steps[dict[str, Any]]:
    """What the arm of ``spec`` finds from W(0) = ``W0``: a learning run (``on_trial``
    gets each of its trials) or a baseline's search, its trials yielded."""
    template = spec.template.with_gains(W0, spec.template.theta_c)
    cfg = spec.config
    if spec.method == "learn":
        return (
            yield from learning_run_steps(
                spec.plant, template, cfg, spec.seed, spec.sim, on_trial=on_trial
            )
        )
    search = baselines.SEARCHES.get(spec.method)
    if search is not None:
        return (yield from search(spec.plant, template, spec.sim, spec.seed, cfg))
    raise ParameterError(f"unknown method {spec.method!r}; choose from {', '.join(METHODS)}")


def run_one(spec: RunSpec, w0: PassProbability | None = None) -> dict[str, Any]:
    """One run -> one row (RUN_COLUMNS), its trials on the scalar kernel, or on the
    spiking network of ``spec.network`` (:func:`striatal.neural.driver.network_drive`,
    network seed = the run's seed; the row also carries ``trial_rewards``, each learning
    trial's reward, for the sweep's trials.csv). Pure: the same spec gives the same row
    (except wall_seconds). :func:`run_steps` for other drivers; ``w0``: W(0)'s evaluation
    when another run of the same :func:`w0_key` has made it (:func:`evaluate_w0`)."""
    if spec.network is not None:
        from striatal.neural.driver import network_drive

        rewards: list[float] = []
        row = network_drive(
            run_steps(spec, on_trial=lambda _state, rec: rewards.append(rec.reward)),
            spec.network.config,
            spec.seed,
            spec.network.simulator,
        )
        return {**row, "trial_rewards": rewards}
    return drive(run_steps(spec, w0=None if w0 is None else lambda: w0))


#: What identifies W(0)'s evaluation of a run (:func:`w0_key`).
W0Key = tuple[Hashable, ...]
#: Where a run finds W(0)'s evaluation made by another run: None, not (yet) made.
W0Source = Callable[[], PassProbability | None]


def w0_key(spec: RunSpec) -> W0Key | None:
    """What W(0)'s evaluation of ``spec`` depends on: runs with the same key (a learner,
    its control and the baselines of one init and seed) evaluate the same W(0) with the
    same noise, so one evaluation serves them all. None: nothing to share (no evaluation
    draws, or the trials run on a spiking network)."""
    if spec.eval_draws <= 0 or spec.network is not None:
        return None
    return (spec.init, spec.seed, spec.template, spec.plant, spec.sim, spec.eval_draws)


def shared_w0(specs: Sequence[RunSpec]) -> dict[W0Key, list[int]]:
    """The indices of ``specs`` by :func:`w0_key`, for the keys that two or more share."""
    groups: dict[W0Key, list[int]] = {}
    for i, spec in enumerate(specs):
        key = w0_key(spec)
        if key is not None:
            groups.setdefault(key, []).append(i)
    return {k: g for k, g in groups.items() if len(g) > 1}


def w0_steps(spec: RunSpec, chunk: int = DRAWS_AT_ONCE) -> Steps[PassProbability]:
    """W(0)'s evaluation of ``spec``'s run: the pass probability of its starting gains
    (``spec.eval_draws`` draws, noise from ``default_rng(seed)``; the row's
    ``pass_rate_W0``), its draws requested ``chunk`` at a time (the same result)."""
    template = spec.template.with_gains(initial_gains(spec.init, spec.seed), spec.template.theta_c)
    return (
        yield from pass_probability_steps(
            spec.plant, template, spec.sim, PROTOCOL, spec.eval_draws, spec.seed, chunk=chunk
        )
    )


#: :func:`w0_steps` on the scalar kernel.
evaluate_w0 = driven(w0_steps)


def run_steps(
    spec: RunSpec, on_trial: OnTrial | None = None, w0: W0Source | None = None
) -> Steps[dict[str, Any]]:
    """:func:`run_one` as :data:`striatal.sim.batch.Steps`.

    After the search: one noise-free re-simulation of the final gains
    (``mean_policy_success``) and, with ``spec.eval_draws`` > 0, the pass probability
    (:func:`striatal.experiments.evaluate.pass_probability`, noise from ``default_rng(seed)``) of
    W(0) (:func:`w0_steps`) and of the final gains; their trials are ``eval_simulations``,
    apart from the arm's budget ``simulations``. ``w0``: asked for W(0)'s evaluation when
    the run needs it, made by another run of the same :func:`w0_key` (the same result:
    the same gains, trials and noise); the run makes its own when it answers None. The
    row counts that evaluation's trials either way.
    """
    t0 = time.perf_counter()
    W0 = initial_gains(spec.init, spec.seed)
    theta_c0 = spec.template.theta_c
    template = spec.template.with_gains(W0, theta_c0)
    cfg = spec.config
    out = yield from search(spec, W0, on_trial)
    final = template.with_gains(out["W"], out["theta_c"]) if out["W"][0] > 0 else None
    mean_ok = False
    if final is not None:
        (rerun,) = yield [
            TrialRequest(spec.plant, final, spec.sim, PROTOCOL, hardware=cfg.hardware)
        ]
        mean_ok = rerun.success
    evals = 1 if final is not None else 0
    robust = math.nan
    if cfg.robust and final is not None:
        report = check_robust(final, plant=spec.plant, max_force=cfg.max_force, track=cfg.track)
        robust, evals = float(report.robust), evals + report.simulations
    rate0 = rate = math.nan
    if spec.eval_draws > 0:
        before = None if w0 is None else w0()
        if before is None:
            before = yield from w0_steps(spec)
        rate0, evals = before.rate, evals + before.simulations
        if final is not None:
            after = yield from pass_probability_steps(
                spec.plant, final, spec.sim, PROTOCOL, spec.eval_draws, spec.seed
            )
            rate, evals = after.rate, evals + after.simulations
    row: dict[str, Any] = {
        "arm": spec.arm,
        "role": spec.role,
        "method": spec.method,
        "learner": cfg.learner if spec.method == "learn" else "-",
        "init": spec.init,
        "seed": spec.seed,
        "alpha": cfg.alpha,
        "gamma": cfg.gamma,
        "success": bool(out["success"]),
        "trials": int(out["trials"]),
    }
    row.update({f"W{i + 1}": float(w) for i, w in enumerate(out["W"])})
    row["theta_c"] = float(out["theta_c"])
    row.update({f"W0_{i + 1}": float(w) for i, w in enumerate(W0)})
    row["theta_c0"] = float(theta_c0)
    row["mean_policy_success"] = bool(mean_ok)
    row["robust"] = robust
    row["simulations"] = int(out["simulations"])
    row["simulated_seconds"] = float(out["simulated_seconds"])
    row["eval_simulations"] = evals
    row["pass_rate_W0"] = rate0
    row["pass_rate"] = rate
    row["wall_seconds"] = time.perf_counter() - t0
    imagined = out.get("imagined", (0, 0.0))  # baselines imagine nothing
    row["imagined_simulations"], row["imagined_seconds"] = int(imagined[0]), float(imagined[1])
    row.update(first_success_columns(row, out.get("first_success"), out.get("margin_reached")))
    return row
