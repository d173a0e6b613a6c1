"""``striatal ablation``: the learner variants side by side from random initial gains."""

from __future__ import annotations

import argparse
import sys

from striatal.ablation import VARIANT_NAMES, markdown_table, run_variant, summary, variant
from striatal.cli import options
from striatal.errors import ParameterError
from striatal.files import atomic_write_text, check_out_dir, write_json

COMMAND = "ablation"
ORDER = 45
HELP = "compare the learner variants over many seeds from random W(0)"
DESCRIPTION = (
    "Run each named learner variant from W(0) uniform in [-1, 1]^6 (as train --init random) "
    "for seeds S..S+N-1 and tabulate success (mean policy) and trials to success "
    "(docs/ablation.md)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seeds", type=int, default=100, help="number of seeds N")
    parser.add_argument(
        "--first-seed", type=int, default=0, help="seeds S..S+N-1 (a fresh set: S = 100)"
    )
    parser.add_argument("--max-trials", type=int, default=300)
    parser.add_argument(
        "--variants",
        default=",".join(VARIANT_NAMES),
        help="comma-separated names from: " + ", ".join(VARIANT_NAMES),
    )
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument(
        "--out",
        type=options.out_path,
        default=None,
        help="write ablation.json and ablation.md here",
    )


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_out_dir(args.out)
    if args.seeds < 1:
        raise ParameterError(f"--seeds must be >= 1, got {args.seeds}")
    if args.first_seed < 0:
        raise ParameterError(f"--first-seed must be >= 0, got {args.first_seed}")
    if args.workers < 1:
        raise ParameterError(f"--workers must be >= 1, got {args.workers}")
    chosen = [variant(n.strip()) for n in args.variants.split(",") if n.strip()]
    configs = [v.config(args.max_trials) for v in chosen]
    rows = []
    runs = {}
    for v, config in zip(chosen, configs, strict=True):
        seeds = range(args.first_seed, args.first_seed + args.seeds)
        result = run_variant(config, seeds, args.workers, v.kind)
        runs[v.name] = {"options": v.options, "config": config.to_dict(), "runs": result}
        rows.append((v, summary(result)))
        print(f"{v.name}: {rows[-1][1]}", file=sys.stderr, flush=True)
    table = markdown_table(rows)
    if args.out is not None:
        write_json(args.out / "ablation.json", runs)
        atomic_write_text(args.out / "ablation.md", table)
    sys.stdout.write(table)
    return 0
