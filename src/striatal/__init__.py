"""striatal: the chapter's basal-ganglia switching REINFORCE learner on the cart-pole.

The physics, the controllers and the learning step exist once, in
:mod:`striatal.kernel`; everything else is a front end to it. The Python API:

- :func:`train`: a whole learning run, as ``striatal train`` runs it (same defaults);
- :func:`simulate`: one run of a controller, as ``striatal simulate`` (same defaults);
- :func:`check_robust`: the robustness set of ``striatal simulate --robust`` (9 runs,
  the motor force held: :class:`Hardware`);
- :mod:`striatal.learners`: the learning rules, their presets and the trial loop;
- :mod:`striatal.rundir`: the files of a run (checkpoint, history.csv, result.json);
- :mod:`striatal.plots`: ``learning_curves(run.history)``, ``figure5(trajectory)``.
"""

from __future__ import annotations

from striatal import learners, plots, rundir
from striatal.learners import LEARNERS, History, LearnerConfig, default_config
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Hardware,
    Plant,
    Simulation,
    SuccessTest,
)
from striatal.robust import check_robust
from striatal.rollout import Protocol, Trajectory, TrialOutcome, run_trial
from striatal.rundir import read_history, read_result
from striatal.training import Run, simulate, train

__version__ = "0.1.0"

# Gymnasium id striatal/CartPoleSwingUp-v0 (and its vector entry point); idempotent.
from striatal.envs import register_envs as _register_envs

_register_envs()

__all__ = [
    "CHAPTER_FINAL_THETA_C",
    "CHAPTER_FINAL_W",
    "CHAPTER_INITIAL_THETA_C",
    "CHAPTER_INITIAL_W",
    "LEARNERS",
    "Controller",
    "Hardware",
    "History",
    "LearnerConfig",
    "Plant",
    "Protocol",
    "Run",
    "Simulation",
    "SuccessTest",
    "Trajectory",
    "TrialOutcome",
    "__version__",
    "check_robust",
    "default_config",
    "learners",
    "plots",
    "read_history",
    "read_result",
    "run_trial",
    "rundir",
    "simulate",
    "train",
]
