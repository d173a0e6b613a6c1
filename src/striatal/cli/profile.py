"""``striatal profile``: performance profiles of the arms of one or more sweeps."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from striatal.cli import options
from striatal.errors import ParameterError
from striatal.io.files import dumps_json

if TYPE_CHECKING:
    from striatal.experiments.profiles import Profile

DESCRIPTION = (
    "Performance profiles from the runs.csv of striatal sweep folders: for each arm (and "
    "each init, when a sweep ran several: --init chapter,random), the "
    "fraction of its seeds solved within a budget of simulations, simulated seconds or "
    "learning trials, with a pointwise Wilson 95 % band. Unsolved seeds count in the "
    "denominator, so each line ends at the arm's success rate. Without --x: simulations "
    "when every runs.csv has that column, else learning trials (with a note on stderr). "
    "The legend names each arm from the settings in the sweep's summary.json."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("sweeps", type=Path, nargs="+", metavar="SWEEP_DIR", help="sweep folders")
    parser.add_argument(
        "--out", type=options.out_path, default=Path("profile.png"), help="PNG (or .pdf/.svg)"
    )
    parser.add_argument(
        "--x",
        choices=("simulations", "simulated_seconds", "trials"),
        default=None,
        help="the budget axis (default: simulations if recorded, else trials)",
    )
    parser.add_argument("--dpi", type=int, default=120, help="resolution of a PNG")
    parser.add_argument("--json", action="store_true", help="print the curves as JSON")


def _settings(folder: Path) -> dict[str, Any]:
    """The ``settings`` of ``folder``'s summary.json ({} when the sweep wrote none)."""
    from striatal.io.schema import read_summary

    path = folder / "summary.json"
    if not path.exists():
        return {}
    data = read_summary(path)
    settings = data.get("settings")
    return settings if isinstance(settings, dict) else {}


def _arm_specs(folder: Path) -> dict[str, Any]:
    """The ``settings.arms`` of ``folder``'s summary.json ({} when the sweep wrote none
    or it records no arms: the legend then uses the arm names)."""
    arms = _settings(folder).get("arms")
    return arms if isinstance(arms, dict) else {}


def _title(folders: list[Path]) -> str | None:
    """The setting of the sweeps (:func:`striatal.viz.profiles.sweeps_title`); None when
    no sweep records its settings."""
    from striatal.viz.profiles import sweeps_title

    return sweeps_title([_settings(f) for f in folders]) or None


def _labels(folders: list[Path], profiles: list[Profile]) -> list[str]:
    """Legend labels of ``profiles`` (named ``arm`` or ``folder/arm``) from each sweep's
    recorded settings, ``", chapter init"`` added to a profile of one of several inits."""
    from striatal.viz import plots

    triples = {}
    for folder in folders:
        for arm, spec in _arm_specs(folder).items():
            name = arm if len(folders) == 1 else f"{folder.name}/{arm}"
            triples[name] = (folder.name, arm, spec)
    arms = list(dict.fromkeys(p.arm for p in profiles))
    named = plots.arm_labels([triples.get(arm, (arm.partition("/")[0], arm, None)) for arm in arms])
    label = dict(zip(arms, named, strict=True))
    return [f"{label[p.arm]}, {p.init} init" if p.init else label[p.arm] for p in profiles]


def run(args: argparse.Namespace) -> int:
    from striatal.experiments.profiles import X_LABELS, sweep_profiles
    from striatal.viz import plots

    out = plots.check_image_path(args.out, (".png", ".pdf", ".svg"))
    if not 10 <= args.dpi <= 1000:
        raise ParameterError(f"--dpi must be in [10, 1000], got {args.dpi}")
    profiles, column, note = sweep_profiles(args.sweeps, args.x)
    labels = _labels(list(args.sweeps), profiles)
    fig = plots.performance_profiles(
        profiles, xlabel=X_LABELS[column], labels=labels, title=_title(list(args.sweeps))
    )
    plots.save_figure(fig, out, dpi=args.dpi)
    if note:
        print(f"note: {note}", file=sys.stderr)
    if args.json:
        sys.stdout.write(
            dumps_json(
                {
                    "x": column,
                    "note": note,
                    "band": "pointwise Wilson 95 %",
                    "profiles": [
                        {**p.to_dict(), "label": label}
                        for p, label in zip(profiles, labels, strict=True)
                    ],
                }
            )
        )
        return 0
    for p, label in zip(profiles, labels, strict=True):
        lo, hi = p.low[-1], p.high[-1]
        named = p.name if label == p.name else f"{p.name} = {label}"
        print(
            f"{named}: {p.successes}/{p.runs} solved = {100 * p.success_rate:.3g} % "
            f"(95 % Wilson {100 * lo:.3g}-{100 * hi:.3g} %) within {p.budget[-1]:g} {column}"
        )
    print(f"wrote {out}")
    return 0
