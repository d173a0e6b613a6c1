"""``striatal bench``: the kernel's speed beside Gymnasium's cart-pole, in one process.

A thin entry: the measurements and the report are :mod:`striatal.bench`.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import Any

from striatal.cli.guards import bounded_float, bounded_int
from striatal.cli.helpformat import default_note
from striatal.io.files import dumps_json
from striatal.params import check_seed

DESCRIPTION = (
    "Steps per second of one chapter trial (kernel.run_trial, noise generation included) "
    "against Gymnasium's CartPole-v1 step loop, of the batched kernel against "
    "CartPoleVectorEnv at the same batch size, time per trial against duration / dt "
    "(linear fit), the wall time of `striatal train --init chapter`, and the kernels' "
    "first-call (compile or cache-load) time in this and a fresh process. Both sides of "
    "each ratio are timed alternately in the same process, warm-up excluded."
)

#: Largest --batch-size: the batched side draws B x duration/dt noise floats (200 MB
#: at 4096 and the default 60-s trial at dt = 0.01).
MAX_BATCH = 4096
#: Largest --seconds per timed repeat (one hour).
MAX_SECONDS = 3600.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the full report as JSON")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a short run (10-s trials, batch 32, 2 repeats, train capped at 20 trials, "
        "no cold compile)",
    )
    parser.add_argument(
        "--batch-size",
        type=bounded_int(1, MAX_BATCH),
        default=None,
        help=f"B of the batched comparison, at most {MAX_BATCH} (its noise is B x steps "
        f"floats) {default_note('256; --quick: 32')}",
    )
    parser.add_argument(
        "--seconds",
        type=bounded_float(0.0, MAX_SECONDS),
        default=None,
        help=f"wall budget of one timed repeat of one side [s], at most {MAX_SECONDS:g} "
        + default_note("0.5"),
    )
    parser.add_argument(
        "--repeats",
        type=bounded_int(1, 100),
        default=None,
        help="timed repeats " + default_note("5; --quick: 2"),
    )
    parser.add_argument("--no-train", action="store_true", help="skip timing striatal train")
    for flag, most, what, documented in (
        (
            "--sweep-seeds",
            10_000,
            "time `striatal sweep --seeds N` (learner + control arm) on 1 and on all workers",
            100,
        ),
        (
            "--memory-runs",
            100_000,
            "peak memory of a sweep of this many runs on one worker, trials capped at 20",
            1000,
        ),
    ):
        parser.add_argument(
            flag,
            type=bounded_int(0, most),
            default=0,
            help=f"{what} (0: skip; the docs use {documented})",
        )
    parser.add_argument(
        "--anchors",
        action="store_true",
        help="also time EnvPool CartPole-v1 and DMC CartpoleSwingup-v1 (needs the [bench] "
        "extra) and gymnax CartPole-v1 (1 env and the batch size; installed apart, else "
        "skipped with the line to install it) beside the kernel",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the policy noise")


def config_from(args: argparse.Namespace) -> Any:
    """The :class:`striatal.bench.BenchConfig` the options ask for (validated)."""
    from striatal.bench.timing import QUICK, BenchConfig

    base = QUICK if args.quick else BenchConfig()
    return replace(
        base,
        batch_size=base.batch_size if args.batch_size is None else args.batch_size,
        seconds=base.seconds if args.seconds is None else args.seconds,
        repeats=base.repeats if args.repeats is None else args.repeats,
        train=base.train and not args.no_train,
        sweep_seeds=args.sweep_seeds,
        memory_runs=args.memory_runs,
        anchors=args.anchors,
    )


def run(args: argparse.Namespace) -> int:
    from striatal.bench.harness import format_report, run_all

    config = config_from(args)
    seed = check_seed(args.seed)
    report = run_all(config, seed=seed)
    if args.json:
        sys.stdout.write(dumps_json(report.to_dict()))
    else:
        sys.stdout.write(format_report(report) + "\n")
    return 0
