"""``striatal sweep``: many learning runs over seeds, a control arm, baselines; resumable."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from striatal.cli import config, learner_options, options
from striatal.cli.config import SEEDS
from striatal.cli.guards import bounded_int
from striatal.cli.lists import CommaList
from striatal.errors import ParameterError
from striatal.experiments import baselines
from striatal.experiments import runner as experiments
from striatal.io.files import check_out_dir, dumps_json
from striatal.learners import rule_of
from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W, Simulation
from striatal.sim.rollout import Protocol

#: The files that ``--out DIR`` gets.
OUT_FILES = ("sweep.json", "runs.csv", "summary.json")

DESCRIPTION = (
    "Run the learner for N seeds spawned from --seed (SeedSequence), for each --init and "
    "each alpha x gamma of the grid, plus the learner's declared no-learning control arm "
    "(chapter, rpe: alpha = 0; pgpe: alpha = 0 and sigma_rate = 0, exploration without "
    "learning) and any --baselines. Every run counts its simulated trials (simulations, "
    "success checks included). Writes runs.csv (one row per run, appended as runs finish; "
    "a rerun with the same --out skips finished runs) and summary.json (success rates with "
    "Wilson intervals, simulations to success with bootstrap intervals, Fisher and McNemar "
    "tests of the learner against its control). Row seed S reruns alone as "
    "'striatal train --seed S --init INIT' with the same learner options."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("sweep")
    g.add_argument(
        "--seeds",
        type=bounded_int(1, config.MAX_SEEDS),
        default=SEEDS,
        help=f"number of seeds N per arm and init (at most {config.MAX_SEEDS:,})",
    )
    g.add_argument("--seed", type=int, default=0, help="root seed of SeedSequence")
    g.add_argument(
        "--init",
        action=CommaList,
        names=("chapter", "random"),
        default=("chapter",),
        help="W(0): the chapter's, and/or uniform in [-1, 1]^6 per seed (as train --init "
        "random); comma-separated",
    )
    g.add_argument(
        "--theta-c0", type=float, default=CHAPTER_INITIAL_THETA_C, help="theta_c(0) [rad]"
    )
    g.add_argument("--alpha-grid", action=CommaList, item=float, help="alphas (default: --alpha)")
    g.add_argument("--gamma-grid", action=CommaList, item=float, help="gammas (default: --gamma)")
    g.add_argument(
        "--no-control", action="store_true", help="skip the learner's no-learning control arm"
    )
    g.add_argument(
        "--eval-draws",
        type=int,
        default=experiments.EVAL_DRAWS,
        help="noisy trials of each pass-probability estimate (W(0) and final gains of every "
        "run), counted as eval_simulations, not in the budget; 0: none",
    )
    g.add_argument(
        "--baselines",
        action=CommaList,
        default=(),
        metavar="NAME[,...]",
        help="baselines to run on the same seeds, from: " + ", ".join(baselines.BASELINES),
    )
    learner_options.add_learner_arguments(parser)
    options.add_controller_arguments(parser, gains_required=False)
    options.add_trial_arguments(parser)
    eg = parser.add_argument_group("engine and output")
    options.add_worker_arguments(eg, connect_timeout=experiments.CONNECT_TIMEOUT)
    eg.add_argument(
        "--engine",
        choices=experiments.ENGINES,
        default="processes",
        help="processes: one learning loop per run (--workers, --backend); batch: the runs of "
        "the learner arms advance in lockstep, trial k of every seed in one batched kernel "
        "call on Numba's threads (the same runs.csv rows; learner arms of chapter, rpe, pgpe "
        "with the sparse reward only); simd: batch on the SIMD kernel, about 3x faster; its "
        "trials equal the exact kernel's within round-off, so rows differ run by run while "
        "the arms' success rates agreed within their intervals where measured "
        "(docs/performance.md)",
    )
    eg.add_argument(
        "--out", type=options.out_path, default=None, help="write runs.csv, summary.json here"
    )
    eg.add_argument("--json", action="store_true", help="print summary.json on stdout")
    eg.add_argument("--no-progress", action="store_true", help="no progress bar")
    config.add_config_arguments(parser)


def prepare(
    args: argparse.Namespace,
) -> tuple[list[experiments.RunSpec], dict[str, Any], int]:
    """(specs, settings, max_trials) the options describe; everything validated."""
    if args.seeds < 1:
        raise ParameterError(f"--seeds must be >= 1, got {args.seeds}")
    options.check_worker_arguments(args)
    if args.eval_draws < 0:
        raise ParameterError(f"--eval-draws must be >= 0, got {args.eval_draws}")
    if args.engine != "processes" and (args.backend != "local" or args.workers != 1):
        raise ParameterError(
            f"--engine {args.engine} runs in this process on Numba's threads "
            "(NUMBA_NUM_THREADS); --workers and --backend ray are for --engine processes"
        )
    config = learner_options.learner_config_from(args)
    plant = options.plant_from(args)
    sim = Simulation(duration=args.duration, dt=args.dt)
    template = options.controller_from(args, CHAPTER_INITIAL_W, args.theta_c0)
    alphas = tuple(args.alpha_grid or ())
    gammas = tuple(args.gamma_grid or ())
    methods = list(args.baselines)
    inits = tuple(dict.fromkeys(args.init))
    seeds = experiments.spawn_seeds(args.seed, args.seeds)
    specs, arm_settings = experiments.build_specs(
        config=config,
        template=template,
        plant=plant,
        sim=sim,
        seeds=seeds,
        inits=inits,  # type: ignore[arg-type]
        alphas=alphas,
        gammas=gammas,
        control=not args.no_control,
        methods=methods,
        eval_draws=args.eval_draws,
    )
    settings: dict[str, Any] = {
        "command": "striatal sweep",
        "root_seed": args.seed,
        "seeds": args.seeds,
        "run_seeds": list(seeds),
        "seed_rule": "SeedSequence(root_seed).spawn(seeds)[i].generate_state(1)[0]",
        "inits": list(inits),
        "theta_c0": template.theta_c,
        "max_trials": config.max_trials,
        "success_on": config.success_on,
        "arms": arm_settings,
        "control": not args.no_control,
        "control_reading": experiments.control_note(config.learner),
        "budget": experiments.NOTE_BUDGET,
        "eval_draws": args.eval_draws,
        "controller": {
            "balance_sign": template.balance_sign,
            "switch": template.switch,
            "inhibition": template.inhibition,
        },
        "plant": {
            "cart_mass": plant.cart_mass,
            "pole_mass": plant.pole_mass,
            "length": plant.length,
            "gravity": plant.gravity,
        },
        "trial": {"dt": sim.dt, "duration": sim.duration, "theta0": sim.theta0, "x0": sim.x0},
        "protocol": experiments.json_roundtrip(Protocol().__dict__),
        "baselines": {
            "lqr": baselines.lqr_fit(plant).to_dict(),
            "random_box": [baselines.RANDOM_BOX[0].tolist(), baselines.RANDOM_BOX[1].tolist()],
            "cmaes": "IPOP-CMA-ES: sigma0 1 from (W(0), theta_c(0)), cma's default "
            "population (9), restarted with twice the population when cma stops, "
            "minimising minus the shaped reward",
        },
        "reproduce": "striatal train --seed S --init INIT with the same learner options "
        "(control arm: the options of settings.arms.control.config)",
    }
    if config.robust:
        # only when set, so the settings of sweeps without it stay as they were
        settings["robust"] = experiments.NOTE_ROBUST
    tuning_root = rule_of(config).tuning_root_of(config)
    if tuning_root is not None:
        settings["tuning_root"] = tuning_root
    return specs, settings, config.max_trials


def in_sample_note(settings: dict[str, Any]) -> str | None:
    """The stderr line of a sweep run on the root its preset was tuned on, else None."""
    root = settings.get("tuning_root")
    if root is None or root != settings["root_seed"]:
        return None
    return (
        f"note: the preset was tuned on root seed {root}: these are its tuning seeds, "
        "not a held-out evaluation (use another --seed)"
    )


def run(args: argparse.Namespace) -> int:
    out = check_out_dir(args.out) if args.out is not None else None
    specs, settings, max_trials = prepare(args)
    note = in_sample_note(settings)
    if note is not None:
        print(note, file=sys.stderr)
    settings["options"] = config.recorded_options(args)
    result = experiments.sweep(
        specs,
        settings,
        out=out,
        max_trials=max_trials,
        backend=args.backend,
        workers=args.workers,
        address=args.address,
        connect_timeout=args.connect_timeout,
        progress=not (args.no_progress or args.json) and sys.stderr.isatty(),
        engine=args.engine,
    )
    if args.json:
        sys.stdout.write(dumps_json(result.summary))
        return 0
    sys.stdout.write(experiments.markdown_table(result.summary))
    for note in result.summary["notes"]:
        print(f"\n{note}")
    print(f"ran {result.ran} runs, {result.skipped} already in --out")
    if out is not None:
        print(f"wrote {out / 'runs.csv'}, {out / 'summary.json'}")
    return 0
