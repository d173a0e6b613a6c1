"""B copies of ``striatal/CartPoleSwingUp-v0`` stepped at once by ``kernel.step_batch``.

Row b behaves exactly as a scalar :class:`~striatal.envs.cartpole.CartPoleSwingUpEnv`
reset with seed ``seed + b``: the same start state, the same kernel step and the
same reward arithmetic, so ``num_envs = 1`` reproduces the scalar env bit for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from striatal.envs.cartpole import (
    action_space,
    check_render_mode,
    clip_action,
    env_frame,
    observation_space,
)
from striatal.envs.task import (
    RESET_OPTIONS,
    SwingUpTask,
    check_reset_options,
    observe,
    outcome,
    start_state,
)
from striatal.errors import ParameterError
from striatal.sim import kernel

__all__ = [
    "MAX_NUM_ENVS",
    "CartPoleSwingUpVectorEnv",
]

#: The most rows one vector env holds (its state arrays take about 100 bytes a row).
MAX_NUM_ENVS = 65_536


def _whole_seed(seed: Any) -> int | None:
    """``seed`` as a Python int >= 0 (a numpy integer too), None kept; else ParameterError."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError(f"a seed must be a whole number >= 0 or None, got {seed!r}")
    return int(seed)


class CartPoleSwingUpVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """``num_envs`` independent swing-up environments on the batched kernel.

    Autoreset (``metadata["autoreset_mode"]`` = ``AutoresetMode.NEXT_STEP``, Gymnasium's
    default): when row b returns terminated or truncated, the *next* ``step`` ignores
    its action, resets it as ``reset()`` without options would (the task's start
    state, any perturbation drawn from row b's generator), as Gymnasium's
    ``SyncVectorEnv`` does, and returns the new first observation with reward 0 and
    terminated = truncated = False. Options given to ``reset`` hold for that reset only.

    ``reset(seed=s)`` seeds row b with ``s + b`` (``s`` an int or a numpy integer; a
    list, tuple or array gives one seed, or None, per row), as Gymnasium's
    ``SyncVectorEnv`` does. ``num_envs`` is at most :data:`MAX_NUM_ENVS`. ``options``
    as for the scalar env;
    ``options["initial_state"]`` may also be (num_envs, 4), and
    ``options["reset_mask"]`` (bool, (num_envs,)) resets only the marked rows.
    ``infos`` holds ``state`` (num_envs, 4), ``t``, ``u`` and ``fault`` with
    ``_key`` masks all True.
    """

    # Gymnasium reads metadata from the class (a plain dict there too); each
    # instance gets its own copy with render_fps = 1 / dt.
    metadata: dict[str, Any] = {  # noqa: RUF012
        "render_modes": ["rgb_array"],
        "render_fps": 100,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **task_options: Any):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
            raise ParameterError(f"num_envs must be a whole number >= 1, got {num_envs!r}")
        if num_envs > MAX_NUM_ENVS:
            raise ParameterError(f"num_envs must be at most {MAX_NUM_ENVS}, got {num_envs}")
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.task = SwingUpTask.from_kwargs(**task_options)
        self.metadata = {**type(self).metadata, "render_fps": self.task.render_fps}
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.single_observation_space = observation_space(self.task)
        self.single_action_space = action_space(self.task)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._plant = self.task.plant.as_array()
        n = self.num_envs
        self._states = np.tile(np.array(self.task.initial_state, dtype=float), (n, 1))
        self._next = np.empty((n, 4))
        self._steps = np.zeros(n, dtype=np.int64)
        self._u = np.zeros(n)
        self._fault = np.zeros(n, dtype=bool)
        self._autoreset = np.zeros(n, dtype=bool)
        self._rngs: list[np.random.Generator] | None = None

    @property
    def states(self) -> np.ndarray:
        """Copy of the raw kernel states (num_envs, 4)."""
        return self._states.copy()

    def _seed(self, seed: Any) -> None:
        n = self.num_envs
        if seed is None:
            if self._rngs is None:
                self._rngs = [seeding.np_random(None)[0] for _ in range(n)]
            return
        if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            first = _whole_seed(seed)
            assert first is not None
            seeds: list[int | None] = [first + i for i in range(n)]
        elif isinstance(seed, list | tuple | np.ndarray) and np.ndim(seed) == 1:
            seeds = [_whole_seed(s) for s in seed]
        else:
            raise ParameterError(
                f"seed must be a whole number, None or a list of {n} of them, got {seed!r}"
            )
        if len(seeds) != n:
            raise ParameterError(f"need {n} seeds, got {len(seeds)}")
        old = self._rngs
        self._rngs = [
            seeding.np_random(s)[0]
            if s is not None
            else (old[i] if old else seeding.np_random()[0])
            for i, s in enumerate(seeds)
        ]

    def _reset_row(self, b: int, options: dict[str, Any] | None) -> None:
        assert self._rngs is not None
        self._commit_row(b, start_state(self.task, self._rngs[b], options))

    def _commit_row(self, b: int, state: np.ndarray) -> None:
        self._states[b] = state
        self._steps[b] = 0
        self._u[b] = 0.0
        self._fault[b] = False
        self._autoreset[b] = False

    def _infos(self) -> dict[str, Any]:
        ones = np.ones(self.num_envs, dtype=bool)
        return {
            "state": self._states.copy(),
            "_state": ones,
            "t": self._steps * self.task.dt,
            "_t": ones.copy(),
            "u": self._u.copy(),
            "_u": ones.copy(),
            "fault": self._fault.copy(),
            "_fault": ones.copy(),
        }

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        opts = check_reset_options(options, (*RESET_OPTIONS, "reset_mask"))
        n = self.num_envs
        mask = opts.pop("reset_mask", None)
        if mask is None:
            mask = np.ones(n, dtype=bool)
        mask = np.asarray(mask)
        if mask.shape != (n,) or mask.dtype != bool:
            raise ParameterError(f"reset_mask must be {n} booleans, got {mask!r}")
        init = opts.get("initial_state")
        rows: list[Any] = [init] * n
        if init is not None and np.ndim(init) == 2:
            if np.shape(init) != (n, 4):
                raise ParameterError(
                    f"initial_state must be (4,) or ({n}, 4), got shape {np.shape(init)}"
                )
            rows = list(np.asarray(init, dtype=float))
        self._seed(seed)
        assert self._rngs is not None
        # Every row's start is computed (and checked) before any row changes.
        starts = {
            int(b): start_state(self.task, self._rngs[b], {**opts, "initial_state": rows[b]})
            for b in np.nonzero(mask)[0]
        }
        for b, state in starts.items():
            self._commit_row(b, state)
        return observe(self._states, self.task.observation, self.task.dtype), self._infos()

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._rngs is None:
            raise ParameterError("call reset() before step()")
        n = self.num_envs
        u = clip_action(actions, self.task.u_max, n, self.task.normalised_action, self.action_space)
        kernel.step_batch(
            self._states, u, self.task.dt, 1, self._plant, self._plant, False, self._next
        )
        self._states, self._next = self._next, self._states
        self._steps += 1
        self._u = u
        reward, terminated, truncated, fault = outcome(self.task, self._states, self._steps, u)
        self._fault = fault
        was_done = self._autoreset.copy()
        for b in np.nonzero(was_done)[0]:
            self._reset_row(int(b), None)
        reward[was_done] = 0.0
        terminated[was_done] = False
        truncated[was_done] = False
        self._autoreset = terminated | truncated
        obs = observe(self._states, self.task.observation, self.task.dtype)
        return obs, reward, terminated, truncated, self._infos()

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One (400, 600, 3) frame per row, as the scalar env draws it."""
        if self.render_mode != "rgb_array":
            return None
        return tuple(
            env_frame(self._states[b], self.task, float(self._steps[b] * self.task.dt))
            for b in range(self.num_envs)
        )
