"""Atomic, data-only file I/O: JSON and CSV, never pickle or eval.

Every writer goes through a temporary file in the destination folder and an
``os.replace``, so a reader never sees a half-written file, even after SIGKILL.
"""

from __future__ import annotations

import contextlib
import csv
import getpass
import hashlib
import io
import json
import math
import os
import re
import signal
import stat
import tempfile
import threading
import time
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    import numpy as np
    from filelock import FileLock

from striatal.errors import DataFileError

__all__ = [
    "MAX_INPUT_BYTES",
    "array_rows",
    "atomic_write_file",
    "atomic_write_set",
    "atomic_write_stream",
    "atomic_write_text",
    "check_no_dangling_link",
    "check_out_dir",
    "count_line_ends",
    "csv_stream",
    "csv_text",
    "dumps_json",
    "lines_marking_last",
    "path_lock",
    "read_csv",
    "read_json",
    "read_lines",
    "read_text",
    "remove_stale_temps",
    "replace_into",
    "write_csv",
    "write_json",
    "write_text_set",
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
    write_text_set([(Path(path), write)])


def write_text_set(files: Sequence[tuple[Path, Callable[[TextIO], object]]]) -> None:
    """Write text files as one set (:func:`atomic_write_set`): ``write(fh)`` for each
    (target, ``write``), UTF-8; all of them are replaced, or none is."""

    def text_file(write: Callable[[TextIO], object]) -> Callable[[Path], None]:
        def write_text(tmp: Path) -> None:
            with tmp.open("w", encoding="utf-8", newline="") as fh:
                write(fh)

        return write_text

    atomic_write_set([(target, text_file(write)) for target, write in files])


def atomic_write_file(path: str | os.PathLike[str], write: Callable[[Path], object]) -> None:
    """``write(tmp)`` writes a temporary file beside ``path`` by its name, then fsync and
    rename onto ``path``.

    For writers that open the file themselves (matplotlib's ``savefig``, Pillow,
    ffmpeg): they must take the format from an argument, not from the name, which
    ends in ``.tmp``. The file gets the mode an ordinary ``open(path, "w")`` would
    give it. A folder that cannot be made or written, or a write that fails (a full
    disk), raises DataFileError naming ``path``.
    """
    atomic_write_set([(Path(path), write)])


def atomic_write_set(files: Sequence[tuple[Path, Callable[[Path], object]]]) -> None:
    """Write several files as one set: every temporary file first, then the renames.

    ``files``: (target, ``write(tmp)``) pairs, as :func:`atomic_write_file` takes one.
    If any write fails (a full disk), every temporary file is removed and the old
    files stay as they were, all of them: a folder never holds a new file beside an
    old one of the same set. The temporary files are named ``.striatal-XXXXXXXX.tmp``
    (any legal target name fits beside them), locked while written, and removed on
    KeyboardInterrupt and on SIGTERM; ones that a killed process left are removed
    at the next write into their folder (:func:`remove_stale_temps`).
    """
    temps: list[tuple[str, FileLock, Path]] = []
    try:
        with _removed_on_sigterm():
            for target, write in files:
                temps.append(_write_temp(target, write))
            for tmp, _fd, target in temps:
                replace_into(tmp, target)
    finally:
        for tmp, lock, _target in temps:
            _LIVE_TEMPS.discard(tmp)
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            lock.release()


#: How a temporary file of :func:`atomic_write_set` begins and ends.
TEMP_PREFIX, TEMP_SUFFIX = ".striatal-", ".tmp"
#: A temporary file that another writer left is removed once this old [s], if it cannot
#: be shown unused by its lock (the names of older striatal versions: ``.NAME.XXXXXXXX.tmp``).
STALE_SECONDS = 3600.0
_OLD_TEMP = re.compile(r"^\..+\.[a-z0-9_]{8}\.tmp$")
#: The temporary files this process is writing (removed by the SIGTERM handler).
_LIVE_TEMPS: set[str] = set()


def _lock_folder() -> Path:
    """The folder of striatal's lock files: one per user, in the system's temporary folder.

    A lock file never goes into a user's folder, so a folder in use holds only its own
    files, and a refused second writer leaves nothing there.
    """
    try:
        user = getpass.getuser()
    except Exception:  # no user name in the environment or the password database
        user = str(os.getpid())
    folder = Path(tempfile.gettempdir()) / f"striatal-locks-{re.sub(r'[^A-Za-z0-9_.-]', '_', user)}"
    folder.mkdir(mode=0o700, exist_ok=True)
    return folder


def path_lock(path: str | os.PathLike[str]) -> FileLock:
    """The :class:`filelock.FileLock` that stands for ``path`` (a folder or a temporary file).

    The lock file is named by a hash of ``path``'s resolved form, so every process that
    names one place, by whatever spelling (a link, a relative path), takes one lock. The
    lock goes away with its process, even after SIGKILL (the operating system's lock on
    an open file).
    """
    from filelock import FileLock  # here, not at the top: ``striatal --help`` stays fast

    key = os.path.realpath(os.fspath(path))
    digest = hashlib.sha256(key.encode("utf-8", "surrogateescape")).hexdigest()[:32]
    return FileLock(_lock_folder() / f"{digest}.lock", timeout=0)


def _write_temp(target: Path, write: Callable[[Path], object]) -> tuple[str, FileLock, Path]:
    """(temporary file, its held lock, ``target``): ``write`` done and fsynced."""
    check_no_dangling_link(target.parent)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temps(target.parent)
        fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=TEMP_SUFFIX, dir=target.parent)
    except OSError as exc:
        raise DataFileError(f"cannot write {target}: {exc.strerror or exc}") from None
    _LIVE_TEMPS.add(tmp)
    from filelock import Timeout

    lock = path_lock(tmp)
    try:
        try:
            with contextlib.suppress(OSError, Timeout):  # no lock folder: age marks it stale
                lock.acquire()
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
    except BaseException:
        _LIVE_TEMPS.discard(tmp)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        lock.release()
        raise
    return tmp, lock, target


