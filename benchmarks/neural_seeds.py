"""Success of the spiking controller over network seeds and neuron counts (docs/neural.md).

Each run: the chapter's final gains, 60 s from theta0 = 3.12, one network seed. One
JSON line per run is appended to ``--out`` as soon as it ends, so a run that is
stopped keeps what it has. Example (what docs/neural.md reports):

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_seeds.py --neurons 2500 \
        --seeds 0-9 --out docs/data/neural_seeds.jsonl
    python benchmarks/neural_seeds.py --summary docs/data/neural_seeds.jsonl
    python benchmarks/neural_seeds.py --summary docs/data/neural_curve.jsonl \
        docs/data/neural_seeds.jsonl --figure docs/img/neural_curve.png
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from striatal.neural.network import NetworkConfig
from striatal.neural.run import run_network
from striatal.params import Controller, Plant, Simulation


def seed_list(text: str) -> list[int]:
    """``"0-9"`` or ``"1,3,5"`` as a list of seeds."""
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def summarize(paths: list[Path]) -> None:
    """Print, per (selection, neurons), the seeds that held the pole and a 95 % interval."""
    from scipy.stats import binomtest

    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines() if line]
    groups: dict[tuple[str, int], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["selection"], r["neurons_requested"]), []).append(r)
    for (sel, n), rs in sorted(groups.items()):
        k = sum(r["upright_last_10s"] for r in rs)
        ci = binomtest(k, len(rs)).proportion_ci(confidence_level=0.95, method="exact")
        ok = sum(r["success"] for r in rs)
        print(
            f"{sel} {n} requested ({rs[0]['neurons']} neurons): upright_last_10s {k}/{len(rs)} "
            f"(95 % CI {ci.low:.2f}-{ci.high:.2f}); chapter's success test {ok}/{len(rs)}"
        )
        for r in sorted(rs, key=lambda r: r["seed"]):
            x, _xd, th, _thd = r["final_state"]
            sw = r["switch_times"]
            print(
                f"  seed {r['seed']}: upright {r['upright_last_10s']!s:5}  first switch "
                f"{sw[0] if sw else float('nan'):6.2f} s  switches {len(sw):2d}  final x "
                f"{x:+.3f} m  theta {th:+.4f} rad  max|x| {r['max_abs_x']:.2f} m"
            )


def curve_figure(paths: list[Path], out: Path) -> None:
    """Seeds upright over the last 10 s against the neuron count (cerebellar switch), with
    exact 95 % intervals: the curve of docs/neural.md."""
    from striatal.neural.figures import upright_curve_figure
    from striatal.viz.plots import save_figure

    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines() if line]
    save_figure(upright_curve_figure(rows), out)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--summary", type=Path, nargs="+", help="summarize these files and stop")
    parser.add_argument("--neurons", type=int, nargs="+", default=[2500])
    parser.add_argument("--seeds", type=seed_list, default=list(range(10)))
    parser.add_argument(
        "--selection", choices=("cerebellum", "basal-ganglia"), default="cerebellum"
    )
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--figure", type=Path, help="with --summary: also draw the curve here")
    args = parser.parse_args()
    if args.summary:
        summarize(args.summary)
        if args.figure is not None:
            curve_figure(args.summary, args.figure)
        return 0
    if args.out is None:
        parser.error("--out is required")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for n in args.neurons:
        for seed in args.seeds:
            r = run_network(
                Controller(),
                Plant(),
                Simulation(duration=args.duration),
                NetworkConfig(neurons=n, selection=args.selection),
                seed,
                record_rates=False,
            )
            row = {"neurons_requested": n, "selection": args.selection, **r.summary()}
            with args.out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(
                f"n={n} seed={seed} upright={r.upright_last_10s} success={r.success} "
                f"cpu/s={r.cpu_time / args.duration:.2f}",
                file=sys.stderr,
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
