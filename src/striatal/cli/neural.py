"""``striatal neural``: the switching controller as a spiking network (nengo) on the kernel."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from striatal.cli import progress
from striatal.errors import ParameterError
from striatal.params import CHAPTER_THETA0, Simulation, check_seed

COMMAND = "neural"
ORDER = 45
HELP = "run the controller as a spiking network (needs the [neural] extra: nengo)"
DESCRIPTION = (
    "Section 4's neural reading built as a spiking network of LIF neurons (nengo): cortex "
    "encodes the sensed state and E~ (eqs 15-16); a balancing channel decodes mu_1 (eq 22) "
    "and a swing-up channel mu_2 (eq 23), one connection per term, excitatory (direct "
    "pathway) for a positive coefficient and inhibitory (indirect) for a negative one; "
    "Purkinje-like gates inhibited by parallel fibres that carry |theta| vs theta_c switch "
    "between them (or, with --selection basal-ganglia, nengo's BasalGanglia + Thalamus). "
    "The plant is the project's kernel (RK4) stepped every 1 ms of network time. Reports the "
    "chapter's success test at T_f, whether |theta| < 0.1 over the last 10 s, the neuron "
    "count and the wall and CPU time per simulated second."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from striatal.cli import options

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
    net.add_argument("--seed", type=int, default=1, help="network seed (encoders, gains, biases)")
    run_g = parser.add_argument_group("run")
    run_g.add_argument("--theta0", type=float, default=CHAPTER_THETA0, help="initial angle [rad]")
    run_g.add_argument("--x0", type=float, default=0.0, help="initial cart position [m]")
    run_g.add_argument("--duration", type=float, default=60.0, help="T_f [s]")
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
    from striatal.files import check_out_dir, dumps_json, write_csv, write_json
    from striatal.kernel import wrap_angle
    from striatal.neural.network import NetworkConfig, require_nengo
    from striatal.neural.run import NEURAL_TRAJ_COLUMNS, run_network

    controller, plant = options.controller_and_plant(args)
    sim = Simulation(theta0=args.theta0, x0=args.x0, duration=args.duration, dt=0.01)
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
    if args.circuit_figure is not None:
        from striatal.plots import check_image_path

        check_image_path(args.circuit_figure, (".png", ".svg", ".pdf"))
    require_nengo()
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
        )
    finally:
        shown.close()
    summary = result.summary()
    summary["settings"] = {
        "controller": controller.to_dict(),
        "plant": {
            "cart_mass": plant.cart_mass,
            "pole_mass": plant.pole_mass,
            "length": plant.length,
            "gravity": plant.gravity,
        },
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
        },
        "integrator": "kernel.rk4_step every 1 ms of network time, u held over the step",
        "success_test": "|theta|<0.05, |x|<0.05, |theta_dot|<0.005, |x_dot|<0.005 at T_f",
        "upright_test": "|theta| < 0.1 at every 1-ms step of the last 10 s",
    }
    if args.out is not None:
        from striatal.neural.figures import activity_figure
        from striatal.plots import save_figure

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
        from striatal.plots import save_figure

        save_figure(circuit_figure(controller, plant, config.selection), args.circuit_figure)
    if args.json:
        sys.stdout.write(dumps_json(summary))
        return 0
    x, xd, th, thd = (float(v) for v in result.data[-1, 1:5])
    th = wrap_angle(th)
    print(f"neurons: {result.neurons}  ({config.selection} switch, seed {seed})")
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
        f"CPU {result.cpu_time / sim.duration:.3f} s (build {result.build_time:.1f} s)"
    )
    if result.fault:
        print("numerical fault: the state blew up")
    if args.out is not None:
        print(f"wrote {args.out}/trajectory.csv, rates.csv, summary.json, activity.png")
    return 0
