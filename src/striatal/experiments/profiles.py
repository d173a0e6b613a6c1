"""Performance profiles: the fraction of seeds solved within a budget, per arm and init.

For an arm run on n seeds, the profile at budget b is

    F(b) = #{seeds solved with cost <= b} / n,

a step function that rises from 0 to the arm's success rate at the largest cost
any of its seeds used. Unsolved seeds stay in n, so F is an honest
solved-within-budget rate, never a rate among the solved. Each point carries
its Wilson 95 % interval (:func:`striatal.experiments.stats.wilson_interval`; a pointwise
band, not a simultaneous one).

The cost is read from a sweep folder's ``runs.csv``: ``simulations`` (every
simulated trial the arm ran) or ``simulated_seconds`` when the file has those
columns, else ``trials`` (learning trials only, which leaves out e.g. the
mean-policy reruns of ``--success-on mean``), with a note saying so. A sweep run
from more than one initial condition (``--init chapter,random``) gives one profile
per (arm, init): seeds started from different gains are never pooled.
"""

from __future__ import annotations

import contextlib
import csv
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from striatal.errors import DataFileError, ParameterError
from striatal.experiments.runs_csv import RUN_COLUMNS
from striatal.experiments.stats import wilson_interval
from striatal.io import schema
from striatal.io.files import lines_marking_last, read_lines

__all__ = [
    "NOTE_TRIALS_FALLBACK",
    "X_COLUMNS",
    "X_LABELS",
    "Profile",
    "SweepRun",
    "choose_x",
    "performance_profile",
    "profiles_of",
    "read_sweep_runs",
    "sweep_profiles",
]

#: The costs a profile can be drawn against, in order of preference.
X_COLUMNS: tuple[str, ...] = ("simulations", "simulated_seconds", "trials")
X_LABELS: Mapping[str, str] = {
    "simulations": "simulations run (every simulated trial)",
    "simulated_seconds": "simulated time [s]",
    "trials": "learning trials",
}
NOTE_TRIALS_FALLBACK = (
    "runs.csv has no 'simulations' column (a sweep from before it was recorded): "
    "the budget is learning trials, which leaves out any extra simulation an arm runs"
)


@dataclass(frozen=True)
class SweepRun:
    """One row of a sweep's runs.csv as a profile needs it."""

    arm: str
    seed: int
    success: bool
    costs: Mapping[str, float]
    init: str = ""


def read_sweep_runs(folder: Path) -> list[SweepRun]:
    """The rows of ``folder/runs.csv`` (written by ``striatal sweep``).

    Needs the columns ``arm``, ``seed``, ``success`` (0/1) and ``trials``; keeps
    ``simulations``, ``simulated_seconds`` and ``init`` when present. Each row is held to
    its schema (:class:`striatal.io.schema.RunRow`, or :class:`~striatal.io.schema.CostRow`
    for a file with fewer columns); a row repeated by (arm, init, seed) counts once, and
    one that disagrees is refused. A last line cut short (a kill during a write) is
    dropped; any other bad line raises DataFileError.
    """
    path = Path(folder) / "runs.csv"
    if not path.exists() and not path.is_symlink():
        raise DataFileError(f"{folder} has no runs.csv (is it a striatal sweep folder?)")
    with contextlib.closing(read_lines(path, what="runs file")) as lines:
        head = next(lines, "")
        if not head.endswith("\n"):
            raise DataFileError(f"runs file {path} is empty")
        header = next(csv.reader(io.StringIO(head)))
        missing = [c for c in ("arm", "seed", "success", "trials") if c not in header]
        if missing:
            raise DataFileError(f"runs file {path} lacks the column(s) {', '.join(missing)}")
        costs = [c for c in X_COLUMNS if c in header]
        # the whole schema of a row where the file has every column, the costs otherwise
        model = schema.RunRow if set(header) >= set(RUN_COLUMNS[:-1]) else schema.CostRow
        parsed: list[tuple[int, dict[str, Any]]] = []
        for i, line, last in lines_marking_last(lines, start=2):
            try:
                if not line.endswith("\n"):
                    raise ValueError("line cut short")
                cells = next(csv.reader(io.StringIO(line)))
                if len(cells) != len(header):
                    raise ValueError(f"{len(cells)} cells, expected {len(header)}")
                row = dict(zip(header, cells, strict=True))
                try:
                    model.model_validate(row)
                except schema.ValidationError as exc:
                    raise ValueError(schema.one_line(exc, "").removeprefix(": ")) from None
                empty = [c for c in costs if not row[c]]
                if empty:
                    raise ValueError(f"its {empty[0]} is empty")
                parsed.append((i, row))
            except (ValueError, StopIteration, csv.Error) as exc:
                if last:
                    break
                raise DataFileError(f"runs file {path} line {i} is malformed: {exc}") from None
    same = [c for c in header if c not in ("wall_seconds", "settings_id")]
    keyed = [(i, {**r, "init": r.get("init", "")}) for i, r in parsed]
    rows = schema.unique_rows(keyed, ("arm", "init", "seed"), f"runs file {path}", same=same)
    runs = [
        SweepRun(
            r["arm"],
            int(r["seed"]),
            r["success"] == "1",
            {c: float(r[c]) for c in costs},
            r["init"],
        )
        for r in rows
    ]
    return runs


