"""A basal-ganglia learner that learns in imagination on a cerebellar forward model ("forward").

The division of labour of Doya (1999): the cerebellum learns an internal model of the
body by supervised learning, the basal ganglia learn by reinforcement. Here:

1. **real trial**: the current gains W and theta_c run once on the real plant, with the
   mean policy (eqs 22-23, no exploration noise), recorded. It is also the success test
   of that controller (``success_on`` "mean"); with ``robust`` the robustness set
   decides, every run counted by the loop.
2. **model fit** (the cerebellum, supervised): the transitions of the real trials so far
   (state, held motor force, next state) fit the forward model ``forward_model``:
   "structured", :func:`striatal.learners.forward.model.fit_structured` (the cart-pole's
   equations with cart mass, pole mass, length and cart friction unknown, started from
   the nominal :class:`~striatal.params.Plant`, gravity known), or "generic" (and
   "generic-gains", the same model),
   :func:`~striatal.learners.forward.model.fit_generic` (no cart-pole equations: an
   ensemble of polynomial ridge regressions, run as a
   :class:`~striatal.sim.learned.LearnedPlant`); "sparse-gains" is "generic-gains"
   with the sparse readout (a few monomials of the raw inputs per output,
   :data:`~striatal.learners.forward.model.SPARSE_TERMS`); "sparse-affine" is
   "sparse-gains" with the force's own monomial in each output's support and fewer
   terms on narrow data (:data:`FIT_OF`).
3. **imagined learning** (the basal ganglia, reinforcement): pgpe, the project's rule
   (:mod:`striatal.learners.pgpe`, its own code through :func:`striatal.learners.loop.learn`),
   learns from W on the model's :class:`World` for at most ``imagine_trials`` trials, with
   its tuned preset. Structured: on the fitted plant, with ``robust`` its robust preset
   (jittered plants) and the robustness set around the fitted plant; a candidate must
   also pass the set on each plant the fit cannot rule out (:meth:`StructuredFit.family`).
   Generic: on the ensemble's mean, with ``robust`` pgpe's plain preset (a learned plant
   has no pole mass to jitter); a candidate must also pass every start of the robustness
   set on each member (:func:`striatal.sim.robust.family_check`), and with
   "generic-gains", "sparse-gains" and "sparse-affine" on the mean with its angular
   acceleration times each of :data:`RESPONSE_GAINS`, each check spent from the budget.
   Else imagination goes on, unless the round found no solution within
   ``imagine_round`` trials (generic: :data:`GENERIC_ROUND` by default): then the next
   real trial's data refit the model first. The candidate, found or not, is the next real
   trial's controller. With ``imagine_margin`` M the plant corners imagination asks for are those at
   x(1 +- (0.2 + M)) (structured: the inner pgpe's jitter and each family plant's set;
   generic-gains and the sparse models: :func:`response_gains`), a margin beyond the real
   checks' +-20 %; the robust preset of these models sets M = 0.1 (:data:`MARGIN_ROBUST`).

Imagined trials run on the model only: they are counted apart (memory "imagined":
imagined simulations and simulated seconds; history column ``imagined``), never in
``simulations``. In imagination the controller's partial feedback linearisation (eq 12)
believes the fitted plant (generic: the plant the real trials' controller believes); on
the real plant it believes the nominal one, as every controller here. Friction is
fitted but not imagined (the kernel's plant has none): a plant with friction is outside
what the structured imagination can represent.

The no-learning control (``imagine_trials`` 0) runs the same real-trial schedule with no
model and no update: W(0) is tried again each trial.
"""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.common import initial_state
from striatal.learners.config import ForwardModel, LearnerConfig, pick
from striatal.learners.forward.model import (
    GenericModel,
    StructuredFit,
    Transitions,
    fit_generic,
    fit_structured,
)
from striatal.learners.loop import default_config, learn_steps
from striatal.learners.rule import Judging, Rule, Trial, TrialContext, TrialPlan, Update
from striatal.learners.state import LearnerState
from striatal.params import N_GAINS, Controller, Plant, Simulation
from striatal.sim.batch import Steps, driven
from striatal.sim.learned import LearnedPlant
from striatal.sim.robust import ROBUST_BOX, family_check_steps
from striatal.sim.rollout import Protocol

__all__ = [
    "FIT_OF",
    "FORWARD",
    "GAINED_MODELS",
    "GENERIC_DURATION",
    "GENERIC_ROUND",
    "MARGIN_MODELS",
    "MARGIN_ROBUST",
    "MAX_TRANSITIONS",
    "RESPONSE_GAINS",
    "ForwardConfig",
    "ForwardRule",
    "World",
    "generic_world",
    "imagine",
    "imagine_steps",
    "response_gains",
    "structured_world",
]