def remove_stale_temps(folder: Path, *, now: float | None = None) -> list[str]:
    """Remove the temporary files a killed writer left in ``folder``; their names.

    A ``.striatal-XXXXXXXX.tmp`` goes if no process holds its lock (its writer is
    gone); a temporary file of an older striatal (``.NAME.XXXXXXXX.tmp``), which has
    no lock, goes once :data:`STALE_SECONDS` old.
    """
    removed: list[str] = []
    now = time.time() if now is None else now
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        name = entry.name
        if not name.endswith(TEMP_SUFFIX) or not entry.is_file(follow_symlinks=False):
            continue
        try:
            if name.startswith(TEMP_PREFIX):
                if name in {os.path.basename(t) for t in _LIVE_TEMPS}:
                    continue
                if not _unlocked(entry.path):
                    continue
            elif _OLD_TEMP.match(name) or name.startswith(TEMP_PREFIX):
                if now - entry.stat(follow_symlinks=False).st_mtime < STALE_SECONDS:
                    continue
            else:
                continue
            os.unlink(entry.path)
            removed.append(name)
        except OSError:
            continue  # gone already, or not ours to remove
    return removed


def _unlocked(path: str) -> bool:
    """Whether no process holds the lock of the temporary file ``path``."""
    from filelock import Timeout

    lock = path_lock(path)
    try:
        lock.acquire()
    except Timeout:
        return False
    lock.release()
    return True


