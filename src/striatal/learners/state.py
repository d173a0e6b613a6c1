"""What a learning run carries between trials and what it records of each trial.

:class:`LearnerState` is plain data, JSON-serialisable with the random
generator's state, so a run can be checkpointed and resumed to the same result.
Each rule keeps its own memory in ``memory`` (a flat name -> numbers mapping):
no field holds one rule's quantity under another's name.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.params import N_GAINS, check_theta_c

__all__ = [
    "BASE_COLUMNS",
    "FLAG_COLUMNS",
    "FirstSuccess",
    "History",
    "LearnerState",
    "TrialRecord",
    "checked_rng_state",
    "history_columns",
]

#: history.csv columns every learner writes before its own ones (the W and theta_c used).
BASE_COLUMNS = ("trial", "reward", "W1", "W2", "W3", "W4", "W5", "W6", "theta_c")
#: ... and after them: what happened in the trial.
FLAG_COLUMNS = ("min_abs_theta_swingup", "ended_at", "success", "fault", "early")


def history_columns(rule_columns: Sequence[str]) -> tuple[str, ...]:
    """The header of history.csv for a rule whose own columns are ``rule_columns``."""
    return (*BASE_COLUMNS, *rule_columns, *FLAG_COLUMNS)


Memory = tuple[tuple[str, tuple[float, ...]], ...]


@dataclass(frozen=True)
class FirstSuccess:
    """Where a run that learns on after its success (``margin_after_success``) first
    succeeded: its trials, simulations and simulated seconds [s] up to and with that
    success's checks, and the controller that passed them (W, theta_c)."""

    trials: int
    simulations: int
    simulated_seconds: float
    W: tuple[float, ...]
    theta_c: float


@dataclass(frozen=True)
class LearnerState:
    """Everything a run needs to continue: JSON-serialisable via :meth:`to_dict`.

    ``memory``: the rule's own quantities, name -> numbers (e.g. the chapter's
    eligibility trace D, pgpe's exploration std); see each rule's ``memory_names``.
    ``simulations``: every simulated trial so far, the learning trials and every
    success check that needed a trial of its own (a mean-policy rerun, the jitter
    corners); ``simulated_seconds``: their total simulated time [s].
    ``first_success``: with ``margin_after_success``, the first success (None before it
    and without the option); ``margin_reached``: a controller then also passed the stop
    margin's wider corners (the run's end).
    """

    trials_done: int
    W: tuple[float, ...]
    theta_c: float
    rng_state: dict[str, Any]
    success: bool = False
    n_positive: int = 0
    memory: Memory = ()
    simulations: int = 0
    simulated_seconds: float = 0.0
    first_success: FirstSuccess | None = None
    margin_reached: bool = False

    def get(self, name: str) -> tuple[float, ...]:
        """The memory entry ``name`` (empty if the rule has not set it yet)."""
        return dict(self.memory).get(name, ())

    def to_dict(self) -> dict[str, Any]:
        """The fields in their order, W as a list and the memory as name -> list;
        ``first_success`` and ``margin_reached`` only when a run has them (so a run
        without ``margin_after_success`` writes what it wrote before)."""
        out = {**asdict(self), "W": list(self.W), "memory": {k: list(v) for k, v in self.memory}}
        first = out.pop("first_success")
        if self.first_success is not None:
            out["first_success"] = {**first, "W": list(self.first_success.W)}
        if not self.margin_reached:
            del out["margin_reached"]
        return out

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> LearnerState:
        """Rebuild from :meth:`to_dict` output; raises ParameterError if anything is off."""
        try:
            W = tuple(float(w) for w in d["W"])
            memory = tuple(
                (str(k), tuple(float(x) for x in v)) for k, v in dict(d.get("memory", {})).items()
            )
            state = cls(
                trials_done=int(d["trials_done"]),
                W=W,
                theta_c=float(d["theta_c"]),
                rng_state=checked_rng_state(d["rng_state"]),
                success=bool(d["success"]),
                n_positive=int(d.get("n_positive", 0)),
                memory=memory,
                simulations=int(d.get("simulations", 0)),
                simulated_seconds=float(d.get("simulated_seconds", 0.0)),
                first_success=_first_success(d.get("first_success")),
                margin_reached=bool(d.get("margin_reached", False)),
            )
        except ParameterError:
            raise
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            raise ParameterError(f"learner state is incomplete or malformed: {exc!r}") from None
        if (
            len(W) != N_GAINS
            or state.trials_done < 0
            or state.n_positive < 0
            or state.simulations < 0
            or not state.simulated_seconds >= 0.0
        ):
            raise ParameterError("learner state has the wrong number of gains or trials")
        first = state.first_success
        if first is not None and (
            len(first.W) != N_GAINS
            or not 0 < first.trials <= state.trials_done
            or not first.trials <= first.simulations <= state.simulations
            or not 0.0 <= first.simulated_seconds <= state.simulated_seconds
        ):
            raise ParameterError("learner state's first success does not fit its run")
        numbers = (
            *W,
            state.theta_c,
            *(x for _, v in memory for x in v),
            *(() if first is None else (*first.W, first.theta_c, first.simulated_seconds)),
        )
        if not all(math.isfinite(v) for v in numbers):
            raise ParameterError("learner state holds a non-finite number")
        check_theta_c(state.theta_c)
        return state


