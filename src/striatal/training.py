"""The Python API of a whole training run: :func:`train` (what ``striatal train`` runs).

``striatal.train(learner="pgpe", init="random", seed=0, max_trials=300)`` gives
exactly what ``striatal train --learner pgpe --init random --seed 0 --max-trials 300``
gives: the same defaults (the learner's tuned preset, :func:`striatal.learners.default_config`),
the same W(0), the same files with ``out=``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.files import check_out_dir
from striatal.learners import (
    History,
    LearnerState,
    TrainResult,
    TrialRecord,
    default_config,
    initial_state,
    learn,
    random_initial_gains,
)
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
    check_seed,
)
from striatal.rollout import Trajectory
from striatal.rollout import simulate as _simulate
from striatal.rundir import RunDir, Setup, history_line, rule_columns, run_settings, setup_of

__all__ = ["DEFAULT_CHECKPOINT_EVERY", "Run", "initial_gains", "simulate", "train"]

#: Trials between checkpoints when a run writes to a folder.
DEFAULT_CHECKPOINT_EVERY = 50


@dataclass(frozen=True)
class Run:
    """A finished (or interrupted) training run.

    ``history``: one row per trial (all of them, also those before a resume);
    ``settings``: the run's settings as stored in result.json; :meth:`to_dict` is
    result.json itself.
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
    out: Path | None = None

    @property
    def controller(self) -> Controller:
        """The learned controller (W, theta_c and the run's readings)."""
        c = self.settings["controller"]
        return Controller(gains=self.W, theta_c=self.theta_c, **c)

    @property
    def plant(self) -> Plant:
        return Plant(**self.settings["plant"])

    def to_dict(self) -> dict[str, Any]:
        payload = TrainResult(
            success=self.success,
            trials=self.trials,
            W=self.W,
            theta_c=self.theta_c,
            seed=self.seed,
            wall_seconds=self.wall_seconds,
            state=self.state,
            learner=self.learner,
            interrupted=self.interrupted,
            settings=self.settings,
        ).to_dict()
        payload["mean_policy_success"] = self.mean_policy_success
        payload["mean_policy_final_state"] = list(self.mean_policy_final_state)
        payload["positive_rewards"] = self.state.n_positive
        return payload


def initial_gains(init: str, seed: int, init_gains: Sequence[float] | None = None) -> tuple:
    """W(0): ``init_gains``, the chapter's ("chapter") or uniform in [-1, 1]^6 ("random")."""
    if init_gains is not None:
        return tuple(float(w) for w in init_gains)
    if init == "chapter":
        return CHAPTER_INITIAL_W
    if init == "random":
        return random_initial_gains(np.random.default_rng([check_seed(seed), 1]))
    raise ParameterError(f"init must be 'chapter' or 'random', got {init!r}")


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
    W0 = initial_gains(init, seed, init_gains)
    template = Controller(gains=W0, theta_c=theta_c0, **controller)
    plant = plant or Plant()
    sim = sim or Simulation()
    settings = run_settings(
        config,
        template,
        plant,
        sim,
        seed=seed,
        init="gains" if init_gains is not None else init,
        W0=W0,
    )
    return settings, setup_of(settings, "the options")


