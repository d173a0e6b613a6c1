"""The Gymnasium ids of striatal and their registration.

A module of its own, free of the env modules, so that the hook of ``import striatal``
can register the ids while :mod:`striatal.envs` is still being imported (Gymnasium
loaded by :mod:`striatal.envs.cartpole` itself).
"""

from __future__ import annotations

__all__ = ["DENSE_ENV_ID", "DM_CONTROL_TRACK", "ENV_ID", "REGISTERED", "register_envs"]

ENV_ID = "striatal/CartPoleSwingUp-v0"

#: The variant most RL code wants: dense reward, 10-s episodes (1000 steps), actions
#: normalised to [-1, 1] and rails of +-1.8 m, as dm_control's cartpole swingup
#: (leaving them terminates the episode).
DENSE_ENV_ID = "striatal/CartPoleSwingUpDense-v0"

#: Half-length of the rails of dm_control's cartpole [m]: its slider joint is limited
#: to [-1.8, 1.8] (``dm_control/suite/cartpole.xml``). The dense id's default track.
DM_CONTROL_TRACK = 1.8

#: Keyword arguments each registered id passes to the env.
REGISTERED: dict[str, dict[str, object]] = {
    ENV_ID: {},
    DENSE_ENV_ID: {
        "reward": "dense",
        "duration": 10.0,
        "normalised_action": True,
        "track": DM_CONTROL_TRACK,
    },
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
