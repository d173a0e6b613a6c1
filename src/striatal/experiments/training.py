"""The Python API of a whole training run: :func:`train` (what ``striatal train`` runs).

``striatal.train(learner="pgpe", init="random", seed=0, max_trials=300)`` gives
exactly what ``striatal train --learner pgpe --init random --seed 0 --max-trials 300``
gives: the same defaults (the learner's tuned preset, :func:`striatal.learners.default_config`),
the same W(0), the same files with ``out=``.
"""

from __future__ import annotations

import math
import numbers
import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from striatal import arguments
from striatal.errors import DataFileError, ParameterError
from striatal.experiments.spec import floor_w1, initial_gains
from striatal.io.files import check_out_dir
from striatal.io.rundir import (
    RUN_FILES,
    RunDir,
    Setup,
    rule_columns,
    run_id,
    run_settings,
    setup_of,
)
from striatal.learners import (
    W1_FLOOR,
    History,
    LearnerState,
    TrialRecord,
    default_config,
    initial_state,
    learn,
)
from striatal.learners.config import MAX_COUNT
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    Controller,
    Hardware,
    Plant,
    Simulation,
    check_seed,
)
from striatal.sim.robust import check_robust
from striatal.sim.rollout import Protocol, SensorNoise, Trajectory
from striatal.sim.rollout import simulate as _simulate

__all__ = [
    "DEFAULT_CHECKPOINT_EVERY",
    "RESUME_MAY_CHANGE",
    "Run",
    "simulate",
    "train",
]

#: Trials between checkpoints when a run writes to a folder.
DEFAULT_CHECKPOINT_EVERY = 50


@dataclass(frozen=True)
class Run:
    """A finished (or interrupted) training run.

    ``history``: one row per trial (all of them, also those before a resume);
    ``settings``: the run's settings as stored in result.json; :meth:`to_dict` is
    result.json itself. ``mean_policy_success``: the learned controller re-simulated
    (with the force held in a robust run); ``robust_report``: in a robust run, the
    learned controller's :func:`striatal.sim.robust.check_robust` report (result.json's
    "robust"), both outside the run's counted simulations.
    """

    success: bool
    trials: int
    W: tuple[float, ...]
    theta_c: float
    seed: int
    learner: str
    interrupted: bool
    wall_seconds: float
    state: LearnerState
    history: History
    settings: dict[str, Any]
    mean_policy_success: bool
    mean_policy_final_state: tuple[float, ...]
    run_id: str = ""
    out: Path | None = None
    robust_report: dict[str, Any] | None = None

    @property
    def controller(self) -> Controller:
        """The learned controller (W, theta_c and the run's readings)."""
        c = self.settings["controller"]
        return Controller(gains=self.W, theta_c=self.theta_c, **c)

    @property
    def plant(self) -> Plant:
        return Plant(**self.settings["plant"])

    def to_dict(self) -> dict[str, Any]:
        """result.json."""
        payload: dict[str, Any] = {
            "success": self.success,
            "trials": self.trials,
            "W": list(self.W),
            "theta_c": self.theta_c,
            "seed": self.seed,
            "wall_seconds": self.wall_seconds,
            "interrupted": self.interrupted,
            "learner": self.learner,
            "simulations": self.state.simulations,
            "simulated_seconds": self.state.simulated_seconds,
            "settings": self.settings,
            "mean_policy_success": self.mean_policy_success,
            "mean_policy_final_state": list(self.mean_policy_final_state),
            "positive_rewards": self.state.n_positive,
            "run_id": self.run_id,
        }
        if self.robust_report is not None:
            # the learned controller run through the whole set again (not in the budget)
            payload["robust"] = self.robust_report
        return payload


def _require(name: str, value: object, kind: type | tuple[type, ...], what: str) -> None:
    """ParameterError naming argument ``name`` unless ``value`` is None or a ``kind``."""
    if value is not None and not isinstance(value, kind):
        raise ParameterError(f"{name} must be {what}, got {value!r}")


def _require_number(name: str, value: object) -> None:
    """ParameterError unless ``value`` is None or a real number (text and bool are not)."""
    if value is not None and (isinstance(value, bool) or not isinstance(value, numbers.Real)):
        raise ParameterError(f"{name} must be a number, got {value!r}")


