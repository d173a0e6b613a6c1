"""The chapter's switching controller as a policy for the Gymnasium environments.

The action is the kernel's mean action :func:`striatal.sim.kernel.policy_mean` (eq 22
balancing, eq 23 swing-up, switched at theta_c, eq 21), optionally with the
Gaussian exploration of eq 5.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from striatal.envs.task import ObservationKind
from striatal.errors import ParameterError
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    BalanceSign,
    Controller,
    Plant,
    SwitchKind,
)
from striatal.sim import kernel

__all__ = [
    "SwitchingController",
]


class SwitchingController:
    """``policy(obs) -> action``: the switching controller of sections 2.2-2.3.

    ``obs`` of shape (n_obs,) gives an action (1,); a batch (B, n_obs) gives (B, 1).

    Parameters
    ----------
    W : the six gains W1..W6 (eqs 22-23).
    theta_c : switching threshold [rad] (eq 21).
    balance_sign, switch, inhibition : readings of the chapter, as in
        :class:`striatal.params.Controller`.
    plant : the plant the controller believes in (l and g enter eqs 22-23).
    observation : ``"trig"`` (theta = atan2(sin theta, cos theta)) or ``"raw"``;
        must match the environment's.
    rng : if given, actions are drawn from the Gaussian policy of eq 5,
        a = mu + sigma(W6) N(0, 1); otherwise the mean action mu is returned.
    """

    def __init__(
        self,
        W: Sequence[float] = CHAPTER_FINAL_W,
        theta_c: float = CHAPTER_FINAL_THETA_C,
        *,
        balance_sign: BalanceSign = "corrected",
        switch: SwitchKind = "hard",
        inhibition: float = 50.0,
        plant: Plant | None = None,
        observation: ObservationKind = "trig",
        rng: np.random.Generator | None = None,
    ) -> None:
        if observation not in ("trig", "raw"):
            raise ParameterError(f"observation must be 'trig' or 'raw', got {observation!r}")
        self.controller = Controller(
            gains=tuple(W),
            theta_c=theta_c,
            balance_sign=balance_sign,
            switch=switch,
            inhibition=inhibition,
        )
        self.plant = Plant() if plant is None else plant
        self.observation = observation
        self.rng = rng
        self._W = np.asarray(self.controller.gains, dtype=float)
        self._model = self.plant.as_array()
        self._grad = np.empty(5)

    @classmethod
    def from_controller(
        cls,
        controller: Controller,
        *,
        plant: Plant | None = None,
        observation: ObservationKind = "trig",
        rng: np.random.Generator | None = None,
    ) -> SwitchingController:
        """The policy of a :class:`striatal.params.Controller`."""
        return cls(
            controller.gains,
            controller.theta_c,
            balance_sign=controller.balance_sign,
            switch=controller.switch,
            inhibition=controller.inhibition,
            plant=plant,
            observation=observation,
            rng=rng,
        )

    @property
    def sigma(self) -> float:
        """Exploration std of eq 5, sigma(W6) = 0.1 + 1 / (1 + exp(-W6)) [m/s^2]."""
        return float(kernel.sigma_of(self._W[5]))

    def state_of(self, obs: np.ndarray) -> tuple[float, float, float, float]:
        """(x, x_dot, theta, theta_dot) from one observation."""
        o = np.asarray(obs, dtype=float)
        if self.observation == "raw":
            if o.shape != (4,):
                raise ParameterError(f"raw observation must have 4 entries, got shape {o.shape}")
            return float(o[0]), float(o[1]), float(o[2]), float(o[3])
        if o.shape != (5,):
            raise ParameterError(f"trig observation must have 5 entries, got shape {o.shape}")
        return float(o[0]), float(o[1]), math.atan2(float(o[2]), float(o[3])), float(o[4])

    def mean_action(self, obs: np.ndarray) -> float:
        """mu of eq 22/23 for one observation [m/s^2]."""
        c = self.controller
        x, x_dot, theta, theta_dot = self.state_of(obs)
        return float(
            kernel.policy_mean(
                x,
                x_dot,
                theta,
                theta_dot,
                self._W,
                c.theta_c,
                c.sign,
                c.soft,
                c.inhibition,
                self._model,
                False,
                self._grad,
            )
        )

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs, dtype=float)
        rows = o[None, :] if o.ndim == 1 else o
        mu = np.array([self.mean_action(r) for r in rows], dtype=float)
        if self.rng is not None:
            mu = mu + self.sigma * self.rng.standard_normal(mu.shape[0])
        return mu[:, None] if o.ndim > 1 else mu
