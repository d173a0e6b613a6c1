"""What a learning rule supplies to the one trial loop (:mod:`striatal.learners.loop`).

A rule is an object with a name, the :class:`LearnerConfig` fields it reads
(``options``: its small frozen config), its tuned preset, its no-learning
control, its own history columns and memory, how its success test judges it
(:class:`Judging`), and two functions: :meth:`Rule.plan` (the trial's gains,
threshold, noise and trace, drawn before the trial) and :meth:`Rule.update` (the
new W, theta_c, memory and history columns after it). Both get the run's
:class:`TrialContext` (the plant believed, the simulation, the protocol, the
hardware). A rule that needs simulations of its own yields them as
:class:`~striatal.sim.rollout.TrialRequest` (:meth:`Rule.run`, :meth:`Rule.update_steps`,
``yield from``), so that every engine runs, and batches, them. The loop does the rest:
restore the generator, run the trial, score it, test success, record the row and
build the next :class:`LearnerState`. docs/architecture.md has the recipe for adding
a rule.
"""

from __future__ import annotations

import typing
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any, ClassVar, Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.config import LearnerConfig
from striatal.learners.state import LearnerState, Memory
from striatal.params import Controller, Hardware, Plant, Simulation
from striatal.sim.batch import Steps
from striatal.sim.rollout import OnlineLearning, Protocol, TrialOutcome, TrialRequest

__all__ = [
    "LOOP_OPTIONS",
    "Judging",
    "Rule",
    "Trial",
    "TrialContext",
    "TrialPlan",
    "Update",
]

#: LearnerConfig fields the loop itself reads, whatever the rule.
LOOP_OPTIONS = (
    "learner",
    "max_trials",
    "success_on",
    "action_every",
    "robust",
    "stop_margin",
    "margin_after_success",
    "max_force",
    "track",
)


@dataclass(frozen=True)
class TrialPlan:
    """How one trial is run (drawn by the rule before the trial).

    ``W``, ``theta_c``: what the controller acts with; ``trace`` (6,) the
    eligibility trace D the kernel updates in place (eq 3) with discount ``gamma``;
    ``rng``: the policy noise of eq 5 (None: the mean policy); ``plant``: the true
    plant of this trial when it differs from the nominal one the controller believes
    in (None: the nominal plant); ``record``: the outcome carries the trial's rows (a
    rule that learns from the trajectory), ``record_checks``: so do the robustness
    set's runs of the judged controller (:attr:`Trial.checks`); ``online``: the gains
    learn within the trial (ac); ``scratch``: the rule's own numbers for its update.
    """

    W: np.ndarray
    theta_c: float
    trace: np.ndarray
    gamma: float
    rng: np.random.Generator | None
    eligibility: str = "score"
    plant: Plant | None = None
    record: bool = False
    online: OnlineLearning | None = None
    scratch: Mapping[str, np.ndarray] = field(default_factory=dict)
    record_checks: bool = False


@dataclass(frozen=True)
class TrialContext:
    """What a run's trials share, handed to the rule's :meth:`Rule.plan`, :meth:`Rule.run`
    and :meth:`Rule.update`: the nominal ``plant`` the controller believes in, the
    controller ``template`` (its readings: balance sign, switch, inhibition), the
    simulation, the protocol (eqs 24-25), the ``hardware`` of every trial and the
    action rate (``action_every`` steps an action is held)."""

    plant: Plant
    template: Controller
    sim: Simulation
    protocol: Protocol
    hardware: Hardware
    action_every: int = 1

    def request(self, plan: TrialPlan) -> TrialRequest:
        """The trial ``plan`` asks for: on its plant (the controller believing the nominal
        one), with its gains, threshold, noise, trace and recording."""
        return TrialRequest(
            self.plant if plan.plant is None else plan.plant,
            self.template,
            self.sim,
            self.protocol,
            rng=plan.rng,
            trace=plan.trace,
            gamma=plan.gamma,
            gains=plan.W,
            action_every=self.action_every,
            chapter_eligibility=plan.eligibility == "chapter",
            model=None if plan.plant is None else self.plant,
            hardware=self.hardware,
            record=plan.record,
            online=plan.online,
            theta_c=plan.theta_c,
        )