def _check_train_arguments(args: dict[str, Any]) -> None:
    """The types of :func:`train`'s arguments (their values are checked where they are used)."""
    for name in ("learner", "init", "balance_sign", "switch"):
        _require(name, args[name], str, "a name")
    for name in ("theta_c0", "inhibition"):
        _require_number(name, args[name])
    gains = args["init_gains"]
    if isinstance(gains, str | bytes) or (gains is not None and not isinstance(gains, Iterable)):
        raise ParameterError(f"init_gains must be six numbers W1..W6, got {gains!r}")
    _require("plant", args["plant"], Plant, "a striatal.Plant")
    _require("sim", args["sim"], Simulation, "a striatal.Simulation")
    _require("out", args["out"], (str, os.PathLike), "a folder (str or Path)")
    if isinstance(args["out"], str) and not args["out"].strip():
        raise ParameterError("out must name a folder, got an empty string")
    if not isinstance(args["resume"], bool):
        raise ParameterError(f"resume must be True or False, got {args['resume']!r}")
    for name in ("on_trial", "should_stop"):
        if args[name] is not None and not callable(args[name]):
            raise ParameterError(f"{name} must be a function, got {args[name]!r}")


def _fresh_setup(
    learner: str,
    init: str,
    init_gains: Sequence[float] | None,
    theta_c0: float,
    seed: int,
    plant: Plant | None,
    sim: Simulation | None,
    controller: dict[str, Any],
    options: dict[str, Any],
) -> tuple[dict[str, Any], Setup]:
    seed = check_seed(seed)
    config = default_config(learner, **options)
    sim = Simulation() if sim is None else sim
    arguments.check_learning_work(
        1,
        config.max_trials,
        config.imagine_trials if config.learner == "forward" else 0,
        math.ceil(sim.duration / sim.dt) if isinstance(sim, Simulation) else 1,
        0,
        "the run",
    )
    W0 = initial_gains(init, seed, init_gains)
    template = Controller(gains=W0, theta_c=theta_c0, **controller)
    plant = Plant() if plant is None else plant
    sim = Simulation() if sim is None else sim
    settings = run_settings(
        config,
        template,
        plant,
        sim,
        seed=seed,
        init="gains" if init_gains is not None else init,
        W0=W0,
    )
    if init_gains is not None and float(init_gains[0]) < W1_FLOOR:
        # the floor is recorded (this key only appears when it acted: older run ids stay)
        settings["w1_floored_from"] = float(init_gains[0])
    return settings, setup_of(settings, "the options")


#: Options that may differ on resume: where the files go, how often to checkpoint,
#: and a larger max_trials (to extend a run).
RESUME_MAY_CHANGE = ("out", "checkpoint_every", "max_trials")


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _resume_changes(
    settings: dict[str, Any], setup: Setup, state: LearnerState, given: dict[str, Any]
) -> dict[str, Any]:
    """The settings of a resumed run: ParameterError naming every given option that
    differs from the checkpoint's (only a larger max_trials may)."""
    have: dict[str, Any] = {
        "learner": setup.config.learner,
        "init": settings.get("init"),
        "init_gains": tuple(setup.template.gains) if settings.get("init") == "gains" else None,
        "theta_c0": setup.template.theta_c,
        "seed": setup.seed,
        "plant": setup.plant,
        "sim": setup.sim,
        "balance_sign": setup.template.balance_sign,
        "switch": setup.template.switch,
        "inhibition": setup.template.inhibition,
        # every field, at its default too (to_dict leaves some of those out)
        **{f.name: getattr(setup.config, f.name) for f in fields(setup.config)},
    }
    differ = []
    for name, value in given.items():
        if name == "max_trials":
            continue
        if name not in have:
            differ.append(f"{_flag(name)} (no such setting)")
        elif name == "init_gains":
            if have[name] is None or floor_w1(value) != have[name]:
                differ.append(f"{_flag(name)}")
        elif name in ("plant", "sim") and isinstance(value, Plant | Simulation):
            # name the fields (the options of striatal train), not the whole record
            differ += [
                f"{_flag(f.name)} (the run has {getattr(have[name], f.name)!r})"
                for f in fields(value)
                if getattr(value, f.name) != getattr(have[name], f.name)
            ]
        elif value != have[name]:
            differ.append(f"{_flag(name)} (the run has {have[name]!r})")
    if differ:
        raise ParameterError(
            "--resume continues the run in its checkpoint; these options differ from it: "
            + ", ".join(differ)
            + " (only --max-trials may grow, --checkpoint-every may change)"
        )
    new = dict(settings)
    if "max_trials" in given:
        m = given["max_trials"]
        if m < state.trials_done or m < setup.config.max_trials:
            raise ParameterError(
                f"--resume may only raise --max-trials (the run has "
                f"{setup.config.max_trials}, {state.trials_done} done), got {m}"
            )
        new["config"] = {**settings["config"], "max_trials": m}
    return new


