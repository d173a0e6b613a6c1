"""``striatal compare``: the table of learner, control and baselines from sweep summaries."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from striatal import experiments
from striatal.cli import options
from striatal.errors import DataFileError, ParameterError
from striatal.files import read_json, write_json

COMMAND = "compare"
ORDER = 41
HELP = "print the comparison table (markdown) of sweep summaries and write it as JSON"
DESCRIPTION = (
    "Read summary.json of one or more sweeps (a folder or the file itself), print one "
    "markdown table of every arm (learner, alpha = 0 control, baselines) per init, and "
    "optionally write the rows as JSON. Run the arms with "
    "'striatal sweep --baselines lqr,hand,random,cmaes'."
)

_KEYS = ("arm", "init", "method", "runs", "success_rate", "unsolved_share", "trials_median")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("summaries", nargs="+", type=Path, help="sweep folders or summary.json")
    parser.add_argument(
        "--out", type=options.out_path, default=None, help="write the table as JSON here"
    )


def load_summary(path: Path) -> dict[str, Any]:
    """A sweep's summary.json (from its folder or the file), checked for its arms."""
    p = path / "summary.json" if path.is_dir() else path
    data = read_json(p, what="sweep summary")
    if not isinstance(data, dict) or not isinstance(data.get("arms"), list):
        raise DataFileError(f"{p} is not the summary.json of a striatal sweep")
    for a in data["arms"]:
        if not isinstance(a, dict) or any(k not in a for k in _KEYS):
            raise DataFileError(f"{p} has an arm without {', '.join(_KEYS)}")
    return data


def learner_of(summary: dict[str, Any], arm: str) -> str | None:
    """The learner (chapter, rpe, pgpe) of a learning arm of a sweep, or None."""
    cfg = summary.get("settings", {}).get("arms", {}).get(arm, {})
    if not isinstance(cfg, dict) or cfg.get("method") != "learn":
        return None
    learner = cfg.get("config", {}).get("learner")
    return learner if isinstance(learner, str) else None


def label_arms(summaries: list[dict[str, Any]], sources: list[str]) -> list[dict[str, Any]]:
    """Every arm of every summary, the learning arms named with their learner when the
    summaries hold more than one learner (``learner (pgpe)``, ``control (pgpe)``)."""
    learners = {learner_of(s, a["arm"]) for s in summaries for a in s["arms"]} - {None}
    arms = []
    for src, s in zip(sources, summaries, strict=True):
        for a in s["arms"]:
            learner = learner_of(s, a["arm"])
            name = f"{a['arm']} ({learner})" if learner and len(learners) > 1 else a["arm"]
            arms.append({**a, "arm": name, "source": src})
    return arms


def run(args: argparse.Namespace) -> int:
    if args.out is not None and not args.out.parent.is_dir():
        raise ParameterError(f"--out {args.out}: folder {args.out.parent} does not exist")
    summaries = [load_summary(p) for p in args.summaries]
    arms = label_arms(summaries, [str(p) for p in args.summaries])
    arms.sort(key=lambda a: (a["init"], a["arm"]))
    table = experiments.markdown_table({"arms": arms})
    if args.out is not None:
        write_json(
            args.out,
            {
                "arms": arms,
                "notes": [experiments.NOTE_CONTROL],
                "settings": [s.get("settings", {}) for s in summaries],
            },
        )
    sys.stdout.write(table)
    return 0
