"""A training run's folder: settings, checkpoint, history.csv and result.json.

One place owns the file formats of a run, so ``striatal train``, the Python API
(:func:`striatal.train`) and every command that reads a result (``simulate
--result``, ``figure``, ``interpret``, ``robustness``) agree on them:

- ``checkpoint.json``: {"version", "run_id", "settings", "state", "history_sha256"}
  (:class:`LearnerState`; the hash of the history.csv rows it covers);
- ``history.csv``: one row per trial, header :func:`striatal.learners.state.history_columns`
  of the learner's own columns ("sigma" for chapter and rpe, "explore" for pgpe);
- ``result.json``: the run's outcome, its settings and run id (:func:`read_result`
  is the one reader).

Every file is written atomically (:mod:`striatal.io.files`); the settings carry a
schema version (:data:`SETTINGS_SCHEMA`). A run's id (:func:`run_id`, a hash of its
starting settings) is stored in checkpoint.json and result.json, and the checkpoint
holds the hash of the history rows it covers, so a resume proves that the three
files belong to one run. :meth:`RunDir.lock` keeps a second process out of a folder
in use.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import itertools
import json
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from striatal.errors import DataFileError, ParameterError
from striatal.io import schema
from striatal.io.files import (
    atomic_write_stream,
    atomic_write_text,
    count_line_ends,
    csv_text,
    path_lock,
    read_json,
    read_lines,
    write_json,
)
from striatal.learners import (
    RULES,
    History,
    LearnerConfig,
    LearnerState,
    TrialRecord,
    check_config,
    rule_of,
)
from striatal.learners.state import history_columns
from striatal.params import Controller, Plant, Simulation, check_seed
from striatal.sim.rollout import Protocol

__all__ = [
    "CHECKPOINT",
    "CHECKPOINT_VERSION",
    "HISTORY",
    "RESULT",
    "RUN_FILES",
    "SETTINGS_SCHEMA",
    "ResultFile",
    "RunDir",
    "Setup",
    "history_line",
    "read_history",
    "read_result",
    "result_of",
    "run_id",
    "run_settings",
    "setup_of",
]

CHECKPOINT = "checkpoint.json"
HISTORY = "history.csv"
RESULT = "result.json"
#: The files of a run folder (none may be a folder: checked before a run computes).
RUN_FILES = (CHECKPOINT, HISTORY, RESULT)
#: Version of checkpoint.json (2: the learner's memory by name, settings with a schema).
CHECKPOINT_VERSION = 2
#: Version of the settings object in checkpoint.json and result.json.
SETTINGS_SCHEMA = 2


@dataclass(frozen=True)
class Setup:
    """Everything a run is made of, rebuilt from its settings."""

    config: LearnerConfig
    template: Controller
    plant: Plant
    sim: Simulation
    seed: int
    protocol: Protocol


def run_settings(
    config: LearnerConfig,
    template: Controller,
    plant: Plant,
    sim: Simulation,
    *,
    seed: int,
    init: str,
    W0: Sequence[float],
    protocol: Protocol | None = None,
) -> dict[str, Any]:
    """The settings object of a run (stored in checkpoint.json and result.json)."""
    return {
        "learner": config.learner,
        "init": init,
        "W0": list(W0),
        "theta_c0": template.theta_c,
        "seed": seed,
        "config": config.to_dict(),
        "controller": {
            "balance_sign": template.balance_sign,
            "switch": template.switch,
            "inhibition": template.inhibition,
        },
        "plant": asdict(plant),
        "trial": {"dt": sim.dt, "duration": sim.duration, "theta0": sim.theta0, "x0": sim.x0},
        "protocol": asdict(protocol or Protocol()),
        "integrator": (
            "rk4, the force of eq 12 held over each step"
            if config.robust
            else "rk4, u held over each step"
        ),
        "reward_timing": "update at the reward event only (r_t = 0 elsewhere)",
        "schema": SETTINGS_SCHEMA,
    }


def run_id(settings: Mapping[str, Any]) -> str:
    """The id of a run: a hash of its starting settings (a run is determined by them)."""
    text = json.dumps(settings, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def setup_of(settings: Any, where: str) -> Setup:
    """The run that ``settings`` describe; DataFileError naming ``where`` if they do not."""
    if not isinstance(settings, dict):
        raise DataFileError(f"{where} is corrupted: its settings are not an object")
    if settings.get("schema") != SETTINGS_SCHEMA:
        raise DataFileError(
            f"{where} has settings schema {settings.get('schema')!r}; this striatal reads "
            f"schema {SETTINGS_SCHEMA} (start a fresh run)"
        )
    for part in ("config", "controller", "plant", "trial", "protocol"):
        if part in settings and not isinstance(settings[part], dict):
            raise DataFileError(
                f"{where} is corrupted: its settings.{part} is not an object, "
                f"got {settings[part]!r}"
            )
    try:
        fields = dict(settings["config"])
        if "max_step" in fields and fields["max_step"] is None:
            fields["max_step"] = math.inf  # JSON has no inf: null is "no bound"
        config = check_config(LearnerConfig(**fields))
        template = Controller(
            gains=settings["W0"], theta_c=settings["theta_c0"], **settings["controller"]
        )
        plant = Plant(**settings["plant"])
        sim = Simulation(**settings["trial"])
        seed = check_seed(settings["seed"])
        protocol = Protocol(**settings["protocol"])
    except KeyError as exc:
        raise DataFileError(f"{where} is corrupted: its settings lack {exc}") from None
    except (TypeError, ValueError) as exc:  # ParameterError is a ValueError
        raise DataFileError(f"{where} is corrupted: settings: {exc}") from None
    return Setup(config, template, plant, sim, seed, protocol)


class RunDir:
    """The files of one run in folder ``path`` (created on the first write)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._history: Any = None
        self._hash = hashlib.sha256()

    @property
    def checkpoint_path(self) -> Path:
        return self.path / CHECKPOINT

    @property
    def history_path(self) -> Path:
        return self.path / HISTORY

    @property
    def result_path(self) -> Path:
        return self.path / RESULT

    # -- one process at a time
    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold an exclusive lock on the folder or raise DataFileError.

        A :class:`filelock.FileLock` (:func:`striatal.io.files.path_lock`): its lock file
        is outside the folder, so nothing is left behind in it, and the lock goes away
        with the process, even after SIGKILL.
        """
        from filelock import Timeout

        try:
            self.path.mkdir(parents=True, exist_ok=True)
            lock = path_lock(self.path)
            lock.acquire()
        except Timeout:
            raise DataFileError(
                f"output folder {self.path} is in use by another striatal process"
            ) from None
        except OSError as exc:
            raise DataFileError(f"cannot use output folder {self.path}: {exc.strerror}") from None
        try:
            yield
        finally:
            lock.release()

    def clear(self) -> None:
        """Remove a previous run's checkpoint and result (a fresh start over an old run)."""
        for p in (self.checkpoint_path, self.result_path):
            with contextlib.suppress(FileNotFoundError):
                p.unlink()

    # -- checkpoint
    def write_checkpoint(self, run: str, settings: Mapping[str, Any], state: LearnerState) -> None:
        """checkpoint.json for ``state``: flushes history.csv first, so it covers its rows."""
        if self._history is not None:
            with self._naming_history():
                self._history.flush()
        write_json(
            self.checkpoint_path,
            {
                "version": CHECKPOINT_VERSION,
                "run_id": run,
                "settings": settings,
                "state": state.to_dict(),
                "history_sha256": self._hash.hexdigest(),
            },
        )

    def read_checkpoint(self) -> tuple[str, dict[str, Any], LearnerState, str]:
        """(run id, settings, state, history hash) of checkpoint.json; else DataFileError.

        Checked against :class:`striatal.io.schema.CheckpointModel`, the learner's memory
        included (:func:`striatal.io.schema.check_memory`).
        """
        path = self.checkpoint_path
        data = read_json(path, what="checkpoint")
        where = f"checkpoint {path}"
        if not isinstance(data, dict) or data.get("version") != CHECKPOINT_VERSION:
            raise DataFileError(
                f"{where} is not a striatal train checkpoint (version {CHECKPOINT_VERSION})"
            )
        model = schema.validated(schema.CheckpointModel, data, where)
        learner = model.settings.get("learner")
        if isinstance(learner, str):
            schema.check_memory(learner, model.state, where)
        try:
            state = LearnerState.from_dict(data["state"])
        except ParameterError as exc:
            raise DataFileError(f"{where} is corrupted: {exc}") from None
        return model.run_id, dict(model.settings), state, model.history_sha256

    # -- history
    def start_history(self, columns: Sequence[str]) -> None:
        """An empty history.csv with ``columns``, opened for appending."""
        header = csv_text(columns, [])
        atomic_write_text(self.history_path, header)
        self._hash = hashlib.sha256(header.encode("utf-8"))
        self._open()

    def keep_history(self, n_rows: int, columns: Sequence[str], digest: str) -> None:
        """Keep the header and the first ``n_rows`` rows (those a checkpoint covers).

        DataFileError unless they hash to ``digest`` (the checkpoint's): history.csv
        belongs to another run, or was edited.
        """
        path = self.history_path
        if not path.exists():
            raise DataFileError(f"history {path} is missing but the checkpoint has {n_rows} trials")
        h = hashlib.sha256()
        kept, more = 0, False  # lines hashed; whether a line follows them
        with contextlib.closing(read_lines(path, what="history")) as lines:
            for line in lines:
                if kept == 0 and line.strip() != ",".join(columns):
                    break
                if kept == 1 + n_rows:
                    more = True
                    break
                h.update(line.encode("utf-8"))
                kept += 1
        if kept < 1 + n_rows:
            raise DataFileError(
                f"history {path} has fewer rows than the checkpoint's {n_rows} trials "
                "or another header"
            )
        if h.hexdigest() != digest:
            raise DataFileError(
                f"history {path} does not belong to the run in {self.checkpoint_path} "
                "(its rows differ from the checkpointed ones)"
            )
        if more:  # the rows after the checkpoint's go: copied line by line, not held

            def first_lines(fh: TextIO) -> None:
                with contextlib.closing(read_lines(path, what="history")) as lines:
                    fh.writelines(itertools.islice(lines, 1 + n_rows))

            atomic_write_stream(path, first_lines)
        self._hash = h
        self._open()

    @contextlib.contextmanager
    def _naming_history(self) -> Iterator[None]:
        """An OSError of history.csv (a full disk: ENOSPC names no file) as DataFileError."""
        try:
            yield
        except OSError as exc:
            raise DataFileError(
                f"cannot write {self.history_path}: {exc.strerror or exc}"
            ) from None

    def _open(self) -> None:
        with self._naming_history():
            self._history = self.history_path.open("a", encoding="utf-8", newline="")

    def append(self, record: TrialRecord) -> None:
        """One row of history.csv (buffered; flushed at each checkpoint and at close)."""
        line = history_line(record)
        if self._history is not None:
            with self._naming_history():
                self._history.write(line)
        self._hash.update(line.encode("utf-8"))

    def close_history(self) -> None:
        if self._history is not None:
            history, self._history = self._history, None
            with self._naming_history():
                history.close()

    def read_history(self) -> History:
        return read_history(self.history_path)

    # -- result
    def write_result(self, payload: Mapping[str, Any]) -> None:
        write_json(self.result_path, payload)

    def read_result(self) -> ResultFile:
        return read_result(self.result_path)

    def check_result_run(self, run: str) -> None:
        """DataFileError if a result.json in the folder belongs to another run than ``run``
        (or breaks its schema: it is read as every result.json is)."""
        if not self.result_path.exists():
            return
        other = self.read_result().data.get("run_id")
        if other != run:
            raise DataFileError(
                f"result {self.result_path} belongs to another run ({other}) than the "
                f"checkpoint ({run}); move it away to resume"
            )


