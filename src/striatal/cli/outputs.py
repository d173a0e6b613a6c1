"""Where a command's ``--out`` may write: never over one of its inputs or a run's files.

:func:`check_out` is called by ``main`` for every command before it runs. A command
whose ``--out`` is a folder names the files it writes there in its module's
``OUT_FILES``; for the others ``--out`` is the file written. Its inputs are every
path among its options (``--result``, ``--config``, the files it reads).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator, Sequence
from pathlib import Path, PurePath

from striatal.errors import ParameterError

#: The files of a training run's or a sweep's folder: no command's ``--out FILE``
#: replaces one of them (the run or sweep that wrote them would be lost).
RUN_FOLDER_FILES = (
    "result.json",
    "checkpoint.json",
    "history.csv",
    "summary.json",
    "sweep.json",
    "runs.csv",
)


#: The kinds of run folder: the files that mark one, and the files it owns.
RUN_KINDS = (
    ("a sweep", ("sweep.json", "runs.csv"), ("sweep.json", "runs.csv", "summary.json")),
    (
        "a training run",
        ("checkpoint.json", "result.json"),
        ("checkpoint.json", "result.json", "history.csv"),
    ),
)


def input_paths(args: argparse.Namespace) -> Iterator[Path]:
    """Every path among the options of ``args`` but ``--out`` (one, or a list of them)."""
    for dest, value in vars(args).items():
        if dest == "out" or dest.startswith("_"):
            continue
        for v in value if isinstance(value, list | tuple) else (value,):
            if isinstance(v, PurePath):
                yield Path(v)


def same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file (through links, ``..``, hard links)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): compare the paths
        return a.resolve() == b.resolve()


def check_out(args: argparse.Namespace, folder_files: Sequence[str] | None) -> None:
    """ParameterError if ``--out`` of ``args`` would overwrite an input or a run's file.

    ``folder_files``: the names a folder ``--out`` gets (None: ``--out`` is a file).
    """
    out = getattr(args, "out", None)
    if not isinstance(out, PurePath):
        return
    out = Path(out)
    targets = [out / n for n in folder_files] if folder_files is not None else [out]
    inputs = list(input_paths(args))
    for target in targets:
        for source in inputs:
            if same_file(target, source):
                raise ParameterError(
                    f"--out {out} would overwrite the input {source}: write the output elsewhere"
                )
    if folder_files is None and out.name in RUN_FOLDER_FILES and out.exists():
        raise ParameterError(
            f"--out {out} would replace the {out.name} of a run or sweep: write elsewhere"
        )
    if folder_files is not None:
        _check_foreign_run(out, folder_files)


def _check_foreign_run(out: Path, folder_files: Sequence[str]) -> None:
    """ParameterError if folder ``out`` holds a run of another kind whose file it would
    replace (``simulate --out`` a sweep's folder: the sweep's summary.json)."""
    for kind, markers, owned in RUN_KINDS:
        if set(markers) <= set(folder_files):
            continue  # the command writes such runs itself (a rerun, a resume)
        if not any((out / m).exists() for m in markers):
            continue
        for name in folder_files:
            if name in owned and (out / name).exists():
                raise ParameterError(
                    f"--out {out} holds {kind}: its {name} would be replaced; write elsewhere"
                )
