"""``striatal ablation``: the learner variants side by side from random initial gains.

A thin layer over the sweep: each variant is an arm of one
:func:`striatal.experiments.sweeps.run_sweep` (resume, progress bar, the Ray backend, the
output folder's lock); the table and ablation.json are written from its rows.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
from typing import Any

from striatal import arguments
from striatal.cli import config, guards, options
from striatal.cli.lists import CommaList
from striatal.errors import ParameterError
from striatal.experiments import pool, sweeps
from striatal.experiments.ablation import (
    VARIANT_NAMES,
    build,
    markdown_table,
    seeds_of,
    table_rows,
    variant,
)
from striatal.io.files import atomic_write_text, check_out_dir, dumps_json, write_json
from striatal.io.rundir import RunDir
from striatal.io.schema import AblationModel

#: The files that ``--out DIR`` gets (its sweep's, then its own).
OUT_FILES = ("sweep.json", "runs.csv", "summary.json", "ablation.json", "ablation.md")

DESCRIPTION = (
    "Run each named learner variant from W(0) uniform in [-1, 1]^6 (as train --init random) "
    "for N seeds spawned from --seed (SeedSequence, as sweep spawns them) and tabulate "
    "success (mean policy, Wilson 95 % interval), trials "
    "and simulations to success (docs/ablation.md). The variants are arms of one sweep: "
    "with --out, runs.csv, summary.json, ablation.json and ablation.md are written there "
    "and a rerun with the same options resumes. Row seed S reruns alone as "
    "'striatal train --init random --seed S' with the variant's options."
)


def first_seed_refused(value: str) -> str:
    """The one line that ``ablation --first-seed VALUE`` gets: the seeds come from a root."""
    return (
        "--first-seed is gone: ablation's seeds are spawned from the root --seed R "
        "(SeedSequence(R).spawn(N)), as sweep's are; for one run's seed use "
        "'striatal train --init random --seed S'"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--seeds", type=arguments.cli_type("seeds"), default=sweeps.SEEDS, help="number of seeds N"
    )
    parser.add_argument(
        "--seed",
        type=arguments.cli_type("seed"),
        default=0,
        help="root seed R: the runs' seeds are SeedSequence(R).spawn(N), the seeds of "
        "'sweep --seed R' (0 is the tuning root of the robust preset; 1, 2, ... evaluate)",
    )
    parser.add_argument(
        "--first-seed",
        dest="refused_first_seed",
        nargs="?",
        action=guards.Refused,
        message=first_seed_refused,
    )
    parser.add_argument(
        "--max-trials",
        type=arguments.cli_type("max_trials"),
        default=300,
        help="learning-trial budget of every variant's run (one budget for all, so the "
        "variants compare on equal terms)",
    )
    parser.add_argument(
        "--variants",
        action=CommaList,
        default=VARIANT_NAMES,
        metavar="NAME[,...]",
        help="variants to run (default: all), from: " + ", ".join(VARIANT_NAMES),
    )
    parser.add_argument(
        "--eval-draws",
        type=arguments.cli_type("eval_draws"),
        default=0,
        help="noisy trials of each pass-probability estimate (W(0) and final gains), "
        "counted apart as eval_simulations; 0: none",
    )
    options.add_worker_arguments(parser, connect_timeout=pool.CONNECT_TIMEOUT)
    parser.add_argument(
        "--out",
        type=options.out_path,
        default=None,
        help="write runs.csv, summary.json, ablation.json and ablation.md here",
    )
    parser.add_argument(
        "--json", action="store_true", help="print ablation.json on stdout (not the table)"
    )
    parser.add_argument(
        "--no-progress", action="store_true", help="no progress bar, no line per variant"
    )
    config.add_config_arguments(parser)


def _count(v: Any) -> str:
    return "-" if not isinstance(v, int | float) or not math.isfinite(v) else f"{v:g}"


def variant_line(name: str, s: dict[str, Any]) -> str:
    """One variant's result as a line: successes of runs, median and 90th pct of trials."""
    if not s["successes"]:
        return f"{name}: 0 of {s['runs']} runs succeeded"
    return (
        f"{name}: {s['successes']} of {s['runs']} runs succeeded; trials to success: "
        f"median {_count(s['median_trials'])}, 90th percentile {_count(s['p90_trials'])}"
    )


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_out_dir(args.out)
    options.check_worker_arguments(args)
    names = list(args.variants)
    if not names:
        raise ParameterError(f"--variants names no variant; choose from {', '.join(VARIANT_NAMES)}")
    if len(set(names)) != len(names):
        raise ParameterError("--variants names a variant twice")
    chosen = [variant(n) for n in names]
    arguments.check_learning_work(
        len(chosen) * args.seeds,
        args.max_trials,
        0,
        math.ceil(60.0 / 0.01),  # every variant's trial: T_f 60 s in steps of 10 ms
        args.eval_draws,
        "the ablation",
    )
    seeds = seeds_of(args.seed, args.seeds)
    specs, settings = build(chosen, seeds, args.max_trials, args.eval_draws, root=args.seed)
    settings["options"] = config.recorded_options(args)
    talk = not (args.no_progress or args.json)
    # the lock covers ablation.json and ablation.md too, written after the sweep
    with RunDir(args.out).lock() if args.out is not None else contextlib.nullcontext():
        result = sweeps.run_sweep(
            specs,
            settings,
            out=args.out,
            max_trials=args.max_trials,
            **options.worker_options(args),
            progress=talk and sys.stderr.isatty(),
            locked=args.out is not None,
        )
        rows, data = table_rows(chosen, result)
        if talk:
            for v, s in rows:
                print(variant_line(v.name, s), file=sys.stderr, flush=True)
        table = markdown_table(rows)
        if args.out is not None:
            AblationModel.of(data, f"{args.out / 'ablation.json'} (as written)")
            write_json(args.out / "ablation.json", data)
            atomic_write_text(args.out / "ablation.md", table)
    sys.stdout.write(dumps_json(data) if args.json else table)
    return 0
