"""Success of the spiking controller over network seeds and neuron counts (docs/neural.md).

Each run: the chapter's final gains, 60 s from theta0 = 3.12, one network seed. One
JSON line per run is appended to ``--out`` as soon as it ends, so a run that is
stopped keeps what it has. Example (what docs/neural.md reports):

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_seeds.py --neurons 2500 \
        --seeds 0-9 --out docs/data/neural_seeds.jsonl
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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--neurons", type=int, nargs="+", default=[2500])
    parser.add_argument("--seeds", type=seed_list, default=list(range(10)))
    parser.add_argument(
        "--selection", choices=("cerebellum", "basal-ganglia"), default="cerebellum"
    )
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
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
