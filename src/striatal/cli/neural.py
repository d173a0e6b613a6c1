"""``striatal neural``: the switching controller as a spiking network (nengo, or Brian2)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from striatal import arguments
from striatal.cli import options, progress
from striatal.cli.helpformat import default_note
from striatal.cli.lists import CommaList
from striatal.errors import ParameterError
from striatal.params import CHAPTER_THETA0, Simulation, SuccessTest, check_seed

#: The simulators of ``--simulator`` (``striatal.neural.run.SIMULATORS``, which imports numpy).
SIMULATORS = ("nengo", "brian2")
#: The rules ``--learn --seeds`` offers (``striatal.neural.driver.NETWORK_RULES``, tested).
NETWORK_LEARNERS = ("chapter", "pgpe", "rpe")
#: What the first run of a network size and run length on Brian2 says.
COMPILE_NOTICE = (
    "striatal: compiling the Brian2 network (once per network size and run length, "
    "about a minute; cached in {where})\n"
)

if TYPE_CHECKING:
    from striatal.neural.network import NetworkConfig
    from striatal.params import Controller, Plant

#: The files that ``--out DIR`` gets (of a run, or of --learn).
OUT_FILES = (
    "trajectory.csv",
    "rates.csv",
    "summary.json",
    "activity.png",
    "learn_history.csv",
    "learn_summary.json",
    "sweep.json",
    "runs.csv",
    "trials.csv",
)

DESCRIPTION = (
    "Section 4's neural reading built as a spiking network of LIF neurons (nengo): cortex "
    "encodes the sensed state and E~ (eqs 15-16); a balancing channel decodes mu_1 (eq 22) "
    "and a swing-up channel mu_2 (eq 23), one connection per term, excitatory (direct "
    "pathway) for a positive coefficient and inhibitory (indirect) for a negative one; "
    "Purkinje-like gates inhibited by parallel fibres that carry |theta| vs theta_c switch "
    "between them (or, with --selection basal-ganglia, nengo's BasalGanglia + Thalamus). "
    "The plant is the project's kernel (RK4) stepped every 1 ms of network time. Reports the "
    "chapter's success test at T_f, whether |theta| < 0.1 over the last 10 s, the neuron "
    "count and the wall and CPU time per simulated second. --simulator brian2 runs the same "
    "network as a compiled Brian2 program with the plant inside it (eqs 8-10, the force "
    "of eq 12 held per step), about 17 times less CPU."
)


#: How each simulator steps the plant (the JSON's ``settings.integrator``).
INTEGRATOR = {
    "nengo": "kernel.rk4_step every 1 ms of network time, u held over the step",
    "brian2": "Brian2 rk4 of eqs 8-9 every 1 ms of network time inside the compiled program, "
    "the force of eq 12 held over the step",
}


def announce_compile(where: Path) -> None:
    """Say on stderr, once, that the Brian2 program is compiling and where it is cached."""
    sys.stderr.write(COMPILE_NOTICE.format(where=where))
    sys.stderr.flush()


def simulator_meant(value: str) -> str | None:
    """The one line that ``neural --backend nengo|brian2`` gets (the option means the
    cluster backend, local or ray); None for any other value."""
    if value not in SIMULATORS:
        return None
    return (
        "--backend is the cluster backend (local, ray) of --learn --seeds; the "
        f"network's simulator is --simulator {value}"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    options.add_controller_arguments(parser, gains_required=True)
    parser.add_argument(
        "--result",
        type=Path,
        default=None,
        help="take W, theta_c, the balancing sign and the plant from this result.json",
    )
    # the rate controller's switch options do not apply: the network has its own switch
    parser.set_defaults(switch="hard", inhibition=50.0)
    net = parser.add_argument_group("network")
    net.add_argument(
        "--neurons", type=int, default=2500, help="LIF neurons of cortex, channels and switch"
    )
    net.add_argument(
        "--selection",
        choices=("cerebellum", "basal-ganglia"),
        default="cerebellum",
        help="what drives the channel gates: parallel fibres -| Purkinje (section 4) or "
        "nengo's BasalGanglia + Thalamus, both from the criterion theta_c - |theta|",
    )
    net.add_argument(
        "--switch-gain",
        type=float,
        default=20.0,
        metavar="GAMMA",
        help="slope [1/rad] of the criterion clip(gamma (theta_c - |theta|), -1, 1)",
    )
    net.add_argument("--synapse", type=float, default=0.005, help="synaptic time constant [s]")
    net.add_argument(
        "--seed",
        type=int,
        default=0,
        help="network seed (encoders, gains, biases) and, with --learn, the exploration's; "
        "with --seeds, the root of the runs' seeds",
    )
    net.add_argument(
        "--simulator",
        choices=SIMULATORS,
        default="nengo",
        help="nengo (the reference) or brian2: the same network, built by nengo's builder, "
        "run as a compiled Brian2 program with the plant inside it (compiled once per "
        "network size and run length, cached beside Numba's cache)",
    )
    run_g = parser.add_argument_group("run")
    run_g.add_argument("--theta0", type=float, default=CHAPTER_THETA0, help="initial angle [rad]")
    run_g.add_argument("--x0", type=float, default=0.0, help="initial cart position [m]")
    run_g.add_argument(
        "--duration", type=float, default=None, help="T_f [s] " + default_note("60; --learn: 30")
    )
    learn = parser.add_argument_group("dopamine (second stage: the chapter's rule on the pathways)")
    learn.add_argument(
        "--learn",
        action="store_true",
        help="run --trials learning trials: exploration on the motor command, eligibility "
        "pre x post per pathway during the trial, the eq-25 reward as dopamine at its end, "
        "the chapter's update (eqs 1-5) of W and so of the transforms between trials",
    )
    learn.add_argument(
        "--trials",
        type=arguments.cli_type("max_trials"),
        default=20,
        help="learning trials (with --learn; at most 30 s each)",
    )
    learn.add_argument(
        "--alpha",
        type=float,
        default=None,
        help="learning rate of eq 4 (with --learn; 0: no learning) "
        + default_note("the chapter learner's, 5.0"),
    )
    runs = parser.add_argument_group(
        "many seeds (with --learn: a sweep of the learner and its control on the network)"
    )
    runs.add_argument(
        "--seeds",
        type=arguments.cli_type("seeds"),
        default=None,
        help="run the learner and its no-learning control on N seeds each, the seeds "
        "SeedSequence(--seed).spawn(N), on the experiment runner as striatal sweep: "
        "runs.csv and summary.json in --out (a rerun resumes), --workers or --backend ray",
    )
    runs.add_argument(
        "--init",
        action=CommaList,
        names=("chapter", "random"),
        default=("chapter",),
        help="with --seeds: W(0), the chapter's and/or uniform in [-1, 1]^6 per seed "
        "(give --chapter-initial; theta_c(0) is --theta-c's)",
    )
    runs.add_argument(
        "--learner",
        choices=NETWORK_LEARNERS,
        default="chapter",
        help="with --seeds: the rule on the pathway weights (its preset, the sparse reward)",
    )
    options.add_worker_arguments(
        runs, connect_timeout=arguments.CONNECT_TIMEOUT, refuse_backend=simulator_meant
    )
    options.add_plant_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    progress.add_progress_argument(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="write trajectory.csv, rates.csv, summary.json and activity.png here (recording "
        "the populations' rates costs simulation time)",
    )
    parser.add_argument(
        "--circuit-figure",
        type=Path,
        default=None,
        metavar="PNG",
        help="also draw the circuit with these gains' pathway signs into this image",
    )


def run(args: argparse.Namespace) -> int:
    from striatal.cli import options
    from striatal.io.files import check_out_dir, dumps_json, write_csv, write_json
    from striatal.neural.network import NetworkConfig, require_nengo
    from striatal.neural.run import NEURAL_TRAJ_COLUMNS, run_network
    from striatal.sim.kernel import wrap_angle

    controller, plant = options.controller_and_plant(args)
    if not args.learn and args.alpha is not None:
        raise ParameterError("--alpha needs --learn")
    if args.seeds is not None and not args.learn:
        raise ParameterError("--seeds needs --learn")
    if args.seeds is None:
        given = [
            name
            for name, value, default in (
                ("--init", args.init, ("chapter",)),
                ("--learner", args.learner, "chapter"),
                ("--backend", args.backend, "local"),
                ("--workers", args.workers, 1),
                ("--address", args.address, None),
            )
            if value != default
        ]
        if given:
            raise ParameterError(f"{', '.join(given)} needs --learn --seeds N")
    else:
        options.check_worker_arguments(args)
    duration = args.duration if args.duration is not None else (30.0 if args.learn else 60.0)
    sim = Simulation(theta0=args.theta0, x0=args.x0, duration=duration, dt=0.01)
    seed = check_seed(args.seed)
    if sim.duration > 3600.0:
        raise ParameterError(f"duration must be at most 3600 s, got {sim.duration}")
    config = NetworkConfig(
        neurons=args.neurons,
        selection=args.selection,
        switch_gain=args.switch_gain,
        synapse=args.synapse,
    )
    if args.out is not None:
        check_out_dir(args.out)
        if args.seeds is None and (args.out / "sweep.json").exists():
            raise ParameterError(
                f"--out {args.out} holds a sweep (of --learn --seeds): write this run elsewhere"
            )
    if args.circuit_figure is not None:
        from striatal.viz.plots import check_image_path

        check_image_path(args.circuit_figure, (".png", ".svg", ".pdf"))
    require_nengo()
    if args.simulator == "brian2":
        from striatal.neural.brian import require_brian2

        require_brian2()
    if args.learn and args.seeds is not None:
        return run_learning_sweep(args, controller, plant, sim, config, seed)
    if args.learn:
        return run_learning(args, controller, plant, sim, config, seed)
    shown = progress.bar(args, total=sim.duration, unit="s")

    def on_progress(t: float) -> None:
        shown.n = round(t, 6)
        shown.update(0)

    try:
        result = run_network(
            controller,
            plant,
            sim,
            config,
            seed,
            record_rates=args.out is not None,
            on_progress=on_progress,
            simulator=args.simulator,
            on_compile=announce_compile,
        )
    finally:
        shown.close()
    summary = result.summary()
    summary["settings"] = {
        "controller": controller.to_dict(),
        "plant": plant.to_dict(),
        "theta0": sim.theta0,
        "x0": sim.x0,
        "duration": sim.duration,
        "network": {
            "neurons_requested": config.neurons,
            "populations": config.sizes(),
            "selection": config.selection,
            "switch_gain": config.switch_gain,
            "synapse": config.synapse,
            "neuron_type": "LIF",
            "network_dt": 0.001,
            "nengo_optimize": config.optimize,
            "simulator": args.simulator,
        },
        "integrator": INTEGRATOR[args.simulator],
        "success_test": str(SuccessTest()),
        "upright_test": "|theta| < 0.1 at every 1-ms step of the last 10 s",
    }
    if args.out is not None:
        from striatal.neural.figures import activity_figure
        from striatal.viz.plots import save_figure

        write_csv(args.out / "trajectory.csv", NEURAL_TRAJ_COLUMNS, result.data.tolist())
        t = [(i + 1) * sim.dt for i in range(result.rates.shape[0])]
        write_csv(
            args.out / "rates.csv",
            ("t_end", *result.populations),
            [[ti, *row] for ti, row in zip(t, result.rates.tolist(), strict=True)],
        )
        write_json(args.out / "summary.json", summary)
        save_figure(activity_figure(result, controller.theta_c), args.out / "activity.png")
    if args.circuit_figure is not None:
        from striatal.neural.figures import circuit_figure
        from striatal.viz.plots import save_figure

        save_figure(circuit_figure(controller, plant, config.selection), args.circuit_figure)
    if args.json:
        sys.stdout.write(dumps_json(summary))
        return 0
    x, xd, th, thd = (float(v) for v in result.data[-1, 1:5])
    th = wrap_angle(th)
    print(
        f"neurons: {result.neurons}  ({config.selection} switch, seed {seed}, "
        f"{args.simulator} simulator)"
    )
    print(f"upright_last_10s: {'yes' if result.upright_last_10s else 'no'}  (|theta| < 0.1)")
    print(
        f"success: {'yes' if result.success else 'no'}  "
        f"(chapter's test at T_f = {sim.duration:g} s)"
    )
    print(
        f"final state: x={x:.3g} m  x_dot={xd:.3g} m/s  theta={th:.3g} rad  "
        f"theta_dot={thd:.3g} rad/s"
    )
    sw = ", ".join(f"{v:.2f}" for v in result.switch_times[:8])
    print(f"switch times [s]: {sw or 'none'}{' ...' if len(result.switch_times) > 8 else ''}")
    print(
        f"time per simulated second: wall {result.wall_per_sim_second:.3f} s, "
        f"CPU {result.cpu_time / sim.duration:.4f} s (build {result.build_time:.1f} s"
        + (f", compile {result.compile_time:.1f} s)" if args.simulator == "brian2" else ")")
    )
    if result.fault:
        print("numerical fault: the state blew up")
    if args.out is not None:
        print(f"wrote {args.out}/trajectory.csv, rates.csv, summary.json, activity.png")
    return 0


def run_learning(
    args: argparse.Namespace,
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
) -> int:
    """``--learn``: the dopamine stage over trials; one line per trial, or one JSON object."""
    from striatal.io.files import dumps_json, write_csv, write_json
    from striatal.neural.driver import NeuralTrial, learn_network

    if args.circuit_figure is not None:
        raise ParameterError("--circuit-figure cannot be combined with --learn")

    def show(t: NeuralTrial) -> None:
        if args.json:
            return
        w = " ".join(f"{v:+.4f}" for v in t.W)
        print(
            f"trial {t.trial:3d}: W [{w}] theta_c {t.theta_c:.3f}  reward {t.reward:+g}  "
            f"upright_last_10s {'yes' if t.upright_last_10s else 'no'}  "
            f"success {'yes' if t.success else 'no'}",
            flush=True,
        )

    result = learn_network(
        controller,
        plant,
        sim,
        config,
        seed,
        trials=args.trials,
        alpha=args.alpha,
        on_trial=show,
        simulator=args.simulator,
        on_compile=announce_compile,
    )
    out = result.to_dict()
    out["settings"] = {
        "controller": controller.to_dict(),
        "theta0": sim.theta0,
        "x0": sim.x0,
        "duration": sim.duration,
        "network": {
            "neurons_requested": config.neurons,
            "selection": config.selection,
            "nengo_optimize": config.optimize,
            "simulator": args.simulator,
        },
    }
    if args.out is not None:
        cols = (
            "trial",
            "reward",
            *(f"W{i}" for i in range(1, 7)),
            "theta_c",
            "success",
            "upright_last_10s",
            "first_switch",
            *(f"D{i}" for i in range(1, 7)),
        )
        rows = [
            [
                t.trial,
                t.reward,
                *t.W,
                t.theta_c,
                t.success,
                t.upright_last_10s,
                t.first_switch,
                *t.eligibility,
            ]
            for t in result.trials
        ]
        write_csv(args.out / "learn_history.csv", cols, rows)
        write_json(args.out / "learn_summary.json", out)
    if args.json:
        sys.stdout.write(dumps_json(out))
        return 0
    w = " ".join(f"{v:+.4f}" for v in result.W)
    print(f"neurons: {result.neurons}  ({config.selection} switch, seed {seed})")
    print(
        f"after {len(result.trials)} trials: W [{w}] theta_c {result.theta_c:.3f}  "
        f"({'solved' if result.solved else 'not solved'})"
    )
    if args.out is not None:
        print(f"wrote {args.out}/learn_history.csv, learn_summary.json")
    return 0


def run_learning_sweep(
    args: argparse.Namespace,
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
) -> int:
    """``--learn --seeds N``: the learner and its control on N seeds each, on the
    experiment runner (:func:`striatal.experiments.network.network_sweep`)."""
    from striatal.experiments import report
    from striatal.experiments.network import network_sweep
    from striatal.io.files import dumps_json
    from striatal.params import CHAPTER_INITIAL_W

    if args.circuit_figure is not None:
        raise ParameterError("--circuit-figure cannot be combined with --learn")
    if tuple(controller.gains) != CHAPTER_INITIAL_W:
        raise ParameterError(
            "with --seeds, W(0) is --init's (chapter or random): give --chapter-initial"
        )
    changes = {} if args.alpha is None else {"alpha": args.alpha}
    result = network_sweep(
        args.learner,
        network=config,
        simulator=args.simulator,
        seeds=args.seeds,
        seed=seed,
        init=args.init,
        max_trials=args.trials,
        sim=sim,
        plant=plant,
        template=controller,
        out=args.out,
        **options.worker_options(args),
        progress=progress.shown(args),
        on_compile=announce_compile,
        **changes,
    )
    if args.json:
        sys.stdout.write(dumps_json(result.summary))
        return 0
    sys.stdout.write(report.markdown_table(result.summary))
    for note in result.summary["notes"]:
        print(f"\n{note}")
    print(f"ran {result.ran} runs, {result.skipped} already in --out")
    if args.out is not None:
        print(
            f"wrote {args.out / 'runs.csv'}, {args.out / 'trials.csv'}, {args.out / 'summary.json'}"
        )
    return 0
