"""striatal: the chapter's basal-ganglia switching REINFORCE learner on the cart-pole.

The physics, the controllers and the learning step exist once, in
:mod:`striatal.sim.kernel`; everything else is a front end to it.

The names below are loaded on first use (PEP 562), so that ``import striatal``
costs milliseconds and the command line can start, and be interrupted with
Ctrl-C, before NumPy and Numba load (docs/reliability.md). The Python API:

- :func:`train`: a whole learning run, as ``striatal train`` runs it (same defaults);
- :func:`simulate`: one run of a controller, as ``striatal simulate`` (same defaults);
- :func:`sweep`: many learning runs over seeds, with the learner's control and baselines,
  as ``striatal sweep`` runs them (same defaults, same rows and summary), as a
  :class:`Sweep` (``.arms``, ``.runs``, ``.plot()``);
- :func:`load`: the :class:`Sweep` or :class:`Run` in a folder that ``striatal sweep``
  or ``striatal train`` wrote (``load("results/sweep-chapter")``, ``load("results/train")``);
- :func:`check_robust`: the robustness set of ``striatal simulate --robust`` (9 runs,
  the motor force held: :class:`Hardware`);
- :mod:`striatal.learners`: the learning rules, their presets and the trial loop;
- :mod:`striatal.io.rundir`: the files of a run (checkpoint, history.csv, result.json);
- :mod:`striatal.viz.plots`: ``learning_curves(run.history)``, ``figure5(trajectory)``.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys

# not ``typing.TYPE_CHECKING``: importing typing (and re) would widen the start-up
# window in which Ctrl-C cannot be caught yet
TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Sequence
    from importlib.machinery import ModuleSpec
    from types import ModuleType
    from typing import Any

    from striatal import learners
    from striatal.experiments.results import Sweep, load
    from striatal.experiments.sweeps import sweep
    from striatal.experiments.training import Run, simulate, train
    from striatal.io import rundir
    from striatal.io.rundir import read_history, read_result
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
    from striatal.sim.robust import check_robust
    from striatal.sim.rollout import Protocol, Trajectory, TrialOutcome, run_trial
    from striatal.viz import plots

__version__ = "0.1.0"

_FROM = {
    "CHAPTER_FINAL_THETA_C": "striatal.params",
    "CHAPTER_FINAL_W": "striatal.params",
    "CHAPTER_INITIAL_THETA_C": "striatal.params",
    "CHAPTER_INITIAL_W": "striatal.params",
    "Controller": "striatal.params",
    "Hardware": "striatal.params",
    "check_robust": "striatal.sim.robust",
    "Plant": "striatal.params",
    "Simulation": "striatal.params",
    "SuccessTest": "striatal.params",
    "Protocol": "striatal.sim.rollout",
    "Trajectory": "striatal.sim.rollout",
    "TrialOutcome": "striatal.sim.rollout",
    "run_trial": "striatal.sim.rollout",
    "LEARNERS": "striatal.learners",
    "History": "striatal.learners",
    "LearnerConfig": "striatal.learners",
    "default_config": "striatal.learners",
    "read_history": "striatal.io.rundir",
    "read_result": "striatal.io.rundir",
    "Run": "striatal.experiments.training",
    "simulate": "striatal.experiments.training",
    "train": "striatal.experiments.training",
    "sweep": "striatal.experiments.sweeps",
    "Sweep": "striatal.experiments.results",
    "load": "striatal.experiments.results",
}


# public submodules of subpackages, named at the top
_MODULES = {"plots": "striatal.viz.plots", "rundir": "striatal.io.rundir"}


def __getattr__(name: str) -> Any:
    if name in _MODULES:
        module = importlib.import_module(_MODULES[name])
        globals()[name] = module
        return module
    if name in _FROM:
        value = getattr(importlib.import_module(_FROM[name]), name)
        globals()[name] = value
        return value
    if not name.startswith("_"):  # a submodule, as ``import striatal`` once loaded them all
        try:
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_FROM, *_MODULES})


def _register_env() -> None:
    # the submodule, not the package: striatal.envs may be half imported here (its
    # cartpole module importing Gymnasium is what fired the hook)
    from striatal.envs.registration import register_envs

    register_envs()


class _RegisterAfterGymnasium:
    """Registers the Gymnasium env id as soon as Gymnasium is imported, then steps aside."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if fullname != "gymnasium":
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        exec_module = spec.loader.exec_module

        def exec_then_register(module: ModuleType) -> None:
            exec_module(module)
            _register_env()

        spec.loader.exec_module = exec_then_register  # type: ignore[method-assign]
        return spec


# ``import striatal`` registers the Gymnasium id striatal/CartPoleSwingUp-v0 (and its
# vector entry point): now if Gymnasium is loaded, else the moment it is.
if "gymnasium" in sys.modules:
    _register_env()
elif not any(isinstance(f, _RegisterAfterGymnasium) for f in sys.meta_path):
    sys.meta_path.insert(0, _RegisterAfterGymnasium())

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
    "Sweep",
    "Trajectory",
    "TrialOutcome",
    "__version__",
    "check_robust",
    "default_config",
    "learners",
    "load",
    "plots",
    "read_history",
    "read_result",
    "run_trial",
    "rundir",
    "simulate",
    "sweep",
    "train",
]
