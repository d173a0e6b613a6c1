"""runs.csv: one row per finished run, appended as runs finish, read back on resume.

Every row is checked against its schema (:class:`striatal.io.schema.RunRow`). A last
line that a kill cut short is dropped on reading; a row whose (arm, init, seed) an
earlier row already has, with the same results, is dropped too, so no run is counted
twice; one with other results is refused.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from striatal.errors import DataFileError
from striatal.io import schema
from striatal.io.files import csv_text, lines_marking_last, read_lines
from striatal.learners.state import FirstSuccess
from striatal.params import N_GAINS

RUN_COLUMNS: tuple[str, ...] = (
    "arm",
    "role",
    "method",
    "learner",
    "init",
    "seed",
    "alpha",
    "gamma",
    "success",
    "trials",
    *(f"W{i}" for i in range(1, N_GAINS + 1)),
    "theta_c",
    *(f"W0_{i}" for i in range(1, N_GAINS + 1)),
    "theta_c0",
    "mean_policy_success",
    "robust",
    "simulations",
    "simulated_seconds",
    "eval_simulations",
    "pass_rate_W0",
    "pass_rate",
    "wall_seconds",
    "imagined_simulations",
    "imagined_seconds",
    "settings_id",
    "first_success_trials",
    "first_success_simulations",
    "first_success_seconds",
    "margin_reached",
)
#: The columns a runs.csv had before each row carried the id of its settings: read with
#: an empty ``settings_id`` (a sweep checks such rows against its sweep.json alone).
COLUMNS_BEFORE_SETTINGS_ID = RUN_COLUMNS[:-5]
#: The columns a runs.csv had before imagined trials were recorded: read as 0 imagined.
COLUMNS_BEFORE_IMAGINED = RUN_COLUMNS[:-7]
#: The columns a runs.csv had before the first-success columns: read with the run's
#: totals as its first success (every run then stopped at it) and no margin test.
COLUMNS_BEFORE_FIRST_SUCCESS = RUN_COLUMNS[:-4]
FIRST_SUCCESS_COLUMNS = RUN_COLUMNS[-4:]
_INT_COLUMNS = ("seed", "trials", "simulations", "eval_simulations", "imagined_simulations")


_BOOL_COLUMNS = ("success", "mean_policy_success")


_STR_COLUMNS = ("arm", "role", "method", "learner", "init")


def first_success_columns(
    row: dict[str, Any], first: FirstSuccess | None, margin_reached: bool | None
) -> dict[str, Any]:
    """runs.csv's first-success columns of a run whose ``row`` holds its totals: the
    trials, simulations and simulated seconds to its first success (a run that learned on
    after it, ``margin_after_success``: ``first``; any other: its totals if it succeeded;
    nan if it did not) and ``margin_reached`` (1/0 with margin_after_success, else nan)."""
    if first is not None:
        to_first = (float(first.trials), float(first.simulations), first.simulated_seconds)
    elif row["success"]:
        to_first = (float(row["trials"]), float(row["simulations"]), row["simulated_seconds"])
    else:
        to_first = (math.nan, math.nan, math.nan)
    return {
        "first_success_trials": to_first[0],
        "first_success_simulations": to_first[1],
        "first_success_seconds": float(to_first[2]),
        "margin_reached": math.nan if margin_reached is None else float(margin_reached),
    }


def row_text(row: dict[str, Any]) -> str:
    """One CSV line (no header) of ``row`` in RUN_COLUMNS order (``settings_id``: the
    row's, else empty)."""
    cells = [
        int(row[c]) if c in _BOOL_COLUMNS else row.get(c, "") if c == "settings_id" else row[c]
        for c in RUN_COLUMNS
    ]
    return csv_text(RUN_COLUMNS, [cells]).split("\n", 1)[1]


def _parse_row(cells: list[str], columns: tuple[str, ...] = RUN_COLUMNS) -> dict[str, Any]:
    if len(cells) != len(columns):
        raise ValueError(f"{len(cells)} cells, expected {len(columns)}")
    try:
        schema.RunRow.model_validate(dict(zip(columns, cells, strict=True)))
    except schema.ValidationError as exc:
        raise ValueError(schema.one_line(exc, "").removeprefix(": ")) from None
    row: dict[str, Any] = {"imagined_simulations": 0, "imagined_seconds": 0.0, "settings_id": ""}
    for name, cell in zip(columns, cells, strict=True):
        if name == "settings_id":
            row[name] = cell
        elif name in _STR_COLUMNS:
            if not cell:
                raise ValueError(f"empty {name}")
            row[name] = cell
        elif name in _INT_COLUMNS:
            row[name] = int(cell)
        elif name in _BOOL_COLUMNS:
            if cell not in ("0", "1"):
                raise ValueError(f"{name} must be 0 or 1, got {cell!r}")
            row[name] = cell == "1"
        else:
            row[name] = float(cell) if cell else math.nan
    if "margin_reached" not in columns:  # an older file: every run stopped at its success
        row.update(first_success_columns(row, None, None))
    return row


def read_runs(path: Path, *, max_trials: int | None = None) -> tuple[list[dict[str, Any]], str]:
    """(rows, clean text) of runs.csv; a last line that does not parse is dropped.

    A last line without its newline or that does not parse is what a kill during
    a write leaves; any other bad line raises DataFileError. A file written before the
    imagined columns were recorded reads with 0 imagined trials, one written before
    ``settings_id`` with an empty id (the clean text of either has today's columns).
    A row whose (arm, init, seed) an earlier row already has is dropped (the first is
    kept) if it agrees with it (wall time aside), so no run is counted twice; one that
    does not is refused. With ``max_trials`` (the sweep's budget), a row of more trials
    is refused.
    """
    if not path.exists():
        return [], csv_text(RUN_COLUMNS, [])
    with contextlib.closing(read_lines(path, what="runs file")) as lines:
        return _read_runs(path, lines, max_trials)


def _read_runs(
    path: Path, lines: Iterator[str], max_trials: int | None
) -> tuple[list[dict[str, Any]], str]:
    head = next(lines, "")
    if not head.endswith("\n"):
        return [], csv_text(RUN_COLUMNS, [])
    known = (
        RUN_COLUMNS,
        COLUMNS_BEFORE_FIRST_SUCCESS,
        COLUMNS_BEFORE_SETTINGS_ID,
        COLUMNS_BEFORE_IMAGINED,
    )
    columns = {",".join(c): c for c in known}.get(head.strip())
    if columns is None:
        if head.startswith("arm,"):
            raise DataFileError(
                f"runs file {path} has the columns of another striatal version (an older "
                "one, before simulations or the robust column were recorded); use another --out"
            )
        raise DataFileError(f"runs file {path} does not have the header of a striatal sweep")
    rows: list[dict[str, Any]] = []
    kept = [head]
    seen: dict[tuple[str, str, int], dict[str, Any]] = {}
    for i, line, last in lines_marking_last(lines, start=2):
        try:
            if not line.endswith("\n"):
                raise ValueError("line cut short")
            cells = next(csv.reader(io.StringIO(line)))
            row = _parse_row(cells, columns)
        except (ValueError, StopIteration, csv.Error) as exc:
            if last:
                break
            raise DataFileError(f"runs file {path} line {i} is malformed: {exc}") from None
        if max_trials is not None and row["trials"] > max_trials:
            raise DataFileError(
                f"runs file {path} line {i}: trials {row['trials']} exceed the sweep's "
                f"budget of {max_trials}"
            )
        key = (row["arm"], row["init"], row["seed"])
        if key in seen:
            schema.unique_rows(
                [(i - 1, seen[key]), (i, row)],
                ("arm", "init", "seed"),
                f"runs file {path}",
                same=[c for c in RUN_COLUMNS if c not in ("wall_seconds", "settings_id")],
            )
            continue
        seen[key] = row
        rows.append(row)
        kept.append(line)
    if columns is not RUN_COLUMNS:  # an older file: its rows again, with today's columns
        return rows, csv_text(RUN_COLUMNS, []) + "".join(row_text(r) for r in rows)
    return rows, "".join(kept)


def sort_rows(rows: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(rows, key=lambda r: (r["arm"], r["init"], int(r["seed"])))
