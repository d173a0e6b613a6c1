"""Gymnasium front end on the one kernel: env, vector env and the chapter's controller as a policy.

``import striatal`` registers :data:`ENV_ID`, so ``gymnasium.make("striatal/CartPoleSwingUp-v0")``
and ``gymnasium.make_vec(ENV_ID, num_envs=B, vectorization_mode="vector_entry_point")`` work.
"""

from __future__ import annotations

from striatal.envs.cartpole import CartPoleSwingUpEnv
from striatal.envs.policies import SwitchingController
from striatal.envs.task import DEFAULT_U_MAX, SwingUpTask, dense_reward
from striatal.envs.vector import CartPoleSwingUpVectorEnv

ENV_ID = "striatal/CartPoleSwingUp-v0"


def register_envs() -> None:
    """Register :data:`ENV_ID` with Gymnasium; calling it again does nothing."""
    import gymnasium

    if ENV_ID in gymnasium.envs.registry:
        return
    gymnasium.register(
        id=ENV_ID,
        entry_point="striatal.envs.cartpole:CartPoleSwingUpEnv",
        vector_entry_point="striatal.envs.vector:CartPoleSwingUpVectorEnv",
    )


__all__ = [
    "DEFAULT_U_MAX",
    "ENV_ID",
    "CartPoleSwingUpEnv",
    "CartPoleSwingUpVectorEnv",
    "SwingUpTask",
    "SwitchingController",
    "dense_reward",
    "register_envs",
]
