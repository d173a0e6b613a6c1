"""``striatal sweep``: many learning runs over seeds, a control arm, baselines; resumable."""

from __future__ import annotations

import argparse
import sys

from striatal import arguments
from striatal.cli import config, learner_options, options
from striatal.cli.lists import CommaList
from striatal.experiments import baselines, pool, report, runner, sweeps
from striatal.io.files import check_out_dir, dumps_json
from striatal.params import CHAPTER_INITIAL_THETA_C, Simulation

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
        type=arguments.cli_type("seeds"),
        default=sweeps.SEEDS,
        help="number of seeds N per arm and init",
    )
    g.add_argument(
        "--seed",
        type=arguments.cli_type("seed"),
        default=0,
        help="root seed S: the runs' seeds are SeedSequence(S).spawn(N)",
    )
    g.add_argument(
        "--init",
        action=CommaList,
        names=("chapter", "random"),
        default=("chapter",),
        help="W(0): the chapter's, and/or uniform in [-1, 1]^6 per seed (as train --init "
        "random); comma-separated",
    )
    g.add_argument(
        "--theta-c0",
        type=arguments.cli_type("theta_c0"),
        default=CHAPTER_INITIAL_THETA_C,
        help="theta_c(0) [rad]",
    )
    g.add_argument("--alpha-grid", action=CommaList, item=float, help="alphas (default: --alpha)")
    g.add_argument("--gamma-grid", action=CommaList, item=float, help="gammas (default: --gamma)")
    g.add_argument(
        "--no-control", action="store_true", help="skip the learner's no-learning control arm"
    )
    g.add_argument(
        "--eval-draws",
        type=arguments.cli_type("eval_draws"),
        default=runner.EVAL_DRAWS,
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
    options.add_worker_arguments(eg, connect_timeout=pool.CONNECT_TIMEOUT)
    eg.add_argument(
        "--engine",
        choices=sweeps.ENGINES,
        default="processes",
        help="processes: one learning loop per run (--workers, --backend); batch: every run "
        "in this process, advanced side by side, the trials they need next in batched kernel "
        "calls on Numba's threads (the same runs.csv rows as processes); simd: batch on the "
        "SIMD kernel; its trials equal the exact kernel's within round-off, so rows differ "
        "run by run while the arms' success rates agreed within their intervals where "
        "measured (docs/performance.md)",
    )
    eg.add_argument(
        "--out", type=options.out_path, default=None, help="write runs.csv, summary.json here"
    )
    eg.add_argument("--json", action="store_true", help="print summary.json on stdout")
    options.add_tensorboard_argument(eg, "each finished run's success, trials and simulations")
    eg.add_argument("--no-progress", action="store_true", help="no progress bar")
    config.add_config_arguments(parser)


def prepare(args: argparse.Namespace) -> sweeps.Plan:
    """The sweep the options describe (:func:`striatal.experiments.sweeps.plan`)."""
    options.check_worker_arguments(args)
    arguments.check_all({"alpha_grid": args.alpha_grid, "gamma_grid": args.gamma_grid}, front="cli")
    return sweeps.plan(
        args.learner,
        seeds=args.seeds,
        seed=args.seed,
        init=args.init,
        theta_c0=args.theta_c0,
        alpha_grid=args.alpha_grid or (),
        gamma_grid=args.gamma_grid or (),
        control=not args.no_control,
        eval_draws=args.eval_draws,
        baselines=args.baselines,
        plant=options.plant_from(args),
        sim=Simulation(duration=args.duration, dt=args.dt),
        balance_sign=args.balance_sign,
        switch=args.switch,
        inhibition=args.inhibition,
        **learner_options.learner_changes(args),
    )


def run(args: argparse.Namespace) -> int:
    out = check_out_dir(args.out) if args.out is not None else None
    the_plan = prepare(args)
    note = sweeps.in_sample_note(the_plan.settings)
    if note is not None:
        print(note, file=sys.stderr)
    settings = {**the_plan.settings, "options": config.recorded_options(args)}
    with options.tracker(args) as tracker:
        result = sweeps.run_sweep(
            the_plan.specs,
            settings,
            out=out,
            max_trials=the_plan.max_trials,
            **options.worker_options(args),
            progress=not (args.no_progress or args.json) and sys.stderr.isatty(),
            engine=args.engine,
            on_run=tracker.on_run if tracker is not None else None,
        )
    if args.json:
        sys.stdout.write(dumps_json(result.summary))
        return 0
    sys.stdout.write(report.markdown_table(result.summary))
    for note in result.summary["notes"]:
        print(f"\n{note}")
    print(f"ran {result.ran} runs, {result.skipped} already in --out")
    if out is not None:
        print(f"wrote {out / 'runs.csv'}, {out / 'summary.json'}")
    return 0
