"""Gymnasium front end on the one kernel: env, vector env and the chapter's controller as a policy.

``import striatal`` registers :data:`ENV_ID` (the chapter's task) and :data:`DENSE_ENV_ID`
(dense reward, 10-s episodes, normalised float32 actions), so
``gymnasium.make("striatal/CartPoleSwingUp-v0")`` and
``gymnasium.make_vec(ENV_ID, num_envs=B, vectorization_mode="vector_entry_point")`` work.
"""

from __future__ import annotations

from striatal.envs.cartpole import CartPoleSwingUpEnv
from striatal.envs.policies import SwitchingController
from striatal.envs.task import DEFAULT_U_MAX, SwingUpTask, dense_reward
from striatal.envs.vector import CartPoleSwingUpVectorEnv

ENV_ID = "striatal/CartPoleSwingUp-v0"

#: The variant most RL code wants: dense reward, 10-s episodes (1000 steps, as
#: dm_control's cartpole swingup), actions normalised to float32 [-1, 1].
DENSE_ENV_ID = "striatal/CartPoleSwingUpDense-v0"

#: Keyword arguments each registered id passes to the env.
REGISTERED: dict[str, dict[str, object]] = {
    ENV_ID: {},
    DENSE_ENV_ID: {"reward": "dense", "duration": 10.0, "normalised_action": True},
}


def register_envs() -> None:
    """Register :data:`ENV_ID` and :data:`DENSE_ENV_ID` with Gymnasium; again does nothing.

    ``max_episode_steps`` is round(duration / dt) of the task asked for: each registered
    spec states its default, and ``gymnasium.make(..., duration=...)`` gets the
    matching time limit from the entry point :func:`striatal.envs.cartpole.make_env`.
    """
    import gymnasium

    for env_id, kwargs in REGISTERED.items():
        if env_id in gymnasium.envs.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point="striatal.envs.cartpole:make_env",
            vector_entry_point="striatal.envs.vector:CartPoleSwingUpVectorEnv",
            kwargs=dict(kwargs),
        )


__all__ = [
    "DEFAULT_U_MAX",
    "DENSE_ENV_ID",
    "ENV_ID",
    "CartPoleSwingUpEnv",
    "CartPoleSwingUpVectorEnv",
    "SwingUpTask",
    "SwitchingController",
    "dense_reward",
    "register_envs",
]
