"""``striatal evaluate``: how often a noisy trial passes the success test with fixed gains."""

from __future__ import annotations

import argparse
import math
import sys

from striatal import arguments
from striatal.cli import options, progress
from striatal.errors import ParameterError
from striatal.io.files import dumps_json
from striatal.params import Controller, Plant, Simulation, SuccessTest

DESCRIPTION = (
    "Run DRAWS noisy trials of the chapter's protocol (the Gaussian policy of eq 5, sigma "
    "from W6) with fixed gains and count how many pass the success test at T_f, judged on "
    "the noisy trial as striatal train does (docs/paper-notes.md section 8). Prints the "
    "pass rate with its Wilson 95 % interval, the share that earned the +10 of eq 25, and "
    "the verdict of the mean policy. Gains: --chapter-final (default), --chapter-initial, "
    "--gains with --theta-c, or --result result.json of striatal train. --hold force, "
    "--max-force and --track add the digital motor, its limit and a finite track "
    "(docs/paper-notes.md section 9). --robust instead runs the robustness set (9 "
    "mean-policy runs, force held) and reports robust yes/no and the cases failed."
)


def _count(text: str) -> int:
    """A count written as 2000 or 2e3; the range is checked by the library."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not value.is_integer():
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}")
    return int(value)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    options.add_gain_source_arguments(parser)
    parser.add_argument(
        "--draws", type=_count, default=2000, help="noisy trials (independent noise draws)"
    )
    parser.add_argument("--seed", type=_count, default=0, help="seed of the noise generator")
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    progress.add_progress_argument(parser)
    options.add_hardware_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from striatal.experiments.evaluate import check_draws, pass_probability
    from striatal.params import check_seed
    from striatal.sim.rollout import Protocol

    check_draws(args.draws)
    check_seed(args.seed)
    # the result.json reader lives with the CLI options for now
    controller, plant = options.controller_and_plant(args)
    sim = options.simulation_from(args)
    hardware = options.hardware_from(args)
    if args.robust:
        return _robust(args, controller, plant, sim)
    if sim.duration < Protocol().check_time:
        raise ParameterError(
            f"--duration must be at least the {Protocol().check_time:g}-s check of eq 24"
        )
    steps = math.ceil(sim.duration / sim.dt)
    arguments.check_work(
        args.draws * steps, "the evaluation", f"{args.draws:,} draws x {steps:,} steps"
    )
    shown = progress.bar(args, total=args.draws, unit="draw")

    def on_draw(k: int) -> None:
        shown.n = k
        shown.update(0)

    try:
        res = pass_probability(
            plant,
            controller,
            sim,
            Protocol(),
            args.draws,
            args.seed,
            hardware=hardware,
            on_draw=on_draw,
        )
    finally:
        shown.close()
    if args.json:
        out = res.to_dict()
        out["duration"] = sim.duration
        out["hardware"] = hardware.to_dict()
        out["success_test"] = f"{SuccessTest()}, on the noisy trial"
        sys.stdout.write(dumps_json(out))
        return 0
    lo, hi = res.rate_ci
    print(
        f"noisy {sim.duration:g}-s trials passing the success test: {res.passes} of "
        f"{res.draws} = {100 * res.rate:.3g} %  (95 % Wilson interval "
        f"{100 * lo:.3g}-{100 * hi:.3g} %)"
    )
    print(
        f"earned the +10 of eq 25: {res.reward_positive} of {res.draws} = "
        f"{100 * res.reward_positive / res.draws:.3g} %"
    )
    print(f"mean policy (no noise) passes: {'yes' if res.mean_policy_pass else 'no'}")
    if not hardware.idealised:
        print(
            f"motor: {hardware.hold} held; max force: "
            f"{'none' if hardware.max_force is None else f'{hardware.max_force:g} N'}; "
            f"track: {'endless' if hardware.track is None else f'{hardware.track:g} m'}"
        )
    print(
        f"gains W = {list(res.gains)}, theta_c = {res.theta_c:g}, seed {res.seed}; "
        f"{res.simulations} simulations, {res.simulated_seconds:.6g} simulated s"
    )
    return 0


def _robust(args: argparse.Namespace, controller: Controller, plant: Plant, sim: Simulation) -> int:
    """``evaluate --robust``: the verdict of the robustness set and the cases failed."""
    from striatal.cli.simulate import run_robust

    report = run_robust(args, controller, plant, sim)
    if args.json:
        sys.stdout.write(dumps_json(report.to_dict()))
        return 0
    print(f"robust: {'yes' if report.robust else 'no'}")
    if report.failed:
        print("cases failed: " + "; ".join(report.failed))
    print(
        f"{report.simulations} mean-policy runs of {report.duration:g} s, force held; "
        "striatal simulate --robust prints every case"
    )
    return 0
