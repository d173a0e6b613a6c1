"""What a sweep or a training run left behind, opened as one object: :class:`Sweep`, :func:`load`.

:func:`striatal.sweep` returns a :class:`Sweep`; :func:`load` opens the folder of one
(runs.csv and sweep.json, read by :func:`striatal.experiments.runs_csv.read_runs` and
summarised by :func:`striatal.experiments.report.summarise`, the code ``striatal sweep``
writes summary.json with) or the folder of a training run (result.json, checkpoint.json
and history.csv, read by :mod:`striatal.io.rundir`) as the
:class:`striatal.experiments.training.Run` that :func:`striatal.train` returned.

>>> sweep = load("results/sweep-chapter")  # doctest: +SKIP
>>> [(a.name, a.success_rate, a.interval) for a in sweep.arms]  # doctest: +SKIP
>>> sweep.plot().savefig("profile.png")  # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from striatal.errors import DataFileError
from striatal.experiments.profiles import X_LABELS, Profile, SweepRun, choose_x, profiles_of
from striatal.experiments.report import markdown_table, summarise
from striatal.experiments.runs_csv import read_runs, sort_rows
from striatal.experiments.training import Run
from striatal.io.files import read_json
from striatal.io.rundir import CHECKPOINT, HISTORY, RESULT, RunDir, read_result

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["ArmResult", "Sweep", "load", "load_run", "load_sweep"]

#: The files of a sweep folder that :func:`load_sweep` reads.
SWEEP_FILES = ("runs.csv", "sweep.json")


@dataclass(frozen=True)
class ArmResult:
    """One arm of a sweep on one init: its rate over ``runs`` seeds with the Wilson 95 %
    interval ``interval``, and every statistic of summary.json's arm (``stats``)."""

    name: str
    init: str
    role: str
    learner: str
    method: str
    runs: int
    successes: int
    success_rate: float
    interval: tuple[float, float] | None
    stats: Mapping[str, Any] = field(repr=False)

    @classmethod
    def of(cls, arm: Mapping[str, Any]) -> ArmResult:
        """From one entry of summary.json's ``arms``."""
        ci = arm.get("success_rate_ci")
        return cls(
            name=str(arm["arm"]),
            init=str(arm["init"]),
            role=str(arm["role"]),
            learner=str(arm["learner"]),
            method=str(arm["method"]),
            runs=int(arm["runs"]),
            successes=int(arm["successes"]),
            success_rate=float(arm["success_rate"]),
            interval=(float(ci[0]), float(ci[1])) if isinstance(ci, list | tuple) else None,
            stats=dict(arm),
        )


@dataclass(frozen=True)
class Sweep:
    """The runs of a sweep and their summary (what ``striatal sweep`` writes into its folder).

    ``rows``: one dict per run (arm, init, seed), the columns of runs.csv, sorted by
    (arm, init, seed); ``summary``: summary.json (its ``settings``: sweep.json);
    ``folder``: where the files are (None for a sweep run without ``out``); ``ran`` and
    ``skipped``: runs computed by the call that returned it and runs found already done
    in ``folder`` (both 0 for a sweep opened with :func:`load`).
    """

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    folder: Path | None = None
    ran: int = 0
    skipped: int = 0

    @property
    def runs(self) -> list[dict[str, Any]]:
        """One row per run, as runs.csv holds them (the same list as ``rows``)."""
        return self.rows

    @cached_property
    def arms(self) -> tuple[ArmResult, ...]:
        """Every (arm, init): learner arm(s), the no-learning control, baselines."""
        return tuple(ArmResult.of(a) for a in self.summary["arms"])

    @property
    def settings(self) -> dict[str, Any]:
        """What the sweep computed with (sweep.json)."""
        settings = self.summary.get("settings", {})
        return settings if isinstance(settings, dict) else {}

    @property
    def learner_vs_control(self) -> list[dict[str, Any]]:
        """Each learner arm against its control: both rates, Fisher's and McNemar's tests."""
        return list(self.summary.get("learner_vs_control", []))

    @property
    def learner_vs_baselines(self) -> list[dict[str, Any]]:
        """Each learner arm against each baseline on the same seeds."""
        return list(self.summary.get("learner_vs_baselines", []))

    def table(self) -> str:
        """The markdown table ``striatal sweep`` prints."""
        return markdown_table(self.summary)

    def profiles(self, x: str | None = None) -> tuple[list[Profile], str, str]:
        """(profiles, column, note): the performance profile of every (arm, init) against
        the budget ``x`` (:func:`striatal.experiments.profiles.choose_x`)."""
        runs = [
            SweepRun(
                r["arm"],
                int(r["seed"]),
                bool(r["success"]),
                {c: float(r[c]) for c in X_LABELS if c in r},
                r["init"],
            )
            for r in self.rows
        ]
        if not runs:
            raise DataFileError("the sweep holds no finished run")
        column, note = choose_x([c for c in X_LABELS if c in self.rows[0]], x)
        return profiles_of(runs, column), column, note

    def plot(self, x: str | None = None, *, title: str | None = None) -> Figure:
        """The performance profiles (fraction of seeds solved against the budget, 95 %
        bands), the arms named from the settings and the title naming the setting."""
        from striatal.viz.profiles import arm_labels, performance_profiles, sweep_title

        profiles, column, _ = self.profiles(x)
        specs = self.settings.get("arms", {})
        named = arm_labels([("", p.arm, specs.get(p.arm)) for p in profiles])
        labels = [
            f"{n}, {p.init} init" if p.init else n for n, p in zip(named, profiles, strict=True)
        ]
        return performance_profiles(
            profiles,
            xlabel=X_LABELS[column],
            labels=labels,
            title=title or sweep_title(self.settings),
        )


