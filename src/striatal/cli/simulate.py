"""``striatal simulate``: one run of the switching controller with the mean policy."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from striatal.cli import options
from striatal.errors import ParameterError
from striatal.io.files import array_rows, check_out_dir, csv_stream, dumps_json, write_text_set
from striatal.params import CHAPTER_HARDWARE, Controller, Hardware, Plant, Simulation, SuccessTest

if TYPE_CHECKING:
    from striatal.sim.robust import RobustReport
    from striatal.sim.rollout import Trajectory

#: The files that ``--out DIR`` gets.
OUT_FILES = ("trajectory.csv", "summary.json")

DESCRIPTION = (
    "Simulate the point-mass cart-pole (eqs 7-14) under the energy swing-up (eq 23) and the "
    "balancing law (eq 22), hard- or soft-switched at theta_c, with the mean policy (no "
    "exploration noise). Reports the chapter's success test at T_f. Gains: --chapter-final "
    "(default), --chapter-initial, --gains with --theta-c, or --result result.json of "
    "striatal train (its W, theta_c, readings and plant). --hold force, --max-force and "
    "--track add the digital motor, its limit and a finite track (docs/paper-notes.md "
    "section 9); --robust runs the robustness set of 9 cases and prints one row a case."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    options.add_gain_source_arguments(parser)
    options.add_hardware_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    parser.add_argument(
        "--out",
        type=options.out_path,
        default=None,
        help="write trajectory.csv and summary.json here",
    )


def summary(traj: Trajectory, settings: dict[str, object]) -> dict[str, object]:
    """The JSON summary of a run (``--json`` and summary.json)."""
    o = traj.outcome
    return {
        "success": o.success,
        "final_state": list(o.final_state),
        "switch_times": traj.switch_times,
        "max_abs_x": o.max_abs_x,
        "max_abs_force": o.max_abs_force,
        "fault": o.fault,
        "end_reason": o.end_reason,
        "ended_at": o.ended_at,
        "settings": settings,
    }


def settings_of(
    args: argparse.Namespace, traj: Trajectory, hardware: Hardware = CHAPTER_HARDWARE
) -> dict[str, object]:
    return {
        "controller": traj.controller.to_dict(),
        "plant": traj.plant.to_dict(),
        "theta0": traj.sim.theta0,
        "x0": traj.sim.x0,
        "duration": traj.sim.duration,
        "dt": traj.sim.dt,
        "integrator": f"rk4, {'u' if hardware.hold == 'u' else 'the force of eq 12'} "
        "held over each step",
        "hardware": hardware.to_dict(),
        "policy": "mean (no exploration noise)",
        "success_test": str(SuccessTest()),
    }


def print_robust(report: RobustReport) -> None:
    """The per-case table of ``--robust``."""
    print(
        f"robustness set: {report.simulations} runs of {report.duration:g} s, force held, "
        "mean policy, the controller keeping its nominal model"
    )
    name_w = max(len(c.case.name) for c in report.cases)
    print(f"{'case':<{name_w}}  success  end      max|x| [m]  max|force| [N]")
    for c in report.cases:
        ok = "yes" if c.success else "no"
        print(
            f"{c.case.name:<{name_w}}  {ok:<7}  {c.end_reason:<7}  "
            f"{c.max_abs_x:10.3g}  {c.max_abs_force:14.3g}"
        )
    verdict = "yes" if report.robust else "no (failed: " + "; ".join(report.failed) + ")"
    print(f"robust: {verdict}")


def run_robust(
    args: argparse.Namespace, controller: Controller, plant: Plant, sim: Simulation
) -> RobustReport:
    """The robustness set for the options given (refusing the ones it sets itself)."""
    from striatal.sim.robust import check_robust

    options.check_robust_run(args)
    return check_robust(
        controller, plant=plant, max_force=args.max_force, track=args.track, dt=sim.dt
    )


def run(args: argparse.Namespace) -> int:
    from striatal.sim.kernel import TRAJ_COLUMNS
    from striatal.sim.rollout import simulate

    controller, plant = options.controller_and_plant(args)
    sim = options.simulation_from(args)
    hardware = options.hardware_from(args)
    if args.robust:
        if args.out is not None:
            raise ParameterError("--robust records no trajectory: drop --out (use --json)")
        report = run_robust(args, controller, plant, sim)
        if args.json:
            sys.stdout.write(dumps_json(report.to_dict()))
        else:
            print_robust(report)
        return 0
    if args.out is not None:
        check_out_dir(args.out, files=("trajectory.csv", "summary.json"))
    traj = simulate(plant, controller, sim, hardware=hardware)
    result = summary(traj, settings_of(args, traj, hardware))
    if args.out is not None:
        # one set: a full disk never leaves a new trajectory beside an old summary
        write_text_set(
            [
                (args.out / "trajectory.csv", csv_stream(TRAJ_COLUMNS, array_rows(traj.data))),
                (args.out / "summary.json", lambda fh: fh.write(dumps_json(result))),
            ]
        )
    if args.json:
        sys.stdout.write(dumps_json(result))
    else:
        o = traj.outcome
        x, xd, th, thd = o.final_state
        verdict = "yes" if o.success else "no"
        print(f"success: {verdict}  (chapter's test at T_f = {traj.sim.duration:g} s)")
        print(
            f"final state: x={x:.3g} m  x_dot={xd:.3g} m/s  "
            f"theta={th:.3g} rad  theta_dot={thd:.3g} rad/s"
        )
        sw = ", ".join(f"{t:.2f}" for t in traj.switch_times[:8])
        more = " ..." if len(traj.switch_times) > 8 else ""
        print(f"switch times [s]: {sw or 'none'}{more}")
        print(f"max |x| = {o.max_abs_x:.3g} m   max |force| = {o.max_abs_force:.3g} N")
        if o.fault:
            print(f"numerical fault: the state blew up at t = {o.ended_at:.2f} s")
        if o.track:
            print(f"ran off the track (|x| > {hardware.track:g} m) at t = {o.ended_at:.2f} s")
        if args.out is not None:
            print(f"wrote {args.out / 'trajectory.csv'} and {args.out / 'summary.json'}")
    return 0
