"""The schema of every file striatal writes, and the one way each is checked.

One schema per file kind, written once (pydantic v2 models, strict: no text for
numbers, no true/false for numbers), so every command and every resume reads a file
through the same checks and a defect in reading is fixed once:

- result.json (:class:`ResultModel`), checkpoint.json (:class:`CheckpointModel`, with
  :class:`StateModel` and each learner's memory, :data:`MEMORY`);
- history.csv (:data:`HISTORY_CELLS`: which columns are counts, flags or may be empty);
- runs.csv (:class:`RunRow`; rows unique by (arm, init, seed), :func:`unique_rows`);
- summary.json (:class:`SummaryModel`, arms :class:`ArmSummary`), sweep.json
  (:class:`SweepModel`), ablation.json (:class:`AblationModel`).

Every field has its type, range and unit; counts are whole numbers >= 0 and consistent
with one another (a run's simulations are at least its trials, its trials at most the
budget); rates lie in [0, 1]. A file that breaks its schema raises DataFileError with
one line naming the file, the field and the value.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    model_validator,
)

from striatal.errors import DataFileError

__all__ = [
    "HISTORY_CELLS",
    "MEMORY",
    "AblationModel",
    "ArmSummary",
    "CheckpointModel",
    "CostRow",
    "MemoryEntry",
    "ResultModel",
    "RunRow",
    "StateModel",
    "SummaryModel",
    "SweepModel",
    "ValidationError",
    "check_memory",
    "one_line",
    "read_summary",
    "read_sweep_settings",
    "unique_rows",
    "validated",
]

#: The largest magnitude of a recorded state or force in a learner's memory (the forward
#: learner's transitions [m, m/s, rad, rad/s, N]): no trial reaches it, and a 1e300 there
#: is a corrupted file that would overflow the model fitted to it.
MAX_MAGNITUDE = 1e12
#: The most trials, seeds or simulations a count in a file may hold (an int32, what
#: every option takes: :data:`striatal.cli.guards.MAX_WHOLE`).
MAX_COUNT = 2**31 - 1
#: The largest seed a file may hold (a SeedSequence's 32-bit words: runs.csv's seeds).
MAX_SEED = 2**32 - 1

_MODEL = ConfigDict(strict=True, extra="allow", frozen=True)
_ROW = ConfigDict(strict=False, extra="forbid", frozen=True)

#: A finite real number [unit as the field says].
Real = Annotated[float, Field(allow_inf_nan=False)]
#: A finite number >= 0 (a duration [s], a cost).
NonNegative = Annotated[float, Field(allow_inf_nan=False, ge=0)]
#: A recorded state or force of a learner's memory, of a size a trial can reach.
Recorded = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE)]
#: A whole number >= 0 (trials, simulations, runs, successes).
Count = Annotated[int, Field(ge=0, le=MAX_COUNT)]
#: A rate or a fraction, in [0, 1].
Rate = Annotated[float, Field(allow_inf_nan=False, ge=0, le=1)]
#: A seed: a whole number in [0, 2**32).
Seed = Annotated[int, Field(ge=0, le=MAX_SEED)]
#: A name (an arm, a learner, an init): non-empty text of one line.
Name = Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[^\n\r]*$")]
#: A 95 % interval [low, high] of a rate, both in [0, 1].
RateInterval = Annotated[list[Rate], Field(min_length=2, max_length=2)]
Interval = Annotated[list[Real], Field(min_length=2, max_length=2)]
Gains = Annotated[list[Real], Field(min_length=6, max_length=6)]


def _empty_is_none(value: object) -> object:
    """A CSV cell: the empty cell is the CSV null (a non-finite number, or not recorded)."""
    return None if value == "" else value


def _whole(value: object) -> object:
    """A CSV cell of a count: "12", never "12.0" or "1e3"."""
    if isinstance(value, str) and not value.strip().lstrip("+-").isdigit():
        raise ValueError("must be a whole number")
    return value


def _flag(value: object) -> object:
    """A CSV cell of a yes/no column: 0 or 1."""
    if isinstance(value, str) and value not in ("0", "1"):
        raise ValueError("must be 0 or 1")
    return value


CsvCount = Annotated[Count, BeforeValidator(_whole)]
CsvSeed = Annotated[Seed, BeforeValidator(_whole)]
CsvFlag = Annotated[bool, BeforeValidator(_flag)]
CsvReal = Annotated[Real | None, BeforeValidator(_empty_is_none)]
CsvNonNegative = Annotated[NonNegative | None, BeforeValidator(_empty_is_none)]
CsvRate = Annotated[Rate | None, BeforeValidator(_empty_is_none)]

M = TypeVar("M", bound=BaseModel)


def one_line(exc: ValidationError, where: str) -> str:
    """The first error of ``exc`` as one line naming ``where``, the field and the value."""
    errors = exc.errors(include_url=False)
    first = errors[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(the whole file)"
    got = first.get("input")
    shown = repr(got)
    if len(shown) > 60:
        shown = shown[:57] + "..."
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    # pydantic names its own classes ("or instance of StateModel"): the user never wrote them
    msg = re.sub(r" or instance of \w+", "", first["msg"])
    msg = msg[0].lower() + msg[1:]
    if first["type"] in ("missing",):
        return f"{where}: field {loc} is missing{more}"
    if first["type"] == "value_error":  # a check across fields: its own sentence
        return f"{where}: {msg.removeprefix('value error, ')}{more}"
    return f"{where}: field {loc}: {msg}, got {shown}{more}"


def validated(model: type[M], data: Any, where: str) -> M:
    """``data`` as ``model``, or DataFileError with one line (:func:`one_line`)."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise DataFileError(one_line(exc, where)) from None
    except RecursionError:
        raise DataFileError(f"{where}: nested too deeply to be a striatal file") from None


