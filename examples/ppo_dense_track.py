"""PPO on the dense id, with and without its track, beside the chapter's controller.

Needs the [rl] extra (stable-baselines3). Run: ``python examples/ppo_dense_track.py``
(options: ``--seeds``, ``--steps``, ``--episodes``; ``--help``). Prints a Markdown table,
the one in docs/gym.md.

Each arm trains PPO (stable-baselines3 defaults but n_steps=1000, batch_size=100 and a
64x64 net, torch on one thread) on the dense id for a budget of env steps, once per
training seed, and evaluates its deterministic policy on the same perturbed starts as
every other row: reset seeds 100, 101, ... (evaluation starts, apart from the training
seeds 0, 1, ...), each state component moved by up to 0.05. The chapter's controller
(:class:`striatal.envs.SwitchingController`, the mean action of eqs 21-23, divided by
u_max) and the zero action act on the same episodes. A row gives the mean over
training seeds of the per-seed mean return, its range over seeds, and what the
episodes did: how many ended at the track, when they ended [s], how many ended
upright (|theta| < pi/9, eq 25's angle, at the last step) and the largest final |x|.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO

import striatal  # noqa: F401  (registers the env ids)
from striatal.envs import DEFAULT_U_MAX, DENSE_ENV_ID, SwitchingController

Policy = Callable[[np.ndarray], np.ndarray]

#: Half-width of the uniform offset of each start state component (the evaluation starts).
PERTURBATION = 0.05
#: First reset seed of the evaluation episodes; training seeds are 0, 1, ...
EVAL_SEED = 100


@dataclass(frozen=True)
class Episodes:
    """Returns, track ends, upright ends and final |x| [m] of one policy on the evaluation set."""

    returns: tuple[float, ...]
    ends: tuple[float, ...]
    off_track: int
    upright: int
    max_final_x: float


def evaluate(policy: Policy, track: float | None, episodes: int) -> Episodes:
    env = gym.make(DENSE_ENV_ID, perturbation=PERTURBATION, track=track)
    returns: list[float] = []
    ends: list[float] = []
    off, up, far = 0, 0, 0.0
    for e in range(episodes):
        obs, info = env.reset(seed=EVAL_SEED + e)
        total, done = 0.0, False
        while not done:
            obs, r, terminated, truncated, info = env.step(policy(obs))
            total += float(r)
            done = terminated or truncated
        returns.append(total)
        ends.append(float(info["t"]))
        off += int(terminated and not info["fault"])
        up += int(abs(math.remainder(float(info["state"][2]), 2 * math.pi)) < math.pi / 9)
        far = max(far, abs(float(info["state"][0])))
    return Episodes(tuple(returns), tuple(ends), off, up, far)


def train_ppo(seed: int, steps: int, track: float | None) -> Policy:
    env = gym.make(DENSE_ENV_ID, track=track)
    model = PPO(
        "MlpPolicy",
        env,
        seed=seed,
        n_steps=1000,
        batch_size=100,
        policy_kwargs={"net_arch": [64, 64]},
        device="cpu",
        verbose=0,
    )
    model.learn(total_timesteps=steps)
    return lambda obs: np.asarray(model.predict(obs, deterministic=True)[0])


def row(name: str, track: float | None, runs: list[Episodes], episodes: int) -> str:
    means = [float(np.mean(r.returns)) for r in runs]
    spread = f"{min(means):.1f} to {max(means):.1f}" if len(means) > 1 else "-"
    n = len(runs) * episodes
    off = sum(r.off_track for r in runs)
    up = sum(r.upright for r in runs)
    far = max(r.max_final_x for r in runs)
    ends = [t for r in runs for t in r.ends]
    rails = "none" if track is None else f"+-{track:g} m"
    return (
        f"| {name} | {rails} | {len(runs)} | {np.mean(means):.1f} | {spread} | "
        f"{off}/{n} | {min(ends):.2f} to {max(ends):.2f} | {up}/{n} | {far:.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="training seeds per PPO arm")
    parser.add_argument(
        "--steps", type=int, nargs="+", default=[3000, 40000], help="PPO budgets [env steps]"
    )
    parser.add_argument("--episodes", type=int, default=3, help="evaluation starts")
    args = parser.parse_args()
    torch.set_num_threads(1)  # small nets: one thread is faster than many on a shared CPU
    start = time.perf_counter()
    lines = [
        "| policy | track | training seeds | mean return | range over seeds | "
        "ended at the track | episodes end at [s] | ended upright | largest final \\|x\\| [m] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    arms: list[tuple[int, float | None]] = [(args.steps[0], None)]
    arms += [(steps, 1.8) for steps in args.steps]
    for steps, track in arms:
        runs = [
            evaluate(train_ppo(seed, steps, track), track, args.episodes)
            for seed in range(args.seeds)
        ]
        lines.append(row(f"PPO, {steps} steps", track, runs, args.episodes))
    chapter = SwitchingController()
    fixed: dict[str, Policy] = {
        "chapter's controller": lambda obs: chapter(obs) / DEFAULT_U_MAX,
        "zero action": lambda obs: np.zeros(1),
    }
    for name, policy in fixed.items():
        lines.append(row(name, 1.8, [evaluate(policy, 1.8, args.episodes)], args.episodes))
    print("\n".join(lines))
    print(
        f"\n{args.episodes} evaluation starts (reset seeds {EVAL_SEED}-"
        f"{EVAL_SEED + args.episodes - 1}, perturbation {PERTURBATION}), 10-s episodes, "
        f"max return 1000; {time.perf_counter() - start:.0f} s wall"
    )


if __name__ == "__main__":
    main()
