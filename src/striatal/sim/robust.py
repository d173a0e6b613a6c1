"""The robustness set: does a controller work from any start?

A controller is *robust* when its mean policy passes the chapter's success test at
T_f = 60 s (end of section 2.4) in every case of :data:`ROBUST_CASES`, all run with
the motor force of eq 12 held over each 10-ms step (``Hardware(hold="force")``,
docs/paper-notes.md section 9) and the controller keeping its nominal model:

1. the nominal plant from the chapter's start (theta0 = 3.12 rad, at rest);
2. the four plant corners: pole mass and length each x0.8 and x1.2 (the true plant
   changes, the controller's model does not);
3. other starts: theta0 = pi - 0.3 and pi + 0.3 rad (x0 = 0); x0 = -0.5 and +0.5 m
   (theta0 = 3.12); everything else at rest.

Nine simulations, no exploration noise and no eq-24 check (a plain run judged at
T_f, as ``striatal simulate`` does). A force limit or a track, when given, applies to
every case.

The stop rule of a learner or a search with ``robust`` (:func:`stop_check`) asks the
same question of a candidate that already passed its own success test on the
nominal plant: it runs the cases in :data:`STOP_ORDER` and stops at the first that
fails (the verdict is the same, all nine pass, at the cost of the runs made),
counting every run.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.params import CHAPTER_THETA0, Controller, Hardware, Plant, Simulation, SuccessTest
from striatal.sim.batch import Steps, TrialRequest, driven
from striatal.sim.rollout import NO_PROTOCOL, SensorNoise, simulate

__all__ = [
    "ROBUST_BOX",
    "ROBUST_CASES",
    "ROBUST_DURATION",
    "ROBUST_HARDWARE",
    "STOP_ORDER",
    "CaseResult",
    "Perturbation",
    "RobustReport",
    "StopCheck",
    "check_robust",
    "corner_cases",
    "corners_check",
    "corners_check_steps",
    "family_check",
    "family_check_steps",
    "nominal_is_the_case",
    "robust_cases",
    "robust_hardware",
    "run_case",
    "stop_check",
    "stop_check_steps",
]

#: The chapter's final time T_f [s] of the robust test.
ROBUST_DURATION = 60.0


@dataclass(frozen=True)
class Perturbation:
    """What a run changes from the nominal one: the true plant's pole mass, length and
    cart mass factors (the controller keeps its nominal model), the start (at rest) and
    Gaussian sensor noise on the x and theta the controller sees (stds in m and rad).

    The one perturbation model of the project: the robustness set's cases
    (:data:`ROBUST_CASES`) and the conditions of ``striatal robustness``
    (:data:`striatal.experiments.robustness.CONDITIONS`) are both made of it.
    """

    name: str
    pole_mass: float = 1.0
    length: float = 1.0
    theta0: float = CHAPTER_THETA0
    x0: float = 0.0
    x_std: float = 0.0
    theta_std: float = 0.0
    cart_mass: float = 1.0

    def plant(self, nominal: Plant) -> Plant:
        """The true plant: ``nominal`` with its pole mass, length and cart mass scaled."""
        plant = nominal.scaled(pole_mass=self.pole_mass, length=self.length)
        if self.cart_mass == 1.0:
            return plant
        return replace(plant, cart_mass=plant.cart_mass * self.cart_mass)

    def sim(self, **kwargs: Any) -> Simulation:
        """A trial from this start (``kwargs``: the other fields of the Simulation)."""
        return Simulation(theta0=self.theta0, x0=self.x0, **kwargs)

    @property
    def sensor(self) -> SensorNoise:
        return SensorNoise(x_std=self.x_std, theta_std=self.theta_std)


#: The half-width of the robustness set's plant corners: pole mass and length x(1 +- it).
ROBUST_BOX = 0.2

#: The nine cases of the robustness set (module docstring).
ROBUST_CASES: tuple[Perturbation, ...] = (
    Perturbation("nominal"),
    Perturbation("pole mass x0.8, length x0.8", pole_mass=0.8, length=0.8),
    Perturbation("pole mass x0.8, length x1.2", pole_mass=0.8, length=1.2),
    Perturbation("pole mass x1.2, length x0.8", pole_mass=1.2, length=0.8),
    Perturbation("pole mass x1.2, length x1.2", pole_mass=1.2, length=1.2),
    Perturbation("theta0 = pi - 0.3", theta0=math.pi - 0.3),
    Perturbation("theta0 = pi + 0.3", theta0=math.pi + 0.3),
    Perturbation("x0 = -0.5 m", x0=-0.5),
    Perturbation("x0 = +0.5 m", x0=0.5),
)


def robust_cases(box: float = ROBUST_BOX) -> tuple[Perturbation, ...]:
    """:data:`ROBUST_CASES` with the four plant corners at pole mass and length
    x(1 +- ``box``) in their places (``box`` :data:`ROBUST_BOX`: the set itself)."""
    if box == ROBUST_BOX:
        return ROBUST_CASES
    if not 0.0 < box < 1.0:
        raise ParameterError(f"a corner box must be in (0, 1), got {box!r}")

    def moved(factor: float) -> float:
        return round(1.0 + math.copysign(box, factor - 1.0), 12)

    return tuple(
        Perturbation(
            f"pole mass x{moved(c.pole_mass):g}, length x{moved(c.length):g}",
            pole_mass=moved(c.pole_mass),
            length=moved(c.length),
        )
        if c.pole_mass != 1.0
        else c
        for c in ROBUST_CASES
    )


def corner_cases(box: float) -> tuple[Perturbation, ...]:
    """The four plant corners of :func:`robust_cases` ``(box)``, from the chapter's
    start, in :data:`STOP_ORDER` (the shorter pole first)."""
    cases = robust_cases(box)
    return tuple(cases[i] for i in STOP_ORDER if cases[i].pole_mass != 1.0)


@dataclass(frozen=True)
class CaseResult:
    """The mean-policy run of one case: success test at T_f, how it ended, its extremes
    (each field but ``case`` is the run's :class:`~striatal.sim.rollout.TrialOutcome`'s)."""

    case: Perturbation
    success: bool
    end_reason: str
    ended_at: float
    final_state: tuple[float, float, float, float]
    max_abs_x: float
    max_abs_force: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "case": self.case.name,
            "pole_mass_factor": self.case.pole_mass,
            "length_factor": self.case.length,
            "cart_mass_factor": self.case.cart_mass,
            "theta0": self.case.theta0,
            "x0": self.case.x0,
            "success": self.success,
            "end_reason": self.end_reason,
            "ended_at": self.ended_at,
            "final_state": list(self.final_state),
            "max_abs_x": self.max_abs_x,
            "max_abs_force": self.max_abs_force,
        }


@dataclass(frozen=True)
class RobustReport:
    """Every case's result; ``robust`` when all pass. ``simulations``: runs made."""

    controller: Controller
    plant: Plant
    hardware: Hardware
    duration: float
    dt: float
    cases: tuple[CaseResult, ...]

    @property
    def robust(self) -> bool:
        return all(c.success for c in self.cases)

    @property
    def failed(self) -> tuple[str, ...]:
        """Names of the cases whose mean-policy run fails the success test."""
        return tuple(c.case.name for c in self.cases if not c.success)

    @property
    def simulations(self) -> int:
        return len(self.cases)

    def to_dict(self) -> dict[str, Any]:
        return {
            "robust": self.robust,
            "failed": list(self.failed),
            "simulations": self.simulations,
            "duration": self.duration,
            "dt": self.dt,
            "hardware": self.hardware.to_dict(),
            "controller": self.controller.to_dict(),
            "nominal_plant": self.plant.to_dict(),
            "policy": "mean (no exploration noise)",
            "success_test": str(SuccessTest()),
            "cases": [c.to_dict() for c in self.cases],
        }