#: Transitions kept from the real runs of each plant (the most recent); each run adds
#: at most :data:`PER_TRIAL` of them, evenly spaced.
MAX_TRANSITIONS = 1200
PER_TRIAL = 400
#: Columns of one kept transition: state (4), held force, next state (4), the true
#: plant's pole mass and length factors (2).
_WIDTH = 11

#: The rule that learns in imagination.
INNER = "pgpe"
#: The gains on the generic model's angular acceleration that ``generic-gains`` also
#: checks a candidate on: the robustness set's pole lengths x1.2 and x0.8 read as a pole
#: that turns 1/1.2 and 1/0.8 as fast (the one piece of prior knowledge it adds: a
#: longer pole turns slower; its pole masses are left to the real checks).
RESPONSE_GAINS = (1.0 / 1.2, 1.0 / 0.8)
#: The generic worlds' own cap on a round of imagination that finds no solution
#: (``imagine_round`` none): chosen on root 0 (docs/results.md, "The generic forward
#: model, round 4"); the structured world has none (its rounds end in a few hundred
#: trials).
GENERIC_ROUND = 500
#: The robust preset of the models that take a margin (:data:`MARGIN_MODELS`):
#: imagination asks for the plant corners at x(1 +- 0.3) (``imagine_margin`` 0.1, chosen
#: on root 0; docs/results.md, "A margin beyond the box" and "The generic forward model,
#: round 5"), so that their controllers hold beyond the robustness set's box; an
#: explicit ``imagine_margin`` (0 included) overrides it.
MARGIN_ROBUST = MappingProxyType({"imagine_margin": 0.1})
#: The forward models whose imagination can ask for wider corners than the checks'.
MARGIN_MODELS: tuple[str, ...] = ("structured", "generic-gains", "sparse-gains", "sparse-affine")
#: The generic models checked on their mean with the :data:`RESPONSE_GAINS`.
GAINED_MODELS: tuple[str, ...] = ("generic-gains", "sparse-gains", "sparse-affine")
#: The generic models' fits beyond the ridge readout
#: (:func:`~striatal.learners.forward.model.fit_generic`'s options): "sparse-affine" is
#: "sparse-gains" with the force's own monomial in each output's support (a
#: control-affine prior: the motor command acts on the accelerations) and 2 terms an
#: output on narrow data (chosen on root 0: docs/results.md, "The generic forward model,
#: round 7").
FIT_OF: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {
        "sparse-gains": MappingProxyType({"readout": "sparse"}),
        "sparse-affine": MappingProxyType(
            {"readout": "sparse", "force_term": "linear", "narrow_terms": 2}
        ),
    }
)
#: The generic worlds' own imagined-trial duration [s] (``imagine_duration`` none;
#: None: the real trial's), chosen with :data:`GENERIC_ROUND`.
GENERIC_DURATION: float | None = None


def response_gains(box: float = ROBUST_BOX) -> tuple[float, float]:
    """:data:`RESPONSE_GAINS` for plant corners at pole length x(1 +- ``box``):
    1/(1 + box) and 1/(1 - box)."""
    return (1.0 / (1.0 + box), 1.0 / (1.0 - box))


@dataclass(frozen=True)
class ForwardConfig:
    """The forward rule's options (see :class:`LearnerConfig` for each)."""

    imagine_trials: int
    imagine_round: int | None
    imagine_duration: float | None
    forward_model: ForwardModel
    imagine_margin: float


@dataclass(frozen=True)
class Imagined:
    """What one round of imagination gave: the candidate ``W`` (6,) and ``theta_c``,
    whether it passed in imagination (``solved``), and the imagined ``simulations`` and
    ``simulated_seconds`` it cost."""

    W: tuple[float, ...]
    theta_c: float
    solved: bool
    simulations: int
    simulated_seconds: float


def transitions_of(
    rows: np.ndarray, factors: tuple[float, float] = (1.0, 1.0), per_trial: int = PER_TRIAL
) -> np.ndarray:
    """At most ``per_trial`` evenly spaced transitions (n, 11) of one recorded run on
    the plant with pole mass and length ``factors`` (rows: kernel.TRAJ_COLUMNS; row k's
    force acts from row k to row k+1)."""
    n = len(rows) - 1
    if n < 1:
        return np.empty((0, _WIDTH))
    k = np.unique(np.linspace(0, n - 1, min(n, per_trial)).astype(int))
    states = rows[:, 1:5]
    return np.column_stack([states[k], rows[k, 6], states[k + 1], np.tile(factors, (len(k), 1))])


