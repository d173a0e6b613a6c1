"""``striatal/CartPoleSwingUp-v0``: the chapter's cart-pole as a Gymnasium environment.

One env step is one :func:`striatal.sim.kernel.rk4_step` of length dt with the
commanded cart acceleration u held, exactly as :func:`striatal.sim.kernel.run_trial`
advances a trial, so a policy that returns the kernel's mean action reproduces
``striatal simulate`` step for step.
"""

from __future__ import annotations

import importlib.util
import os
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import logger, spaces
from gymnasium.wrappers import TimeLimit

from striatal.envs.task import SwingUpTask, observe, outcome, start_state
from striatal.errors import MissingExtraError, ParameterError
from striatal.sim import kernel
from striatal.viz.render import cartpole_frame, follow_camera

__all__ = [
    "RENDER_HEIGHT",
    "RENDER_WIDTH",
    "CartPoleSwingUpEnv",
    "HumanWindow",
    "action_space",
    "check_render_mode",
    "clip_action",
    "env_frame",
    "import_pygame",
    "make_env",
    "observation_space",
    "pygame_available",
    "view",
]

RENDER_WIDTH = 600
RENDER_HEIGHT = 400


def observation_space(task: SwingUpTask) -> spaces.Box:
    """Unbounded Box of ``task.dtype``, except sin and cos theta in [-1, 1] for ``"trig"``.

    x stays unbounded with a track too: the step that leaves the rails returns an
    |x| beyond ``task.track``.
    """
    high = np.full(task.obs_size, np.inf, dtype=task.dtype)
    if task.observation == "trig":
        high[2:4] = 1.0
    return spaces.Box(-high, high, dtype=high.dtype)


def action_space(task: SwingUpTask) -> spaces.Box:
    """Box(1) of ``task.dtype``: u in [-u_max, u_max], in m/s^2 (eq 13); [-1, 1] if normalised."""
    # Bounds built in the space's dtype: a u_max that float32 cannot hold is rounded
    # here, while the env clips to the float64 u_max itself.
    high = np.full(1, 1.0 if task.normalised_action else task.u_max, dtype=task.dtype)
    return spaces.Box(-high, high, dtype=high.dtype)


def clip_action(
    action: Any, u_max: float, n: int, normalised: bool = False, space: Any = None
) -> np.ndarray:
    """(n,) float64 u, in m/s^2, from an action batch of n real scalars, clipped to +-u_max.

    Any real dtype is accepted (a float32 action of the action space, a float64 one of
    a controller) and used as float64. A normalised action a is clipped to [-1, 1]
    and scaled to u = a * u_max. Anything else (text, an object, a complex number)
    raises ParameterError naming the action and ``space``, the action space.
    """
    where = "the action space" if space is None else f"the action space {space}"
    try:
        raw = np.asarray(action)
    except (TypeError, ValueError):
        raw = np.asarray(None)
    if raw.dtype.kind not in "biuf":
        raise ParameterError(
            f"action {action!r} ({type(action).__name__}) is invalid: it must be "
            f"{'a real number' if n == 1 else f'{n} real numbers'} in {where}"
        )
    a = raw.astype(float)
    if a.size != n:
        raise ParameterError(f"action must hold {n} number(s) of {where}, got shape {a.shape}")
    a = a.reshape(n)
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"action must be finite, got {a}")
    if normalised:
        return np.clip(a, -1.0, 1.0) * u_max
    return np.clip(a, -u_max, u_max)


def view(state: np.ndarray, task: SwingUpTask) -> tuple[float, float]:
    """(x_limit, camera_x) [m] of the env's picture: a +-4 m view that follows the cart."""
    x_limit = 4.0
    margin = 1.2 * task.plant.length + 0.5
    return x_limit, follow_camera(float(state[0]), x_limit, margin)


def env_frame(state: np.ndarray, task: SwingUpTask, t: float) -> np.ndarray:
    """(400, 600, 3) uint8 picture of one env state, the camera following the cart."""
    x_limit, camera_x = view(state, task)
    return cartpole_frame(
        state,
        task.plant,
        t=t,
        width=RENDER_WIDTH,
        height=RENDER_HEIGHT,
        x_limit=x_limit,
        camera_x=camera_x,
    )