@contextlib.contextmanager
def _removed_on_sigterm() -> Iterator[None]:
    """While the block runs, SIGTERM removes the live temporary files, then ends the
    process as SIGTERM would have. Only where SIGTERM has its default action and in the
    main thread (a program's own handler, or a thread, is left alone)."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return

    def on_term(signum: int, _frame: object) -> None:
        for tmp in list(_LIVE_TEMPS):
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGTERM)

    signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


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

    Every JSON and TOML input goes through here (a CSV that can be large is read line by
    line, :func:`read_lines`). A folder, a device (``/dev/zero``), a FIFO or a socket,
    or a file that is too big, raises DataFileError before a byte is read: none can
    hang or exhaust memory.
    """
    p = Path(path)
    try:
        with _open_checked(p, what, max_bytes) as fh:
            # a buffer of the file's size, not of the limit (read(n) allocates n first)
            size = os.fstat(fh.fileno()).st_size
            data = fh.read(size + 1)
            if len(data) > size:  # it grew since: read on, up to the limit
                data += fh.read(max_bytes + 1 - len(data))
        _check_size(p, len(data), what, max_bytes)
        # utf-8-sig: a byte-order mark that an editor put first is not part of the text
        return data.decode("utf-8-sig")
    except FileNotFoundError:
        raise DataFileError(f"{what} {p} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"{what} {p} cannot be read: {exc}") from None


def read_lines(
    path: str | os.PathLike[str], *, what: str = "file", max_bytes: int = MAX_INPUT_BYTES
) -> Generator[str, None, None]:
    """The lines of a regular file of at most ``max_bytes``, one at a time, line ends kept.

    The checks of :func:`read_text`, but the text is never held whole: a reader that
    keeps only numbers (a history's columns) needs memory for those alone. Line ends
    are kept as written (``newline=""``, as :mod:`csv` wants). A decoding error, or a file
    that grows past ``max_bytes`` while it is read, raises DataFileError.
    """
    p = Path(path)
    try:
        with (
            _open_checked(p, what, max_bytes) as raw,
            io.TextIOWrapper(raw, encoding="utf-8-sig", newline="") as fh,
        ):
            read = 0
            for line in fh:
                read += len(line)
                _check_size(p, read, what, max_bytes)
                yield line
    except FileNotFoundError:
        raise DataFileError(f"{what} {p} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"{what} {p} cannot be read: {exc}") from None


def count_line_ends(
    path: str | os.PathLike[str], *, what: str = "file", max_bytes: int = MAX_INPUT_BYTES
) -> int:
    """How many line ends (``\\n`` or a lone ``\\r``) a regular file of at most
    ``max_bytes`` has, read a block at a time: at least the number of its lines but the
    last, so a reader can allocate its rows before it parses them."""
    p = Path(path)
    n, last = 0, b""
    try:
        with _open_checked(p, what, max_bytes) as fh:
            while block := fh.read(2**20):
                n += block.count(b"\n") + block.count(b"\r") - block.count(b"\r\n")
                n -= last == b"\r" and block[:1] == b"\n"
                last = block[-1:]
    except FileNotFoundError:
        raise DataFileError(f"{what} {p} does not exist") from None
    except OSError as exc:
        raise DataFileError(f"{what} {p} cannot be read: {exc}") from None
    return n


def lines_marking_last(lines: Iterable[str], start: int = 1) -> Iterator[tuple[int, str, bool]]:
    """(number, line, whether it is the last) of each of ``lines``, numbered from
    ``start``, one line ahead: a reader can tell a last line (which a kill may have cut
    short) from the others without holding the file."""
    it = iter(lines)
    line = next(it, None)
    n = start
    while line is not None:
        following = next(it, None)
        yield n, line, following is None
        line, n = following, n + 1


def _open_checked(p: Path, what: str, max_bytes: int) -> io.BufferedReader:
    """``p`` opened for reading in binary, once it is known to be a regular file of at
    most ``max_bytes``."""
    st = os.stat(p)  # stat, unlike open, does not wait for a FIFO's writer
    if stat.S_ISDIR(st.st_mode):
        raise DataFileError(f"{what} {p} is a folder, not a file")
    _check_regular(p, st, what, max_bytes)
    # O_NONBLOCK: if a FIFO took the file's place since the stat, open does not wait
    fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
    fh = os.fdopen(fd, "rb")
    try:
        _check_regular(p, os.fstat(fh.fileno()), what, max_bytes)
    except BaseException:
        fh.close()
        raise
    return fh  # type: ignore[return-value]


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
    atomic_write_stream(path, csv_stream(header, rows))


def csv_stream(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> Callable[[TextIO], None]:
    """``write(fh)`` of the CSV text of ``header`` and ``rows``, row by row (for
    :func:`write_text_set`)."""

    def write(fh: TextIO) -> None:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([_csv_cell(v) for v in row])

    return write


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