def robust_hardware(max_force: float | None = None, track: float | None = None) -> Hardware:
    """The motor of the robustness set: the force held, with an optional limit and track."""
    return Hardware(hold="force", max_force=max_force, track=track)


def run_case(
    controller: Controller,
    case: Perturbation,
    *,
    plant: Plant | None = None,
    hardware: Hardware | None = None,
    duration: float = ROBUST_DURATION,
    dt: float = 0.01,
) -> CaseResult:
    """The mean-policy run of one case: the true plant is ``plant`` scaled by the case,
    the controller's model is ``plant`` itself (default: the chapter's plant)."""
    if case.sensor.active:
        raise ParameterError(
            f"robust case {case.name!r} has sensor noise: the robustness set runs noise-free "
            "(striatal robustness runs conditions with sensor noise)"
        )
    nominal = plant or Plant()
    hw = hardware or robust_hardware()
    sim = case.sim(duration=duration, dt=dt)
    o = simulate(
        case.plant(nominal), controller, sim, protocol=NO_PROTOCOL, model=nominal, hardware=hw
    )
    kept = {f.name: getattr(o.outcome, f.name) for f in fields(CaseResult) if f.name != "case"}
    return CaseResult(case=case, **kept)


def check_robust(
    controller: Controller,
    *,
    plant: Plant | None = None,
    max_force: float | None = None,
    track: float | None = None,
    duration: float = ROBUST_DURATION,
    dt: float = 0.01,
    cases: tuple[Perturbation, ...] = ROBUST_CASES,
) -> RobustReport:
    """Run every case of the robustness set (module docstring) and report.

    ``plant``: the nominal plant, which the controller keeps as its model (default:
    the chapter's); ``max_force`` [N] and ``track`` [m]: a motor limit and a track
    for every case (default: none). Deterministic: no random draws.
    """
    if not isinstance(controller, Controller):
        raise ParameterError(f"controller must be a striatal.Controller, got {controller!r}")
    if plant is not None and not isinstance(plant, Plant):
        raise ParameterError(f"plant must be a striatal.Plant, got {plant!r}")
    nominal = plant or Plant()
    hw = robust_hardware(max_force, track)
    results = tuple(
        run_case(controller, c, plant=nominal, hardware=hw, duration=duration, dt=dt) for c in cases
    )
    return RobustReport(
        controller=controller,
        plant=nominal,
        hardware=hw,
        duration=duration,
        dt=dt,
        cases=results,
    )


