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

from pydantic import ValidationError

from striatal.io.schema.common import (
    MAX_COUNT,
    MAX_MAGNITUDE,
    MAX_SEED,
    one_line,
    unique_rows,
    validated,
)
from striatal.io.schema.run import (
    HISTORY_CELLS,
    MAX_MEMORY_NUMBERS,
    MEMORY,
    CheckpointModel,
    ControllerModel,
    MemoryEntry,
    PlantModel,
    ResultModel,
    RunSettingsModel,
    StateModel,
    check_memory,
)
from striatal.io.schema.sweep import (
    AblationModel,
    ArmSummary,
    BaselinePair,
    CostRow,
    McNemar,
    PairSummary,
    RunRow,
    SummaryModel,
    SweepModel,
    read_summary,
    read_sweep_settings,
)

__all__ = [
    "HISTORY_CELLS",
    "MAX_COUNT",
    "MAX_MAGNITUDE",
    "MAX_MEMORY_NUMBERS",
    "MAX_SEED",
    "MEMORY",
    "AblationModel",
    "ArmSummary",
    "BaselinePair",
    "CheckpointModel",
    "ControllerModel",
    "CostRow",
    "McNemar",
    "MemoryEntry",
    "PairSummary",
    "PlantModel",
    "ResultModel",
    "RunRow",
    "RunSettingsModel",
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