# -- result.json and checkpoint.json ------------------------------------------------


class ControllerModel(BaseModel):
    """settings.controller: the readings of the switching controller (section 2.3, 4)."""

    model_config = _MODEL
    balance_sign: Literal["corrected", "chapter"] = "corrected"
    switch: Literal["hard", "soft"] = "hard"
    inhibition: Annotated[float, Field(allow_inf_nan=False, gt=0)] = 50.0


class PlantModel(BaseModel):
    """settings.plant [kg, kg, m, m/s^2] (section 2.1)."""

    model_config = _MODEL
    cart_mass: Annotated[float, Field(allow_inf_nan=False, gt=0)] = 1.0
    pole_mass: Annotated[float, Field(allow_inf_nan=False, gt=0)] = 0.1
    length: Annotated[float, Field(allow_inf_nan=False, gt=0)] = 1.0
    gravity: Annotated[float, Field(allow_inf_nan=False, gt=0)] = 9.8


class RunSettingsModel(BaseModel):
    """The settings object of a run (:func:`striatal.io.rundir.run_settings`)."""

    model_config = _MODEL
    learner: Name | None = None
    seed: Annotated[int, Field(ge=0, le=MAX_COUNT)] | None = None
    controller: ControllerModel = ControllerModel()
    plant: PlantModel = PlantModel()
    config: dict[str, Any] | None = None


class ResultModel(BaseModel):
    """result.json of ``striatal train``: the learned W [W1..W6] and theta_c [rad], the
    outcome and its counts."""

    model_config = _MODEL
    W: Gains
    theta_c: Annotated[float, Field(allow_inf_nan=False, gt=0, le=math.pi)]
    learner: Name | None = None
    success: bool | None = None
    trials: Count | None = None
    simulations: Count | None = None
    simulated_seconds: NonNegative | None = None
    positive_rewards: Count | None = None
    wall_seconds: NonNegative | None = None
    interrupted: bool | None = None
    run_id: Name | None = None
    settings: RunSettingsModel = RunSettingsModel()

    @model_validator(mode="after")
    def _counts(self) -> ResultModel:
        if self.trials is not None:
            if self.simulations is not None and self.simulations < self.trials:
                raise ValueError(
                    f"simulations ({self.simulations}) are fewer than trials ({self.trials})"
                )
            if self.positive_rewards is not None and self.positive_rewards > self.trials:
                raise ValueError(
                    f"positive_rewards ({self.positive_rewards}) exceed trials ({self.trials})"
                )
            if self.success and self.trials == 0:
                raise ValueError("success with 0 trials")
        return self


