"""Kernel speed of two source trees, measured alternately: ns per simulated step.

    python benchmarks/compare_trees.py OLD_SRC NEW_SRC [--rounds 5] [--seconds 0.5]

Each round runs one subprocess per tree (OLD, NEW, OLD, NEW, ...), with PYTHONPATH set
to that tree's src/ folder; a subprocess warms the kernels up (compilation or the Numba
cache, excluded) and times, for about ``--seconds`` each, the scalar trial
(``kernel.run_trial``), the batch over cores (``run_trials_batch``, B = 256), the
lockstep batch (``run_trials_lockstep``, B = 256) and the online trial
(``online.run_online_trial``, alpha = beta = 0.001), all on the chapter's 60-s trial
(:class:`striatal.sim.bench.TrialSetup`) with the policy noise drawn before the timing.
Alternating spreads a shared machine's load over both trees; the table gives the
median of the rounds and NEW / OLD. The load average is printed before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, sys, time
import numpy as np
from striatal.sim import bench, kernel, online

seconds = float(sys.argv[1])
setup = bench.TrialSetup.chapter(60.0, 0.01)
n = setup.n_steps
rng = np.random.default_rng(0)
noise = rng.standard_normal(n)
out = np.empty(kernel.N_OUT)
B = 256
outs = np.empty((B, kernel.N_OUT))


def scalar():
    return bench.run_kernel_trial(setup, noise, out)


def batch(lockstep):
    normals = rng.standard_normal((B, n))
    state0, gains, plant, control, protocol, _, learning, _ = setup.args
    args = (
        np.tile(state0, (B, 1)),
        kernel.BatchGains(np.tile(gains.W, (B, 1)), np.full(B, gains.theta_c)),
        plant,
        control,
        protocol,
        normals,
        kernel.TraceArgs(learning.gamma, np.zeros((B, 6))),
    )
    run = kernel.run_trials_lockstep if lockstep else kernel.run_trials_batch

    def call():
        args[6].trace[:] = 0.0
        run(*args, outs)
        return int(outs[:, kernel.OUT_END_STEP].sum())

    return call


def online_trial():
    state0, gains, plant, control, protocol, noise_args, learning, _ = setup.args
    W = np.array(gains.W)

    def call():
        W[:] = gains.W
        critic = online.CriticArgs(
            alpha=0.001, beta=0.001, discount=0.99, critic_decay=0.9, max_step=1.0,
            w1_floor=1e-3, check_x=protocol.check_x, weights=np.zeros(online.N_FEATURES),
            trace=np.zeros(online.N_FEATURES), stats=np.zeros(online.N_STATS),
            normalise=False, square_rate=0.001, square=np.zeros(1), gains_end=np.zeros(6),
        )
        online.run_online_trial(
            state0, gains._replace(W=W), plant, control, protocol,
            noise_args._replace(action=noise), learning._replace(trace=np.zeros(6)),
            critic, out,
        )
        return int(out[kernel.OUT_END_STEP])

    return call


result = {}
for name, run in (
    ("run_trial", scalar),
    ("run_trials_batch", batch(False)),
    ("run_trials_lockstep", batch(True)),
    ("online", online_trial()),
):
    run()
    calls = bench.calibrate(run, seconds)
    steps, elapsed = bench.timed(run, calls)
    result[name] = 1e9 * elapsed / steps
print(json.dumps(result))
"""

KERNELS = ("run_trial", "run_trials_batch", "run_trials_lockstep", "online")


def measure(src: Path, seconds: float) -> dict[str, float]:
    """ns per step of each kernel, from a subprocess importing ``src``'s striatal."""
    env = dict(os.environ, PYTHONPATH=str(src))
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(seconds)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    result: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("old", type=Path, help="the reference tree's src/ folder")
    parser.add_argument("new", type=Path, help="the tree compared with it (src/)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=0.5, help="timing per kernel and call")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}", flush=True)
    runs: dict[str, list[dict[str, float]]] = {"old": [], "new": []}
    for i in range(args.rounds):
        for side in ("old", "new"):
            r = measure(getattr(args, side), args.seconds)
            runs[side].append(r)
            cells = " ".join(f"{k}={r[k]:.1f}" for k in KERNELS)
            print(f"round {i + 1} {side}: {cells}", flush=True)
    print(f"load average after: {os.getloadavg()}")
    print(f"{'ns per step (median)':<24}{'old':>10}{'new':>10}{'new/old':>10}")
    for k in KERNELS:
        old = statistics.median(r[k] for r in runs["old"])
        new = statistics.median(r[k] for r in runs["new"])
        print(f"{k:<24}{old:>10.2f}{new:>10.2f}{new / old:>10.3f}")


if __name__ == "__main__":
    main()
