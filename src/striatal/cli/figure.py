"""``striatal figure``: the chapter's Figure 5 for one run with the mean policy."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from striatal.cli import options
from striatal.errors import DataFileError, ParameterError
from striatal.files import read_json
from striatal.params import Controller, Plant

COMMAND = "figure"
ORDER = 40
HELP = "draw the chapter's Figure 5 (snapshots, tip path, x and theta) for one run"
DESCRIPTION = (
    "Simulate one run with the mean policy and draw the chapter's Figure 5 in one PNG: "
    "(top) a cart-and-pole stick figure every 0.2 s, laid out along the strip at "
    "x(t) + 0.5 m/s * t so that time reads left to right, orange under the swing-up "
    "controller and blue under balancing; (middle) the path of the pole tip "
    "(x + l sin theta, l cos theta); (bottom) x(t) and theta(t) with the switch times as "
    "dashed lines. Gains: --chapter-final (default), --chapter-initial, --gains with "
    "--theta-c, or --result result.json of striatal train."
)


def add_gain_source_arguments(parser: argparse.ArgumentParser) -> None:
    """The shared controller, run and plant groups, plus --result result.json."""
    options.add_controller_arguments(parser, gains_required=True)
    parser.add_argument(
        "--result",
        type=Path,
        default=None,
        help="take W, theta_c, the controller readings and the plant from this result.json",
    )
    options.add_simulation_arguments(parser)
    options.add_plant_arguments(parser)


def _result_controller(path: Path) -> tuple[Controller, Plant]:
    data = read_json(path, what="result")
    if not isinstance(data, dict):
        raise DataFileError(f"result {path} is not a striatal result.json")
    try:
        settings: dict[str, Any] = data.get("settings") or {}
        ctrl: dict[str, Any] = settings.get("controller") or {}
        plant_d: dict[str, Any] = settings.get("plant") or {}
        controller = Controller(
            gains=tuple(data["W"]),
            theta_c=data["theta_c"],
            balance_sign=ctrl.get("balance_sign", "corrected"),
            switch=ctrl.get("switch", "hard"),
            inhibition=ctrl.get("inhibition", 50.0),
        )
        plant = Plant(
            **{
                k: plant_d[k]
                for k in ("cart_mass", "pole_mass", "length", "gravity")
                if k in plant_d
            }
        )
    except (KeyError, TypeError, AttributeError) as exc:
        raise DataFileError(f"result {path} lacks W, theta_c or settings: {exc!r}") from None
    except ParameterError as exc:
        raise DataFileError(f"result {path} holds an unusable controller: {exc}") from None
    return controller, plant


def controller_and_plant(args: argparse.Namespace) -> tuple[Controller, Plant]:
    """The controller and plant from --result, or from the gain and plant options."""
    if args.result is not None:
        if args.gains is not None or args.chapter_initial or args.chapter_final:
            raise ParameterError("give either --result or a gain set, not both")
        if args.theta_c is not None:
            raise ParameterError("--theta-c cannot be combined with --result")
        return _result_controller(args.result)
    gains, theta_c = options.gains_from(args)
    return options.controller_from(args, gains, theta_c), options.plant_from(args)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_gain_source_arguments(parser)
    parser.add_argument("--out", type=Path, default=Path("fig5.png"), help="PNG (or .pdf/.svg)")
    parser.add_argument(
        "--every", type=float, default=0.2, help="time between motion snapshots [s]"
    )
    parser.add_argument("--dpi", type=int, default=120, help="resolution of a PNG")


def run(args: argparse.Namespace) -> int:
    from striatal import plots
    from striatal.rollout import simulate

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    controller, plant = controller_and_plant(args)
    sim = options.simulation_from(args)
    if not (math.isfinite(args.every) and args.every > 0):
        raise ParameterError(f"--every must be > 0 s, got {args.every}")
    if not 10 <= args.dpi <= 1000:
        raise ParameterError(f"--dpi must be in [10, 1000], got {args.dpi}")
    traj = simulate(plant, controller, sim)
    fig = plots.figure5(traj, every=args.every)
    plots.save_figure(fig, out, dpi=args.dpi)
    o = traj.outcome
    print(
        f"wrote {out}: {len(plots.snapshot_indices(traj, args.every))} snapshots, "
        f"{len(traj.switch_times)} switch(es), success test "
        f"{'passed' if o.success else 'failed'}"
    )
    return 0
