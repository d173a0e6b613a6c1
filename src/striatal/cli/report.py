"""``striatal report``: one self-contained HTML page of sweeps or a training run."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from striatal.cli import options
from striatal.errors import ParameterError
from striatal.io.files import dumps_json

DESCRIPTION = (
    "Write one HTML page of a sweep folder (striatal sweep --out DIR), a training run's "
    "folder (striatal train --out DIR), or several sweep folders side by side: the "
    "settings, every arm's success rate with its Wilson 95 % interval, the paired tests "
    "of each learner against its control and the baselines (Fisher, McNemar), the "
    "performance profiles, the learning curves of a run, and the commands that made "
    "them. Figures and the maths typesetting (MathJax) are inside the file: it opens "
    "with no network. Needs the [report] extra (Jinja2, MathJax)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "folders", type=Path, nargs="+", metavar="DIR", help="sweep or training run folders"
    )
    parser.add_argument(
        "--out",
        type=options.out_path,
        default=None,
        help="the page, .html (default: report.html in the first DIR)",
    )
    parser.add_argument(
        "--json", action="store_true", help="print a JSON record of what was written on stdout"
    )


def run(args: argparse.Namespace) -> int:
    from striatal.reports.page import write_report

    out = args.out if args.out is not None else args.folders[0] / "report.html"
    if not out.parent.is_dir():
        raise ParameterError(f"--out {out}: folder {out.parent} does not exist")
    words = ["striatal", "report", *(str(f) for f in args.folders)]
    if args.out is not None:
        words += ["--out", str(args.out)]
    path = write_report(args.folders, out, command=shlex.join(words))
    if args.json:
        sys.stdout.write(
            dumps_json({"wrote": str(path), "folders": [str(f) for f in args.folders]})
        )
        return 0
    print(f"wrote {path}")
    return 0
