"""``striatal interpret``: the neural reading of section 4 for a set of gains."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from striatal.cli import options
from striatal.errors import DataFileError, ParameterError
from striatal.io.files import dumps_json
from striatal.params import Plant

DESCRIPTION = (
    "Section 4's neural reading of a gain set: mu_1 (balancing, eq 22) and mu_2 (swing-up, "
    "eq 23) as linear forms with numeric coefficients, each labelled direct (excitatory, "
    "positive) or indirect (inhibitory, negative) pathway; and, from a history.csv of "
    "striatal train, how many updates potentiated (LTP) or depressed (LTD) each gain after a "
    "dopamine burst (reward > 0) or dip (reward < 0). Gains from RESULT (result.json; its "
    "history.csv beside it is read when present), or --chapter-final (default), "
    "--chapter-initial, --gains with --theta-c."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--result",
        type=Path,
        default=None,
        help="take W, theta_c and the plant from this result.json of striatal train",
    )
    # the old spelling (the file as a word): refused with one line naming --result
    parser.add_argument("old_result", nargs="?", default=None, help=argparse.SUPPRESS)
    options.add_controller_arguments(parser, gains_required=True)
    options.add_plant_arguments(parser)
    parser.add_argument(
        "--history",
        type=Path,
        default=None,
        help="history.csv of striatal train (default: the one beside RESULT, if any)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def _from_result(path: Path) -> tuple[list[float], float, str, Plant, str]:
    from striatal.io.rundir import read_result

    r = read_result(path)
    return list(r.W), r.theta_c, r.controller.balance_sign, r.plant, r.learner


def build(args: argparse.Namespace) -> dict[str, Any]:
    """The JSON reading for the parsed command line (validates everything first)."""
    from striatal.io.rundir import read_history
    from striatal.neural import interpret

    learner = "chapter"
    if args.old_result is not None:
        raise ParameterError(
            f"give the result file as --result {args.old_result} (as simulate, figure, "
            "animate and neural take it)"
        )
    if args.result is not None:
        if args.gains is not None or args.chapter_initial or args.chapter_final:
            raise ParameterError("give either RESULT or a gain set, not both")
        W, theta_c, sign, plant, learner = _from_result(args.result)
        source = str(args.result)
    else:
        gains, theta_c = options.gains_from(args)
        W, sign, plant = list(gains), args.balance_sign, options.plant_from(args)
        source = (
            "--gains"
            if args.gains is not None
            else ("--chapter-initial" if args.chapter_initial else "--chapter-final")
        )
    history_path = args.history
    if history_path is None and args.result is not None:
        sibling = args.result.parent / "history.csv"
        history_path = sibling if sibling.exists() else None
    try:
        out: dict[str, Any] = interpret.reading(W, theta_c, plant, sign)
    except ParameterError as exc:
        raise (DataFileError(f"result {args.result}: {exc}") if args.result else exc) from None
    out["source"] = source
    out["learner"] = learner
    if history_path is not None:
        h = read_history(history_path)
        table = interpret.plasticity_table(h.W, h.reward)
        from striatal.learners import RULES

        rule = RULES.get(learner) if isinstance(learner, str) else None
        out["plasticity"] = {
            "history": str(history_path),
            "trials": len(h),
            "updates": max(len(h) - 1, 0),
            "updates_after_burst": int((h.reward[:-1] > 0).sum()),
            "updates_after_dip": int((h.reward[:-1] < 0).sum()),
            "per_gain": [p.to_dict() for p in table],
            "note": (
                "an update is W(k+1) - W(k), made after trial k's reward; burst = reward > 0, "
                "dip = reward < 0. W6 sets sigma (exploration), not a pathway weight."
                + (
                    ""
                    if rule is not None and rule.raw_reward_signal
                    else f" Learner {learner!r}: its dopamine-like signal is not the raw "
                    "reward (reward prediction error or shaped reward), so the split by the "
                    "reward's sign is only a first reading."
                )
            ),
        }
    return out


def _print_human(r: dict[str, Any]) -> None:
    W = " ".join(f"{w:.4f}" for w in r["W"])
    print(f"gains ({r['source']}): W = [{W}]   theta_c = {r['theta_c']:.4f} rad")
    print(
        f"balance sign: {r['balance_sign']}   plant: l = {r['plant']['length']:g} m, "
        f"g = {r['plant']['gravity']:g} m/s^2"
    )
    for key, title in (("mu_1", "balancing, eq 22"), ("mu_2", "swing-up, eq 23")):
        block = r[key]
        print()
        print(f"{block['form']}   ({title})")
        print(f"  {'signal':<24} {'coefficient':>12}  {'from W':<18} pathway")
        for t in block["terms"]:
            label = {
                "direct": "direct (excitatory)",
                "indirect": "indirect (inhibitory)",
                "silent": "silent (zero)",
            }[t["pathway"]]
            sig = "E~ theta_dot cos theta" if t["signal"] == "energy_pump" else t["signal"]
            print(f"  {sig:<24} {t['coefficient']:>+12.4f}  {t['formula']:<18} {label}")
    print()
    print("sign convention: " + r["sign_note"])
    p = r.get("plasticity")
    if p is None:
        return
    print()
    print(
        f"plasticity from {p['history']}: {p['trials']} trials, {p['updates']} updates "
        f"({p['updates_after_burst']} after a dopamine burst, reward > 0; "
        f"{p['updates_after_dip']} after a dip, reward < 0)"
    )
    print(
        f"  {'gain':<5} {'LTP|burst':>10} {'LTD|burst':>10} {'LTP|dip':>10} {'LTD|dip':>10} "
        f"{'unchanged':>10}"
    )
    for g in p["per_gain"]:
        print(
            f"  {g['weight']:<5} {g['ltp_after_burst']:>10} {g['ltd_after_burst']:>10} "
            f"{g['ltp_after_dip']:>10} {g['ltd_after_dip']:>10} {g['unchanged']:>10}"
        )
    print("  " + p["note"])


def run(args: argparse.Namespace) -> int:
    result = build(args)
    if args.json:
        sys.stdout.write(dumps_json(result))
    else:
        _print_human(result)
    return 0