class MemoryEntry(BaseModel):
    """What one entry of a learner's memory may hold: its lengths, whether a run that
    has done a trial must have it, and the size of its values."""

    model_config = ConfigDict(frozen=True)
    sizes: tuple[int, ...] | None = None
    multiple_of: int = 1
    required: bool = True
    counts: bool = False


#: The memory of each learner in checkpoint.json (``state.memory``: name -> numbers).
#: A learner not listed here (a rule registered by a user) is held to its rule's
#: ``memory_names`` and finite numbers only.
MEMORY: dict[str, dict[str, MemoryEntry]] = {
    "chapter": {"trace": MemoryEntry(sizes=(6,))},
    "rpe": {
        "trace": MemoryEntry(sizes=(6,)),
        "reward_mean": MemoryEntry(sizes=(1,)),
        "rpe_square": MemoryEntry(sizes=(1,)),
    },
    "pgpe": {
        "explore": MemoryEntry(sizes=(6,)),
        "reward_mean": MemoryEntry(sizes=(1,)),
        "rpe_square": MemoryEntry(sizes=(1,)),
        "pair_z": MemoryEntry(sizes=(0, 6), required=False),
        "pair_reward": MemoryEntry(sizes=(0, 1), required=False),
        "pair_scale": MemoryEntry(sizes=(0, 2), required=False),
    },
    "ac": {
        "critic": MemoryEntry(sizes=(6,)),
        "trace": MemoryEntry(sizes=(6,)),
        "rpe_square": MemoryEntry(sizes=(1,)),
    },
    # the recorded transitions (n, 9): state (4), force (1), next state (4); at most
    # 1 200 of them; and the imagined trials so far and their simulated seconds
    "forward": {
        "data": MemoryEntry(multiple_of=9),
        "imagined": MemoryEntry(sizes=(2,), counts=True),
    },
}
#: The most numbers one memory entry holds (forward's 1 200 transitions of 9).
MAX_MEMORY_NUMBERS = 1200 * 9

MemoryNumbers = Annotated[list[Recorded], Field(max_length=MAX_MEMORY_NUMBERS)]


class StateModel(BaseModel):
    """checkpoint.json's ``state``: a :class:`striatal.learners.LearnerState`."""

    model_config = _MODEL
    trials_done: Count
    W: Gains
    theta_c: Annotated[float, Field(allow_inf_nan=False, gt=0, le=math.pi)]
    rng_state: dict[str, Any]
    success: bool
    n_positive: Count = 0
    memory: dict[Name, MemoryNumbers] = {}
    simulations: Count = 0
    simulated_seconds: NonNegative = 0.0

    @model_validator(mode="after")
    def _counts(self) -> StateModel:
        if self.n_positive > self.trials_done:
            raise ValueError(
                f"n_positive ({self.n_positive}) exceeds trials_done ({self.trials_done})"
            )
        if self.simulations < self.trials_done:
            raise ValueError(
                f"simulations ({self.simulations}) are fewer than trials_done ({self.trials_done})"
            )
        return self


class CheckpointModel(BaseModel):
    """checkpoint.json of ``striatal train`` (version 2)."""

    model_config = _MODEL
    version: Literal[2]
    run_id: Name
    settings: dict[str, Any]
    state: StateModel
    history_sha256: Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]


