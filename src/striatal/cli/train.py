"""``striatal train``: the chapter's learner, run until the success test holds."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections import deque
from dataclasses import asdict, replace
from pathlib import Path
from types import FrameType
from typing import Any, TextIO

import numpy as np

from striatal.cli import EXIT_INTERRUPTED, learner_options, options
from striatal.errors import DataFileError, ParameterError
from striatal.files import (
    atomic_write_text,
    check_out_dir,
    csv_text,
    dumps_json,
    read_json,
    write_json,
)
from striatal.learn import (
    HISTORY_COLUMNS,
    LearnerConfig,
    LearnerState,
    TrainResult,
    TrialRecord,
    initial_state,
    random_initial_gains,
    train,
)
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
    check_seed,
)
from striatal.rollout import Protocol, simulate

COMMAND = "train"
ORDER = 20
HELP = "run the chapter's switching REINFORCE learner (or a variant: --learner)"
DESCRIPTION = (
    "Learn the six gains and theta_c with the chapter's REINFORCE rule (eqs 1-5, 21-25): "
    "60-s trials from theta = 3.12 at rest, a Gaussian policy, eligibility traces and the "
    "sparse reward, until the chapter's success test holds or --max-trials. "
    "--init random draws W(0) uniformly in [-1, 1]^6 (W1 floored at 0.001) from the seed. "
    "--learner rpe / pgpe select the variants beyond the chapter (docs/ablation.md); "
    "unset learning options take the chosen learner's defaults."
)
CHECKPOINT = "checkpoint.json"
CHECKPOINT_VERSION = 1


def add_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("start")
    start = g.add_mutually_exclusive_group()
    start.add_argument(
        "--init",
        choices=("chapter", "random"),
        default="chapter",
        help="chapter: W(0) of the chapter; random: uniform in [-1, 1]^6 drawn from --seed",
    )
    start.add_argument(
        "--init-gains", type=float, nargs=6, metavar=("W1", "W2", "W3", "W4", "W5", "W6")
    )
    g.add_argument(
        "--theta-c0", type=float, default=CHAPTER_INITIAL_THETA_C, help="theta_c(0) [rad]"
    )
    g.add_argument("--seed", type=int, default=0, help="seed of the policy noise (and random W(0))")
    learner_options.add_learner_arguments(parser)
    options.add_controller_arguments(parser, gains_required=False)
    rg = parser.add_argument_group("trial")
    rg.add_argument("--dt", type=float, default=0.01, help="control and RK4 step [s]")
    rg.add_argument("--duration", type=float, default=60.0, help="trial length T_f [s]")
    options.add_plant_arguments(parser)
    og = parser.add_argument_group("output")
    og.add_argument("--out", type=Path, default=None, help="write result.json, history.csv here")
    og.add_argument("--json", action="store_true", help="print result.json on stdout")
    og.add_argument(
        "--checkpoint-every", type=int, default=50, help="checkpoint every N trials (with --out)"
    )
    og.add_argument("--resume", action="store_true", help="continue the run checkpointed in --out")
    og.add_argument("--no-progress", action="store_true", help="no progress bar")


def _settings(
    args: argparse.Namespace,
    config: LearnerConfig,
    template: Controller,
    plant: Plant,
    sim: Simulation,
    W0: tuple[float, ...],
) -> dict[str, Any]:
    return {
        "learner": config.learner,
        "init": "gains" if args.init_gains is not None else args.init,
        "W0": list(W0),
        "theta_c0": template.theta_c,
        "seed": args.seed,
        "config": config.to_dict(),
        "controller": {
            "balance_sign": template.balance_sign,
            "switch": template.switch,
            "inhibition": template.inhibition,
        },
        "plant": asdict(plant),
        "trial": {"dt": sim.dt, "duration": sim.duration, "theta0": sim.theta0, "x0": sim.x0},
        "protocol": asdict(Protocol()),
        "integrator": "rk4, u held over each step",
        "reward_timing": "update at the reward event only (r_t = 0 elsewhere)",
    }


Setup = tuple[LearnerConfig, Controller, Plant, Simulation, int]


def _from_settings(s: dict[str, Any], where: str) -> Setup:
    """The run that ``settings`` describe; DataFileError naming ``where`` if they do not."""
    try:
        config = LearnerConfig(**s["config"])
        template = Controller(gains=s["W0"], theta_c=s["theta_c0"], **s["controller"])
        plant = Plant(**s["plant"])
        sim = Simulation(**s["trial"])
        seed = check_seed(s["seed"])
    except KeyError as exc:
        raise DataFileError(f"{where} is corrupted: its settings lack {exc}") from None
    except (TypeError, ValueError) as exc:  # ParameterError is a ValueError
        raise DataFileError(f"{where} is corrupted: settings: {exc}") from None
    return config, template, plant, sim, seed


def _fresh(args: argparse.Namespace) -> tuple[dict[str, Any], LearnerState]:
    seed = check_seed(args.seed)
    config = learner_options.learner_config_from(args)
    plant = options.plant_from(args)
    sim = Simulation(duration=args.duration, dt=args.dt)
    if args.init_gains is not None:
        W0 = tuple(args.init_gains)
    elif args.init == "random":
        W0 = random_initial_gains(np.random.default_rng([seed, 1]))
    else:
        W0 = CHAPTER_INITIAL_W
    template = options.controller_from(args, W0, args.theta_c0)
    if args.checkpoint_every < 1:
        raise ParameterError(f"--checkpoint-every must be >= 1, got {args.checkpoint_every}")
    settings = _settings(args, config, template, plant, sim, W0)
    return settings, initial_state(W0, template.theta_c, seed)


def _load_checkpoint(out: Path) -> tuple[dict[str, Any], LearnerState]:
    """(settings, state) of ``out``/checkpoint.json, both checked; else DataFileError."""
    path = out / CHECKPOINT
    data = read_json(path, what="checkpoint")
    if not isinstance(data, dict) or data.get("version") != CHECKPOINT_VERSION:
        raise DataFileError(f"checkpoint {path} is not a striatal train checkpoint")
    try:
        state = LearnerState.from_dict(data["state"])
        settings = data["settings"]
    except (KeyError, TypeError, ParameterError) as exc:
        raise DataFileError(f"checkpoint {path} is corrupted: {exc}") from None
    if not isinstance(settings, dict):
        raise DataFileError(f"checkpoint {path} is corrupted: its settings are not an object")
    return settings, state


def _truncate_history(path: Path, n_rows: int) -> None:
    """Keep the header and the first n_rows rows (those covered by the checkpoint)."""
    if not path.exists():
        if n_rows:
            raise DataFileError(f"history {path} is missing but the checkpoint has {n_rows} trials")
        atomic_write_text(path, csv_text(HISTORY_COLUMNS, []))
        return
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    if len(lines) < 1 + n_rows or lines[0].strip() != ",".join(HISTORY_COLUMNS):
        raise DataFileError(f"history {path} has fewer rows than the checkpoint's {n_rows} trials")
    atomic_write_text(path, "".join(lines[: 1 + n_rows]))


class _StopRequest:
    """SIGINT/SIGTERM handler for the learning loop.

    The first signal only sets ``requested``: the run stops after the trial in
    progress, once its history row (and any checkpoint due) is written, so the final
    checkpoint never counts a trial that history.csv lacks. A second signal stops at
    once (KeyboardInterrupt); the run then keeps only the trials already recorded.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.requested = False
        self._old: dict[int, Any] = {}

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __enter__(self) -> _StopRequest:
        # signal handlers can only be set from the main thread
        if threading.current_thread() is threading.main_thread():
            self._old = {s: signal.signal(s, self) for s in self.SIGNALS}
        return self

    def __exit__(self, *exc: object) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_out_dir(args.out)
    if args.resume:
        if args.out is None:
            raise ParameterError("--resume needs --out DIR holding a checkpoint")
        settings, state = _load_checkpoint(args.out)
        where = f"checkpoint {args.out / CHECKPOINT}"
    else:
        settings, state = _fresh(args)
        where = "the options"  # settings built from validated options: never reported
    config, template, plant, sim, seed = _from_settings(settings, where)

    history: TextIO | None = None
    if args.out is not None:
        hpath = args.out / "history.csv"
        if args.resume:
            _truncate_history(hpath, state.trials_done)
        else:
            atomic_write_text(hpath, csv_text(HISTORY_COLUMNS, []))
        history = hpath.open("a", encoding="utf-8", newline="")

    def checkpoint(s: LearnerState) -> None:
        if args.out is not None:
            if history is not None:
                history.flush()
            write_json(
                args.out / CHECKPOINT,
                {"version": CHECKPOINT_VERSION, "settings": settings, "state": s.to_dict()},
            )

    from tqdm import tqdm

    bar = tqdm(
        total=config.max_trials,
        initial=state.trials_done,
        unit="trial",
        disable=args.no_progress or args.json or not sys.stderr.isatty(),
        file=sys.stderr,
    )
    recent: deque[float] = deque(maxlen=50)
    recorded = state  # the state after the last trial whose history row is written
    stop = _StopRequest()

    def on_trial(s: LearnerState, rec: TrialRecord) -> None:
        nonlocal recorded
        if history is not None:
            history.write(csv_text(HISTORY_COLUMNS, [rec.row()]).split("\n", 1)[1])
        recorded = s
        recent.append(rec.reward)
        bar.update(1)
        bar.set_postfix(reward=rec.reward, plus10=f"{np.mean([r > 0 for r in recent]):.2f}")
        if s.trials_done % args.checkpoint_every == 0:
            checkpoint(s)
        if stop.requested:
            raise KeyboardInterrupt

    try:
        with stop:
            result = train(plant, template, config, seed, sim=sim, state=state, on_trial=on_trial)
    finally:
        bar.close()
    if result.interrupted and result.state is not recorded:
        # stopped between a trial's update and its history row: that trial is not kept
        result = replace(
            result,
            success=recorded.success,
            trials=recorded.trials_done,
            W=recorded.W,
            theta_c=recorded.theta_c,
            state=recorded,
        )
    checkpoint(result.state)
    if history is not None:
        history.close()
    payload = _payload(result, settings, plant, template, sim)
    if args.out is not None:
        write_json(args.out / "result.json", payload)
    if args.json:
        sys.stdout.write(dumps_json(payload))
    else:
        _print_human(payload, args.out)
    return EXIT_INTERRUPTED if result.interrupted else 0


