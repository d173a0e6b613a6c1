"""``striatal switch-figure``: the cerebellar soft switch of section 4 against |theta|."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from striatal.cli import options
from striatal.cli.lists import CommaList
from striatal.io.files import dumps_json
from striatal.params import CHAPTER_FINAL_THETA_C, check_theta_c

DESCRIPTION = (
    "The cerebellar soft switch of section 4, read with the labels swapped "
    "(docs/paper-notes.md section 4): balancing weight clip(gamma (theta_c - |theta|), 0,"
    " 1) on mu_1 and swing-up weight clip(gamma (|theta| - theta_c), 0, 1) on mu_2, for "
    "each gamma given, beside the hard switch; and their sum, which shows the dead zone "
    "of half-width 1/gamma at theta_c."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--theta-c",
        type=float,
        default=CHAPTER_FINAL_THETA_C,
        help="switching threshold [rad]",
    )
    parser.add_argument(
        "--inhibition",
        action=CommaList,
        item=float,
        # one curve and legend entry each: more than a dozen cannot be told apart, and
        # the legend's layout grows faster than linearly in their number
        max_items=12,
        default=(2.0, 5.0, 20.0, 50.0),
        metavar="GAMMA[,...]",
        help="strengths of lateral inhibition gamma [1/rad], one curve each; comma-separated",
    )
    parser.add_argument(
        "--out", type=options.out_path, default=Path("soft_switch.png"), help="PNG file"
    )
    parser.add_argument("--dpi", type=int, default=120, help="resolution of a PNG")
    parser.add_argument(
        "--json", action="store_true", help="print a JSON record of what was written on stdout"
    )


def run(args: argparse.Namespace) -> int:
    from striatal.errors import ParameterError
    from striatal.viz import plots

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    theta_c = check_theta_c(args.theta_c)
    if not 10 <= args.dpi <= 1000:
        raise ParameterError(f"--dpi must be in [10, 1000], got {args.dpi}")
    fig = plots.switch_figure(theta_c, args.inhibition)
    plots.save_figure(fig, out, dpi=args.dpi)
    if args.json:
        record = {"wrote": str(out), "theta_c": theta_c, "inhibition": list(args.inhibition)}
        sys.stdout.write(dumps_json(record))
        return 0
    print(f"wrote {out}: theta_c = {theta_c:g} rad, gamma = {', '.join(map(str, args.inhibition))}")
    return 0
