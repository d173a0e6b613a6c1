"""``striatal curves``: learning curves of one striatal train run."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from striatal.cli import options
from striatal.errors import ParameterError
from striatal.io.files import dumps_json

DESCRIPTION = (
    "Learning curves from history.csv of striatal train, in one figure: the reward of each "
    "trial (the sparse +10 / 0 / -5 with the running fraction of positive rewards, or the "
    "shaped reward with its running mean) and the running fraction passing the success "
    "test; the six gains used in each trial; theta_c; then the learner's own columns "
    "(chapter, rpe: the policy std sigma; pgpe: its exploration std). The learner and its "
    "reward are read from the result.json or checkpoint.json beside history.csv."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("history", type=Path, help="history.csv of striatal train")
    parser.add_argument(
        "--out", type=options.out_path, default=Path("curves.png"), help="PNG (or .pdf/.svg)"
    )
    parser.add_argument("--window", type=int, default=50, help="trials in the running fractions")
    parser.add_argument("--dpi", type=int, default=120, help="resolution of a PNG")
    parser.add_argument(
        "--json", action="store_true", help="print a JSON record of what was written on stdout"
    )


def run(args: argparse.Namespace) -> int:
    from striatal.io.rundir import read_history
    from striatal.viz import plots

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    if args.window < 1:
        raise ParameterError(f"--window must be >= 1, got {args.window}")
    if not 10 <= args.dpi <= 1000:
        raise ParameterError(f"--dpi must be in [10, 1000], got {args.dpi}")
    history = read_history(args.history)
    fig = plots.learning_curves(history, window=args.window)
    plots.save_figure(fig, out, dpi=args.dpi)
    if args.json:
        record = {"wrote": str(out), "history": str(args.history), "trials": len(history)}
        sys.stdout.write(dumps_json({**record, "window": args.window}))
        return 0
    print(f"wrote {out}: {len(history)} trials")
    return 0