def train(
    learner: str | None = None,
    *,
    init: str | None = None,
    init_gains: Sequence[float] | None = None,
    theta_c0: float | None = None,
    seed: int | None = None,
    plant: Plant | None = None,
    sim: Simulation | None = None,
    balance_sign: str | None = None,
    switch: str | None = None,
    inhibition: float | None = None,
    out: str | Path | None = None,
    resume: bool = False,
    checkpoint_every: int = DEFAULT_CHECKPOINT_EVERY,
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    **options: Any,
) -> Run:
    """Train a learner from W(0) until the success test holds or ``max_trials``.

    ``learner``: a key of :data:`striatal.learners.RULES` (default "chapter");
    ``**options``: any :class:`striatal.learners.LearnerConfig` field
    (``max_trials``, ``alpha``, ``eligibility="chapter"``...), applied over the
    learner's tuned preset. ``init``: "chapter" (W(0) of the chapter, the default)
    or "random" (uniform in [-1, 1]^6 from ``seed``, default 0), unless
    ``init_gains`` gives W(0); ``theta_c0`` default 0.6. ``plant``, ``sim`` and the
    controller readings default to the chapter's. With ``out`` the run writes
    history.csv, checkpoint.json (every ``checkpoint_every`` trials) and result.json
    there, holding an exclusive lock on the folder; a fresh run first removes an
    older run's checkpoint and result. ``resume=True`` continues the run
    checkpointed in ``out``: every other argument given must equal the run's
    (ParameterError naming those that differ), except a larger ``max_trials``.
    ``on_trial`` is called after each trial's row is recorded; ``should_stop`` is
    asked after it (True: stop there, the result is ``interrupted``). Ctrl-C
    stops likewise.
    """
    _check_train_arguments(
        {
            "learner": learner,
            "init": init,
            "init_gains": init_gains,
            "theta_c0": theta_c0,
            "plant": plant,
            "sim": sim,
            "balance_sign": balance_sign,
            "switch": switch,
            "inhibition": inhibition,
            "out": out,
            "resume": resume,
            "on_trial": on_trial,
            "should_stop": should_stop,
        }
    )
    # a NumPy number is the Python number it holds (np.int64(2) is a whole number)
    seed, theta_c0, inhibition, checkpoint_every = (
        arguments.plain(v) for v in (seed, theta_c0, inhibition, checkpoint_every)
    )
    options = {k: arguments.plain(v) for k, v in options.items()}
    if seed is not None:
        seed = arguments.check(arguments.ARGS["seed"], seed)
    for name, value in (("theta_c0", theta_c0), ("inhibition", inhibition)):
        if value is not None:
            arguments.check(arguments.ARGS[name], value)
    if isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, int):
        raise ParameterError(f"checkpoint_every must be a whole number, got {checkpoint_every!r}")
    if checkpoint_every < 1:
        raise ParameterError(f"--checkpoint-every must be >= 1, got {checkpoint_every}")
    given = {
        k: v
        for k, v in {
            "learner": learner,
            "init": init,
            "init_gains": init_gains,
            "theta_c0": theta_c0,
            "seed": seed,
            "plant": plant,
            "sim": sim,
            "balance_sign": balance_sign,
            "switch": switch,
            "inhibition": inhibition,
            **options,
        }.items()
        if v is not None
    }
    if resume:
        if out is None:
            raise ParameterError("--resume needs --out DIR holding a checkpoint")
        rundir = RunDir(check_out_dir(out, files=RUN_FILES))
        if not rundir.checkpoint_path.exists():
            raise DataFileError(f"checkpoint {rundir.checkpoint_path} does not exist")
        with rundir.lock():
            run, settings, state, digest = rundir.read_checkpoint()
            setup = setup_of(settings, f"checkpoint {rundir.checkpoint_path}")
            settings = _resume_changes(settings, setup, state, given)
            setup = setup_of(settings, f"checkpoint {rundir.checkpoint_path}")
            rundir.check_result_run(run)
            rundir.keep_history(state.trials_done, rule_columns(setup.config), digest)
            return _run(
                run, settings, setup, state, rundir, checkpoint_every, on_trial, should_stop
            )
    settings, setup = _fresh_setup(
        learner or "chapter",
        init or "chapter",
        init_gains,
        CHAPTER_INITIAL_THETA_C if theta_c0 is None else theta_c0,
        0 if seed is None else seed,
        plant,
        sim,
        {
            "balance_sign": balance_sign or "corrected",
            "switch": switch or "hard",
            "inhibition": 50.0 if inhibition is None else inhibition,
        },
        options,
    )
    state = initial_state(setup.template.gains, setup.template.theta_c, setup.seed)
    run = run_id(settings)
    if out is None:
        return _run(run, settings, setup, state, None, checkpoint_every, on_trial, should_stop)
    rundir = RunDir(check_out_dir(out, files=RUN_FILES))
    with rundir.lock():
        rundir.clear()
        rundir.start_history(rule_columns(setup.config))
        return _run(run, settings, setup, state, rundir, checkpoint_every, on_trial, should_stop)


