"""The schemas of a training run's files: result.json, checkpoint.json (with each
learner's memory) and history.csv's cells."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from striatal.errors import DataFileError
from striatal.io.schema.common import (
    _MODEL,
    MAX_COUNT,
    Count,
    Gains,
    Name,
    NonNegative,
    Recorded,
)


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
    has done a trial must have it, and the range of its values (``nonnegative``: all
    >= 0; ``whole_at``: the positions that are counts, whole numbers)."""

    model_config = ConfigDict(frozen=True)
    sizes: tuple[int, ...] | None = None
    multiple_of: int = 1
    required: bool = True
    nonnegative: bool = False
    whole_at: tuple[int, ...] = ()


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
    # the recorded transitions (n, 11): state (4), force (1), next state (4), the true
    # plant's pole mass and length factors (2); at most 1 200 of each of the five plants
    # the real checks run (the nominal one and the robustness set's four corners); and
    # the imagined trials so far and their simulated seconds
    "forward": {
        "data": MemoryEntry(multiple_of=11),
        "imagined": MemoryEntry(sizes=(2,), nonnegative=True, whole_at=(0,)),
    },
}
#: The most numbers one memory entry holds (forward's 1 200 transitions of 11 on each of
#: five plants).
MAX_MEMORY_NUMBERS = 1200 * 5 * 11

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
        if entry.nonnegative and any(v < 0 for v in values):
            raise DataFileError(f"{where}: state.memory.{name} holds a negative count")
        fraction = [i for i in entry.whole_at if i < n and values[i] != int(values[i])]
        if fraction:
            raise DataFileError(
                f"{where}: state.memory.{name}.{fraction[0]} is a count, not a whole "
                f"number ({values[fraction[0]]!r})"
            )
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
#: not recorded in this trial, e.g. the fitted pole mass of a trial that fitted none);
#: "angle": theta_c, in (0, pi] [rad] as every learner keeps it (eq 21).
HISTORY_CELLS: dict[str, Literal["count", "flag", "empty", "nonnegative", "angle"]] = {
    "trial": "count",
    "theta_c": "angle",
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
