"""``striatal animate``: a GIF (or MP4) of one run with the mean policy."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from striatal.cli import options
from striatal.cli.options import add_gain_source_arguments, controller_and_plant
from striatal.errors import ParameterError
from striatal.io.files import dumps_json

DESCRIPTION = (
    "Simulate one run with the mean policy and write an animation: a frame every "
    "speed / fps seconds of simulated time, drawn by striatal.viz.render.cartpole_frame. "
    "A .gif is written with Pillow; a .mp4 needs ffmpeg on PATH. Gains as for "
    "striatal figure."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_gain_source_arguments(parser)
    parser.add_argument(
        "--out", type=options.out_path, default=Path("run.gif"), help=".gif or .mp4"
    )
    parser.add_argument("--fps", type=float, default=15.0, help="frames per second of video")
    parser.add_argument(
        "--speed", type=float, default=3.0, help="simulated seconds per second of video"
    )
    parser.add_argument("--width", type=int, default=720, help="frame width [px]")
    parser.add_argument("--height", type=int, default=320, help="frame height [px]")
    parser.add_argument(
        "--json", action="store_true", help="print a JSON record of what was written on stdout"
    )


def run(args: argparse.Namespace) -> int:
    from striatal.sim.rollout import simulate
    from striatal.viz import plots

    out = plots.check_image_path(args.out, (".gif", ".mp4"))
    if out.suffix.lower() == ".mp4" and plots.ffmpeg_path() is None:
        raise ParameterError("writing .mp4 needs ffmpeg on PATH; write a .gif instead")
    for name in ("fps", "speed"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(f"--{name} must be a finite number > 0, got {v}")
    controller, plant = controller_and_plant(args)
    sim = options.simulation_from(args)
    plots.check_animation(sim.duration, args.fps, args.speed, args.width, args.height)
    traj = simulate(plant, controller, sim)
    frames = plots.animation_frames(
        traj, fps=args.fps, speed=args.speed, width=args.width, height=args.height
    )
    plots.save_animation(frames, out, fps=args.fps)
    if args.json:
        record = {
            "wrote": str(out),
            "frames": len(frames),
            "fps": args.fps,
            "speed": args.speed,
            "simulated_seconds": float(traj.t[-1]),
            "width": args.width,
            "height": args.height,
        }
        sys.stdout.write(dumps_json(record))
        return 0
    print(
        f"wrote {out}: {len(frames)} frames at {args.fps:g} fps, {args.speed:g}x real time "
        f"({traj.t[-1]:g} s simulated)"
    )
    return 0
