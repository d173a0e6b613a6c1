"""Experiment files: a command's options in a TOML file, read with ``--config``.

``striatal sweep --config exp.toml`` (and ``ablation``) reads every option from a TOML
file whose keys are the long option names (``max-trials`` or ``max_trials``); an option
given on the command line wins over the file, and a key that names no option of the
command is refused (one line, exit 2). ``--print-config`` prints the options in effect
as such a file instead of running. The options that decide what a sweep computes are
recorded in its summary.json (``settings.options``); ``--from-summary FILE`` reads them
back, so ``striatal sweep --print-config --from-summary DIR/summary.json`` writes the
file that reruns a finished sweep, and ``--from-summary`` alone reruns it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path, PurePath
from typing import Any

from striatal.cli import lists
from striatal.errors import DataFileError, ParameterError

#: ``--workers`` of every command that has it (sweep, ablation): one worker process,
#: which a shared machine can spare (the workers change the wall time, never the
#: results). Their ``--seeds``: :data:`striatal.experiments.sweeps.SEEDS`.
WORKERS = 1
#: The options of this module: never in a file, never recorded.
CONFIG_DESTS = ("config", "from_summary", "print_config")
#: Options that say where and how a run goes, not what it computes: not recorded in
#: summary.json (a rerun elsewhere, with other workers, computes the same thing).
RUN_ONLY = (
    "out",
    "workers",
    "backend",
    "address",
    "connect_timeout",
    "engine",
    "json",
    "no_progress",
    "tensorboard",
)


def add_config_arguments(parser: argparse.ArgumentParser) -> None:
    """--config, --from-summary and --print-config."""
    g = parser.add_argument_group("experiment file")
    g.add_argument(
        "--config",
        type=Path,
        default=None,
        metavar="TOML",
        help="read the options from this TOML file (keys: the long option names, "
        "e.g. max-trials = 300); options on the command line win",
    )
    g.add_argument(
        "--from-summary",
        type=Path,
        default=None,
        metavar="SUMMARY",
        help="read the options recorded in a finished run's summary.json (or its folder); "
        "--config and the command line win",
    )
    g.add_argument(
        "--print-config",
        action="store_true",
        help="print the options in effect as a TOML file for --config, and exit without running",
    )


def wants_file(args: argparse.Namespace) -> bool:
    """Whether the command has to read an experiment file or print one."""
    return any(getattr(args, d, None) for d in CONFIG_DESTS)


def _plain(value: Any) -> Any:
    """A value as TOML and JSON hold it: tuples as lists, paths as strings."""
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, PurePath):
        return str(value)
    return value


def option_values(args: argparse.Namespace, *, skip: Sequence[str] = ()) -> dict[str, Any]:
    """Every option of ``args`` by its long name (``max-trials``), unset ones as None."""
    leave = {"command", *CONFIG_DESTS, *skip}
    return {
        dest.replace("_", "-"): _plain(value)
        for dest, value in vars(args).items()
        if not dest.startswith("_") and dest not in leave
    }


def recorded_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options that decide what the run computes, as summary.json's settings.options.

    ``--engine simd`` is recorded (its rows equal the exact engines' only within
    round-off, so --from-summary must run it again); the exact engines are not.
    """
    values = option_values(args, skip=RUN_ONLY)
    if getattr(args, "engine", None) == "simd":
        values["engine"] = "simd"
    return {k: v for k, v in values.items() if v is not None}


#: Largest experiment file read [bytes]: 1 MiB (one holds a few dozen options).
MAX_CONFIG_BYTES = 2**20


def read_toml(path: Path) -> dict[str, Any]:
    """The options of an experiment file, read through :func:`striatal.io.files.read_text`:
    a FIFO, a device or a file over :data:`MAX_CONFIG_BYTES` is refused before reading."""
    from striatal.io.files import read_text

    if not os.path.lexists(path):
        raise DataFileError(f"--config {path}: no such file")
    text = read_text(path, what="--config", max_bytes=MAX_CONFIG_BYTES)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DataFileError(f"--config {path} is not TOML: {exc}") from None


def read_summary_options(path: Path, command: str) -> dict[str, Any]:
    """The options recorded in ``path`` (a summary.json or its folder) by ``command``."""
    from striatal.io.schema import read_summary

    p = path / "summary.json" if path.is_dir() else path
    data = read_summary(p, what="--from-summary")
    settings = data.get("settings")
    if not isinstance(settings, dict):
        raise DataFileError(f"--from-summary {p} holds no settings block")
    made_by = settings.get("command")
    if made_by != f"striatal {command}":
        raise DataFileError(
            f"--from-summary {p} was written by {made_by!r}, not striatal {command}"
        )
    found = settings.get("options")
    if not isinstance(found, dict):
        raise DataFileError(
            f"--from-summary {p} records no options (written before experiment files); "
            "rerun it with the options of its settings block"
        )
    return found


