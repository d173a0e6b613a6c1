"""Eq 21 read under the swing-up is a ratchet: what it does to the no-learning controls.

The chapter learner's no-learning control is the learner with alpha = 0: W stays at
W(0), but theta_c still follows eq 21 (``theta_c_rule`` "swingup", the literal reading,
paper NOTES sections 6 and 11). Under the swing-up |theta| >= theta_c, so theta_c only
rises (until min |theta| > 1.4 resets it to 0.6). This prints:

1. ``--rate N``: the rate controller with the chapter's W(0) at fixed thresholds theta_c,
   N noisy 30-s trials each from theta = 3.12 (the Gaussian policy of eq 5, generator
   ``default_rng(seed)`` for seed 0..N-1):
   the +10 rate of eq 25, the median |x(30)| and the fraction upright within pi/9;
2. ``--network N``: the same on the spiking network (Brian2, 2 500 neurons), seeds
   0..N-1: each seed's first learning trial at that theta_c (same network, same draws);
3. ``--files F:SIDE ...``: in a ``benchmarks/neural_learn.py`` file, the alpha-0 runs of
   SIDE, per eq-21 reading (``--theta-c-rule``; none: the preset's): theta_c's rise per
   trial, its resets, and the +10 rate of the trials run (not the +10 that ``--compare``
   fills in after a passed success test) per third of the trials and per theta_c band.

    OPENBLAS_NUM_THREADS=1 python benchmarks/eq21_ratchet.py --rate 200 --network 20 \\
        --files docs/data/neural_learn_rate_r4.jsonl:rate \\
        docs/data/neural_learn_brian2_r4.csv:network

``--files`` reads what ``benchmarks/neural_learn.py`` writes (its JSONL or ``--trim`` table).
"""

from __future__ import annotations

import argparse
import itertools
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from striatal.params import CHAPTER_INITIAL_W, Controller, Plant, Simulation

THETA_CS = (0.6, 0.8, 1.0, 1.1, 1.2, 1.3, 1.4)
BANDS = (0.0, 0.7, 0.9, 1.0, 1.1, 1.2, 1.5)
SIM = Simulation(duration=30.0)
BOX_X, BOX_THETA = 0.1, math.pi / 9  # eq 25


def _wrap(th: float) -> float:
    return float(np.angle(np.exp(1j * th)))


def _line(label: str, finals: list[tuple[float, float]]) -> str:
    x = np.abs([f[0] for f in finals])
    th = np.abs([_wrap(f[1]) for f in finals])
    win = np.mean((x < BOX_X) & (th < BOX_THETA))
    return (
        f"{label}: +10 {win:.2f} of {len(finals)}, median |x(30)| {np.median(x):.3f} m, "
        f"upright within pi/9 {np.mean(th < BOX_THETA):.2f}"
    )


def rate_sweep(n: int) -> None:
    from striatal.sim.rollout import simulate

    for tc in THETA_CS:
        ctl = Controller(gains=CHAPTER_INITIAL_W, theta_c=tc)
        finals = []
        for seed in range(n):
            d = simulate(Plant(), ctl, SIM, rng=np.random.default_rng(seed)).data
            finals.append((float(d[-1, 1]), float(d[-1, 3])))
        print(_line(f"rate theta_c {tc:.1f}", finals))


def network_sweep(n: int) -> None:
    from striatal.neural.driver import learn_with_rule
    from striatal.neural.network import NetworkConfig

    for tc in THETA_CS:
        finals = []
        for seed in range(n):
            runs: list[Any] = []
            learn_with_rule(
                "chapter",
                Controller(gains=CHAPTER_INITIAL_W, theta_c=tc),
                Plant(),
                SIM,
                NetworkConfig(neurons=2500),
                seed,
                trials=1,
                alpha=0.0,
                on_run=runs.append,
            )
            d = runs[0].run.data
            finals.append((float(d[-1, 1]), float(d[-1, 3])))
        print(_line(f"network theta_c {tc:.1f}", finals), flush=True)


def file_report(spec: str) -> None:
    """The alpha-0 runs of SIDE in FILE, one report per eq-21 reading the file holds."""
    from neural_learn import trial_rows  # beside this script (benchmarks/ is its sys.path[0])

    path, side = spec.rsplit(":", 1)
    rows = [r for r in trial_rows([Path(path)]) if r["side"] == side and r["alpha"] == 0]
    for reading in sorted({r.get("theta_c_rule") or "" for r in rows}):
        label = f"theta_c={reading}" if reading else "eq 21 as preset"
        _report(f"{Path(path).name} {side} alpha=0 {label}", [
            r for r in rows if (r.get("theta_c_rule") or "") == reading
        ])  # fmt: skip


def _report(label: str, rows: list[dict[str, Any]]) -> None:
    by: dict[int, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by[int(r["seed"])].append(r)
    rises, resets = [], 0
    for runs in by.values():
        runs.sort(key=lambda r: r["trial"])
        for a, b in itertools.pairwise(runs):
            d = b["theta_c"] - a["theta_c"]
            if d < 0:
                resets += 1
            else:
                rises.append(d)
    last = max(r["trial"] for r in rows)
    print(
        f"{label}: {len(by)} seeds, {len(rows)} trials run (to trial {last}); theta_c rises "
        f"{np.mean(rises):.4f} a trial (median {np.median(rises):.4f}), {resets} resets"
    )
    trial = np.array([r["trial"] for r in rows])
    tc = np.array([r["theta_c"] for r in rows])
    win = np.array([r["reward"] > 0 for r in rows])
    third = math.ceil(last / 3)
    for lo in range(1, last + 1, third):
        m = (trial >= lo) & (trial < lo + third)
        print(
            f"  trials {lo}-{min(lo + third - 1, last)}: {m.sum()} run, +10 {win[m].mean():.2f}, "
            f"mean theta_c {tc[m].mean():.2f}"
        )
    for lo, hi in itertools.pairwise(BANDS):
        m = (tc >= lo) & (tc < hi)
        if m.any():
            print(f"  theta_c in [{lo:.1f}, {hi:.1f}): {m.sum()} trials, +10 {win[m].mean():.2f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=int, default=0, help="noisy rate trials per theta_c")
    parser.add_argument("--network", type=int, default=0, help="network seeds per theta_c")
    parser.add_argument("--files", nargs="*", default=[], help="FILE:SIDE (jsonl or trimmed csv)")
    args = parser.parse_args()
    if args.rate:
        rate_sweep(args.rate)
    for spec in args.files:
        file_report(spec)
    if args.network:
        network_sweep(args.network)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
