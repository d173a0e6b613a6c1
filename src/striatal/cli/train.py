"""``striatal train``: the chapter's learner, run until the success test holds."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections import deque
from dataclasses import replace
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from striatal import interrupts
from striatal.cli import EXIT_INTERRUPTED, learner_options, options
from striatal.errors import ParameterError
from striatal.experiments.training import DEFAULT_CHECKPOINT_EVERY, train
from striatal.io.files import check_out_dir, dumps_json
from striatal.io.rundir import RUN_FILES, RunDir, setup_of
from striatal.learners import LearnerState, TrialRecord, default_config
from striatal.params import CHAPTER_INITIAL_THETA_C, Simulation

#: The files that ``--out DIR`` gets.
OUT_FILES = RUN_FILES

DESCRIPTION = """\
Learn the six gains and theta_c with the chapter's REINFORCE rule (eqs 1-5, 21-25): 60-s
trials from theta = 3.12 at rest, a Gaussian policy, eligibility traces and the sparse
reward, until the chapter's success test holds or --max-trials. --init random draws W(0)
uniformly in [-1, 1]^6 from the seed; there and in --init-gains a W1 below 0.001 is
floored at 0.001 (docs/paper-notes.md section 11). --learner rpe / pgpe / ac select the
variants beyond the chapter (docs/ablation.md, docs/results.md); unset learning options
take the chosen learner's defaults.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("start")
    start = g.add_mutually_exclusive_group()
    start.add_argument(
        "--init",
        choices=("chapter", "random"),
        default="chapter",
        help="chapter: W(0) of the chapter; random: uniform in [-1, 1]^6 drawn from --seed",
    )
    options.add_gains_argument(
        start,
        "--init-gains",
        help="W(0) given by hand; W1 < 0.001 is floored at 0.001, as --init random does",
    )
    g.add_argument(
        "--theta-c0", type=float, default=CHAPTER_INITIAL_THETA_C, help="theta_c(0) [rad]"
    )
    g.add_argument("--seed", type=int, default=0, help="seed of the policy noise (and random W(0))")
    learner_options.add_learner_arguments(parser)
    options.add_controller_arguments(parser, gains_required=False)
    options.add_trial_arguments(parser)
    og = parser.add_argument_group("output")
    og.add_argument(
        "--out", type=options.out_path, default=None, help="write result.json, history.csv here"
    )
    og.add_argument("--json", action="store_true", help="print result.json on stdout")
    og.add_argument(
        "--checkpoint-every",
        type=int,
        default=DEFAULT_CHECKPOINT_EVERY,
        help="checkpoint every N trials (with --out)",
    )
    og.add_argument(
        "--resume",
        action="store_true",
        help="continue the run checkpointed in --out; its settings come from the checkpoint: "
        "other options given must equal them (refused otherwise), except a larger "
        "--max-trials (extends the run) and --checkpoint-every",
    )
    og.add_argument("--no-progress", action="store_true", help="no progress bar")
    options.add_tensorboard_argument(og, "every trial's history row and simulations so far")


