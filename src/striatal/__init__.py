"""striatal: the chapter's basal-ganglia switching REINFORCE learner on the cart-pole.

The physics, the controllers and the learning step exist once, in
:mod:`striatal.kernel`; everything else is a front end to it.
"""

from __future__ import annotations

from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
    SuccessTest,
)
from striatal.rollout import Protocol, Trajectory, TrialOutcome, run_trial, simulate

__version__ = "0.1.0"

# Gymnasium id striatal/CartPoleSwingUp-v0 (and its vector entry point); idempotent.
from striatal.envs import register_envs as _register_envs

_register_envs()

__all__ = [
    "CHAPTER_FINAL_THETA_C",
    "CHAPTER_FINAL_W",
    "CHAPTER_INITIAL_THETA_C",
    "CHAPTER_INITIAL_W",
    "Controller",
    "Plant",
    "Protocol",
    "Simulation",
    "SuccessTest",
    "Trajectory",
    "TrialOutcome",
    "__version__",
    "run_trial",
    "simulate",
]