def train(
    learner: str = "chapter",
    *,
    init: str = "chapter",
    init_gains: Sequence[float] | None = None,
    theta_c0: float = CHAPTER_INITIAL_THETA_C,
    seed: int = 0,
    plant: Plant | None = None,
    sim: Simulation | None = None,
    balance_sign: str = "corrected",
    switch: str = "hard",
    inhibition: float = 50.0,
    out: str | Path | None = None,
    resume: bool = False,
    checkpoint_every: int = DEFAULT_CHECKPOINT_EVERY,
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    **options: Any,
) -> Run:
    """Train a learner from W(0) until the success test holds or ``max_trials``.

    ``learner``: a key of :data:`striatal.learners.RULES`; ``**options``: any
    :class:`striatal.learners.LearnerConfig` field (``max_trials``, ``alpha``,
    ``eligibility="chapter"``...), applied over the learner's tuned preset.
    ``init``: "chapter" (W(0) of the chapter) or "random" (uniform in [-1, 1]^6
    from ``seed``), unless ``init_gains`` gives W(0). With ``out`` the run writes
    history.csv, checkpoint.json (every ``checkpoint_every`` trials) and
    result.json there; ``resume=True`` continues the run checkpointed in ``out``
    (the other arguments are then taken from its settings). ``on_trial`` is
    called after each trial's row is recorded; ``should_stop`` is asked after it
    (True: stop there, the result is ``interrupted``). Ctrl-C stops likewise.
    """
    if isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, int):
        raise ParameterError(f"checkpoint_every must be a whole number, got {checkpoint_every!r}")
    if checkpoint_every < 1:
        raise ParameterError(f"--checkpoint-every must be >= 1, got {checkpoint_every}")
    rundir = None
    if out is not None:
        rundir = RunDir(check_out_dir(out))
    past = None
    if resume:
        if rundir is None:
            raise ParameterError("--resume needs --out DIR holding a checkpoint")
        settings, state = rundir.read_checkpoint()
        setup = setup_of(settings, f"checkpoint {rundir.checkpoint_path}")
        columns = rule_columns(setup.config)
        rundir.keep_history(state.trials_done, columns)
        past = rundir.read_history() if state.trials_done else None
    else:
        settings, setup = _fresh_setup(
            learner,
            init,
            init_gains,
            theta_c0,
            seed,
            plant,
            sim,
            {"balance_sign": balance_sign, "switch": switch, "inhibition": inhibition},
            options,
        )
        state = initial_state(setup.template.gains, setup.template.theta_c, setup.seed)
        columns = rule_columns(setup.config)
        if rundir is not None:
            rundir.start_history(columns)
    config = setup.config
    records: list[TrialRecord] = []
    recorded = state  # the state after the last trial whose history row is written
    history_file = rundir.open_history() if rundir is not None else None

    def checkpoint(s: LearnerState) -> None:
        if rundir is not None:
            if history_file is not None:
                history_file.flush()
            rundir.write_checkpoint(settings, s)

    def record(s: LearnerState, rec: TrialRecord) -> None:
        nonlocal recorded
        if history_file is not None:
            history_file.write(history_line(rec))
        records.append(rec)
        recorded = s
        if s.trials_done % checkpoint_every == 0:
            checkpoint(s)
        if on_trial is not None:
            on_trial(s, rec)
        if should_stop is not None and should_stop():
            raise KeyboardInterrupt

    t0 = time.perf_counter()
    try:
        result = learn(
            setup.plant,
            setup.template,
            config,
            setup.seed,
            sim=setup.sim,
            protocol=setup.protocol,
            state=state,
            on_trial=record,
        )
    finally:
        if history_file is not None:
            history_file.flush()
    if result.interrupted and result.state is not recorded:
        # stopped between a trial's update and its history row: that trial is not kept
        result = replace(
            result,
            success=recorded.success,
            trials=recorded.trials_done,
            W=recorded.W,
            theta_c=recorded.theta_c,
            state=recorded,
        )
    checkpoint(result.state)
    if history_file is not None:
        history_file.close()
    reward_kind = config.reward
    history = (
        past.plus(records) if past is not None else History.of(config.learner, records, reward_kind)
    )
    if not history.columns:
        history = History(config.learner, columns, (), reward_kind)
    learned = setup.template.with_gains(result.W, result.theta_c)
    check = _simulate(setup.plant, learned, setup.sim).outcome
    run = Run(
        success=result.success,
        trials=result.trials,
        W=result.W,
        theta_c=result.theta_c,
        seed=setup.seed,
        learner=config.learner,
        interrupted=result.interrupted,
        wall_seconds=time.perf_counter() - t0,
        state=result.state,
        history=history,
        settings=settings,
        mean_policy_success=check.success,
        mean_policy_final_state=tuple(check.final_state),
        out=rundir.path if rundir is not None else None,
    )
    if rundir is not None:
        rundir.write_result(run.to_dict())
    return run


def simulate(
    plant: Plant | None = None,
    controller: Controller | None = None,
    sim: Simulation | None = None,
    **kwargs: Any,
) -> Trajectory:
    """One run of the switching controller with ``striatal simulate``'s defaults.

    Defaults: the chapter's plant, its learned W and theta_c (``--chapter-final``),
    60 s from theta = 3.12 at rest, the mean policy. ``kwargs`` go to
    :func:`striatal.rollout.simulate` (protocol, rng, model, sensor, action_every).
    """
    return _simulate(
        plant or Plant(),
        controller or Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C),
        sim or Simulation(),
        **kwargs,
    )