class _StopRequest:
    """SIGINT/SIGTERM handler for the learning loop.

    The first signal only sets ``requested`` and says so in one line on stderr: the run
    stops after the trial in progress (a forward learner's trial includes its
    imagination, which can take minutes), once its history row (and any checkpoint due)
    is written, so the final checkpoint never counts a trial that history.csv lacks. A
    second signal stops at
    once (KeyboardInterrupt, as soon as no Numba code runs: see
    :func:`striatal.interrupts.raise_when_safe`); the run then keeps only the trials
    already recorded.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.requested = False
        self._old: dict[int, Any] = {}

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        if self.requested:
            interrupts.raise_when_safe(frame)
            return
        self.requested = True
        sys.stderr.write(
            "striatal train: stopping after the trial in progress; "
            "interrupt again to stop now (the trials recorded so far are kept)\n"
        )
        sys.stderr.flush()

    def __enter__(self) -> _StopRequest:
        # signal handlers can only be set from the main thread
        if threading.current_thread() is threading.main_thread():
            self._old = {s: signal.signal(s, self) for s in self.SIGNALS}
        return self

    def __exit__(self, *exc: object) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)


_PLANT = ("cart_mass", "pole_mass", "length", "gravity")
_TRIAL = ("dt", "duration")
_READINGS = ("balance_sign", "switch", "inhibition")
_START = ("learner", "init", "init_gains", "theta_c0", "seed")


def _explicit(args: argparse.Namespace) -> set[str]:
    """The options given on the command line, also those given at their default value
    (:func:`striatal.cli.options_given`, which ``main`` stores as ``args._given``)."""
    return set(args._given)


def _train_arguments(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`striatal.train`: every option for a fresh run; on
    ``--resume`` only those given, which train checks against the checkpoint."""
    if not args.resume:
        return {
            **{k: getattr(args, k) for k in (*_START, *_READINGS)},
            "plant": options.plant_from(args),
            "sim": Simulation(duration=args.duration, dt=args.dt),
            **learner_options.learner_changes(args),
        }
    given = _explicit(args)
    kwargs: dict[str, Any] = {k: getattr(args, k) for k in (*_START, *_READINGS) if k in given}
    kwargs.update(learner_options.learner_changes(args))
    if given & {*_PLANT, *_TRIAL}:
        # compare only the fields given: the rest are taken from the checkpoint, read (and
        # checked, so a malformed plant is one line) as train reads it
        rundir = RunDir(args.out)
        _, settings, _, _ = rundir.read_checkpoint()
        setup = setup_of(settings, f"checkpoint {rundir.checkpoint_path}")
        if given & set(_PLANT):
            changes = {k: getattr(args, k) for k in _PLANT if k in given}
            kwargs["plant"] = replace(setup.plant, **changes)
        if given & set(_TRIAL):
            changes = {k: getattr(args, k) for k in _TRIAL if k in given}
            kwargs["sim"] = replace(setup.sim, **changes)
    return kwargs


def run(args: argparse.Namespace) -> int:
    """A thin layer over :func:`striatal.train`: options in, progress bar, printout."""
    if args.out is not None:
        check_out_dir(args.out)
    if args.resume and args.out is None:
        raise ParameterError("--resume needs --out DIR holding a checkpoint")
    kwargs = _train_arguments(args)
    max_trials = kwargs.get("max_trials") or default_config(args.learner).max_trials

    from tqdm import tqdm

    bar = tqdm(
        total=max_trials,
        unit="trial",
        disable=args.no_progress or args.json or not sys.stderr.isatty(),
        file=sys.stderr,
    )
    recent: deque[float] = deque(maxlen=50)

    stop = _StopRequest()
    try:
        with stop, options.tracker(args) as tracker:

            def on_trial(s: LearnerState, rec: TrialRecord) -> None:
                recent.append(rec.reward)
                bar.n = s.trials_done
                bar.update(0)
                bar.set_postfix(reward=rec.reward, mean=f"{np.mean(recent):.2f}")
                if tracker is not None:
                    tracker.on_trial(s, rec)

            result = train(
                out=args.out,
                resume=args.resume,
                checkpoint_every=args.checkpoint_every,
                on_trial=on_trial,
                should_stop=lambda: stop.requested,
                **kwargs,
            )
    finally:
        bar.close()
    payload = result.to_dict()
    if args.json:
        sys.stdout.write(dumps_json(payload))
    else:
        _print_human(payload, args.out)
    return EXIT_INTERRUPTED if result.interrupted else 0


def _print_human(p: dict[str, Any], out: Path | None) -> None:
    verdict = "success" if p["success"] else "no success"
    if p["interrupted"]:
        verdict = "interrupted"
    print(f"{verdict} after {p['trials']} trials ({p['wall_seconds']:.1f} s)")
    print("W = " + " ".join(f"{w:.4f}" for w in p["W"]) + f"   theta_c = {p['theta_c']:.4f}")
    print(f"mean policy passes the success test: {'yes' if p['mean_policy_success'] else 'no'}")
    if out is not None:
        print(f"wrote {out / 'result.json'}, {out / 'history.csv'}")