#: The motor of every case and of a learner's trials with ``robust``: the force held.
ROBUST_HARDWARE = Hardware(hold="force")

#: The order in which :func:`stop_check` runs the cases (indices into ROBUST_CASES):
#: the two corners with the shorter pole first, which most learned controllers fail
#: (docs/results.md), the nominal plant last. It changes the cost, not the verdict.
STOP_ORDER: tuple[int, ...] = (3, 1, 4, 5, 6, 2, 7, 8, 0)


@dataclass(frozen=True)
class StopCheck:
    """The robust stop rule's verdict on one candidate and what it cost.

    ``simulations``: the runs made (the cases up to the first failure);
    ``simulated_seconds``: their simulated time [s]; ``failed``: the first case that
    failed (None when robust).
    """

    robust: bool
    simulations: int
    simulated_seconds: float
    failed: str | None = None
    #: With ``record``: each run's true plant (pole mass, length) factors and its rows
    #: (kernel.TRAJ_COLUMNS), for a learner that learns from its checks.
    recorded: tuple[tuple[tuple[float, float], np.ndarray], ...] = ()


def nominal_is_the_case(sim: Simulation, action_every: int = 1) -> bool:
    """True when a noise-free run of ``sim`` with the force held on the nominal plant
    is the nominal case itself: the chapter's start at rest, T_f = 60 s, the success
    test's default box, a new action every step.

    The eq-24 check of the learner's protocol can only end a trial early; a trial that
    passes the success test at T_f under it follows the same trajectory as the case
    (no check), so it passes the case too (tests/test_robust_stop.py).
    """
    return sim == Simulation(dt=sim.dt) and action_every == 1


def _case_request(
    controller: Controller,
    W: np.ndarray,
    case: Perturbation,
    plant: Plant,
    model: Plant,
    dt: float,
    hardware: Hardware,
) -> TrialRequest:
    """The mean-policy run of ``case``'s start, 60 s, on ``plant``, believing ``model``."""
    sim = case.sim(duration=ROBUST_DURATION, dt=dt)
    return TrialRequest(
        plant, controller, sim, NO_PROTOCOL, gains=W, model=model, hardware=hardware
    )


def _until_failure(
    requests: Iterable[tuple[str, TrialRequest, tuple[float, float]]], record: bool = False
) -> Steps[StopCheck]:
    """Run the named requests in order (each yielded) up to the first that fails its
    success test at T_f, every run and its simulated seconds counted. ``record``: each
    run recorded (the same outcome), its rows kept in the verdict with its plant's
    factors."""
    runs, seconds = 0, 0.0
    recorded: list[tuple[tuple[float, float], np.ndarray]] = []
    for name, request, factors in requests:
        (outcome,) = yield [replace(request, record=True) if record else request]
        if record and outcome.rows is not None:
            recorded.append((factors, outcome.rows))
        runs += 1
        seconds += outcome.ended_at
        if not outcome.success:
            return StopCheck(False, runs, seconds, name, tuple(recorded))
    return StopCheck(True, runs, seconds, recorded=tuple(recorded))


