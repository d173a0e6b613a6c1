"""Argument groups shared by several commands, and their conversion to parameter sets."""

from __future__ import annotations

import argparse
import contextlib
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from striatal import arguments
from striatal.cli import config
from striatal.cli.helpformat import default_note
from striatal.errors import ParameterError
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    CHAPTER_THETA0,
    Controller,
    Hardware,
    HoldKind,
    Plant,
    Simulation,
    check_gains,
)

if TYPE_CHECKING:
    from striatal.io.tracking import TensorBoardTracker


def out_path(text: str) -> Path:
    """The ``--out`` option type of every command: a path, never the empty string."""
    if not text.strip():
        raise argparse.ArgumentTypeError("--out must name a file or folder, got an empty string")
    return Path(text)


def out_format(path: Path, suffixes: tuple[str, ...]) -> str:
    """The format of ``--out path``, taken from its suffix (one of ``suffixes``), or
    ParameterError naming the suffixes the command writes."""
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        raise ParameterError(
            f"--out {path}: the format is taken from the suffix; use {' or '.join(suffixes)}"
        )
    return suffix


def add_plant_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("plant (section 2.1)")
    g.add_argument("--cart-mass", type=float, default=1.0, help="M [kg]")
    g.add_argument("--pole-mass", type=float, default=0.1, help="m [kg] (point mass)")
    g.add_argument("--length", type=float, default=1.0, help="l [m]")
    g.add_argument("--gravity", type=float, default=9.8, help="g [m/s^2]")


def plant_from(args: argparse.Namespace) -> Plant:
    return Plant(
        cart_mass=args.cart_mass,
        pole_mass=args.pole_mass,
        length=args.length,
        gravity=args.gravity,
    )


def add_gains_argument(group: Any, flag: str, *, help: str) -> None:
    """An option that takes the six gains W1..W6 as six words (a vector, not a list)."""
    group.add_argument(
        flag, type=float, nargs=6, metavar=("W1", "W2", "W3", "W4", "W5", "W6"), help=help
    )


def add_trial_arguments(parser: argparse.ArgumentParser) -> None:
    """--dt and --duration of every learning trial, then the plant's options."""
    g = parser.add_argument_group("trial")
    g.add_argument("--dt", type=float, default=0.01, help="control and RK4 step [s]")
    g.add_argument("--duration", type=float, default=60.0, help="trial length T_f [s]")
    add_plant_arguments(parser)


def add_controller_arguments(parser: argparse.ArgumentParser, *, gains_required: bool) -> None:
    """--gains/--theta-c/--chapter-final/--chapter-initial and the readings of the chapter."""
    g = parser.add_argument_group("controller (sections 2.2-2.3, 4)")
    if gains_required:
        choice = g.add_mutually_exclusive_group()
        add_gains_argument(choice, "--gains", help="the six gains of eqs 22-23 (W1 > 0)")
        choice.add_argument(
            "--chapter-final",
            action="store_true",
            help=f"the chapter's learned W {list(CHAPTER_FINAL_W)} and theta_c = "
            f"{CHAPTER_FINAL_THETA_C}, the gain set used when none is chosen",
        )
        choice.add_argument(
            "--chapter-initial",
            action="store_true",
            help=f"the chapter's W(0) {list(CHAPTER_INITIAL_W)} and theta_c = "
            f"{CHAPTER_INITIAL_THETA_C}",
        )
        g.add_argument(
            "--theta-c",
            type=float,
            default=None,
            help="switching threshold [rad], balancing while |theta| < theta_c (eq 21) "
            + default_note("the one of the chosen gain set"),
        )
    g.add_argument(
        "--balance-sign",
        choices=("corrected", "chapter"),
        default="corrected",
        help="sign of the theta terms of the balancing law (docs/paper-notes.md, section 1): "
        "'corrected' stabilises; 'chapter' is eq 20 as printed and makes the upright unstable",
    )
    g.add_argument(
        "--switch",
        choices=("hard", "soft"),
        default="hard",
        help="hard switch at |theta| < theta_c (section 2.3) or the cerebellar soft switch "
        "with lateral inhibition (section 4; docs/paper-notes.md, section 4)",
    )
    g.add_argument(
        "--inhibition",
        type=float,
        default=50.0,
        metavar="GAMMA",
        help="strength of lateral inhibition of the soft switch [1/rad]",
    )