def history_line(record: TrialRecord) -> str:
    """One history.csv line (no header) for ``record``."""
    return csv_text(record.columns, [record.row()]).split("\n", 1)[1]


def _learner_of_columns(columns: Sequence[str]) -> str:
    for name, rule in RULES.items():
        if tuple(columns) == history_columns(rule.history_columns):
            return name
    return "unknown"


#: Rows of history.csv parsed at a time: the text of one chunk is all a reader holds
#: beside the numbers.
HISTORY_CHUNK = 1024


def read_history(path: str | Path, *, learner: str | None = None) -> History:
    """Parse a history.csv of ``striatal train`` or raise DataFileError.

    The learner is taken from the result.json or checkpoint.json beside it, else
    from the columns (sigma: chapter or rpe; explore: pgpe). The file is read line by
    line (:func:`striatal.io.files.read_lines`), :data:`HISTORY_CHUNK` rows at a time
    into float arrays: the reader holds the numbers (8 bytes a cell) and one chunk's
    text, never the file's.
    """
    p = Path(path)
    with contextlib.closing(read_lines(p, what="history")) as lines:
        reader = csv.reader(lines)
        try:
            columns = tuple(next(reader, ()))
        except csv.Error as exc:
            raise DataFileError(f"history {p} cannot be read as CSV: {exc}") from None
        if len(set(columns)) != len(columns):
            raise DataFileError(f"history {p} names a column twice")
        reward_kind = "sparse"
        settings = _sibling_settings(p)
        if settings is not None:
            learner = learner or settings.get("learner")
            cfg = settings.get("config")
            if isinstance(cfg, dict) and cfg.get("reward") in ("sparse", "shaped"):
                reward_kind = cfg["reward"]
        learner = learner or _learner_of_columns(columns)
        if learner in RULES:
            want = history_columns(RULES[learner].history_columns)
            missing = [c for c in want if c not in columns]
            if missing:
                raise DataFileError(f"history {p} lacks the column(s) {', '.join(missing)}")
        for c in ("trial", "reward", "W1", "W2", "W3", "W4", "W5", "W6", "theta_c", "success"):
            if c not in columns:
                raise DataFileError(f"history {p} lacks the column {c}")
        kinds = [schema.HISTORY_CELLS.get(c, "finite") for c in columns]
        # every row but the header ends a line: one array of at most that many rows
        data = np.empty((max(count_line_ends(p, what="history"), 1), len(columns)))
        n = 0  # rows parsed
        rows: list[list[str]] = []
        try:
            for line, row in enumerate(reader, start=2):
                if len(row) != len(columns):
                    raise DataFileError(
                        f"history {p} line {line}: {len(row)} cells, expected {len(columns)}"
                    )
                rows.append(row)
                if len(rows) == HISTORY_CHUNK:
                    n = _history_chunk(rows, columns, kinds, p, data, n)
                    rows = []
        except csv.Error as exc:
            raise DataFileError(f"history {p} cannot be read as CSV: {exc}") from None
    if rows:
        n = _history_chunk(rows, columns, kinds, p, data, n)
    if n == 0:
        raise DataFileError(f"history {p} has no trials")
    # a shorter file than its line ends say (CR LF, quoted line ends) is copied once
    data = data[:n] if n > len(data) // 2 else data[:n].copy()
    trial = data[:, columns.index("trial")]
    if np.any(trial != trial[0] + np.arange(len(trial))):
        raise DataFileError(
            f"history {p}: its trial numbers are not consecutive (a row repeated or missing)"
        )
    if settings is None and "reward" in columns:
        # no settings beside it: the sparse reward takes only the values of eqs 24-25
        reward = data[:, columns.index("reward")]
        if not np.all(np.isin(reward, (10.0, 0.0, -5.0))):
            reward_kind = "shaped"
    return History(learner=learner, columns=columns, data=data, reward_kind=reward_kind)