def _run(
    run: str,
    settings: dict[str, Any],
    setup: Setup,
    state: LearnerState,
    rundir: RunDir | None,
    checkpoint_every: int,
    on_trial: Callable[[LearnerState, TrialRecord], None] | None,
    should_stop: Callable[[], bool] | None,
) -> Run:
    """The learning loop of :func:`train` with its files (``rundir``, set up and locked)."""
    config = setup.config
    records: list[TrialRecord] = []
    recorded = state  # the state after the last trial whose history row is written

    def checkpoint(s: LearnerState) -> None:
        if rundir is not None:
            rundir.write_checkpoint(run, settings, s)

    def record(s: LearnerState, rec: TrialRecord) -> None:
        nonlocal recorded
        if rundir is not None:
            rundir.append(rec)  # the rows live on disk: memory stays flat however long
        else:
            records.append(rec)
        recorded = s
        if s.trials_done % checkpoint_every == 0:
            checkpoint(s)
        if on_trial is not None:
            on_trial(s, rec)
        if should_stop is not None and should_stop():
            raise KeyboardInterrupt

    t0 = time.perf_counter()
    interrupted = False
    try:
        try:
            final = learn(
                setup.plant,
                setup.template,
                config,
                setup.seed,
                sim=setup.sim,
                protocol=setup.protocol,
                state=state,
                on_trial=record,
            )
        except KeyboardInterrupt:
            # the run ends at the last state with a history row (a trial updated but not
            # yet written is not kept)
            interrupted, final = True, recorded
        checkpoint(final)
    finally:
        if rundir is not None:
            rundir.close_history()
    columns = rule_columns(config)
    if rundir is not None:
        history = (
            rundir.read_history()
            if recorded.trials_done
            else History.of(config.learner, [], config.reward)
        )
    else:
        history = History.of(config.learner, records, config.reward)
    if not history.columns:
        history = History(config.learner, columns, reward_kind=config.reward)
    learned = setup.template.with_gains(final.W, final.theta_c)
    hardware = config.hardware
    check = _simulate(setup.plant, learned, setup.sim, hardware=hardware).outcome
    report = (
        check_robust(
            learned, plant=setup.plant, max_force=config.max_force, track=config.track
        ).to_dict()
        if config.robust
        else None
    )
    out = Run(
        success=final.success,
        trials=final.trials_done,
        W=final.W,
        theta_c=final.theta_c,
        seed=setup.seed,
        learner=config.learner,
        interrupted=interrupted,
        wall_seconds=time.perf_counter() - t0,
        state=final,
        history=history,
        settings=settings,
        mean_policy_success=check.success,
        mean_policy_final_state=tuple(check.final_state),
        run_id=run,
        out=rundir.path if rundir is not None else None,
        robust_report=report,
    )
    if rundir is not None:
        rundir.write_result(out.to_dict())
    return out


def simulate(
    plant: Plant | None = None,
    controller: Controller | None = None,
    sim: Simulation | None = None,
    **kwargs: Any,
) -> Trajectory:
    """One run of the switching controller with ``striatal simulate``'s defaults.

    Defaults: the chapter's plant, its learned W and theta_c (``--chapter-final``),
    60 s from theta = 3.12 at rest, the mean policy. ``kwargs`` go to
    :func:`striatal.sim.rollout.simulate` (protocol, rng, model, sensor, action_every,
    hardware: the motor's hold and limit and the track, docs/paper-notes.md section 10).
    """
    _require("plant", plant, Plant, "a striatal.Plant")
    _require("controller", controller, Controller, "a striatal.Controller")
    _require("sim", sim, Simulation, "a striatal.Simulation")
    for name, (kind, what) in _SIMULATE_KWARGS.items():
        _require(name, kwargs.get(name), kind, what)
    if "action_every" in kwargs:
        every = kwargs["action_every"]
        if isinstance(every, bool) or not isinstance(every, numbers.Integral):
            raise ParameterError(f"action_every must be a whole number >= 1, got {every!r}")
        if not 1 <= int(every) <= MAX_COUNT:
            raise ParameterError(f"action_every must be in [1, {MAX_COUNT:,}], got {every!r}")
    return _simulate(
        Plant() if plant is None else plant,
        Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
        if controller is None
        else controller,
        Simulation() if sim is None else sim,
        **kwargs,
    )


#: The keyword arguments of :func:`simulate` checked by type (None: their default).
_SIMULATE_KWARGS: dict[str, tuple[type, str]] = {
    "protocol": (Protocol, "a striatal.Protocol"),
    "rng": (np.random.Generator, "a numpy.random.Generator"),
    "model": (Plant, "a striatal.Plant"),
    "sensor": (SensorNoise, "a striatal.sim.rollout.SensorNoise"),
    "hardware": (Hardware, "a striatal.Hardware"),
}
