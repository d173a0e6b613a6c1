"""``striatal/CartPoleSwingUp-v0``: the chapter's cart-pole as a Gymnasium environment.

One env step is one :func:`striatal.kernel.rk4_step` of length dt with the
commanded cart acceleration u held, exactly as :func:`striatal.kernel.run_trial`
advances a trial, so a policy that returns the kernel's mean action reproduces
``striatal simulate`` step for step.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from striatal import kernel
from striatal.envs.task import SwingUpTask, observe, outcome, start_state
from striatal.errors import ParameterError
from striatal.render import cartpole_frame

RENDER_WIDTH = 600
RENDER_HEIGHT = 400


def observation_space(task: SwingUpTask) -> spaces.Box:
    """Unbounded float64 Box, except sin and cos theta in [-1, 1] for ``"trig"``."""
    high = np.full(task.obs_size, np.inf)
    if task.observation == "trig":
        high[2:4] = 1.0
    return spaces.Box(-high, high, dtype=np.float64)


def action_space(task: SwingUpTask) -> spaces.Box:
    """Box(1): commanded cart acceleration u in [-u_max, u_max] [m/s^2] (eq 13)."""
    return spaces.Box(-task.u_max, task.u_max, shape=(1,), dtype=np.float64)


def clip_action(action: Any, u_max: float, n: int) -> np.ndarray:
    """(n,) float64 u from an action batch of n scalars, clipped to +-u_max."""
    a = np.asarray(action, dtype=float)
    if a.size != n:
        raise ParameterError(f"action must hold {n} number(s), got shape {a.shape}")
    a = a.reshape(n)
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"action must be finite, got {a}")
    return np.clip(a, -u_max, u_max)


class CartPoleSwingUpEnv(gym.Env[np.ndarray, np.ndarray]):
    """Swing-up and balance of the point-mass cart-pole (section 2), Gymnasium API.

    Action: Box(1) commanded cart acceleration u [m/s^2], clipped to
    [-u_max, u_max] (default 50). Observation: [x, x_dot, sin theta, cos theta,
    theta_dot] (``observation="trig"``, default) or the raw kernel state
    [x, x_dot, theta, theta_dot] (``"raw"``, theta unwrapped). Rewards: see
    :class:`~striatal.envs.task.SwingUpTask`. ``terminated``: the eq-24 check
    failed at t = 30 s, or the state blew up (non-finite or beyond 1e8);
    ``truncated``: the time limit ``duration`` (default 60 s) was reached.

    Keyword arguments are the fields of :class:`~striatal.envs.task.SwingUpTask`
    (plant, dt, duration, u_max, observation, reward, protocol, initial_state,
    perturbation). ``reset(options={"initial_state": [...], "perturbation": p})``
    overrides the start for one episode. ``info`` holds ``state`` (raw, after the
    step), ``t`` [s], ``u`` (the clipped action applied) and ``fault``.
    """

    # Gymnasium reads metadata from the class (a plain dict there too).
    metadata: dict[str, Any] = {  # noqa: RUF012
        "render_modes": ["rgb_array"],
        "render_fps": 50,
    }

    def __init__(self, render_mode: str | None = None, **task_options: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ParameterError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.task = SwingUpTask.from_kwargs(**task_options)
        self.render_mode = render_mode
        self.observation_space = observation_space(self.task)
        self.action_space = action_space(self.task)
        self._plant = self.task.plant.as_array()
        self._state = np.array(self.task.initial_state, dtype=float)
        self._steps = 0
        self._u = 0.0

    @property
    def state(self) -> np.ndarray:
        """Copy of the raw kernel state [x, x_dot, theta, theta_dot] (theta unwrapped)."""
        return self._state.copy()

    @property
    def t(self) -> float:
        """Simulated time [s] since the last reset."""
        return self._steps * self.task.dt

    def _obs(self) -> np.ndarray:
        return observe(self._state[None, :], self.task.observation)[0]

    def _info(self, fault: bool = False) -> dict[str, Any]:
        return {"state": self.state, "t": self.t, "u": self._u, "fault": fault}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._state = start_state(self.task, self.np_random, options)
        self._steps = 0
        self._u = 0.0
        return self._obs(), self._info()

    def step(
        self, action: np.ndarray
    ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        u = clip_action(action, self.task.u_max, 1)
        s = self._state
        x, x_dot, theta, theta_dot = kernel.rk4_step(
            s[0], s[1], s[2], s[3], float(u[0]), self.task.dt, self._plant, self._plant, False
        )
        self._state = np.array([x, x_dot, theta, theta_dot], dtype=float)
        self._steps += 1
        self._u = float(u[0])
        reward, terminated, truncated, fault = outcome(
            self.task, self._state[None, :], np.array([self._steps]), u
        )
        return (
            self._obs(),
            float(reward[0]),
            bool(terminated[0]),
            bool(truncated[0]),
            self._info(bool(fault[0])),
        )

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """(400, 600, 3) uint8 frame, the picture of :func:`striatal.render.cartpole_frame`."""
        if self.render_mode != "rgb_array":
            return None
        return cartpole_frame(self._state, self.task.plant, t=self.t)