def _word(value: Any) -> str:
    """One value as the command line writes it."""
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def tokens(parser: argparse.ArgumentParser, values: Mapping[str, Any], source: str) -> list[str]:
    """The command-line words that give ``parser`` the options ``values`` (from ``source``)."""
    by_flag = {o: a for a in parser._actions for o in a.option_strings}
    words: list[str] = []
    for key, value in values.items():
        name = str(key).replace("_", "-")
        dest = name.replace("-", "_")
        if isinstance(value, dict):
            raise ParameterError(
                f"{source}: [{key}] is a table; write its options at the top level (key = value)"
            )
        action = by_flag.get(f"--{name}")
        if action is not None and action.nargs == 0:
            dest = action.dest  # a flag: --normalise = false is its partner --no-normalise
        group = (
            [action]
            if action is not None and action.nargs != 0
            else [a for a in parser._actions if a.dest == dest and a.option_strings]
        )
        if (
            not group
            or dest in CONFIG_DESTS
            or any(
                isinstance(a, argparse._HelpAction) or a.help == argparse.SUPPRESS for a in group
            )
        ):
            raise ParameterError(f"{source}: unknown option {key!r} for this command")
        words += _words_of(group, value, f"{source}: {key}")
    return words


def _numeric(convert: Any) -> bool:
    """Whether an option's ``type`` (or a list's item) reads a number."""
    return convert in (int, float) or bool(getattr(convert, "numeric", False))


def _check_not_text(action: argparse.Action, value: Any, where: str) -> None:
    """ParameterError if a file gives text where the option takes a number: ``seeds = "2"``
    is not the number 2 (TOML has numbers; only ``none`` of a "no limit" option is text)."""
    convert = action.item if isinstance(action, lists.CommaList) else action.type
    values = value if isinstance(value, list) else [value]
    if _numeric(convert) and any(isinstance(v, str) for v in values):
        if (
            isinstance(value, str)
            and value.strip().lower() == "none"
            and getattr(convert, "takes_none", False)
        ):
            return
        raise ParameterError(f"{where} must be a number, not the text {value!r:.40}")


def _words_of(group: Sequence[argparse.Action], value: Any, where: str) -> list[str]:
    first = group[0]
    _check_not_text(first, value, where)
    flag = first.option_strings[-1]
    if first.nargs == 0:  # a flag (store_true, or one of a pair like --normalise/--no-normalise)
        if not isinstance(value, bool):
            raise ParameterError(f"{where} must be true or false, got {value!r}")
        for a in group:
            if a.const is value:
                return [a.option_strings[-1]]
        if value is first.default:
            return []
        raise ParameterError(f"{where} = {str(value).lower()} cannot be set")
    if isinstance(value, bool):
        raise ParameterError(f"{where} takes a value, not {str(value).lower()}")
    if isinstance(value, list):
        if isinstance(first, lists.CommaList):
            return [f"{flag}={','.join(_word(v) for v in value)}"]
        if first.nargs in (None, argparse.OPTIONAL):
            raise ParameterError(f"{where} takes one value, not a list")
        return [flag, *(_word(v) for v in value)]
    if isinstance(first.nargs, int) and first.nargs > 1:
        raise ParameterError(f"{where} takes a list of {first.nargs} values")
    return [f"{flag}={_word(value)}"]


def _refuse_with(parser: argparse.ArgumentParser, source: str) -> Any:
    def error(message: str) -> Any:
        raise ParameterError(f"{source}: {message}")

    return error


def apply(
    parser: argparse.ArgumentParser, args: argparse.Namespace, argv: Sequence[str]
) -> argparse.Namespace:
    """``args`` with the options of --from-summary, then --config, under those of ``argv``."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    command_parser = sub.choices[args.command]
    words: list[str] = []
    for source, values in (
        (f"--from-summary {args.from_summary}", _summary_values(args)),
        (f"--config {args.config}", read_toml(args.config) if args.config else {}),
    ):
        found = tokens(command_parser, values, source)
        # each source's options alone first, so that an error names the file
        command_parser.error = _refuse_with(command_parser, source)  # type: ignore[method-assign]
        try:
            command_parser.parse_args(found)
        finally:
            del command_parser.error
        words += found
    at = list(argv).index(args.command) + 1
    return parser.parse_args([*argv[:at], *words, *argv[at:]])


def _summary_values(args: argparse.Namespace) -> dict[str, Any]:
    if args.from_summary is None:
        return {}
    return read_summary_options(args.from_summary, args.command)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    # JSON's string escapes are TOML's basic-string escapes; DEL must be escaped in TOML
    return json.dumps(str(value), ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_text(command: str, args: argparse.Namespace) -> str:
    """The options of ``args`` as a TOML file that ``striatal COMMAND --config`` reads."""
    lines = [
        f"# options of striatal {command}; rerun with: striatal {command} --config FILE",
        "# (options given on the command line win over this file)",
    ]
    for key, value in option_values(args).items():
        if value is None:
            lines.append(f"# {key}: not set, its default applies")
        else:
            text = _toml_value(_plain(value))
            try:
                text.encode("utf-8")
            except UnicodeEncodeError:
                # a path of bytes that are not UTF-8 (surrogate escapes): TOML cannot hold it
                raise ParameterError(
                    f"--{key} is not valid UTF-8 text, which a config file cannot hold; "
                    "give it on the command line"
                ) from None
            lines.append(f"{key} = {text}")
    return "\n".join(lines) + "\n"
