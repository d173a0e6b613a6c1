"""Atomic, data-only file I/O: JSON and CSV, never pickle or eval.

Every writer goes through a temporary file in the destination folder and an
``os.replace``, so a reader never sees a half-written file, even after SIGKILL.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from striatal.errors import DataFileError


def check_out_dir(path: str | os.PathLike[str]) -> Path:
    """``path`` as a Path if it is, or can be made, a writable folder; creates nothing.

    Raises DataFileError otherwise, so a command can refuse before it computes.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise DataFileError(f"output folder {p} exists and is not a folder")
    probe = p
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise DataFileError(f"cannot create output folder {p}: {probe} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise DataFileError(f"cannot create or write output folder {p}: {probe} is not writable")
    return p


def _umask() -> int:
    """The process's file-mode creation mask (read without changing it, where possible)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` atomically (temp file + fsync + rename).

    The file gets the mode an ordinary ``open(path, "w")`` would give it (0666 less
    the umask), not mkstemp's 0600. A folder that cannot be made or written raises
    DataFileError.
    """
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise DataFileError(f"cannot write {target}: {exc.strerror or exc}") from None
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _finite_json(obj: Any) -> Any:
    """Replace non-finite floats by None so the JSON is standard (RFC 8259)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _finite_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite_json(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):
        return _finite_json(obj.item())
    return obj


def dumps_json(obj: Any) -> str:
    """Standard JSON text (no NaN/Infinity tokens), indented, with a trailing newline."""
    return json.dumps(_finite_json(obj), indent=2, allow_nan=False) + "\n"


def write_json(path: str | os.PathLike[str], obj: Any) -> None:
    """Atomically write ``obj`` as JSON."""
    atomic_write_text(path, dumps_json(obj))


def _reject_constant(token: str) -> Any:
    raise ValueError(f"{token} is not a number in standard JSON (striatal writes null)")


def _finite_float(token: str) -> float:
    v = float(token)
    if not math.isfinite(v):
        raise ValueError(f"{token} is out of the range of a float")
    return v


def read_json(path: str | os.PathLike[str], *, what: str = "file") -> Any:
    """Read a JSON file or raise DataFileError naming the file and the problem."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataFileError(f"{what} {p} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"{what} {p} cannot be read: {exc}") from None
    try:
        return json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float)
    except json.JSONDecodeError as exc:
        raise DataFileError(
            f"{what} {p} is not valid JSON (truncated or corrupted?): {exc}"
        ) from None
    except (ValueError, RecursionError) as exc:
        raise DataFileError(f"{what} {p} is not a striatal data file: {exc}") from None


def _csv_cell(v: Any) -> Any:
    """A float with repr precision; NaN and +-inf become an empty cell (the CSV null)."""
    if isinstance(v, float):
        return repr(float(v)) if math.isfinite(v) else ""
    return v


def csv_text(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """CSV text with a header line; floats written with repr precision, non-finite ones empty."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([_csv_cell(v) for v in row])
    return buf.getvalue()


def write_csv(
    path: str | os.PathLike[str], header: Sequence[str], rows: Iterable[Sequence[Any]]
) -> None:
    """Atomically write a CSV file."""
    atomic_write_text(path, csv_text(header, rows))


def read_csv(path: str | os.PathLike[str], *, what: str = "file") -> list[dict[str, str]]:
    """Read a CSV file with a header into dicts, or raise DataFileError."""
    p = Path(path)
    try:
        with p.open(encoding="utf-8", newline="") as fh:
            rows = list(csv.DictReader(fh))
    except FileNotFoundError:
        raise DataFileError(f"{what} {p} does not exist") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DataFileError(f"{what} {p} cannot be read as CSV: {exc}") from None
    return rows