def check_render_mode(render_mode: str | None, modes: list[str]) -> None:
    """ParameterError unless ``render_mode`` is None or one of ``modes``."""
    if render_mode is not None and render_mode not in modes:
        raise ParameterError(f"render_mode must be None or one of {modes}, got {render_mode!r}")


def import_pygame() -> Any:
    """The pygame module, or MissingExtraError naming the ``[render]`` extra."""
    # pygame greets on stdout when imported, which would mix into a user's output.
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError:
        raise MissingExtraError(
            "render_mode='human' needs pygame, the [render] extra: pip install 'striatal[render]'"
        ) from None
    return pygame


def pygame_available() -> bool:
    """True if pygame (the ``[render]`` extra) can be imported."""
    try:
        return importlib.util.find_spec("pygame") is not None
    except (ImportError, ValueError):  # ValueError: sys.modules["pygame"] is None
        return False


class HumanWindow:
    """A pygame window that shows frames at the env's frame rate (render_mode="human")."""

    def __init__(self, width: int, height: int, fps: float) -> None:
        self.pygame = import_pygame()
        self.size = (width, height)
        self.fps = fps
        self.window: Any = None
        self.clock: Any = None

    def show(self, frame: np.ndarray) -> None:
        """Draw ``frame`` (H, W, 3) and wait so that frames come at ``fps``."""
        pg = self.pygame
        if self.window is None:
            pg.display.init()
            pg.display.set_caption("striatal cart-pole")
            self.window = pg.display.set_mode(self.size)
            self.clock = pg.time.Clock()
        surface = pg.surfarray.make_surface(np.ascontiguousarray(frame.transpose(1, 0, 2)))
        self.window.blit(surface, (0, 0))
        pg.event.pump()
        pg.display.flip()
        self.clock.tick(self.fps)

    def close(self) -> None:
        """Close the window (pygame's display module is shut down)."""
        if self.window is not None:
            self.pygame.display.quit()
            self.window = None