def check_memory(learner: str, state: StateModel, where: str) -> None:
    """DataFileError unless ``state.memory`` is what ``learner`` keeps (:data:`MEMORY`).

    Every name is one the learner keeps; every entry has an allowed length; after a
    trial, every entry the learner always keeps is there (a deleted or emptied memory
    would make a resumed run differ from the run it continues).
    """
    from striatal.learners import RULES

    spec = MEMORY.get(learner)
    if spec is None:
        names = RULES[learner].memory_names if learner in RULES else ()
        unknown = [k for k in state.memory if k not in names]
        if unknown:
            raise DataFileError(f"{where}: state.memory.{unknown[0]} is not kept by {learner}")
        return
    for name, values in state.memory.items():
        entry = spec.get(name)
        if entry is None:
            raise DataFileError(
                f"{where}: state.memory.{name} is not kept by the {learner} learner "
                f"(it keeps {', '.join(spec)})"
            )
        n = len(values)
        if (entry.sizes is not None and n not in entry.sizes) or n % entry.multiple_of:
            want = (
                " or ".join(str(s) for s in entry.sizes)
                if entry.sizes is not None
                else f"a multiple of {entry.multiple_of}"
            )
            raise DataFileError(f"{where}: state.memory.{name} holds {n} numbers, not {want}")
        if entry.counts and any(v < 0 for v in values):
            raise DataFileError(f"{where}: state.memory.{name} holds a negative count")
    if state.trials_done > 0:
        for name, entry in spec.items():
            if entry.required and not state.memory.get(name):
                raise DataFileError(
                    f"{where}: state.memory.{name} is missing or empty after "
                    f"{state.trials_done} trials"
                )


# -- history.csv ---------------------------------------------------------------------

#: How each history.csv column is checked (a column not listed: a finite number).
#: "count": a whole number >= 0; "flag": 0 or 1; "empty": a number, or empty (NaN:
#: not recorded in this trial, e.g. the fitted pole mass of a trial that fitted none).
HISTORY_CELLS: dict[str, Literal["count", "flag", "empty", "nonnegative"]] = {
    "trial": "count",
    "success": "flag",
    "fault": "flag",
    "early": "flag",
    "ended_at": "nonnegative",
    "min_abs_theta_swingup": "empty",
    "imagined": "count",
    "model_pole_mass": "empty",
    "model_length": "empty",
    "solved_in_imagination": "flag",
}


# -- runs.csv ------------------------------------------------------------------------


class RunRow(BaseModel):
    """One row of runs.csv: one learning run (or baseline run) of a sweep.

    Units: simulated_seconds, imagined_seconds, wall_seconds [s]; theta_c [rad].
    """

    model_config = _ROW
    arm: Name
    role: Name
    method: Name
    learner: Name
    init: Name
    seed: CsvSeed
    alpha: CsvReal = None
    gamma: CsvReal = None
    success: CsvFlag
    trials: CsvCount
    W1: CsvReal
    W2: CsvReal
    W3: CsvReal
    W4: CsvReal
    W5: CsvReal
    W6: CsvReal
    theta_c: CsvReal
    W0_1: CsvReal
    W0_2: CsvReal
    W0_3: CsvReal
    W0_4: CsvReal
    W0_5: CsvReal
    W0_6: CsvReal
    theta_c0: CsvReal
    mean_policy_success: CsvFlag
    robust: CsvRate = None
    simulations: CsvCount
    simulated_seconds: CsvNonNegative
    eval_simulations: CsvCount
    pass_rate_W0: CsvRate = None  # noqa: N815 (the column's name in runs.csv)
    pass_rate: CsvRate = None
    wall_seconds: CsvNonNegative = None
    imagined_simulations: CsvCount = 0
    imagined_seconds: CsvNonNegative = 0.0
    settings_id: Annotated[str, Field(max_length=64, pattern=r"^[0-9a-zA-Z]*$")] = ""

    @model_validator(mode="after")
    def _counts(self) -> RunRow:
        if self.simulations < self.trials:
            raise ValueError(
                f"simulations ({self.simulations}) are fewer than trials ({self.trials})"
            )
        if self.success and self.trials == 0:
            raise ValueError("success with 0 trials")
        return self