def gains_from(args: argparse.Namespace) -> tuple[tuple[float, ...], float]:
    """(gains, theta_c) from --gains/--chapter-final/--chapter-initial/--theta-c."""
    if getattr(args, "gains", None) is not None:
        gains = check_gains(args.gains)
        if args.theta_c is None:
            raise ParameterError("--gains needs --theta-c as well")
        return gains, args.theta_c
    if getattr(args, "chapter_initial", False):
        return (
            CHAPTER_INITIAL_W,
            args.theta_c if args.theta_c is not None else CHAPTER_INITIAL_THETA_C,
        )
    theta_c = args.theta_c if args.theta_c is not None else CHAPTER_FINAL_THETA_C
    return CHAPTER_FINAL_W, theta_c


def controller_from(
    args: argparse.Namespace, gains: tuple[float, ...], theta_c: float
) -> Controller:
    return Controller(
        gains=gains,
        theta_c=theta_c,
        balance_sign=args.balance_sign,
        switch=args.switch,
        inhibition=args.inhibition,
    )


def add_simulation_arguments(parser: argparse.ArgumentParser, *, duration: float = 60.0) -> None:
    g = parser.add_argument_group("run")
    g.add_argument("--theta0", type=float, default=CHAPTER_THETA0, help="initial angle [rad]")
    g.add_argument("--x0", type=float, default=0.0, help="initial cart position [m]")
    g.add_argument("--duration", type=float, default=duration, help="T_f [s]")
    g.add_argument(
        "--dt", type=float, default=0.01, help="control and RK4 step [s], u held over it"
    )


def simulation_from(args: argparse.Namespace) -> Simulation:
    return Simulation(theta0=args.theta0, x0=args.x0, duration=args.duration, dt=args.dt)


def add_hardware_arguments(parser: argparse.ArgumentParser) -> None:
    """--hold, --max-force, --track and --robust (docs/paper-notes.md section 9)."""
    g = parser.add_argument_group("motor and track (docs/paper-notes.md section 9)")
    g.add_argument(
        "--hold",
        choices=("u", "force"),
        default=None,
        help="what the motor holds over each step dt: 'u' (the chapter's idealisation) or "
        "'force' (eq 12 computed at the sample with the controller's model, held while the "
        "plant's eqs 8-9 integrate) " + default_note("u; --robust: force"),
    )
    g.add_argument(
        "--max-force",
        type=float,
        default=None,
        metavar="F",
        help="motor limit [N]: the force is clipped to [-F, F] (default: none)",
    )
    g.add_argument(
        "--track",
        type=float,
        default=None,
        metavar="L",
        help="track half-length [m]: |x| > L ends the run as a failure (default: none)",
    )
    g.add_argument(
        "--robust",
        action="store_true",
        help="run the robustness set (force held; nominal plant, the four pole mass x "
        "length corners at x0.8/x1.2, theta0 = pi -/+ 0.3, x0 = -/+ 0.5 m; 9 runs of "
        "60 s, mean policy) instead of one run; --max-force and --track apply to every case",
    )


def hardware_from(args: argparse.Namespace) -> Hardware:
    """The motor and track of --hold/--max-force/--track (with --robust: the force held)."""
    if args.robust and args.hold == "u":
        raise ParameterError("--robust always holds the force: drop --hold u")
    hold: HoldKind = "force" if args.robust or args.hold == "force" else "u"
    return Hardware(hold=hold, max_force=args.max_force, track=args.track)


def check_robust_run(args: argparse.Namespace) -> None:
    """--robust sets its own starts and T_f: refuse the run options that it would ignore."""
    defaults = {"theta0": CHAPTER_THETA0, "x0": 0.0, "duration": 60.0}
    given = [f"--{k.replace('_', '-')}" for k, v in defaults.items() if getattr(args, k) != v]
    if given:
        raise ParameterError(
            f"--robust sets the starts and T_f = 60 s itself: drop {', '.join(given)}"
        )