class CartPoleSwingUpEnv(gym.Env[np.ndarray, np.ndarray]):
    """Swing-up and balance of the point-mass cart-pole (section 2), Gymnasium API.

    Action: Box(1) commanded cart acceleration u [m/s^2], clipped to
    [-u_max, u_max] (default 50); with ``normalised_action=True`` in [-1, 1],
    u = a * u_max. Observation: [x, x_dot, sin theta, cos theta, theta_dot]
    (``observation="trig"``, default) or the raw kernel state [x, x_dot, theta,
    theta_dot] (``"raw"``, theta unwrapped). Both spaces and the observations are
    float32 (``dtype="float64"`` for the kernel's own precision); the physics is
    float64, and actions of any real dtype are accepted. Rewards: see
    :class:`~striatal.envs.task.SwingUpTask`. ``terminated``: the cart left the
    track (|x| > ``track``, when a track is set), the eq-24 check failed at
    t = 30 s, or the state blew up (non-finite or beyond 1e8); ``truncated``: the
    time limit ``duration`` (default 60 s) was reached. A ``step`` after the episode
    ended, without a ``reset``, warns once (``gymnasium.logger.warn``, as Gymnasium's
    own envs do) and returns the last observation, ``info`` and flags again with
    reward 0; the state no longer moves.

    Keyword arguments are the fields of :class:`~striatal.envs.task.SwingUpTask`
    (plant, dt, duration, u_max, observation, reward, protocol, initial_state,
    perturbation, normalised_action, track, dtype).
    ``reset(options={"initial_state": [...], "perturbation": p})`` overrides the
    start for one episode (other keys raise ParameterError). ``info`` holds
    ``state`` (raw, after the step), ``t`` [s], ``u`` (the clipped action applied,
    [m/s^2]) and ``fault``.

    Rendering: ``"rgb_array"`` returns (400, 600, 3) frames; ``"human"`` shows them
    in a pygame window (the ``[render]`` extra) at ``metadata["render_fps"]`` =
    1 / dt, real time.
    """

    # Gymnasium reads metadata from the class (a plain dict there too): "human" is
    # always listed so that gymnasium.make hands it to __init__ (which names the
    # extra if pygame is missing). Each instance gets its own copy with
    # render_fps = 1 / dt (recorded video plays in real time) and only the modes
    # it can draw (env_checker.check_env makes every listed mode).
    metadata: dict[str, Any] = {  # noqa: RUF012
        "render_modes": ["human", "rgb_array"],
        "render_fps": 100,
    }

    def __init__(self, render_mode: str | None = None, **task_options: Any) -> None:
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.task = SwingUpTask.from_kwargs(**task_options)
        modes = [
            m for m in type(self).metadata["render_modes"] if m != "human" or pygame_available()
        ]
        self.metadata = {
            **type(self).metadata,
            "render_modes": modes,
            "render_fps": self.task.render_fps,
        }
        self.render_mode = render_mode
        self._window = (
            HumanWindow(RENDER_WIDTH, RENDER_HEIGHT, self.task.render_fps)
            if render_mode == "human"
            else None
        )
        self.observation_space = observation_space(self.task)
        self.action_space = action_space(self.task)
        self._plant = self.task.plant.as_array()
        self._state = np.array(self.task.initial_state, dtype=float)
        self._steps = 0
        self._u = 0.0
        self._ended: tuple[bool, bool, bool] | None = None
        self._warned = False

    @property
    def state(self) -> np.ndarray:
        """Copy of the raw kernel state [x, x_dot, theta, theta_dot] (theta unwrapped)."""
        return self._state.copy()

    @property
    def t(self) -> float:
        """Simulated time [s] since the last reset."""
        return self._steps * self.task.dt

    def _obs(self) -> np.ndarray:
        return observe(self._state[None, :], self.task.observation, self.task.dtype)[0]

    def _info(self, fault: bool = False) -> dict[str, Any]:
        return {"state": self.state, "t": self.t, "u": self._u, "fault": fault}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        # gymnasium's seeding takes only a Python int; a numpy integer is one too.
        if isinstance(seed, np.integer):
            seed = int(seed)
        super().reset(seed=seed)
        self._state = start_state(self.task, self.np_random, options)
        self._steps = 0
        self._u = 0.0
        self._ended = None
        self._warned = False
        if self._window is not None:
            self.render()
        return self._obs(), self._info()

    def step(
        self, action: np.ndarray
    ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        u = clip_action(action, self.task.u_max, 1, self.task.normalised_action, self.action_space)
        if self._ended is not None:
            return self._after_end(*self._ended)
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
        if terminated[0] or truncated[0]:
            self._ended = (bool(terminated[0]), bool(truncated[0]), bool(fault[0]))
        if self._window is not None:
            self.render()
        return (
            self._obs(),
            float(reward[0]),
            bool(terminated[0]),
            bool(truncated[0]),
            self._info(bool(fault[0])),
        )

    def _after_end(
        self, terminated: bool, truncated: bool, fault: bool
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The terminal step again, reward 0, with one warning per episode."""
        if not self._warned:
            ended = "terminated" if terminated else "truncated"
            logger.warn(
                f"step() called after this episode already returned {ended} = True; call "
                "reset() to start a new one (until then every step returns the last "
                "observation with reward 0)"
            )
            self._warned = True
        return self._obs(), 0.0, terminated, truncated, self._info(fault)

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """The current picture (:func:`env_frame`): returned (rgb_array) or shown (human).

        The view is +-4 m of track and follows the cart once it nears the edge.
        """
        if self.render_mode is None:
            return None
        frame = env_frame(self._state, self.task, self.t)
        if self._window is not None:
            self._window.show(frame)
            return None
        return frame

    def close(self) -> None:
        """Close the human-mode window, if one is open."""
        if self._window is not None:
            self._window.close()
        super().close()


def make_env(**kwargs: Any) -> gym.Env[np.ndarray, np.ndarray]:
    """Entry point of the registered ids: the env under a TimeLimit of its own episode length.

    ``gymnasium.make`` then reports ``env.spec.max_episode_steps`` = round(duration / dt)
    for the duration actually asked for. The env truncates at that step itself (the
    chapter reward is decided there), so the wrapper never cuts an episode short.
    """
    env = CartPoleSwingUpEnv(**kwargs)
    return TimeLimit(env, env.task.n_steps)


# gymnasium.make reads render_modes from the entry point's metadata.
make_env.metadata = CartPoleSwingUpEnv.metadata  # type: ignore[attr-defined]
