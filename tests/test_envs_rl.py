"""A real agent (stable-baselines3 SAC) trains on ``striatal/CartPoleSwingUp-v0``.

Needs the [rl] extra; skipped with the reason when stable-baselines3 is missing.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import striatal  # noqa: F401  (registers the env id)
from striatal.envs import ENV_ID

pytestmark = [pytest.mark.rl, pytest.mark.slow]

DURATION = 5.0  # s: 500-step episodes keep the run short


def _episode_return(policy: Callable[[np.ndarray], np.ndarray], seed: int) -> float:
    env = gym.make(ENV_ID, reward="dense", duration=DURATION)
    obs, _ = env.reset(seed=seed)
    total = 0.0
    done = False
    while not done:
        obs, r, terminated, truncated, _ = env.step(policy(obs))
        total += float(r)
        done = terminated or truncated
    return total


def test_sac_trains_on_the_env() -> None:
    sb3 = pytest.importorskip(
        "stable_baselines3",
        reason="stable-baselines3 not installed: pip install 'striatal[rl]'",
    )
    import torch
    from stable_baselines3.common.env_checker import check_env

    torch.set_num_threads(1)
    env = gym.make(ENV_ID, reward="dense", duration=DURATION)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # Physical units (u in m/s^2) on purpose; the spaces are float32, so no other warning.
        warnings.filterwarnings("ignore", message=".*symmetric and normalized Box.*")
        check_env(env.unwrapped)
    model = sb3.SAC(
        "MlpPolicy",
        env,
        seed=0,
        learning_starts=500,
        policy_kwargs={"net_arch": [64, 64]},
        device="cpu",
        verbose=0,
    )

    def act(obs: np.ndarray) -> np.ndarray:
        return np.asarray(model.predict(obs, deterministic=True)[0])

    before = np.mean([_episode_return(act, 100 + s) for s in range(2)])
    model.learn(total_timesteps=3000)
    after = np.mean([_episode_return(act, 100 + s) for s in range(2)])
    still = np.mean([_episode_return(lambda o: np.zeros(1), 100 + s) for s in range(2)])
    # Doing nothing leaves the pole hanging (return ~0.03 of a possible 500). The untrained
    # actor scores ~7; after 3000 steps SAC pumps energy into the pole (~53: comparable to
    # uniform random +-50 m/s^2 actions; far from a swing-up, which needs many more steps).
    assert still < 0.1
    assert after > 3.0 * max(before, still)
    assert after > 20.0