class CostRow(BaseModel):
    """The columns of a runs.csv row that a performance profile reads (a file of another
    striatal version may hold only these): the arm, its init and seed, whether it
    solved, and its costs [trials, simulations, s]."""

    model_config = ConfigDict(strict=False, extra="ignore", frozen=True)
    arm: Name
    init: str = ""
    seed: CsvSeed
    success: CsvFlag
    trials: CsvCount
    simulations: CsvCount | None = None
    simulated_seconds: CsvNonNegative = None

    @model_validator(mode="after")
    def _counts(self) -> CostRow:
        if self.simulations is not None and self.simulations < self.trials:
            raise ValueError(
                f"simulations ({self.simulations}) are fewer than trials ({self.trials})"
            )
        return self


def unique_rows(
    rows: Iterable[tuple[int, dict[str, Any]]],
    key: Sequence[str],
    where: str,
    *,
    same: Sequence[str] | None = None,
) -> list[dict[str, Any]]:
    """``rows`` (line number, row) with a row repeated by ``key`` kept once.

    A repeat that agrees with the first on ``same`` (default: every field) is what a
    resume after a kill can leave, and is dropped; one that conflicts is refused.
    """
    seen: dict[tuple[Any, ...], dict[str, Any]] = {}
    out: list[dict[str, Any]] = []
    for line, row in rows:
        k = tuple(row[c] for c in key)
        first = seen.get(k)
        if first is None:
            seen[k] = row
            out.append(row)
            continue
        fields = same if same is not None else tuple(row)
        differ = [f for f in fields if not _same(first.get(f), row.get(f))]
        if differ:
            named = ", ".join(f"{c}={v}" for c, v in zip(key, k, strict=True))
            raise DataFileError(
                f"{where} line {line}: a second row for {named} with another {differ[0]}"
            )
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


# -- summary.json, sweep.json, ablation.json -----------------------------------------


class ArmSummary(BaseModel):
    """One arm of summary.json's ``arms``: its rate over ``runs`` seeds with its Wilson
    95 % interval, and its costs [simulations, s, trials]."""

    model_config = _MODEL
    arm: Name
    init: Name
    method: Name
    role: Name | None = None
    learner: Name | None = None
    runs: Count
    successes: Count | None = None
    success_rate: Rate | None
    success_rate_ci: RateInterval | None = None
    unsolved_share: Rate | None
    trials_median: NonNegative | None
    trials_q1: NonNegative | None = None
    trials_q3: NonNegative | None = None
    simulations_median: NonNegative | None = None
    simulations_median_ci: Interval | None = None
    simulations_iqm: NonNegative | None = None
    simulations_iqm_ci: Interval | None = None
    simulations_total: Count | None = None
    trials_total: Count | None = None
    mean_policy_success_rate: Rate | None = None
    robust_rate: Rate | None = None
    pass_rate_W0_mean: Rate | None = None  # noqa: N815 (the field's name in the file)
    pass_rate_mean: Rate | None = None
    wall_seconds_total: NonNegative | None = None
    notes: list[str] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> ArmSummary:
        if self.successes is not None and self.successes > self.runs:
            raise ValueError(f"successes ({self.successes}) exceed runs ({self.runs})")
        rate = self.success_rate
        if rate is not None and self.runs == 0:
            raise ValueError("a success rate over 0 runs")
        if (
            rate is not None
            and self.successes is not None
            and abs(rate * self.runs - self.successes) > 1e-6 * max(1, self.runs)
        ):
            raise ValueError(
                f"success_rate {rate} is not successes/runs = {self.successes}/{self.runs}"
            )
        if rate is not None and self.success_rate_ci is not None:
            lo, hi = self.success_rate_ci
            if not lo - 1e-9 <= rate <= hi + 1e-9:
                raise ValueError(f"success_rate {rate} lies outside its interval [{lo}, {hi}]")
            if lo > hi:
                raise ValueError(f"success_rate_ci [{lo}, {hi}] has low > high")
        if (
            rate is not None
            and self.unsolved_share is not None
            and abs(rate + self.unsolved_share - 1) > 1e-6
        ):
            raise ValueError(
                f"unsolved_share {self.unsolved_share} is not 1 - success_rate ({rate})"
            )
        if (
            self.simulations_total is not None
            and self.trials_total is not None
            and self.simulations_total < self.trials_total
        ):
            raise ValueError(
                f"simulations_total ({self.simulations_total}) is below trials_total "
                f"({self.trials_total})"
            )
        return self