@dataclass(frozen=True)
class Trial:
    """A trial as the loop hands it to :meth:`Rule.update`: the plan it ran, its outcome,
    its reward (eqs 24-25, or the shaped reward) and the success test's verdict; with
    the plan's ``record_checks``, ``checks``: the robustness set's runs (each run's true
    plant's pole mass and length factors, and its rows), counted by the loop as always."""

    plan: TrialPlan
    outcome: TrialOutcome
    reward: float
    success: bool
    checks: tuple[tuple[tuple[float, float], np.ndarray], ...] = ()


@dataclass(frozen=True)
class Update:
    """The rule's answer after a trial: the next W, theta_c and memory, and the values of
    its history columns for this trial (``extra``: (name, value) in the order of
    :attr:`Rule.history_columns`)."""

    W: tuple[float, ...]
    theta_c: float
    memory: Memory
    extra: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class Judging:
    """How a rule's success test judges it (:func:`striatal.learners.loop.success_checks`).

    ``controller``: "state" judges the state's mean W and theta_c; "candidate" the
    controller the trial ran (the plan's W and theta_c: pgpe's perturbed p', forward's
    real trial), whose trial must then be noise-free, and on success :meth:`Rule.update`
    must return it. ``mean_policy_only``: why the test can only be judged on the mean
    policy (the rule's trials act with it); empty: success_on "noisy" is taken too.
    """

    controller: Literal["state", "candidate"] = "state"
    mean_policy_only: str = ""

    @property
    def candidate(self) -> bool:
        return self.controller == "candidate"