def choose_x(available: Sequence[str], x: str | None) -> tuple[str, str]:
    """(column, note) for the budget axis.

    ``x`` None takes ``simulations`` if every file has it, else ``trials`` with
    :data:`NOTE_TRIALS_FALLBACK`. An ``x`` that some file lacks is refused.
    """
    if x is None:
        if "simulations" in available:
            return "simulations", ""
        return "trials", NOTE_TRIALS_FALLBACK
    if x not in X_COLUMNS:
        raise ParameterError(f"--x must be one of {', '.join(X_COLUMNS)}, got {x!r}")
    if x not in available:
        raise ParameterError(
            f"--x {x}: the runs.csv given have no {x!r} column (they have "
            f"{', '.join(c for c in X_COLUMNS if c in available)})"
        )
    return x, ""


@dataclass(frozen=True)
class Profile:
    """The performance profile of one arm (from one init, when its sweep ran several).

    ``init`` is the initial condition of its seeds, "" when the sweep had only one;
    ``budget`` (k,) ascending, starting at 0 and ending at the largest cost of any
    seed; ``solved`` (k,) the fraction of the ``runs`` seeds solved within each
    budget; ``low``/``high`` (k,) its pointwise Wilson 95 % band.
    """

    arm: str
    runs: int
    successes: int
    budget: np.ndarray
    solved: np.ndarray
    low: np.ndarray
    high: np.ndarray
    init: str = ""

    @property
    def name(self) -> str:
        """``arm``, or ``arm (init init)`` when the sweep ran several inits."""
        return f"{self.arm} ({self.init} init)" if self.init else self.arm

    @property
    def success_rate(self) -> float:
        return self.successes / self.runs

    def to_dict(self) -> dict[str, Any]:
        return {
            "arm": self.arm,
            "init": self.init or None,
            "runs": self.runs,
            "successes": self.successes,
            "budget": self.budget.tolist(),
            "solved": self.solved.tolist(),
            "low": self.low.tolist(),
            "high": self.high.tolist(),
        }


def performance_profile(
    arm: str, costs: Sequence[float], solved: Sequence[bool], init: str = ""
) -> Profile:
    """Profile of one arm from each seed's cost and whether it solved the task.

    Steps at every distinct cost of a solved seed; the last point is the largest
    cost of any seed (the budget the unsolved ones used), where F equals the
    success rate.
    """
    c = np.asarray(costs, dtype=float)
    ok = np.asarray(solved, dtype=bool)
    if c.shape != ok.shape or c.ndim != 1 or c.size == 0:
        raise ParameterError(f"arm {arm!r}: need one cost and one verdict per seed, at least one")
    if not np.all(np.isfinite(c)) or np.any(c < 0):
        raise ParameterError(f"arm {arm!r}: costs must be finite and >= 0")
    n = c.size
    steps = np.unique(c[ok])
    budget = np.unique(np.concatenate([[0.0], steps, [c.max()]]))
    counts = np.searchsorted(np.sort(c[ok]), budget, side="right")
    bands = [wilson_interval(int(k), n).bounds or [0.0, 1.0] for k in counts]
    return Profile(
        arm=arm,
        runs=n,
        successes=int(ok.sum()),
        budget=budget,
        solved=counts / n,
        low=np.array([b[0] for b in bands]),
        high=np.array([b[1] for b in bands]),
        init=init,
    )


def sweep_profiles(folders: Sequence[Path], x: str | None = None) -> tuple[list[Profile], str, str]:
    """(profiles, column, note): one profile per arm of every sweep folder.

    Arms are named ``arm`` with one folder and ``folder/arm`` with several. A folder
    whose runs started from more than one init gives one profile per (arm, init),
    its ``init`` set; otherwise ``init`` is "".
    """
    if not folders:
        raise ParameterError("give at least one sweep folder")
    per_folder = [(Path(f), read_sweep_runs(Path(f))) for f in folders]
    for folder, runs in per_folder:
        if not runs:
            raise DataFileError(f"{folder}/runs.csv holds no finished run")
    available = [c for c in X_COLUMNS if all(c in runs[0].costs for _, runs in per_folder)]
    column, note = choose_x(available, x)
    profiles = []
    for folder, runs in per_folder:
        prefix = "" if len(per_folder) == 1 else f"{folder.name}/"
        profiles += profiles_of(runs, column, prefix)
    return profiles, column, note


def profiles_of(runs: Sequence[SweepRun], column: str, prefix: str = "") -> list[Profile]:
    """One profile per arm of one sweep's ``runs`` against cost ``column``, named
    ``prefix + arm``; one per (arm, init), its ``init`` set, when the runs started from
    more than one init."""
    several = len({r.init for r in runs}) > 1
    profiles = []
    for arm, init in dict.fromkeys((r.arm, r.init if several else "") for r in runs):
        mine = [r for r in runs if r.arm == arm and (not several or r.init == init)]
        profiles.append(
            performance_profile(
                prefix + arm, [r.costs[column] for r in mine], [r.success for r in mine], init
            )
        )
    return profiles
