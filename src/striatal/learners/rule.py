"""What a learning rule supplies to the one trial loop (:mod:`striatal.learners.loop`).

A rule is an object with a name, the :class:`LearnerConfig` fields it reads
(``options``: its small frozen config), its tuned preset, its no-learning
control, its own history columns and memory, and two functions: :meth:`Rule.plan`
(the trial's gains, threshold, noise and trace, drawn before the trial) and
:meth:`Rule.update` (the new W, theta_c and memory after it). The loop does the
rest: restore the generator, run the trial, score it, test success, record the
row and build the next :class:`LearnerState`. docs/architecture.md has the recipe
for adding a rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from striatal.errors import ParameterError
from striatal.learners.config import LearnerConfig
from striatal.learners.state import LearnerState, Memory
from striatal.params import Plant
from striatal.sim.robust import CheckRecorder
from striatal.sim.rollout import TrialOutcome

__all__ = ["LOOP_OPTIONS", "Rule", "Trial", "TrialPlan", "Update"]

#: LearnerConfig fields the loop itself reads, whatever the rule.
LOOP_OPTIONS = (
    "learner",
    "max_trials",
    "success_on",
    "action_every",
    "robust",
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
    in (None: the nominal plant); ``scratch``: the rule's own numbers for its update.
    """

    W: np.ndarray
    theta_c: float
    trace: np.ndarray
    gamma: float
    rng: np.random.Generator | None
    eligibility: str = "score"
    plant: Plant | None = None
    scratch: Mapping[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class Trial:
    """A trial as the loop hands it to :meth:`Rule.update`: the plan it ran, its outcome,
    its reward (eqs 24-25, or the shaped reward) and the success test's verdict."""

    plan: TrialPlan
    outcome: TrialOutcome
    reward: float
    success: bool


@dataclass(frozen=True)
class Update:
    """The rule's answer after a trial: the next W, theta_c and memory."""

    W: tuple[float, ...]
    theta_c: float
    memory: Memory


class Rule:
    """Base of the learning rules; subclasses set the class attributes and two methods."""

    #: Name in the registry and in ``LearnerConfig.learner``.
    name: ClassVar[str]
    #: One line for ``--help`` and the docs.
    summary: ClassVar[str]
    #: The rule's own frozen config (a dataclass whose fields are LearnerConfig fields).
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
    #: Whether theta_c_rule "learned" (theta_c perturbed and updated with the gains) applies.
    learns_theta_c: ClassVar[bool] = False
    #: Whether the success test (success_on "mean") judges the controller the trial ran
    #: (the plan's W and theta_c: pgpe's candidate p') rather than the state's mean W.
    #: Then, on success, :meth:`update` must return the plan's W and theta_c.
    judges_candidate: ClassVar[bool] = False
    #: Why the rule's success test can only be judged on the mean policy (its trials act
    #: with it); empty: the rule also takes success_on "noisy".
    mean_policy_only: ClassVar[str] = ""
    #: Whether the rule's dopamine-like signal is the raw reward of eqs 24-25 (the
    #: chapter's), so that splitting its updates by the reward's sign reads bursts and dips.
    raw_reward_signal: ClassVar[bool] = False
    #: Whether the rule runs its trial itself (:meth:`run`): a rule that changes W within
    #: the trial (ac). Otherwise the loop runs the plan with :mod:`striatal.sim.rollout`.
    runs_trial: ClassVar[bool] = False

    @property
    def options(self) -> tuple[str, ...]:
        """Every LearnerConfig field this rule (with the loop) reads."""
        return (*LOOP_OPTIONS, *(f.name for f in fields(self.config_type)))

    def check(self, config: LearnerConfig) -> None:
        """ParameterError if ``config`` sets a field this rule does not read, or a bad mix."""
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
        if self.mean_policy_only and config.success_on != "mean":
            raise ParameterError(
                f"learner {self.name!r} {self.mean_policy_only}: its success test is judged "
                "on the mean policy (success_on 'mean')"
            )
        if config.theta_c_rule == "learned" and not self.learns_theta_c:
            raise ParameterError(
                "theta_c_rule 'learned' (theta_c perturbed and updated with the gains) "
                f"needs a learner that learns it (pgpe), not {self.name!r}"
            )

    def tuning_root_of(self, config: LearnerConfig) -> int | None:
        """The root :func:`striatal.learners.default_config` took ``config``'s preset from
        (:attr:`robust_tuning_root` with ``config.robust``, else :attr:`tuning_root`)."""
        return self.robust_tuning_root if config.robust else self.tuning_root

    def control_config(self, config: LearnerConfig) -> LearnerConfig:
        """``config`` with learning switched off as :attr:`control` says."""
        return replace(config, **self.control)

    def plan(
        self, state: LearnerState, config: LearnerConfig, rng: np.random.Generator, plant: Plant
    ) -> TrialPlan:
        raise NotImplementedError

    def check_recorder(self, plan: TrialPlan) -> CheckRecorder | None:
        """Where the robustness set's runs of ``plan``'s candidate go, recorded with their
        plant factors (a rule that learns from its checks, which the loop counts as
        always); None (the default): not recorded."""
        return None

    def run(self, config: LearnerConfig, plan: TrialPlan, trial: Mapping[str, Any]) -> TrialOutcome:
        """Run ``plan``'s trial (rules with :attr:`runs_trial` only); ``trial``: the loop's
        keyword arguments of :func:`striatal.sim.rollout.run_trial` (plant, controller, sim,
        protocol, gains, rng, trace, gamma, action_every, chapter_eligibility, model). The
        trial's sparse reward (eqs 24-25) is the outcome's."""
        raise NotImplementedError

    def update(self, state: LearnerState, config: LearnerConfig, trial: Trial) -> Update:
        """The next W, theta_c and memory; with ``success`` W and theta_c must stay
        (or, with :attr:`judges_candidate`, become the plan's: the controller judged)."""
        raise NotImplementedError

    def imagined(self, state: LearnerState) -> tuple[int, float]:
        """The trials run so far on a model rather than the plant, and their simulated
        seconds: counted apart from ``LearnerState.simulations`` (none for most rules)."""
        return 0, 0.0

    def extra(self, state: LearnerState, plan: TrialPlan) -> tuple[tuple[str, float], ...]:
        """Values of :attr:`history_columns` for the trial run from ``state``."""
        return ()
