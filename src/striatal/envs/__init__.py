"""Gymnasium front end on the one kernel: env, vector env and the chapter's controller as a policy.

``import striatal`` registers :data:`ENV_ID` (the chapter's task) and :data:`DENSE_ENV_ID`
(dense reward, 10-s episodes, normalised actions, +-1.8 m rails), both with float32
spaces, so
``gymnasium.make("striatal/CartPoleSwingUp-v0")`` and
``gymnasium.make_vec(ENV_ID, num_envs=B, vectorization_mode="vector_entry_point")`` work.
"""

from __future__ import annotations

from striatal.envs.cartpole import CartPoleSwingUpEnv
from striatal.envs.policies import SwitchingController
from striatal.envs.registration import (
    DENSE_ENV_ID,
    DM_CONTROL_TRACK,
    ENV_ID,
    REGISTERED,
    register_envs,
)
from striatal.envs.task import DEFAULT_U_MAX, SwingUpTask, dense_reward
from striatal.envs.vector import CartPoleSwingUpVectorEnv

__all__ = [
    "DEFAULT_U_MAX",
    "DENSE_ENV_ID",
    "DM_CONTROL_TRACK",
    "ENV_ID",
    "REGISTERED",
    "CartPoleSwingUpEnv",
    "CartPoleSwingUpVectorEnv",
    "SwingUpTask",
    "SwitchingController",
    "dense_reward",
    "register_envs",
]