class PValue(BaseModel):
    model_config = _MODEL
    p_value: Rate | None


class PairSummary(BaseModel):
    """One learner-against-control comparison of summary.json."""

    model_config = _MODEL
    arm: Name
    control: Name
    init: Name
    fisher: PValue
    mcnemar: PValue | None = None


class SummaryModel(BaseModel):
    """summary.json of a sweep (or an ablation): its arms, comparisons, notes, settings."""

    model_config = _MODEL
    arms: Annotated[list[ArmSummary], Field(max_length=100_000)]
    learner_vs_control: list[PairSummary] = []
    notes: list[str] = []
    settings: dict[str, Any] = {}

    @model_validator(mode="after")
    def _unique(self) -> SummaryModel:
        seen: set[tuple[str, str]] = set()
        for a in self.arms:
            if (a.arm, a.init) in seen:
                raise ValueError(f"arm {a.arm!r} (init {a.init!r}) appears twice")
            seen.add((a.arm, a.init))
        return self


class SweepModel(BaseModel):
    """sweep.json: the settings of a sweep (what every run of its folder computes).

    A sweep reruns only with settings equal to these, so any change is refused there;
    this schema holds the types of the fields a reader takes from it.
    """

    model_config = _MODEL
    command: Literal["striatal sweep", "striatal ablation"] | None = None
    seeds: Count | list[Seed] | None = None
    max_trials: Annotated[int, Field(ge=1, le=MAX_COUNT)] | None = None
    eval_draws: Count | None = None
    arms: dict[Name, dict[str, Any]] | None = None
    root_seed: Seed | None = None
    run_seeds: list[Seed] | None = None

    @model_validator(mode="after")
    def _seeds(self) -> SweepModel:
        if (
            self.run_seeds is not None
            and isinstance(self.seeds, int)
            and len(self.run_seeds) != self.seeds
        ):
            raise ValueError(f"run_seeds holds {len(self.run_seeds)} seeds, not {self.seeds}")
        return self


class AblationRun(BaseModel):
    model_config = _MODEL
    seed: Seed
    success: bool
    trials: Count
    simulations: Count
    simulated_seconds: NonNegative


class AblationVariant(BaseModel):
    model_config = _MODEL
    options: str
    runs: list[AblationRun]

    @model_validator(mode="after")
    def _unique(self) -> AblationVariant:
        seeds = [r.seed for r in self.runs]
        if len(set(seeds)) != len(seeds):
            raise ValueError("a seed appears twice")
        return self


class AblationModel(BaseModel):
    """ablation.json: each variant's options and runs (seed order)."""

    model_config = ConfigDict(strict=True, frozen=True)
    variants: dict[Name, AblationVariant]

    @classmethod
    def of(cls, data: Mapping[str, Any], where: str) -> AblationModel:
        """The variants of an ablation.json object (its keys other than settings)."""
        variants = {k: v for k, v in data.items() if isinstance(v, dict) and "runs" in v}
        return validated(cls, {"variants": variants}, where)


# -- the readers of the JSON files of a sweep ----------------------------------------


def read_summary(path: str | Path, *, what: str = "sweep summary") -> dict[str, Any]:
    """A sweep's summary.json (``path`` the file or its folder), checked against
    :class:`SummaryModel`; the parsed object (every command that reads one calls this)."""
    from striatal.io.files import read_json

    p = Path(path)
    p = p / "summary.json" if p.is_dir() else p
    data = read_json(p, what=what)
    if not isinstance(data, dict) or "arms" not in data:
        raise DataFileError(f"{what} {p} is not the summary.json of a striatal sweep")
    validated(SummaryModel, data, f"{what} {p}")
    return data


def read_sweep_settings(path: str | Path) -> dict[str, Any]:
    """A sweep's sweep.json, checked against :class:`SweepModel`; the parsed object."""
    from striatal.io.files import read_json

    p = Path(path)
    data = read_json(p, what="sweep settings")
    validated(SweepModel, data, f"sweep settings {p}")
    return dict(data)
