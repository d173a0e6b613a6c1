"""What the forward learner's benchmarks share: their run options and their runs.

A benchmark beside this file imports it (benchmarks/ is a script's ``sys.path[0]``):
``add_run_options`` gives ``--root``, ``--first``, ``--seeds``, ``--forward-model``
(and ``add_margin_option`` ``--imagine-margin``), ``run_seeds`` the run seeds
``spawn_seeds(root, first + seeds)[first:]``, and ``train_forward`` one run as
``striatal sweep --learner forward --robust --init random --max-trials 300`` runs it.
"""

from __future__ import annotations

import argparse
from typing import Any

import striatal
from striatal.experiments.spec import spawn_seeds


def add_run_options(parser: argparse.ArgumentParser, *, seeds: int, forward_model: str) -> None:
    """The run seeds' root, first index and count, and the forward model."""
    parser.add_argument("--root", type=int, default=0)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--seeds", type=int, default=seeds)
    parser.add_argument("--forward-model", default=forward_model)


def add_margin_option(parser: argparse.ArgumentParser) -> None:
    """``--imagine-margin``; none leaves the model's robust preset."""
    parser.add_argument(
        "--imagine-margin",
        type=float,
        default=None,
        help="none: the model's robust preset (structured, generic-gains, the sparse models: 0.1)",
    )


def run_seeds(args: argparse.Namespace) -> list[int]:
    """The run seeds ``spawn_seeds(root, first + seeds)[first:]``."""
    return list(spawn_seeds(args.root, args.first + args.seeds)[args.first :])


def margin_options(args: argparse.Namespace) -> dict[str, float]:
    """``imagine_margin`` for ``striatal.train`` if ``--imagine-margin`` was given."""
    margin = getattr(args, "imagine_margin", None)
    return {} if margin is None else {"imagine_margin": margin}


def train_forward(seed: int, forward_model: str, **options: Any) -> Any:
    """One forward run from random gains under ``--robust``, 300 real trials at most."""
    return striatal.train(
        "forward",
        init="random",
        seed=seed,
        robust=True,
        forward_model=forward_model,
        max_trials=300,
        **options,
    )
