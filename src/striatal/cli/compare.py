"""``striatal compare``: the table of learner, control and baselines from sweep summaries."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from striatal.cli import options
from striatal.errors import ParameterError
from striatal.io.files import atomic_write_text, dumps_json, write_json

DESCRIPTION = (
    "Read summary.json of one or more sweeps (a folder or the file itself), print one "
    "markdown table of every arm (learner, its no-learning control, baselines) per init: "
    "success rate with its Wilson 95 % interval, simulations to success (median and IQM "
    "with bootstrap 95 % intervals), then each learner against its control (Fisher's "
    "exact test, McNemar's on the shared seeds); optionally write the rows as JSON. Run "
    "the arms with 'striatal sweep --baselines lqr,hand,random,cmaes'."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("summaries", nargs="+", type=Path, help="sweep folders or summary.json")
    parser.add_argument(
        "--out",
        type=options.out_path,
        default=None,
        help="write the table here, its format from the suffix: .json or .md (markdown)",
    )
    parser.add_argument(
        "--json", action="store_true", help="print the table as JSON (as --out writes it)"
    )


def load_summary(path: Path) -> dict[str, Any]:
    """A sweep's summary.json (from its folder or the file), read through its schema
    (:func:`striatal.io.schema.read_summary`: types, rates in [0, 1], counts >= 0 and
    consistent, arms unique)."""
    from striatal.io.schema import read_summary

    data = read_summary(path)
    data["settings"] = data.get("settings") or {}
    data["learner_vs_control"] = data.get("learner_vs_control") or []
    return data


def learner_of(summary: dict[str, Any], arm: str) -> str | None:
    """The learner (chapter, rpe, pgpe) of a learning arm of a sweep, or None."""
    arms = summary.get("settings", {}).get("arms", {})
    cfg = arms.get(arm, {}) if isinstance(arms, dict) else {}
    if not isinstance(cfg, dict) or cfg.get("method") != "learn":
        return None
    config = cfg.get("config", {})
    learner = config.get("learner") if isinstance(config, dict) else None
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


def label_pairs(summaries: list[dict[str, Any]], sources: list[str]) -> list[dict[str, Any]]:
    """Every learner-against-control pair, both arms named with their learner when the
    summaries hold more than one learner (as :func:`label_arms` names them), with the
    summary it came from (``source``)."""
    learners = {learner_of(s, a["arm"]) for s in summaries for a in s["arms"]} - {None}
    pairs = []
    for src, s in zip(sources, summaries, strict=True):
        for c in s["learner_vs_control"]:
            c = {**c, "source": src}
            learner = learner_of(s, c["arm"])
            if learner and len(learners) > 1:
                c = {
                    **c,
                    "arm": f"{c['arm']} ({learner})",
                    "control": f"{c['control']} ({learner})",
                }
            pairs.append(c)
    return pairs


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        options.out_format(args.out, (".json", ".md"))
        if not args.out.parent.is_dir():
            raise ParameterError(f"--out {args.out}: folder {args.out.parent} does not exist")
    summaries = [load_summary(p) for p in args.summaries]
    sources = [str(p) for p in args.summaries]
    arms = label_arms(summaries, sources)
    arms.sort(key=lambda a: (a["init"], a["arm"], a["source"]))
    pairs = label_pairs(summaries, sources)
    from striatal.experiments import report

    table = report.markdown_table({"arms": arms, "learner_vs_control": pairs})
    record = {
        "arms": arms,
        "learner_vs_control": pairs,
        "notes": list(dict.fromkeys(n for s in summaries for n in s.get("notes", []) or [])),
        "settings": [s.get("settings", {}) for s in summaries],
    }
    if args.out is not None:
        if args.out.suffix.lower() == ".md":
            atomic_write_text(args.out, table)
        else:
            write_json(args.out, record)
    sys.stdout.write(dumps_json(record) if args.json else table)
    return 0