def load_sweep(folder: str | Path) -> Sweep:
    """The sweep in ``folder`` (runs.csv and sweep.json of ``striatal sweep``), its summary
    computed again from the rows (the same numbers as its summary.json: the bootstrap
    intervals are seeded by arm and init)."""
    path = Path(folder)
    settings = read_json(path / "sweep.json", what="sweep settings")
    if not isinstance(settings, dict) or not isinstance(settings.get("max_trials"), int):
        raise DataFileError(f"{path / 'sweep.json'} is not the settings of a striatal sweep")
    rows, _ = read_runs(path / "runs.csv")
    if not rows:
        raise DataFileError(f"{path / 'runs.csv'} holds no finished run")
    summary = summarise(rows, settings["max_trials"], settings)
    return Sweep(rows=sort_rows(rows), summary=summary, folder=path)


def load_run(folder: str | Path) -> Run:
    """The training run in ``folder`` (result.json, checkpoint.json, history.csv of
    ``striatal train``), as :func:`striatal.train` returned it."""
    rundir = RunDir(folder)
    result = read_result(rundir.result_path)
    run, _, state, _ = rundir.read_checkpoint()
    data = result.data
    if run != data.get("run_id"):
        raise DataFileError(
            f"{rundir.checkpoint_path} belongs to another run ({run}) than "
            f"{rundir.result_path} ({data.get('run_id')})"
        )
    history = rundir.read_history()
    robust = data.get("robust")
    return Run(
        success=bool(data.get("success")),
        trials=int(data.get("trials", state.trials_done)),
        W=result.W,
        theta_c=result.theta_c,
        seed=int(result.settings.get("seed", 0)),
        learner=result.learner,
        interrupted=bool(data.get("interrupted", False)),
        wall_seconds=float(data.get("wall_seconds", math.nan)),
        state=state,
        history=history,
        settings=result.settings,
        mean_policy_success=bool(data.get("mean_policy_success")),
        mean_policy_final_state=tuple(float(v) for v in data.get("mean_policy_final_state", ())),
        run_id=run,
        out=rundir.path,
        robust_report=robust if isinstance(robust, dict) else None,
    )


def load(path: str | Path) -> Sweep | Run:
    """The sweep or training run in folder ``path``: a :class:`Sweep` for a folder of
    ``striatal sweep`` (runs.csv, sweep.json), a :class:`striatal.experiments.training.Run`
    for one of ``striatal train`` (result.json, checkpoint.json, history.csv).

    ``path`` may also name one of those files: its folder is opened. DataFileError when
    the folder holds neither.
    """
    p = Path(path)
    if p.is_file() and p.name in (*SWEEP_FILES, "summary.json", RESULT, CHECKPOINT, HISTORY):
        p = p.parent
    if not p.is_dir():
        raise DataFileError(f"{path}: no such folder")
    if all((p / f).is_file() for f in SWEEP_FILES):
        return load_sweep(p)
    if all((p / f).is_file() for f in (RESULT, CHECKPOINT, HISTORY)):
        return load_run(p)
    raise DataFileError(
        f"{path} is neither a sweep folder (runs.csv, sweep.json) nor a training run's "
        "(result.json, checkpoint.json, history.csv)"
    )