def kept_data(state: LearnerState) -> np.ndarray:
    """The transitions (n, 11) in the state's memory "data"."""
    flat = np.array(state.get("data"), dtype=float)
    return flat.reshape(-1, _WIDTH)


def keep_recent(data: np.ndarray, limit: int = MAX_TRANSITIONS) -> np.ndarray:
    """The most recent ``limit`` transitions of each plant (factor pair) in ``data``,
    in their order: a plant seen once is not forgotten as others are run."""
    if len(data) == 0:
        return data
    _, plant = np.unique(data[:, 9:], axis=0, return_inverse=True)
    plant = plant.ravel()
    keep = np.zeros(len(data), dtype=bool)
    for p in np.unique(plant):
        keep[np.flatnonzero(plant == p)[-limit:]] = True
    return data[keep]


def believed_plant(nominal: Plant) -> Plant:
    """The plain plant the real trials' controller believes (:attr:`TrialContext.plant`,
    the nominal one): its four parameters only, so imagination's controller never holds
    the object the loop was given (no learned dynamics, nothing beyond what eq 12 uses)."""
    return Plant(
        cart_mass=nominal.cart_mass,
        pole_mass=nominal.pole_mass,
        length=nominal.length,
        gravity=nominal.gravity,
    )


@dataclass(frozen=True)
class World:
    """What imagination runs on: the ``plant`` the inner learner learns on, whether it
    may learn there with its robust preset (``jitter``: pgpe's jittered plants need a
    plant with a pole mass to scale), and the ``family`` of plants a candidate must also
    pass the robustness set on (``family_model``: what the controller believes there;
    None: each plant itself)."""

    plant: Plant
    family: tuple[Plant, ...]
    jitter: bool
    family_model: Plant | None
    #: Whether a candidate a family plant refuses is learned on that plant next (its
    #: checks spent from the budget, as with ``charge_checks``).
    rehearse: bool = False
    #: Whether the family checks' runs are spent from the imagined budget too, so that
    #: ``imagine_trials`` bounds every imagined simulation after a real trial (give or
    #: take one check), not only the inner learner's trials.
    charge_checks: bool = False
    #: The world's own ``imagine_round`` and ``imagine_duration`` (used when the options
    #: are none; None: no cap, the real trial's duration).
    round_trials: int | None = None
    duration: float | None = None


def structured_world(fit: StructuredFit) -> World:
    """The fitted cart-pole: learn on it (robust preset and all), check on the four plants
    the fit cannot rule out (:meth:`StructuredFit.family`), each believed exactly."""
    return World(fit.plant, fit.family(), jitter=True, family_model=None)


def generic_world(model: GenericModel, believed: Plant, gains: tuple[float, ...] = ()) -> World:
    """The generic ensemble, the controller believing ``believed`` throughout: learn on
    its mean (one evaluation a step), check on each member (the ensemble's doubt) and on
    its mean with the angular acceleration times each of ``gains``
    (:meth:`~striatal.sim.learned.LearnedDynamics.gained`; not for a conditioned model),
    every check spent from the imagined budget (``charge_checks``), a round without a
    solution capped at :data:`GENERIC_ROUND` trials and the imagined trials lasting
    :data:`GENERIC_DURATION` unless the options say otherwise.
    A model conditioned on the plant factors is also checked on its mean at each plant
    the data hold (the corners the real checks ran), and a candidate a family plant
    refuses is learned on that plant next (``rehearse``)."""
    if model.conditioned:
        cd = model.conditioned_dynamics()
        mean = LearnedPlant.conditioned_on(cd.mean(), believed)
        members = tuple(
            LearnedPlant.conditioned_on(cd.member(k), believed) for k in range(cd.members)
        )
        corners = tuple(
            mean.scaled(pole_mass=a, length=b) for a, b in model.plants if (a, b) != (1.0, 1.0)
        )
        return World(
            mean,
            members + corners,
            False,
            believed,
            rehearse=True,
            charge_checks=True,
            round_trials=GENERIC_ROUND,
            duration=GENERIC_DURATION,
        )
    dynamics = model.dynamics()
    members = tuple(LearnedPlant.of(dynamics.member(k), believed) for k in range(dynamics.members))
    average = dynamics.mean()
    gained = tuple(LearnedPlant.of(average.gained(g), believed) for g in gains)
    return World(
        LearnedPlant.of(average, believed),
        members + gained,
        False,
        believed,
        charge_checks=True,
        round_trials=GENERIC_ROUND,
        duration=GENERIC_DURATION,
    )