def _case_runs(
    controller: Controller,
    gains: np.ndarray | None,
    cases: Iterable[Perturbation],
    plant: Plant,
    dt: float,
    hardware: Hardware,
) -> Iterator[tuple[str, TrialRequest, tuple[float, float]]]:
    """Each case's (name, request, plant factors), the controller (with ``gains`` if
    given) keeping ``plant`` as its model: the runs :func:`_until_failure` takes."""
    W = np.asarray(controller.gains if gains is None else gains, dtype=float)
    for case in cases:
        request = _case_request(controller, W, case, case.plant(plant), plant, dt, hardware)
        yield case.name, request, (case.pole_mass, case.length)


def stop_check_steps(
    controller: Controller,
    plant: Plant,
    dt: float,
    *,
    gains: np.ndarray | None = None,
    nominal_passed: bool = False,
    hardware: Hardware = ROBUST_HARDWARE,
    record: bool = False,
    box: float = ROBUST_BOX,
) -> Steps[StopCheck]:
    """Is ``controller`` (with ``gains`` if given: a learner's guarded W) robust?

    Runs the cases of :data:`ROBUST_CASES` in :data:`STOP_ORDER`, mean policy, 60 s,
    ``hardware`` (force held), the controller keeping ``plant`` as its model, and stops
    at the first failure. ``nominal_passed``: the caller's own success test already was
    the nominal case (:func:`nominal_is_the_case`) and it passed; it is not run again.
    The verdict equals :func:`check_robust`'s ``robust``. Its runs are yielded
    (:data:`striatal.sim.batch.Steps`); :func:`stop_check` runs them. ``record``: the
    verdict keeps every run's rows with its case's plant factors. ``box``: the plant
    corners at x(1 +- box) instead (:func:`robust_cases`; a wider box than the set's
    asks for a margin).
    """
    every = robust_cases(box)
    cases = [every[i] for i in STOP_ORDER if not (nominal_passed and every[i] == ROBUST_CASES[0])]
    runs = _case_runs(controller, gains, cases, plant, dt, hardware)
    return (yield from _until_failure(runs, record))


#: :func:`stop_check_steps` run to its end on the scalar kernel.
stop_check = driven(stop_check_steps)


def corners_check_steps(
    controller: Controller,
    plant: Plant,
    dt: float,
    box: float,
    *,
    gains: np.ndarray | None = None,
    hardware: Hardware = ROBUST_HARDWARE,
) -> Steps[StopCheck]:
    """The four plant corners at x(1 +- ``box``) (:func:`corner_cases`), run as the
    robustness set runs its cases (mean policy, 60 s, ``hardware``, the controller
    keeping ``plant`` as its model), up to the first failure, every run counted."""
    runs = _case_runs(controller, gains, corner_cases(box), plant, dt, hardware)
    return (yield from _until_failure(runs))


#: :func:`corners_check_steps` run to its end on the scalar kernel.
corners_check = driven(corners_check_steps)


def family_check_steps(
    controller: Controller,
    plants: tuple[Plant, ...],
    dt: float,
    *,
    model: Plant | None = None,
    gains: np.ndarray | None = None,
    hardware: Hardware = ROBUST_HARDWARE,
    box: float = ROBUST_BOX,
) -> Steps[StopCheck]:
    """The robust stop rule on each plant of ``plants`` (a family a model cannot rule
    out), stopping at the first failure, every run counted. ``model`` None: each plant
    is believed exactly and :func:`stop_check`'s cases run around it (its corners
    scaled from it, at x(1 +- ``box``)). Else the controller believes ``model`` and the
    plants replace the corners: each start of :data:`ROBUST_CASES` (the nominal start
    and the four others) on each plant, learned plants included."""
    if model is None:
        runs, seconds = 0, 0.0
        for plant in plants:
            verdict = yield from stop_check_steps(
                controller, plant, dt, gains=gains, hardware=hardware, box=box
            )
            runs += verdict.simulations
            seconds += verdict.simulated_seconds
            if not verdict.robust:
                return StopCheck(False, runs, seconds, verdict.failed)
        return StopCheck(True, runs, seconds)
    W = np.asarray(controller.gains if gains is None else gains, dtype=float)
    starts = [c for c in ROBUST_CASES if c.pole_mass == 1.0 and c.length == 1.0]
    return (
        yield from _until_failure(
            (
                f"plant {k}, {case.name}",
                _case_request(controller, W, case, plant, model, dt, hardware),
                (1.0, 1.0),
            )
            for k, plant in enumerate(plants)
            for case in starts
        )
    )


#: :func:`family_check_steps` run to its end on the scalar kernel.
family_check = driven(family_check_steps)