def _history_chunk(
    rows: list[list[str]],
    columns: Sequence[str],
    kinds: Sequence[str],
    p: Path,
    data: np.ndarray,
    n: int,
) -> int:
    """Parse ``rows`` into ``data[n : n + len(rows)]``, each cell as
    :data:`striatal.io.schema.HISTORY_CELLS` says it may be (a bad cell is named by
    :func:`_history_cell`, with its line); return the rows parsed so far."""
    if n + len(rows) > len(data):
        raise DataFileError(f"history {p} changed while it was read")
    first = n + 2  # the file's line of rows[0] (a line per row, after the header)
    for j, (cells, c, kind) in enumerate(zip(zip(*rows, strict=True), columns, kinds, strict=True)):
        try:
            col = np.fromiter(map(float, cells), float, count=len(cells))
            empty = None
        except ValueError:  # an empty cell, or text: the empty ones are NaN if allowed
            empty = np.fromiter((x == "" for x in cells), bool, count=len(cells))
            try:
                col = np.fromiter((float(x) if x else 0.0 for x in cells), float, len(cells))
            except ValueError:
                col = np.zeros(len(cells))
                empty = None
                _first_bad(cells, c, kind, p, first, np.ones(len(cells), bool))
        bad = ~np.isfinite(col)
        if kind == "flag":
            bad |= (col != 0.0) & (col != 1.0)
        elif kind == "count":
            bad |= (col < 0) | (col != np.floor(col))
        elif kind == "nonnegative":
            bad |= col < 0
        elif kind == "angle":
            bad |= (col <= 0) | (col > math.pi)
        if empty is not None:
            bad |= empty & (kind != "empty")
            if kind == "empty":
                bad &= ~empty
                col[empty] = math.nan
        if bad.any():
            _first_bad(cells, c, kind, p, first, bad)
        data[n : n + len(rows), j] = col
    return n + len(rows)