def imagine_steps(
    world: World,
    controller: Controller,
    config: LearnerConfig,
    sim: Simulation,
    protocol: Protocol,
    seed: int,
) -> Steps[Imagined]:
    """Learn with :data:`INNER` on ``world.plant`` from ``controller`` (gains, theta_c)
    for at most ``config.imagine_trials`` imagined trials (eqs 22-25 with the inner
    rule's preset; with ``config.robust`` its stop rule, and its robust preset where
    ``world.jitter``). A solution must also be robust on each plant of
    ``world.family`` (with ``robust``), else the inner learner goes on from it with a
    new seed; with ``world.rehearse`` on the family plant that refused it; with
    ``world.charge_checks`` (or ``rehearse``) the checks' runs are spent from the budget
    too. A round (one seed) that finds no solution within ``config.imagine_round``
    trials (None: ``world.round_trials``; None again: the budget left) ends the
    imagination: its candidate is the next real trial's, whose data refit the model.
    The inner learner's trials last ``config.imagine_duration`` (None:
    ``world.duration``; None again, or longer: ``sim``'s); the family checks keep the
    robustness set's. Every imagined trial is yielded
    (:data:`striatal.sim.batch.Steps`), so the engine that runs the real trials runs
    them too; :func:`imagine` runs them here."""
    box = ROBUST_BOX + config.imagine_margin
    jitter = {"plant_jitter": box} if config.robust and world.jitter else {}
    inner = default_config(
        INNER,
        robust=config.robust and world.jitter,
        max_force=config.max_force,
        track=config.track,
        action_every=config.action_every,
        **jitter,
    )
    duration = config.imagine_duration or world.duration
    if duration is not None:
        sim = replace(sim, duration=min(duration, sim.duration))
    simulations, seconds, budget = 0, 0.0, config.imagine_trials
    per_round = config.imagine_round or world.round_trials or budget
    charged = world.rehearse or world.charge_checks
    template, round_seed, plant = controller, seed, world.plant
    solved = False
    while budget > 0 and not solved:
        result = yield from learn_steps(
            plant,
            template,
            replace(inner, max_trials=min(budget, per_round)),
            initial_state(template.gains, template.theta_c, round_seed),
            sim,
            protocol,
        )
        budget -= result.trials_done
        simulations += result.simulations
        seconds += result.simulated_seconds
        template = replace(template, gains=tuple(result.W), theta_c=result.theta_c)
        solved = result.success
        if solved and config.robust:
            for member in world.family:
                verdict = yield from family_check_steps(
                    template,
                    (member,),
                    sim.dt,
                    model=world.family_model,
                    hardware=config.hardware,
                    box=box,
                )
                simulations += verdict.simulations
                seconds += verdict.simulated_seconds
                if charged:
                    budget -= verdict.simulations
                if not verdict.robust:
                    solved = False
                    if world.rehearse:
                        plant = member
                    break
        elif not solved:
            break
        round_seed += 1
    return Imagined(
        W=tuple(float(w) for w in template.gains),
        theta_c=float(template.theta_c),
        solved=solved,
        simulations=simulations,
        simulated_seconds=seconds,
    )


#: :func:`imagine_steps` run to its end on the scalar kernel.
imagine = driven(imagine_steps)