def _payload(
    result: TrainResult,
    settings: dict[str, Any],
    plant: Plant,
    template: Controller,
    sim: Simulation,
) -> dict[str, Any]:
    payload = TrainResult(
        success=result.success,
        trials=result.trials,
        W=result.W,
        theta_c=result.theta_c,
        seed=result.seed,
        wall_seconds=result.wall_seconds,
        state=result.state,
        interrupted=result.interrupted,
        settings=settings,
    ).to_dict()
    learned = template.with_gains(result.W, result.theta_c)
    check = simulate(plant, learned, sim).outcome
    payload["mean_policy_success"] = check.success
    payload["mean_policy_final_state"] = list(check.final_state)
    payload["positive_rewards"] = result.state.n_positive
    return payload


def _print_human(p: dict[str, Any], out: Path | None) -> None:
    verdict = "success" if p["success"] else "no success"
    if p["interrupted"]:
        verdict = "interrupted"
    print(f"{verdict} after {p['trials']} trials ({p['wall_seconds']:.1f} s)")
    print("W = " + " ".join(f"{w:.4f}" for w in p["W"]) + f"   theta_c = {p['theta_c']:.4f}")
    print(f"mean policy passes the success test: {'yes' if p['mean_policy_success'] else 'no'}")
    if out is not None:
        print(f"wrote {out / 'result.json'}, {out / 'history.csv'}")