def _first_bad(
    cells: Sequence[str], column: str, kind: str, p: Path, first: int, bad: np.ndarray
) -> None:
    """Raise the DataFileError of the first cell of ``cells`` that :func:`_history_cell`
    refuses (``bad`` marks those that may be)."""
    for i in np.flatnonzero(bad):
        _history_cell(cells[int(i)], column, kind, f"history {p} line {first + int(i)}")
    raise DataFileError(f"history {p}: column {column} holds a cell it may not")


def _history_cell(cell: str | None, column: str, kind: str, where: str) -> float:
    """One history.csv cell as :data:`striatal.io.schema.HISTORY_CELLS` says it may be."""
    if cell is None:
        raise DataFileError(f"{where}: column {column} is missing (a short row)")
    if cell == "":
        if kind == "empty":
            return math.nan
        raise DataFileError(f"{where}: column {column} is empty")
    try:
        v = float(cell)
    except ValueError:
        raise DataFileError(f"{where}: column {column} is not a number ({cell!r:.40})") from None
    if not math.isfinite(v):
        raise DataFileError(f"{where}: column {column} is not finite")
    if kind == "flag" and v not in (0.0, 1.0):
        raise DataFileError(f"{where}: column {column} must be 0 or 1, got {cell!r:.40}")
    if kind == "count" and (v < 0 or v != int(v)):
        raise DataFileError(
            f"{where}: column {column} must be a whole number >= 0, got {cell!r:.40}"
        )
    if kind == "nonnegative" and v < 0:
        raise DataFileError(f"{where}: column {column} must be >= 0, got {cell!r:.40}")
    if kind == "angle" and not 0 < v <= math.pi:
        raise DataFileError(f"{where}: column {column} must be in (0, pi], got {cell!r:.40}")
    return v


