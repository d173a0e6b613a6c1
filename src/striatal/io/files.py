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
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    import numpy as np

from striatal.errors import DataFileError

__all__ = [
    "MAX_INPUT_BYTES",
    "array_rows",
    "atomic_write_file",
    "atomic_write_stream",
    "atomic_write_text",
    "check_no_dangling_link",
    "check_out_dir",
    "csv_text",
    "dumps_json",
    "read_csv",
    "read_json",
    "read_text",
    "replace_into",
    "write_csv",
    "write_json",
]


def check_out_dir(path: str | os.PathLike[str], files: Sequence[str] = ()) -> Path:
    """``path`` as a Path if it is, or can be made, a writable folder; creates nothing.

    ``files``: the names the command will write there; none may be a folder. Raises
    DataFileError otherwise, so a command can refuse before it computes.
    """
    p = Path(path)
    check_no_dangling_link(p)
    if p.exists() and not p.is_dir():
        raise DataFileError(f"output folder {p} exists and is not a folder")
    for name in files:
        if (p / name).is_dir():
            raise DataFileError(f"cannot write {p / name}: it is a folder")
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


def check_no_dangling_link(path: str | os.PathLike[str]) -> None:
    """Raise DataFileError if ``path`` or a folder above it is a link to nothing.

    Such a path cannot be created (mkdir says "File exists"), so a command checks it
    before it computes, not after.
    """
    p = Path(path)
    for probe in (p, *p.parents):
        if probe.is_symlink() and not probe.exists():
            raise DataFileError(
                f"output {p}: {probe} is a symbolic link to {os.readlink(probe)}, "
                "which does not exist"
            )


def replace_into(tmp: str | os.PathLike[str], target: Path) -> None:
    """``os.replace(tmp, target)``; an error names ``target``, never the hidden ``tmp``."""
    if target.is_dir():
        raise DataFileError(f"cannot write {target}: it is a folder")
    try:
        os.replace(tmp, target)
    except OSError as exc:
        raise DataFileError(f"cannot write {target}: {exc.strerror or exc}") from None


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` atomically (temp file + fsync + rename).

    The file gets the mode an ordinary ``open(path, "w")`` would give it (0666 less
    the umask), not mkstemp's 0600. A folder that cannot be made or written raises
    DataFileError.
    """
    atomic_write_stream(path, lambda fh: fh.write(text))


def atomic_write_stream(path: str | os.PathLike[str], write: Callable[[TextIO], object]) -> None:
    """``write(fh)`` into a temporary file beside ``path``, then fsync and rename.

    The text goes to the file as ``write`` produces it, so a large file never has
    to be held in memory. A folder that cannot be made or written raises DataFileError.
    """

    def write_text(tmp: Path) -> None:
        with tmp.open("w", encoding="utf-8", newline="") as fh:
            write(fh)

    atomic_write_file(path, write_text)


def atomic_write_file(path: str | os.PathLike[str], write: Callable[[Path], object]) -> None:
    """``write(tmp)`` writes a temporary file beside ``path`` by its name, then fsync and
    rename onto ``path``.

    For writers that open the file themselves (matplotlib's ``savefig``, Pillow,
    ffmpeg): they must take the format from an argument, not from the name, which
    ends in ``.tmp``. The file gets the mode an ordinary ``open(path, "w")`` would
    give it. A folder that cannot be made or written, or a write that fails (a full
    disk), raises DataFileError naming ``path``.
    """
    target = Path(path)
    check_no_dangling_link(target.parent)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise DataFileError(f"cannot write {target}: {exc.strerror or exc}") from None
    try:
        try:
            try:
                os.fchmod(fd, 0o666 & ~_umask())
            finally:
                os.close(fd)
            write(Path(tmp))
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
        except OSError as exc:
            # a full disk (ENOSPC) or a quota: the error names no file, so name the target
            raise DataFileError(f"cannot write {target}: {exc.strerror or exc}") from None
        replace_into(tmp, target)
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


#: Largest file striatal reads as input [bytes]: 256 MiB. Its own files are far smaller
#: (history.csv of 100,000 trials: about 25 MB); anything bigger is not one of them.
MAX_INPUT_BYTES = 256 * 2**20


def read_text(
    path: str | os.PathLike[str], *, what: str = "file", max_bytes: int = MAX_INPUT_BYTES
) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes`` (:data:`MAX_INPUT_BYTES`).

    Every JSON, CSV and TOML input goes through here. A folder, a device
    (``/dev/zero``), a FIFO or a socket, or a file that is too big, raises
    DataFileError before a byte is read: none can hang or exhaust memory.
    """
    p = Path(path)
    try:
        st = os.stat(p)  # stat, unlike open, does not wait for a FIFO's writer
        if stat.S_ISDIR(st.st_mode):
            raise DataFileError(f"{what} {p} is a folder, not a file")
        _check_regular(p, st, what, max_bytes)
        # O_NONBLOCK: if a FIFO took the file's place since the stat, open does not wait
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
        with os.fdopen(fd, "rb") as fh:
            _check_regular(p, os.fstat(fh.fileno()), what, max_bytes)
            data = fh.read(max_bytes + 1)
        _check_size(p, len(data), what, max_bytes)
        # utf-8-sig: a byte-order mark that an editor put first is not part of the text
        return data.decode("utf-8-sig")
    except FileNotFoundError:
        raise DataFileError(f"{what} {p} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"{what} {p} cannot be read: {exc}") from None


def _check_regular(p: Path, st: os.stat_result, what: str, max_bytes: int) -> None:
    if not stat.S_ISREG(st.st_mode):
        raise DataFileError(f"{what} {p} is not a regular file (a device, FIFO or socket?)")
    _check_size(p, st.st_size, what, max_bytes)


def _check_size(p: Path, size: int, what: str, max_bytes: int) -> None:
    if size > max_bytes:
        raise DataFileError(
            f"{what} {p} is larger than {max_bytes / 2**20:g} MiB, the most striatal reads"
        )


def read_json(path: str | os.PathLike[str], *, what: str = "file") -> Any:
    """Read a JSON file (through :func:`read_text`) or raise DataFileError naming it."""
    p = Path(path)
    text = read_text(p, what=what)
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
    """Atomically write a CSV file, row by row (the same bytes as :func:`csv_text`).

    ``rows`` may be a generator (see :func:`array_rows`): memory stays bounded
    whatever the number of rows.
    """

    def write(fh: TextIO) -> None:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([_csv_cell(v) for v in row])

    atomic_write_stream(path, write)


def array_rows(data: np.ndarray, chunk: int = 4096) -> Iterator[list[float]]:
    """The rows of a 2-D array as lists of Python floats, ``chunk`` rows converted at a time.

    ``data.tolist()`` would hold every cell as a Python float at once (about 6 GB for
    10,000,000 steps of 8 columns); this holds ``chunk`` rows.
    """
    for start in range(0, len(data), chunk):
        yield from data[start : start + chunk].tolist()


def read_csv(path: str | os.PathLike[str], *, what: str = "file") -> list[dict[str, str]]:
    """Read a CSV file (through :func:`read_text`) with a header into dicts."""
    p = Path(path)
    text = read_text(p, what=what)
    try:
        return list(csv.DictReader(io.StringIO(text, newline="")))
    except csv.Error as exc:
        raise DataFileError(f"{what} {p} cannot be read as CSV: {exc}") from None
