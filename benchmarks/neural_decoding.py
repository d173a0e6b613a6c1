"""How well the spiking channels decode mu_1 (eq 22) and mu_2 (eq 23) (docs/neural.md).

States are sampled in each channel's region (balancing: |theta| < 0.6; swing-up:
|theta| > 1.4), held 0.2 s each, and the decoded means averaged over the last 0.1 s
are compared with the rate controller's (``kernel.policy_mean``, hard switch).

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_decoding.py --neurons 2500 --seed 1
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from striatal.neural.network import NetworkConfig
from striatal.neural.run import held_state_response
from striatal.params import Controller, Plant
from striatal.sim import kernel


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--neurons", type=int, default=2500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--states", type=int, default=20)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.states
    bal = np.column_stack(
        [
            rng.uniform(-3, 3, n),
            rng.uniform(-2, 2, n),
            rng.uniform(-0.6, 0.6, n),
            rng.uniform(-1.5, 1.5, n),
        ]
    )
    swing = np.column_stack(
        [
            rng.uniform(-3, 3, n),
            rng.uniform(-2, 2, n),
            rng.uniform(1.4, math.pi, n) * rng.choice([-1.0, 1.0], n),
            rng.uniform(-5, 5, n),
        ]
    )
    c, plant = Controller(), Plant()
    p = plant.as_array()
    W = np.array(c.gains)

    def rate(s: np.ndarray) -> float:
        return kernel.policy_mean(
            s[0], s[1], s[2], s[3], W, c.theta_c, c.sign, False, 50.0, p, False, np.zeros(5)
        )

    r = held_state_response(
        c, plant, NetworkConfig(neurons=args.neurons), args.seed, np.vstack([bal, swing])
    )
    for name, states, key, sl in (
        ("mu_1", bal, "mu_1", slice(0, n)),
        ("mu_2", swing, "mu_2", slice(n, 2 * n)),
    ):
        want = np.array([rate(s) for s in states])
        got = r[key][sl]
        err = got - want
        slope = np.polyfit(want, got, 1)[0]
        print(
            f"{name}: {n} states, rate-controller range [{want.min():.2f}, {want.max():.2f}] "
            f"m/s^2; network - rate: rms {np.sqrt(np.mean(err**2)):.3f}, mean "
            f"{err.mean():+.3f}, max |.| {np.abs(err).max():.3f} m/s^2; slope of a fit {slope:.3f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