def _learner_name(value: object, where: str) -> str | None:
    """``value`` if it can name a learner (text, or None: not stated), else DataFileError."""
    if value is None or isinstance(value, str):
        return value
    raise DataFileError(f"{where}: learner must be a name, got {value!r}")


def _sibling_settings(history_path: Path) -> dict[str, Any] | None:
    """The settings in the result.json or checkpoint.json beside a history.csv, if readable."""
    for name in (RESULT, CHECKPOINT):
        f = history_path.parent / name
        if f.exists():
            try:
                data = read_json(f)
            except DataFileError:
                continue
            s = data.get("settings") if isinstance(data, dict) else None
            if isinstance(s, dict):
                schema.validated(
                    schema.RunSettingsModel, s, f"{f}, beside {history_path}: its settings"
                )
                return s
    return None


@dataclass(frozen=True)
class ResultFile:
    """What every command takes from a result.json of ``striatal train``."""

    path: Path
    W: tuple[float, ...]
    theta_c: float
    controller: Controller
    plant: Plant
    learner: str
    success: bool | None
    trials: int | None
    settings: dict[str, Any]
    data: dict[str, Any]


def result_of(data: Any, path: str | Path) -> ResultFile:
    """:func:`read_result` of already-parsed JSON ``data`` read from ``path``."""
    p = Path(path)
    where = f"result {p}" if str(path) else "result"
    if not isinstance(data, dict) or "W" not in data or "theta_c" not in data:
        raise DataFileError(f"{where} is not a striatal result.json (no W and theta_c)")
    schema.validated(schema.ResultModel, data, where)
    W, theta_c = data["W"], data["theta_c"]
    settings = data.get("settings", {})
    if not isinstance(settings, dict):
        raise DataFileError(f"{where}: its settings must be an object, got {settings!r}")
    ctrl = settings.get("controller", {})
    plant_d = settings.get("plant", {})
    if not isinstance(ctrl, dict) or not isinstance(plant_d, dict):
        raise DataFileError(f"{where}: settings.controller and settings.plant must be objects")
    try:
        controller = Controller(
            gains=tuple(W),
            theta_c=theta_c,
            balance_sign=ctrl.get("balance_sign", "corrected"),
            switch=ctrl.get("switch", "hard"),
            inhibition=ctrl.get("inhibition", 50.0),
        )
        plant = Plant(
            **{
                k: plant_d[k]
                for k in ("cart_mass", "pole_mass", "length", "gravity")
                if k in plant_d
            }
        )
    except ParameterError as exc:
        raise DataFileError(f"{where} holds an unusable controller: {exc}") from None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DataFileError(f"{where} lacks W, theta_c or settings: {exc!r}") from None
    stated = _learner_name(settings.get("learner"), f"{where}: its settings")
    if "learner" in data:
        stated = _learner_name(data["learner"], where)
    learner = stated or "chapter"
    success = data.get("success")
    trials = data.get("trials")
    return ResultFile(
        path=p,
        W=controller.gains,
        theta_c=controller.theta_c,
        controller=controller,
        plant=plant,
        learner=str(learner),
        success=bool(success) if isinstance(success, bool) else None,
        trials=trials if isinstance(trials, int) else None,
        settings=settings,
        data=data,
    )


def read_result(path: str | Path) -> ResultFile:
    """The one reader of a result.json of ``striatal train`` (DataFileError if unusable)."""
    return result_of(read_json(path, what="result"), path)


def rule_columns(config: LearnerConfig) -> tuple[str, ...]:
    """The history.csv header of a run with ``config``."""
    return history_columns(rule_of(config).history_columns)
