"""``striatal figure``: the chapter's Figure 5 for one run with the mean policy."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from striatal.cli import options
from striatal.errors import ParameterError
from striatal.io.files import dumps_json
from striatal.limits import count_of_steps

DESCRIPTION = (
    "Simulate one run with the mean policy and draw the chapter's Figure 5 in one PNG: "
    "(top) a cart-and-pole stick figure every 0.2 s, laid out along the strip at "
    "x(t) + 0.5 m/s * t so that time reads left to right, orange under the swing-up "
    "controller and blue under balancing; (middle) the path of the pole tip "
    "(x + l sin theta, l cos theta); (bottom) x(t) and theta(t) with the switch times as "
    "dashed lines. Gains: --chapter-final (default), --chapter-initial, --gains with "
    "--theta-c, or --result result.json of striatal train. Prints the figure's caption "
    "(the run's gains, readings and outcome, and how to read each panel)."
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
    parser.add_argument(
        "--json", action="store_true", help="print a JSON record of what was written on stdout"
    )


def run(args: argparse.Namespace) -> int:
    from striatal.sim.rollout import simulate
    from striatal.viz import plots

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    controller, plant = options.controller_and_plant(args)
    sim = options.simulation_from(args)
    if not (math.isfinite(args.every) and args.every > 0):
        raise ParameterError(f"--every must be > 0 s, got {args.every}")
    count_of_steps(
        sim.duration, args.every, cap=plots.MAX_SNAPSHOTS, what="snapshots", fix="raise --every"
    )
    if not 10 <= args.dpi <= 1000:
        raise ParameterError(f"--dpi must be in [10, 1000], got {args.dpi}")
    traj = simulate(plant, controller, sim)
    fig = plots.figure5(traj, every=args.every)
    plots.save_figure(fig, out, dpi=args.dpi)
    o = traj.outcome
    snapshots = len(plots.drawn_snapshots(traj, args.every)[0])
    caption = plots.figure5_caption(traj, every=args.every)
    if args.json:
        record = {
            "wrote": str(out),
            "snapshots": snapshots,
            "switch_times": [float(t) for t in traj.switch_times],
            "success": bool(o.success),
            "W": list(controller.gains),
            "theta_c": controller.theta_c,
            "duration": sim.duration,
            "caption": caption,
        }
        sys.stdout.write(dumps_json(record))
        return 0
    print(
        f"wrote {out}: {snapshots} snapshots, {len(traj.switch_times)} switch(es), "
        f"success test {'passed' if o.success else 'failed'}"
    )
    print(caption)
    return 0
