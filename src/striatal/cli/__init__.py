"""The ``striatal`` command: a thin layer that parses, calls the library and prints.

Each subcommand is a module of this package, named in :data:`COMMANDS` with its one-line
help; it has ``add_arguments(parser)``, ``run(args) -> int`` and optionally
``DESCRIPTION``. Only the module of the command being run is imported, and importing it
is cheap (NumPy at most: Numba, SciPy and Matplotlib load inside ``run``), so
``striatal --help`` and ``striatal X --help`` answer at once. Any
:class:`~striatal.errors.StriatalError` becomes one line on stderr and exit 2.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple, NoReturn

from striatal import interrupts
from striatal.cli import config, guards, jit, outputs
from striatal.cli.helpformat import DefaultsHelpFormatter
from striatal.errors import StriatalError
from striatal.io.files import check_no_dangling_link

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
#: 128 + SIGPIPE: what a shell reports for a program whose reader went away (``| head``).
EXIT_BROKEN_PIPE = 141


_NUMBER = r"(?:(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?|inf(?:inity)?|nan)"
#: A value, not an option: a negative number as ``float`` reads it (``-2e-1``, ``-.5``,
#: ``-inf``, ``-nan``) or a comma-separated list starting with one (``-1,2``).
NEGATIVE_VALUE = re.compile(rf"^-{_NUMBER}(?:\s*,\s*[-+]?{_NUMBER})*$", re.IGNORECASE)


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line on stderr and exits 2.

    Every command's parser is one of these, so a negative value reads as a value
    everywhere: argparse's own test knows only ``-1`` and ``-1.5`` and takes
    ``-2e-1``, ``-inf`` or ``-1,2`` for an unknown option; ``type=int`` is read by
    :func:`~striatal.cli.guards.whole_number` (at most 2**31 - 1). Their help is formatted by
    :class:`~striatal.cli.helpformat.DefaultsHelpFormatter` (each default stated once).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", DefaultsHelpFormatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUE
        # ``type=int`` of every option is bounded (cli.guards.MAX_WHOLE)
        self.register("type", int, guards.whole_number)

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


class Command(NamedTuple):
    """A subcommand: its module in this package, its one-line help, and whether it runs
    the compiled kernel (then its first compile is announced: :mod:`striatal.cli.jit`)."""

    module: str
    help: str
    compiles: bool = True


#: Every subcommand, in the order of ``striatal --help``.
COMMANDS: dict[str, Command] = {
    "simulate": Command(
        "simulate", "simulate the cart-pole under the switching controller (mean policy)"
    ),
    "evaluate": Command(
        "evaluate", "chance that a noisy trial passes the success test with fixed gains"
    ),
    "train": Command(
        "train", "run the chapter's switching REINFORCE learner (or a variant: --learner)"
    ),
    "figure": Command(
        "figure", "draw the chapter's Figure 5 (snapshots, tip path, x and theta) for one run"
    ),
    "sweep": Command(
        "sweep",
        "many learning runs over seeds (and a grid), with the learner's control and baselines",
    ),
    "compare": Command(
        "compare",
        "print the comparison table (markdown) of sweep summaries and write it as JSON",
        compiles=False,
    ),
    "curves": Command(
        "curves",
        "plot reward, running success rate, W1..W6, theta_c and the learner's own columns",
        compiles=False,
    ),
    "profile": Command(
        "profile",
        "fraction of seeds solved against budget, per arm, with 95 %% bands",
        compiles=False,
    ),
    "report": Command(
        "report",
        "one self-contained HTML page of a sweep, a training run or several sweeps",
        compiles=False,
    ),
    "animate": Command(
        "animate", "animate one run of the switching controller as a GIF (or MP4 with ffmpeg)"
    ),
    "switch-figure": Command(
        "switch_figure",
        "plot the soft switch's balancing and swing-up weights against |theta|",
        compiles=False,
    ),
    "ablation": Command(
        "ablation", "compare the learner variants over many seeds from random W(0)"
    ),
    "interpret": Command(
        "interpret",
        "read mu_1, mu_2 as direct/indirect pathway activity and the updates as LTP/LTD",
        compiles=False,
    ),
    "neural": Command(
        "neural", "run the controller as a spiking network (needs the [neural] extra: nengo)"
    ),
    "robustness": Command(
        "robustness", "success of learned gains when pole mass/length differ or sensors are noisy"
    ),
    "bench": Command(
        "bench", "benchmark the kernel against Gymnasium's CartPole (docs/performance.md)"
    ),
}


def command_module(name: str) -> ModuleType:
    """The module of command ``name`` (imported now, not before)."""
    return importlib.import_module(f"{__name__}.{COMMANDS[name].module}")


def command_of(argv: Sequence[str]) -> str | None:
    """The command that ``argv`` names (its first word that is not an option), if any."""
    for word in argv:
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``striatal`` parser. With ``only`` a command's name, only that command's
    options are declared (the others are listed, their modules not imported); with
    ``only=""`` none are."""
    from striatal import __version__

    parser = OneLineParser(
        prog="striatal",
        description="The chapter's basal-ganglia switching REINFORCE learner on the cart-pole.",
    )
    parser.add_argument("--version", action="version", version=f"striatal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    sub.required = True
    for name, command in COMMANDS.items():
        if only is not None and name != only:
            sub.add_parser(name, help=command.help)
            continue
        mod = command_module(name)
        p = sub.add_parser(
            name, help=command.help, description=getattr(mod, "DESCRIPTION", command.help)
        )
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def options_given(command: str, words: Sequence[str]) -> frozenset[str]:
    """The dests of the options of ``command`` that ``words`` (the whole command line) give.

    An option given at its default value counts as given: it is found by parsing
    ``words`` again with every default of the command left out, not by comparing values.
    """
    parser = build_parser(only=command)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    own = sub.choices[command]
    dests = {a.dest for a in own._actions if a.option_strings}
    for action in own._actions:
        action.default = argparse.SUPPRESS
    return frozenset(vars(parser.parse_args(list(words)))) & dests


def tolerate_any_encoding() -> None:
    """Make stdout and stderr print what they cannot encode as an escape, not raise.

    Under ``PYTHONIOENCODING=latin-1`` or an ASCII locale a theta or a minus sign would
    otherwise stop a command with UnicodeEncodeError; every command prints through these.
    """
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None and (stream.encoding or "").lower() not in ("utf-8", "utf8"):
            reconfigure(errors="backslashreplace")


def ignore_late_interrupts() -> None:
    """Ignore SIGINT from now on: the command is stopped or done, the process ending.

    A Ctrl-C while the interpreter exits (joining a worker pool's threads, running
    atexit handlers) would otherwise end the process by SIGINT, after the run was
    already stopped or finished and its files written.
    """
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``striatal`` and ``python -m striatal``; returns the exit code.

    Ctrl-C at any point, while the libraries load too (they load here, when the
    command's module or its ``run`` imports them, not when ``striatal.cli`` is
    imported), exits 130
    without a traceback. Run as the program (``argv`` None: it parses ``sys.argv``),
    a Ctrl-C once the first is being handled, or once the command has returned,
    is ignored: the exit code stays the command's.
    """
    if argv is None:
        interrupts.install()  # the ``striatal`` script; ``python -m striatal`` did already
    rc = _main(argv)
    if argv is None:
        # the command is over, its files written and its exit code chosen; what is
        # left is the interpreter's exit, which a Ctrl-C would turn into death by SIGINT
        ignore_late_interrupts()
        if interrupts.received():
            interrupts.forget_unhandled()
    return rc


def _load_failure(exc: BaseException) -> str:
    """One line for a library that could not load while the command was being set up."""
    limit = "the process's memory limit (ulimit -v) is too small for NumPy and Numba"
    if isinstance(exc, MemoryError):
        return f"out of memory while loading the libraries: {limit}"
    cause = str(exc.__context__ if exc.__context__ is not None else exc)
    if "map segment" in cause or "Cannot allocate memory" in cause:
        library = Path(cause.split(":")[0]).name if ".so" in cause else "a shared library"
        return f"out of memory while loading {library}: {limit}"
    first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return f"a library could not load: {first[:200]}"


def _main(argv: Sequence[str] | None) -> int:
    tolerate_any_encoding()
    # Numba's OpenMP threads then sleep between kernel calls instead of spinning, so the
    # Python threads of a batch sweep (its noise) get the cores (docs/performance.md)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    try:
        words = sys.argv[1:] if argv is None else argv
        parser = build_parser(only=command_of(words) or "")
        args = parser.parse_args(argv)
        args._given = options_given(args.command, words)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except (MemoryError, OSError) as exc:
        # the libraries could not load: a memory limit (ulimit -v) too small for them
        sys.stderr.write(f"striatal: error: {_load_failure(exc)}\n")
        return EXIT_USAGE
    except Exception:
        if interrupts.received():  # an import cut short by Ctrl-C, reported as another error
            return EXIT_INTERRUPTED
        raise
    try:
        if config.wants_file(args):
            given = args._given
            args = config.apply(parser, args, sys.argv[1:] if argv is None else argv)
            args._given = given
            if args.print_config:
                sys.stdout.write(config.toml_text(args.command, args))
                return 0
        outputs.check_out(args, getattr(command_module(args.command), "OUT_FILES", None))
        out = getattr(args, "out", None)
        if isinstance(out, str | os.PathLike) and str(out):
            # every --out (a folder or a file): a link to nothing above it can never be
            # written, so say so now rather than after the computation
            check_no_dangling_link(Path(out).parent)
        if COMMANDS[args.command].compiles:
            jit.announce_compiles()
        return int(args._run(args))
    except StriatalError as exc:
        sys.stderr.write(f"striatal {args.command}: error: {exc}\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write(f"striatal {args.command}: interrupted\n")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader of stdout went away; files were written before printing. Point
        # stdout at /dev/null so the interpreter's final flush does not fail again.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except MemoryError:
        sys.stderr.write(
            f"striatal {args.command}: error: out of memory (the process's memory limit, "
            "ulimit -v, or the machine's); nothing more was written\n"
        )
        return EXIT_USAGE
    except OSError as exc:
        # an output folder that is a file, a read-only disk, a full disk: the user's to fix
        where = f"{exc.filename}: " if exc.filename else ""
        sys.stderr.write(f"striatal {args.command}: error: {where}{exc.strerror or exc}\n")
        return EXIT_USAGE
    except Exception:
        if interrupts.received():  # a Ctrl-C that a library turned into another error
            sys.stderr.write(f"striatal {args.command}: interrupted\n")
            return EXIT_INTERRUPTED
        raise