class ForwardRule(Rule):
    """Real trial, model fit, imagined learning with pgpe, and again (module docstring).

    The preset has no tuned number of its own (the inner learner's presets are pgpe's,
    its imagined budget 2000 trials set before any sweep ran): ``tuning_root`` None.
    With ``robust`` the inner learner is pgpe's robust preset, the generic worlds' round
    cap (:data:`GENERIC_ROUND`) and the models' margin (:data:`MARGIN_ROBUST`)
    were chosen on root 0: ``robust_tuning_root`` 0.
    """

    name = "forward"
    summary = (
        "a cerebellar forward model fitted to the real trials; pgpe learns on it in "
        "imagination, real trials only gather data and verify"
    )
    config_type = ForwardConfig
    preset = MappingProxyType({"success_on": "mean"})
    control = MappingProxyType({"imagine_trials": 0})
    control_text = (
        "no model is fitted and nothing is learned: the same real-trial schedule, each "
        "trial the noise-free W(0) with its checks"
    )
    robust_tuning_root = 0
    history_columns = ("imagined", "model_pole_mass", "model_length", "solved_in_imagination")
    memory_names = ("data", "imagined")
    judging = Judging("candidate", mean_policy_only="runs its real trials with the mean policy")

    def robust_preset_of(self, changes: Mapping[str, Any]) -> Mapping[str, Any]:
        """:data:`MARGIN_ROBUST` for the models of :data:`MARGIN_MODELS` (the structured
        model when ``changes`` name none), else none."""
        model = changes.get("forward_model", LearnerConfig().forward_model)
        if model in MARGIN_MODELS:
            return MARGIN_ROBUST
        return self.robust_preset

    def check(self, config: LearnerConfig) -> None:
        """Also: the generic model needs scikit-learn (refused before the first trial)."""
        super().check(config)
        if config.imagine_margin > 0.0 and not (
            config.robust and config.forward_model in MARGIN_MODELS
        ):
            raise ParameterError(
                "imagine_margin widens the plant corners imagination checks: it needs --robust "
                "and --forward-model structured, generic-gains, sparse-gains or sparse-affine"
            )
        if config.forward_model != "structured" and importlib.util.find_spec("sklearn") is None:
            raise ParameterError(
                f"--forward-model {config.forward_model} needs scikit-learn: "
                "pip install 'striatal[model]'"
            )

    def plan(
        self,
        state: LearnerState,
        config: LearnerConfig,
        rng: np.random.Generator,
        context: TrialContext,
    ) -> TrialPlan:
        """The real trial: the state's W and theta_c, mean policy, recorded (its
        transitions feed the model); the seed of this trial's imagination drawn."""
        return TrialPlan(
            W=np.array(state.W, dtype=float),
            theta_c=state.theta_c,
            trace=np.zeros(N_GAINS),
            gamma=0.0,
            rng=None,
            record=True,
            # the conditioned model learns from the real checks too (their plant factors
            # are known); the other models fit one plant, the control fits nothing
            record_checks=config.forward_model == "conditioned" and config.imagine_trials > 0,
            scratch={"seed": np.array([rng.integers(2**31 - 1)], dtype=np.int64)},
        )

    def update_steps(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Steps[Update]:
        """Keep the real trial's transitions; unless it succeeded, fit the model and learn
        in imagination from its W (:func:`imagine_steps`, every imagined trial yielded);
        the candidate found is the next real trial's controller."""
        plan, success = trial.plan, trial.success
        c = pick(ForwardConfig, config)
        rows = trial.outcome.rows
        new = [transitions_of(rows) if rows is not None else np.empty((0, _WIDTH))]
        new += [transitions_of(run, factors) for factors, run in trial.checks]
        data = keep_recent(np.concatenate([kept_data(state), *new]))
        done = state.get("imagined") or (0.0, 0.0)
        W, theta_c = tuple(float(w) for w in plan.W), plan.theta_c
        report: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        if not success and c.imagine_trials > 0 and len(data) > 0:
            sim = context.sim
            template = replace(context.template, gains=W, theta_c=theta_c)
            seed = int(plan.scratch["seed"][0])
            if c.forward_model != "structured":
                transitions = Transitions(
                    data[:, :4], data[:, 4], data[:, 5:9], sim.dt, data[:, 9:]
                )
                model = fit_generic(
                    transitions,
                    np.random.default_rng(seed),
                    conditioned=c.forward_model == "conditioned",
                    **FIT_OF.get(c.forward_model, {}),
                )
                box = ROBUST_BOX + c.imagine_margin
                gains = response_gains(box) if c.forward_model in GAINED_MODELS else ()
                world = generic_world(model, believed_plant(context.plant), gains)
                fitted = (math.nan, math.nan)
            else:
                nominal = (data[:, 9:] == 1.0).all(axis=1)
                transitions = Transitions(
                    data[nominal, :4], data[nominal, 4], data[nominal, 5:9], sim.dt
                )
                fit = fit_structured(transitions)
                world = structured_world(fit)
                fitted = (fit.plant.pole_mass, fit.plant.length)
            dream = yield from imagine_steps(world, template, config, sim, context.protocol, seed)
            W, theta_c = dream.W, dream.theta_c
            done = (done[0] + dream.simulations, done[1] + dream.simulated_seconds)
            report = (float(dream.simulations), *fitted, float(dream.solved))
        return Update(
            W=W,
            theta_c=float(theta_c),
            memory=(
                ("data", tuple(float(v) for v in data.ravel())),
                ("imagined", (float(done[0]), float(done[1]))),
            ),
            # the imagined simulations after this trial, the fitted pole mass [kg] and
            # length [m] they ran on, and whether imagination found a solution (0: none ran)
            extra=tuple(zip(self.history_columns, report, strict=True)),
        )

    def imagined(self, state: LearnerState) -> tuple[int, float]:
        """The imagined trials so far and their simulated seconds (memory "imagined")."""
        done = state.get("imagined") or (0.0, 0.0)
        return int(done[0]), float(done[1])


FORWARD = ForwardRule()
