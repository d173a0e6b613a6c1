"""Dopamine on the network's pathways against the rate-based learner, from the same start.

Both sides: the chapter's W(0) and theta_c(0) = 0.6, the chapter learner's options
(alpha 5, gamma 0.999, b = 0, sparse reward of eq 25), ``--trials`` trials of
``--duration`` s from theta0 = 3.12, per seed. ``--side network`` runs
:func:`striatal.neural.learn.learn_network` (seed: network and exploration noise);
``--side rate`` runs ``striatal.train`` (seed: its policy noise). One JSON line per
trial is appended to ``--out`` as it ends, then one line with the final W. Example
(what docs/neural.md reports):

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_learn.py --side network --seeds 0-2 \
        --trials 20 --duration 30 --neurons 1500 --out docs/data/neural_learn.jsonl
    python benchmarks/neural_learn.py --side rate --seeds 0-2 --trials 20 --duration 30 \
        --out docs/data/neural_learn.jsonl
    python benchmarks/neural_learn.py --summary docs/data/neural_learn.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W, Controller, Simulation


def seed_list(text: str) -> list[int]:
    """``"0-9"`` or ``"1,3,5"`` as a list of seeds."""
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def append(path: Path, row: dict[str, Any]) -> None:
    with path.open("a") as fh:
        fh.write(json.dumps(row) + "\n")


def run_network_side(args: argparse.Namespace, seed: int) -> None:
    from striatal.neural.learn import NeuralTrial, learn_network
    from striatal.neural.network import NetworkConfig
    from striatal.params import Plant

    base = {
        "side": "network",
        "seed": seed,
        "neurons_requested": args.neurons,
        "duration": args.duration,
        "alpha": args.alpha,
        "backend": args.backend,
    }

    def on_trial(t: NeuralTrial) -> None:
        append(args.out, {**base, "kind": "trial", **t.to_dict()})
        print(
            f"network seed={seed} trial={t.trial} reward={t.reward:+g} W={np.round(t.W, 3)} "
            f"cpu={t.cpu_time:.1f}s",
            file=sys.stderr,
            flush=True,
        )

    r = learn_network(
        Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C),
        Plant(),
        Simulation(duration=args.duration),
        NetworkConfig(neurons=args.neurons),
        seed,
        trials=args.trials,
        alpha=args.alpha,
        on_trial=on_trial,
        backend=args.backend,
    )
    append(
        args.out,
        {
            **base,
            "kind": "final",
            "W": list(r.W),
            "theta_c": r.theta_c,
            "solved": r.solved,
            "neurons": r.neurons,
        },
    )


def run_rate_side(args: argparse.Namespace, seed: int) -> None:
    import striatal

    base = {"side": "rate", "seed": seed, "duration": args.duration, "alpha": args.alpha}

    def on_trial(_state: Any, rec: Any) -> None:
        append(
            args.out,
            {
                **base,
                "kind": "trial",
                "trial": rec.trial,
                "W": list(rec.W),
                "theta_c": rec.theta_c,
                "reward": rec.reward,
                "success": rec.success,
                "fault": rec.fault,
            },
        )

    run = striatal.train(
        "chapter",
        init="chapter",
        seed=seed,
        sim=Simulation(duration=args.duration),
        max_trials=args.trials,
        alpha=args.alpha,
        on_trial=on_trial,
    )
    append(
        args.out,
        {**base, "kind": "final", "W": list(run.W), "theta_c": run.theta_c, "solved": run.success},
    )


def summarize(paths: list[Path]) -> None:
    """Per side and alpha: rewards (+10 count), W(0) -> final W per seed, and the mean change."""
    from striatal.experiments.stats import wilson_interval

    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines() if line]
    groups: dict[tuple[str, float, int], list[dict]] = {}
    for r in rows:
        side = r["side"] if r.get("backend", "nengo") == "nengo" else f"{r['side']}-{r['backend']}"
        groups.setdefault((side, r["alpha"], r["duration"]), []).append(r)
    W0 = np.array(CHAPTER_INITIAL_W)
    for (side, alpha, dur), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], str(kv[0][1]))):
        trials = [r for r in rs if r["kind"] == "trial"]
        finals = {r["seed"]: r for r in rs if r["kind"] == "final"}
        seeds = sorted({r["seed"] for r in trials})
        k = sum(r["reward"] > 0 for r in trials)
        ci = wilson_interval(k, len(trials))
        lo, hi = (ci.low or 0.0), (ci.high or 0.0)
        print(
            f"{side} alpha={alpha} {dur:g}-s trials: {len(trials)} trials over seeds {seeds}; "
            f"reward +10 in {k}/{len(trials)} (95 % Wilson {lo:.2f}-{hi:.2f}); "
            f"success test {sum(r['success'] for r in trials)}/{len(trials)}"
        )
        deltas = []
        for s in seeds:
            ts = sorted((r for r in trials if r["seed"] == s), key=lambda r: r["trial"])
            rew = "".join("+" if r["reward"] > 0 else "-" for r in ts)
            if s in finals:
                Wf = np.array(finals[s]["W"])
                deltas.append(Wf - W0)
                wf = " ".join(f"{w:+.3f}" for w in Wf)
                tail = f"final W [{wf}] theta_c {finals[s]['theta_c']:.3f}"
            else:
                tail = "(not finished)"
            print(f"  seed {s}: rewards {rew}  {tail}")
        if deltas:
            d = np.mean(deltas, axis=0)
            print("  mean W(final) - W(0): [" + " ".join(f"{v:+.3f}" for v in d) + "]")
        half = max(1, max((r["trial"] for r in trials), default=1) // 2)
        first = [r["reward"] > 0 for r in trials if r["trial"] <= half]
        second = [r["reward"] > 0 for r in trials if r["trial"] > half]
        if first and second:
            print(
                f"  +10 rewards: trials 1-{half} {sum(first)}/{len(first)}, "
                f"later {sum(second)}/{len(second)}"
            )


def learn_figure(paths: list[Path], out: Path) -> None:
    """W1..W6 per trial, network (solid) and rate learner (dashed), one colour per seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines() if line]
    trials = [r for r in rows if r["kind"] == "trial" and r["alpha"] > 0]
    fig, axes = plt.subplots(2, 3, figsize=(10, 5.5), sharex=True, constrained_layout=True)
    seeds = sorted({r["seed"] for r in trials})
    for side, style in (("network", "-"), ("rate", "--")):
        for ci, s in enumerate(seeds):
            ts = sorted(
                (r for r in trials if r["side"] == side and r["seed"] == s),
                key=lambda r: r["trial"],
            )
            if not ts:
                continue
            W = np.array([r["W"] for r in ts])
            t = [r["trial"] for r in ts]
            for i, ax in enumerate(axes.ravel()):
                ax.plot(
                    t,
                    W[:, i],
                    style,
                    color=f"C{ci}",
                    marker="o",
                    ms=3,
                    label=f"{side} seed {s}" if i == 0 else None,
                )
    for i, ax in enumerate(axes.ravel()):
        ax.set_title(f"W{i + 1}", fontsize=9)
        ax.axhline(CHAPTER_INITIAL_W[i], color="0.7", lw=0.8)
    for ax in axes[1]:
        ax.set_xlabel("trial (W used in it)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(
        "chapter's rule from the chapter's W(0): spiking network (solid) vs rate learner (dashed)",
        fontsize=10,
    )
    fig.savefig(out, dpi=110)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--summary", type=Path, nargs="+", help="summarize these files and stop")
    parser.add_argument("--side", choices=("network", "rate"))
    parser.add_argument("--seeds", type=seed_list, default=[0, 1, 2])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--neurons", type=int, default=1500)
    parser.add_argument("--alpha", type=float, default=5.0)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--figure", type=Path, help="with --summary: also draw W per trial here")
    parser.add_argument(
        "--backend", choices=("nengo", "brian2"), default="nengo", help="the network's simulator"
    )
    args = parser.parse_args()
    if args.summary:
        summarize(args.summary)
        if args.figure is not None:
            learn_figure(args.summary, args.figure)
        return 0
    if args.out is None or args.side is None:
        parser.error("--side and --out are required")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for seed in args.seeds:
        (run_network_side if args.side == "network" else run_rate_side)(args, seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