class Rule:
    """Base of the learning rules; subclasses set the class attributes and two methods."""

    #: Name in the registry and in ``LearnerConfig.learner``.
    name: ClassVar[str]
    #: One line for ``--help`` and the docs.
    summary: ClassVar[str]
    #: The rule's own frozen config (a dataclass whose fields are LearnerConfig fields;
    #: a field typed with a narrower Literal than LearnerConfig's says which values the
    #: rule takes: e.g. only pgpe's theta_c_rule takes "learned").
    config_type: ClassVar[type]
    #: The tuned preset: LearnerConfig fields changed from their defaults (docs/ablation.md).
    preset: ClassVar[Mapping[str, Any]] = MappingProxyType({})
    #: The changes the robust stop rule adds to :attr:`preset` (``robust=True``), before
    #: the options given (docs/results.md, "Robust from any start").
    robust_preset: ClassVar[Mapping[str, Any]] = MappingProxyType({})
    #: The sweep root seed (``striatal sweep --seed``) whose seeds :attr:`preset` was tuned
    #: on; None: tuned on seeds no sweep root spawns (docs/results.md, "Protocol").
    tuning_root: ClassVar[int | None] = None
    #: The same for :attr:`robust_preset`.
    robust_tuning_root: ClassVar[int | None] = None
    #: The no-learning control: the fields changed to switch learning off (the sweep's
    #: control arm), everything else (exploration, eq 21) kept.
    control: ClassVar[Mapping[str, Any]] = MappingProxyType({"alpha": 0.0})
    #: What the control still learns, if anything (said in the sweep's control note).
    control_also: ClassVar[str] = ""
    #: What the control arm does, when the sweep's note cannot say it from :attr:`control`
    #: alone (empty: the note says it).
    control_text: ClassVar[str] = ""
    #: The rule's own history.csv columns (between theta_c and the trial's flags).
    history_columns: ClassVar[tuple[str, ...]] = ()
    #: The entries the rule keeps in ``LearnerState.memory``.
    memory_names: ClassVar[tuple[str, ...]] = ()
    #: How the success test judges the rule.
    judging: ClassVar[Judging] = Judging()
    #: Whether the rule's dopamine-like signal is the raw reward of eqs 24-25 (the
    #: chapter's), so that splitting its updates by the reward's sign reads bursts and dips
    #: (``striatal interpret``).
    raw_reward_signal: ClassVar[bool] = False

    @property
    def options(self) -> tuple[str, ...]:
        """Every LearnerConfig field this rule (with the loop) reads."""
        return (*LOOP_OPTIONS, *(f.name for f in fields(self.config_type)))

    def check(self, config: LearnerConfig) -> None:
        """ParameterError if ``config`` sets a field this rule does not read, a value its
        config's type does not take, or a bad mix."""
        default = LearnerConfig()
        unused = [
            f.name
            for f in fields(LearnerConfig)
            if f.name not in self.options and getattr(config, f.name) != getattr(default, f.name)
        ]
        if unused:
            raise ParameterError(
                f"learner {self.name!r} does not use {', '.join(unused)} "
                f"(it reads: {', '.join(o for o in self.options if o != 'learner')})"
            )
        for name, kind in typing.get_type_hints(self.config_type).items():
            taken = typing.get_args(kind) if typing.get_origin(kind) is Literal else None
            value = getattr(config, name)
            if taken is not None and value not in taken:
                raise ParameterError(
                    f"learner {self.name!r} does not take {name} {value!r} "
                    f"(it takes: {', '.join(map(str, taken))})"
                )
        if config.stop_margin > 0.0 and not config.robust:
            raise ParameterError(
                "stop_margin widens the robust stop rule: it needs --robust "
                f"(got stop_margin {config.stop_margin!r} without it)"
            )
        if config.margin_after_success and config.stop_margin == 0.0:
            raise ParameterError(
                "margin_after_success keeps learning until the stop margin is reached: it "
                "needs --robust --stop-margin M > 0"
            )
        if self.judging.mean_policy_only and config.success_on != "mean":
            raise ParameterError(
                f"learner {self.name!r} {self.judging.mean_policy_only}: its success test is "
                "judged on the mean policy (success_on 'mean')"
            )

    def robust_preset_of(self, changes: Mapping[str, Any]) -> Mapping[str, Any]:
        """The changes ``robust=True`` adds for a run asked with the options ``changes``:
        :attr:`robust_preset`, unless the rule's robust preset depends on another option
        (forward's on its model)."""
        return self.robust_preset

    def tuning_root_of(self, config: LearnerConfig) -> int | None:
        """The root :func:`striatal.learners.default_config` took ``config``'s preset from
        (:attr:`robust_tuning_root` with ``config.robust``, else :attr:`tuning_root`)."""
        return self.robust_tuning_root if config.robust else self.tuning_root

    def control_config(self, config: LearnerConfig) -> LearnerConfig:
        """``config`` with learning switched off as :attr:`control` says."""
        return replace(config, **self.control)

    def plan(
        self,
        state: LearnerState,
        config: LearnerConfig,
        rng: np.random.Generator,
        context: TrialContext,
    ) -> TrialPlan:
        """The trial to run from ``state``, drawing from ``rng``."""
        raise NotImplementedError

    def run(
        self, config: LearnerConfig, plan: TrialPlan, context: TrialContext
    ) -> Steps[TrialOutcome]:
        """The trial of ``plan``, yielded as one request (:meth:`TrialContext.request`); its
        outcome. A rule whose trial differs (ac: u held whatever the run's motor)
        overrides it, and yields what it runs."""
        (outcome,) = yield [context.request(plan)]
        return outcome

    def update(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Update:
        """The next W, theta_c and memory and the trial's history columns; with
        ``success`` W and theta_c must stay (or, judging its candidate, become the
        plan's: the controller judged)."""
        raise NotImplementedError

    def update_steps(
        self, state: LearnerState, config: LearnerConfig, trial: Trial, context: TrialContext
    ) -> Steps[Update]:
        """:meth:`update` as :data:`striatal.sim.batch.Steps`: a rule that needs simulations
        to update (forward's imagined learning) overrides this and yields them
        (``yield from``); the default runs none."""
        return self.update(state, config, trial, context)
        yield  # a generator: the loop runs every rule's update with ``yield from``

    def imagined(self, state: LearnerState) -> tuple[int, float]:
        """The trials run so far on a model rather than the plant, and their simulated
        seconds: counted apart from ``LearnerState.simulations`` (none for most rules)."""
        return 0, 0.0
