"""The building blocks of every file's schema: typed numbers with their ranges, the
CSV cell readers, and the one-line message of a file that breaks its schema."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import Annotated, Any, TypeVar

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from striatal.errors import DataFileError

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
