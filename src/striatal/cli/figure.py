"""``striatal figure``: the chapter's Figure 5 for one run with the mean policy."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from striatal.cli import options
from striatal.errors import ParameterError

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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    options.add_gain_source_arguments(parser)
    parser.add_argument(
        "--out", type=options.out_path, default=Path("fig5.png"), help="PNG (or .pdf/.svg)"
    )
    parser.add_argument(
        "--every", type=float, default=0.2, help="time between motion snapshots [s]"
    )
    parser.add_argument("--dpi", type=int, default=120, help="resolution of a PNG")


def run(args: argparse.Namespace) -> int:
    from striatal import plots
    from striatal.rollout import simulate

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    controller, plant = options.controller_and_plant(args)
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