def _first_success(d: Any) -> FirstSuccess | None:
    """:class:`FirstSuccess` from its :meth:`LearnerState.to_dict` form (None: none)."""
    if d is None:
        return None
    first = FirstSuccess(
        trials=int(d["trials"]),
        simulations=int(d["simulations"]),
        simulated_seconds=float(d["simulated_seconds"]),
        W=tuple(float(w) for w in d["W"]),
        theta_c=float(d["theta_c"]),
    )
    check_theta_c(first.theta_c)
    return first


def checked_rng_state(value: object) -> dict[str, Any]:
    """``value`` as the state of a PCG64 generator (the learner's), or ParameterError."""
    rng = np.random.default_rng()
    try:
        rng.bit_generator.state = dict(value)  # type: ignore[call-overload]
    except (TypeError, ValueError, KeyError, OverflowError) as exc:
        raise ParameterError(
            f"learner state rng_state is not the state of a PCG64 generator: {exc}"
        ) from None
    return dict(rng.bit_generator.state)


@dataclass(frozen=True)
class TrialRecord:
    """One row of history.csv: the W and theta_c used in the trial and what happened.

    ``extra``: the rule's own columns (name, value), e.g. ("sigma", ...) for the
    chapter's per-step policy std, ("explore", ...) for pgpe's exploration std.
    """

    trial: int
    reward: float
    W: tuple[float, ...]
    theta_c: float
    min_abs_theta_swingup: float
    ended_at: float
    success: bool
    fault: bool
    early: bool
    extra: tuple[tuple[str, float], ...] = ()

    @property
    def columns(self) -> tuple[str, ...]:
        return history_columns([k for k, _ in self.extra])

    def row(self) -> list[Any]:
        return [
            self.trial,
            self.reward,
            *self.W,
            self.theta_c,
            *(v for _, v in self.extra),
            self.min_abs_theta_swingup,
            self.ended_at,
            int(self.success),
            int(self.fault),
            int(self.early),
        ]


def _cell(v: Any) -> float:
    """A history value as history.csv gives it back: non-finite numbers become NaN."""
    x = float(v)
    return x if math.isfinite(x) else math.nan


@dataclass(frozen=True, eq=False)
class History:
    """A run's history, one row per trial (in memory, or read from history.csv).

    ``columns``: the header (:func:`history_columns` of the learner's own columns);
    ``data``: (trials, len(columns)) float64, read-only, one row per trial; NaN where
    history.csv holds an empty cell (a non-finite value, e.g. min_abs_theta_swingup of
    a trial that never swung up). Numbers only: a history of a million trials takes
    8 bytes a cell. Two histories are equal when their learner, columns, reward and
    numbers are (NaN equal to NaN).
    """

    learner: str
    columns: tuple[str, ...]
    data: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    reward_kind: str = "sparse"

    def __post_init__(self) -> None:
        # a view, not a copy: a history read from a file is not held twice
        data = np.asarray(self.data, dtype=float).view()
        if data.size == 0:
            data = data.reshape(0, len(self.columns))
        if data.ndim != 2:
            raise ParameterError(f"history data must be (trials, columns), got {data.shape}")
        if data.shape[1] != len(self.columns):
            raise ParameterError(
                f"history data has {data.shape[1]} columns, its header {len(self.columns)}"
            )
        data.flags.writeable = False
        object.__setattr__(self, "data", data)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, History):
            return NotImplemented
        return (
            (self.learner, self.columns, self.reward_kind)
            == (other.learner, other.columns, other.reward_kind)
        ) and np.array_equal(self.data, other.data, equal_nan=True)

    __hash__ = None  # type: ignore[assignment]

    def __len__(self) -> int:
        return len(self.data)

    def column(self, name: str) -> np.ndarray:
        """One column as a float array (KeyError if the learner does not record it)."""
        if name not in self.columns:
            raise KeyError(f"history of learner {self.learner!r} has no column {name!r}")
        return self.data[:, self.columns.index(name)].copy()

    @property
    def rule_columns(self) -> tuple[str, ...]:
        """The learner's own columns (between theta_c and the trial's flags)."""
        return self.columns[len(BASE_COLUMNS) : len(self.columns) - len(FLAG_COLUMNS)]

    @property
    def trial(self) -> np.ndarray:
        return self.column("trial")

    @property
    def reward(self) -> np.ndarray:
        return self.column("reward")

    @property
    def W(self) -> np.ndarray:
        """(n, 6) the gains used in each trial."""
        return np.stack([self.column(f"W{i}") for i in range(1, 7)], axis=1).reshape(-1, 6)

    @property
    def theta_c(self) -> np.ndarray:
        return self.column("theta_c")

    @property
    def success(self) -> np.ndarray:
        return self.column("success").astype(bool)

    @classmethod
    def of(
        cls, learner: str, records: Sequence[TrialRecord], reward_kind: str = "sparse"
    ) -> History:
        """The history of in-memory records (all of one learner)."""
        columns = records[0].columns if records else ()
        data = np.array([[_cell(v) for v in r.row()] for r in records], dtype=float)
        return cls(learner=learner, columns=columns, data=data, reward_kind=reward_kind)
