"""``striatal robustness``: learned controllers on a plant they did not learn on."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from striatal import arguments
from striatal.cli import options
from striatal.cli.lists import CommaList
from striatal.errors import DataFileError, ParameterError
from striatal.io.files import atomic_write_text, dumps_json, read_json
from striatal.io.schema import AblationModel
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant

DESCRIPTION = (
    "Run the mean policy of learned gains (train result.json files, or the successful runs "
    "of an ablation.json) on plants with pole mass and length +-20 % and with sensor noise, "
    "the controller believing the nominal plant. Each cell: success test % / balanced at "
    "T_f (+10 reward) %. References: the chapter's final gains (hand-tuned) and the sweep's "
    "LQR baseline (LQR-fitted balancing gains with the chapter's swing-up)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "files",
        type=Path,
        nargs="+",
        help="result.json or ablation.json; with --margin, sweep folders (or their runs.csv), "
        "each as NAME=PATH to call its learner arm NAME",
    )
    parser.add_argument(
        "--margin",
        action="store_true",
        help="run the margin set instead (conditions outside the robustness set: a "
        "pole-length scan at pole mass x0.8 and x1.2, random pole mass and length draws in "
        "[0.6, 1.4], cart mass x0.7 and x1.3, farther starts; force held, 60 s, the success "
        "test at T_f) on each arm's solved runs of the sweeps, paired with the arm "
        "'random' on the seeds both solved",
    )
    parser.add_argument(
        "--variants",
        action=CommaList,
        default=(),
        metavar="NAME[,...]",
        help="variants of an ablation.json, one column each (default: all)",
    )
    parser.add_argument(
        "--repeats",
        type=arguments.cli_type("repeats"),
        default=10,
        help="sensor-noise runs per controller",
    )
    parser.add_argument(
        "--seed", type=arguments.cli_type("seed"), default=0, help="seed of the sensor noise"
    )
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    parser.add_argument(
        "--out",
        type=options.out_path,
        default=None,
        help="write the table here, its format from the suffix: .md (markdown) or .json (the rows)",
    )


def run(args: argparse.Namespace) -> int:
    from striatal.experiments import baselines
    from striatal.experiments.robustness import CONDITIONS, controller_groups, robustness_table

    if args.out is not None:
        options.out_format(args.out, (".md", ".json"))
    if args.margin:
        return _margin(args)
    merged: dict[str, list[Controller]] = {}
    for f in args.files:
        try:
            data = read_json(f, what="result")
            if isinstance(data, dict) and "W" not in data:
                AblationModel.of(data, f"ablation {f}")
            found = controller_groups(data, variants=args.variants)
        except (KeyError, TypeError) as exc:
            raise DataFileError(f"{f} is not a result.json or ablation.json: {exc!r}") from None
        except ParameterError as exc:
            raise DataFileError(f"{f}: {exc}") from None
        for name, ctrls in found:
            merged.setdefault(name, []).extend(ctrls)
    missing = [v for v in args.variants if v not in merged]
    if missing:
        raise ParameterError(f"no successful run of variant(s) {', '.join(missing)} in the files")
    if not merged:
        raise ParameterError("the files hold no successful run to evaluate")
    reference = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    lqr_W, lqr_theta_c = baselines.lqr_controller(Plant())
    groups = [
        *merged.items(),
        ("chapter's final gains", [reference]),
        ("LQR baseline", [Controller(lqr_W, lqr_theta_c)]),
    ]
    controllers = sum(len(c) for _, c in groups)
    noisy = sum(1 for c in CONDITIONS if c.sensor.active)
    runs = controllers * (len(CONDITIONS) - noisy + noisy * args.repeats)
    steps = 6000  # each run: T_f 60 s in steps of 10 ms
    arguments.check_work(
        runs * steps,
        "the robustness table",
        f"{controllers:,} controllers x ({len(CONDITIONS) - noisy} conditions + {noisy} noisy "
        f"x {args.repeats:,} repeats) x {steps:,} steps",
    )
    table, rows = robustness_table(groups, CONDITIONS, repeats=args.repeats, seed=args.seed)
    if args.out is not None:
        atomic_write_text(args.out, dumps_json(rows) if args.out.suffix == ".json" else table)
    sys.stdout.write(dumps_json(rows) if args.json else table)
    return 0


def _margin(args: argparse.Namespace) -> int:
    from striatal.experiments.robustness import margin_table, sweep_controllers
    from striatal.experiments.runs_csv import read_runs

    arms: dict[str, dict[int, Controller]] = {}
    for f in args.files:
        name, sep, rest = str(f).partition("=")
        learner, f = (name, Path(rest)) if sep else ("learner", f)
        path = f / "runs.csv" if f.is_dir() else f
        if not path.is_file():
            raise DataFileError(f"{path}: no such sweep runs.csv")
        rows, _ = read_runs(path)
        for arm, by_seed in sweep_controllers(rows).items():
            named = {"learner": learner, "control": f"{learner} control"}.get(arm, arm)
            arms.setdefault(named, {}).update(by_seed)
    if not arms:
        raise ParameterError("the sweeps hold no successful run to evaluate")
    table, rows = margin_table(arms)
    if args.out is not None:
        atomic_write_text(args.out, dumps_json(rows) if args.out.suffix == ".json" else table)
    sys.stdout.write(dumps_json(rows) if args.json else table)
    return 0