def json_ready(obj: Any) -> Any:
    """Floats that JSON can hold (non-finite become None)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def add_gain_source_arguments(parser: argparse.ArgumentParser) -> None:
    """The shared controller, run and plant groups, plus --result result.json."""
    add_controller_arguments(parser, gains_required=True)
    parser.add_argument(
        "--result",
        type=Path,
        default=None,
        help="take W, theta_c, the controller readings and the plant from this result.json",
    )
    add_simulation_arguments(parser)
    add_plant_arguments(parser)


def result_controller(path: Path) -> tuple[Controller, Plant]:
    """The controller (W, theta_c, readings) and plant of a result.json of train."""
    from striatal.io.rundir import read_result

    r = read_result(path)
    return r.controller, r.plant


def controller_and_plant(args: argparse.Namespace) -> tuple[Controller, Plant]:
    """The controller and plant from --result, or from the gain and plant options."""
    if args.result is not None:
        if args.gains is not None or args.chapter_initial or args.chapter_final:
            raise ParameterError("give either --result or a gain set, not both")
        if args.theta_c is not None:
            raise ParameterError("--theta-c cannot be combined with --result")
        return result_controller(args.result)
    gains, theta_c = gains_from(args)
    return controller_from(args, gains, theta_c), plant_from(args)


def add_worker_arguments(
    group: argparse.ArgumentParser | argparse._ArgumentGroup,
    *,
    connect_timeout: float,
    refuse_backend: Callable[[str], str | None] | None = None,
) -> None:
    """--backend, --address, --connect-timeout and --workers of a command that runs many
    learning runs (sweep, ablation, neural --learn --seeds); check them with
    :func:`check_worker_arguments`. ``refuse_backend(value)``: the one line a --backend
    value gets that this command's user may have meant as another option (None: the
    parser's own "invalid choice")."""
    backends = ("local", "ray")

    def backend(text: str) -> str:
        if text not in backends and refuse_backend is not None:
            message = refuse_backend(text)
            if message is not None:
                raise argparse.ArgumentTypeError(message)
        return text

    group.add_argument(
        "--backend",
        type=backend,
        choices=backends,
        default="local",
        help="local worker processes, or a Ray cluster (--address)",
    )
    group.add_argument(
        "--address", default=None, help="Ray cluster address HOST:PORT (--backend ray)"
    )
    group.add_argument(
        "--connect-timeout",
        type=arguments.cli_type("connect_timeout"),
        default=connect_timeout,
        help="give up on a Ray address that accepts no connection after this many seconds",
    )
    group.add_argument(
        "--workers",
        type=arguments.cli_type("workers"),
        default=config.WORKERS,
        help="local worker processes",
    )


def check_worker_arguments(args: argparse.Namespace) -> None:
    """ParameterError unless the options of :func:`add_worker_arguments` make sense
    (:func:`striatal.experiments.pool.check_backend`, checked before any work)."""
    from striatal.experiments.pool import check_backend

    check_backend(**worker_options(args))


def worker_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options of :func:`add_worker_arguments` as the keywords of
    :func:`striatal.experiments.sweeps.run_sweep` and ``pool.check_backend`` take them."""
    return {
        "backend": args.backend,
        "workers": args.workers,
        "address": args.address,
        "connect_timeout": args.connect_timeout,
    }


def add_tensorboard_argument(group: argparse._ArgumentGroup, what: str) -> None:
    """--tensorboard DIR: ``what`` as TensorBoard scalars (:mod:`striatal.io.tracking`)."""
    group.add_argument(
        "--tensorboard",
        type=out_path,
        default=None,
        metavar="DIR",
        help=f"write {what} as TensorBoard scalars here (the [tracking] extra)",
    )


@contextlib.contextmanager
def tracker(args: argparse.Namespace) -> Iterator[TensorBoardTracker | None]:
    """The TensorBoard tracker of ``--tensorboard DIR`` (closed after), None without it."""
    if getattr(args, "tensorboard", None) is None:
        yield None
        return
    from striatal.io.tracking import TensorBoardTracker

    with TensorBoardTracker(args.tensorboard) as t:
        yield t
