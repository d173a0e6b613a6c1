"""Where the spiking learner's trial differs from the rate learner's: traces and noise.

For each seed: one exploring trial of the network (Brian2 simulator, the chapter's W(0)
and theta_c(0) = 0.6, 30 s from theta = 3.12, the exploration of
``default_rng(seed)``, as a learning run's first trial) and, along the network's own
states and the same exploration, what the rate learner would have accumulated:

- **trace**: the cosine between the network's D = (J^T E, E_6) and the rate learner's D
  of eq 3 (``kernel.policy_mean``'s gradient through ``kernel.trace_step``) on the same
  states and draws, and their norms' ratio;
- **decoding noise**: the rms of u - eps - mu(state), the part of the network's command
  that is neither the rate law's mean nor the exploration (the traces do not see it),
  against sigma, the exploration's own std;
- **reward**: eq 25 at T_f for the network; the rate controller's reward on the same
  seeds is in benchmarks/neural_learn.py's files.

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_trace_fidelity.py --seeds 0-4
"""

from __future__ import annotations

import argparse

import numpy as np

from striatal.neural.learn import Eligibility, gain_eligibility, trial_reward
from striatal.neural.network import NetworkConfig
from striatal.neural.run import run_network
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    CHAPTER_THETA0,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import kernel
from striatal.sim.rollout import Protocol


def seed_list(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seed_list, default=[0, 1, 2, 3, 4])
    parser.add_argument("--gamma", type=float, default=0.999)
    args = parser.parse_args()
    ctrl = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
    plant = Plant()
    sim = Simulation(theta0=CHAPTER_THETA0, duration=30.0, dt=0.01)
    W = np.array(ctrl.gains)
    sigma = kernel.sigma_of(W[5])
    p = plant.as_array()
    rows = []
    for seed in args.seeds:
        noise = np.random.default_rng(seed).standard_normal(sim.n_steps)
        elig = Eligibility(sigma, noise, args.gamma, 10)
        run = run_network(
            ctrl, plant, sim, NetworkConfig(), seed, exploration=elig, simulator="brian2"
        )
        d_net = gain_eligibility(elig.trace, elig.sigma_trace, W, plant, ctrl.sign)
        d_rate = np.zeros(6)
        residual = []
        for k in range(sim.n_steps):
            _t, x, xd, th, thd, u = run.data[k, :6]
            grad = np.zeros(5)
            mu = kernel.policy_mean(
                x, xd, th, thd, W, ctrl.theta_c, ctrl.sign, False, 50.0, p, False, grad
            )
            eps = sigma * noise[k]
            d_rate = np.array(kernel.trace_step(eps, sigma, args.gamma, *grad, *d_rate))
            residual.append(u - eps - mu)
        cos = float(
            d_net[:5] @ d_rate[:5] / (np.linalg.norm(d_net[:5]) * np.linalg.norm(d_rate[:5]))
        )
        ratio = float(np.linalg.norm(d_net[:5]) / np.linalg.norm(d_rate[:5]))
        rms = float(np.sqrt(np.mean(np.square(residual))))
        reward = trial_reward(run, Protocol())
        switch = run.switch_times[0] if run.switch_times else float("nan")
        rows.append((cos, ratio, rms, reward))
        print(
            f"seed {seed}: trace cosine (W1..W5) {cos:+.3f}, |D_net| / |D_rate| {ratio:.2f}; "
            f"decoding noise rms {rms:.3f} m/s^2 (sigma {sigma:.3f}); reward {reward:+g}; "
            f"first switch {switch:.2f} s",
            flush=True,
        )
    a = np.array(rows)
    print(
        f"mean over {len(rows)} seeds: cosine {a[:, 0].mean():+.3f} (min {a[:, 0].min():+.3f}), "
        f"norm ratio {a[:, 1].mean():.2f}, decoding noise rms {a[:, 2].mean():.3f} m/s^2 "
        f"= {a[:, 2].mean() / sigma:.2f} sigma; +10 in {int((a[:, 3] > 0).sum())}/{len(rows)}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
