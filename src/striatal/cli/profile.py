"""``striatal profile``: performance profiles of the arms of one or more sweeps."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from striatal.errors import ParameterError
from striatal.io.files import dumps_json

DESCRIPTION = (
    "Performance profiles from the runs.csv of striatal sweep folders: for each arm, the "
    "fraction of its seeds solved within a budget of simulations, simulated seconds or "
    "learning trials, with a pointwise Wilson 95 % band. Unsolved seeds count in the "
    "denominator, so each line ends at the arm's success rate. Without --x: simulations "
    "when every runs.csv has that column, else learning trials (with a note)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("sweeps", type=Path, nargs="+", metavar="SWEEP_DIR", help="sweep folders")
    parser.add_argument("--out", type=Path, required=True, help="PNG (or .pdf/.svg)")
    parser.add_argument(
        "--x",
        choices=("simulations", "simulated_seconds", "trials"),
        default=None,
        help="the budget axis (default: simulations if recorded, else trials)",
    )
    parser.add_argument("--dpi", type=int, default=120, help="resolution of a PNG")
    parser.add_argument("--json", action="store_true", help="print the curves as JSON")


def run(args: argparse.Namespace) -> int:
    from striatal.experiments.profiles import X_LABELS, sweep_profiles
    from striatal.viz import plots

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    if not 10 <= args.dpi <= 1000:
        raise ParameterError(f"--dpi must be in [10, 1000], got {args.dpi}")
    profiles, column, note = sweep_profiles(args.sweeps, args.x)
    fig = plots.performance_profiles(profiles, xlabel=X_LABELS[column], note=note)
    plots.save_figure(fig, out, dpi=args.dpi)
    if args.json:
        sys.stdout.write(
            dumps_json(
                {
                    "x": column,
                    "note": note,
                    "band": "pointwise Wilson 95 %",
                    "profiles": [p.to_dict() for p in profiles],
                }
            )
        )
        return 0
    if note:
        print(f"note: {note}")
    for p in profiles:
        lo, hi = p.low[-1], p.high[-1]
        print(
            f"{p.arm}: {p.successes}/{p.runs} solved = {100 * p.success_rate:.3g} % "
            f"(95 % Wilson {100 * lo:.3g}-{100 * hi:.3g} %) within {p.budget[-1]:g} {column}"
        )
    print(f"wrote {out}")
    return 0
