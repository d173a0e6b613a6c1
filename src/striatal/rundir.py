"""A training run's folder: settings, checkpoint, history.csv and result.json.

One place owns the file formats of a run, so ``striatal train``, the Python API
(:func:`striatal.train`) and every command that reads a result (``simulate
--result``, ``figure``, ``interpret``, ``robustness``) agree on them:

- ``checkpoint.json``: {"version", "run_id", "settings", "state"} (:class:`LearnerState`);
- ``history.csv``: one row per trial, header :func:`striatal.learners.state.history_columns`
  of the learner's own columns ("sigma" for chapter and rpe, "explore" for pgpe);
- ``result.json``: the run's outcome, its settings and run id (:func:`read_result`
  is the one reader).

Every file is written atomically (:mod:`striatal.files`); the settings carry a
schema version (:data:`SETTINGS_SCHEMA`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, TextIO

from striatal.errors import DataFileError, ParameterError
from striatal.files import atomic_write_text, csv_text, read_csv, read_json, write_json
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
from striatal.rollout import Protocol

__all__ = [
    "CHECKPOINT",
    "CHECKPOINT_VERSION",
    "HISTORY",
    "RESULT",
    "SETTINGS_SCHEMA",
    "ResultFile",
    "RunDir",
    "Setup",
    "read_history",
    "read_result",
    "result_of",
    "run_settings",
]

CHECKPOINT = "checkpoint.json"
HISTORY = "history.csv"
RESULT = "result.json"
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
        "integrator": "rk4, u held over each step",
        "reward_timing": "update at the reward event only (r_t = 0 elsewhere)",
        "schema": SETTINGS_SCHEMA,
    }


def setup_of(settings: Any, where: str) -> Setup:
    """The run that ``settings`` describe; DataFileError naming ``where`` if they do not."""
    if not isinstance(settings, dict):
        raise DataFileError(f"{where} is corrupted: its settings are not an object")
    if settings.get("schema") != SETTINGS_SCHEMA:
        raise DataFileError(
            f"{where} has settings schema {settings.get('schema')!r}; this striatal reads "
            f"schema {SETTINGS_SCHEMA} (start a fresh run)"
        )
    try:
        config = check_config(LearnerConfig(**settings["config"]))
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

    @property
    def checkpoint_path(self) -> Path:
        return self.path / CHECKPOINT

    @property
    def history_path(self) -> Path:
        return self.path / HISTORY

    @property
    def result_path(self) -> Path:
        return self.path / RESULT

    # -- checkpoint
    def write_checkpoint(self, settings: Mapping[str, Any], state: LearnerState) -> None:
        write_json(
            self.checkpoint_path,
            {"version": CHECKPOINT_VERSION, "settings": settings, "state": state.to_dict()},
        )

    def read_checkpoint(self) -> tuple[dict[str, Any], LearnerState]:
        """(settings, state) of checkpoint.json, both checked; else DataFileError."""
        path = self.checkpoint_path
        data = read_json(path, what="checkpoint")
        if not isinstance(data, dict) or data.get("version") != CHECKPOINT_VERSION:
            raise DataFileError(
                f"checkpoint {path} is not a striatal train checkpoint "
                f"(version {CHECKPOINT_VERSION})"
            )
        try:
            state = LearnerState.from_dict(data["state"])
            settings = data["settings"]
        except (KeyError, TypeError, ParameterError) as exc:
            raise DataFileError(f"checkpoint {path} is corrupted: {exc}") from None
        if not isinstance(settings, dict):
            raise DataFileError(f"checkpoint {path} is corrupted: its settings are not an object")
        return settings, state

    # -- history
    def start_history(self, columns: Sequence[str]) -> None:
        """An empty history.csv with ``columns``."""
        atomic_write_text(self.history_path, csv_text(columns, []))

    def keep_history(self, n_rows: int, columns: Sequence[str]) -> None:
        """Keep the header and the first ``n_rows`` rows (those a checkpoint covers)."""
        path = self.history_path
        if not path.exists():
            if n_rows:
                raise DataFileError(
                    f"history {path} is missing but the checkpoint has {n_rows} trials"
                )
            self.start_history(columns)
            return
        lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
        if len(lines) < 1 + n_rows or lines[0].strip() != ",".join(columns):
            raise DataFileError(
                f"history {path} has fewer rows than the checkpoint's {n_rows} trials "
                "or another header"
            )
        atomic_write_text(path, "".join(lines[: 1 + n_rows]))

    def open_history(self) -> TextIO:
        """history.csv opened for appending rows (:func:`history_line`)."""
        return self.history_path.open("a", encoding="utf-8", newline="")

    def read_history(self) -> History:
        return read_history(self.history_path)

    # -- result
    def write_result(self, payload: Mapping[str, Any]) -> None:
        write_json(self.result_path, payload)

    def read_result(self) -> ResultFile:
        return read_result(self.result_path)


def history_line(record: TrialRecord) -> str:
    """One history.csv line (no header) for ``record``."""
    return csv_text(record.columns, [record.row()]).split("\n", 1)[1]


def _learner_of_columns(columns: Sequence[str]) -> str:
    for name, rule in RULES.items():
        if tuple(columns) == history_columns(rule.history_columns):
            return name
    return "unknown"


def read_history(path: str | Path, *, learner: str | None = None) -> History:
    """Parse a history.csv of ``striatal train`` or raise DataFileError.

    The learner is taken from the result.json or checkpoint.json beside it, else
    from the columns (sigma: chapter or rpe; explore: pgpe).
    """
    p = Path(path)
    rows = read_csv(p, what="history")
    if not rows:
        raise DataFileError(f"history {p} has no trials")
    columns = tuple(rows[0].keys())
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
    out: list[tuple[float, ...]] = []
    for line, row in enumerate(rows, start=2):
        values = []
        for c in columns:
            cell = row.get(c)
            try:
                v = float(cell) if cell != "" else math.nan  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise DataFileError(
                    f"history {p} line {line}: column {c} is not a number ({cell!r})"
                ) from None
            if not math.isfinite(v) and c not in ("min_abs_theta_swingup",):
                raise DataFileError(f"history {p} line {line}: column {c} is not finite")
            values.append(v)
        out.append(tuple(values))
    return History(learner=learner, columns=columns, rows=tuple(out), reward_kind=reward_kind)


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
    settings = data.get("settings", {})
    if not isinstance(settings, dict):
        raise DataFileError(f"{where}: its settings must be an object, got {settings!r}")
    ctrl = settings.get("controller", {})
    plant_d = settings.get("plant", {})
    if not isinstance(ctrl, dict) or not isinstance(plant_d, dict):
        raise DataFileError(f"{where}: settings.controller and settings.plant must be objects")
    try:
        controller = Controller(
            gains=tuple(data["W"]),
            theta_c=data["theta_c"],
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
    learner = data.get("learner", settings.get("learner")) or "chapter"
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
