"""One run of a sweep: its spec (arm, start, seed, settings), its seed and its W(0).

A sweep is a list of :class:`RunSpec` (frozen, picklable), one per (arm, init, seed).
Both engines read them: the process engine (:mod:`striatal.experiments.pool`) and
the lockstep engine (:mod:`striatal.experiments.lockstep_sweep`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.learners import LearnerConfig, random_initial_gains
from striatal.params import CHAPTER_INITIAL_W, Controller, Plant, Simulation

__all__ = ["Init", "RunSpec", "initial_gains", "spawn_seeds"]

Init = Literal["chapter", "random"]


@dataclass(frozen=True)
class RunSpec:
    """One run: an arm (learner settings or a baseline), a start and a seed.

    ``template`` carries theta_c(0) and the readings (balance sign, switch,
    inhibition); its gains are replaced by W(0) of ``init``.
    """

    arm: str
    method: str
    init: Init
    seed: int
    config: LearnerConfig
    template: Controller
    plant: Plant
    sim: Simulation
    role: str = "learner"
    eval_draws: int = 0

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.arm, self.init, self.seed)


def spawn_seeds(root: int, n: int) -> tuple[int, ...]:
    """The n integer run seeds of root seed ``root``: SeedSequence(root).spawn(n)[i]."""
    if n < 1:
        raise ParameterError(f"the number of seeds must be >= 1, got {n}")
    if root < 0:
        raise ParameterError(f"the root seed must be >= 0, got {root}")
    return tuple(int(child.generate_state(1)[0]) for child in np.random.SeedSequence(root).spawn(n))


def initial_gains(init: Init, seed: int) -> tuple[float, ...]:
    """W(0): the chapter's, or uniform in [-1, 1]^6 drawn as ``striatal train --init random``."""
    if init == "chapter":
        return CHAPTER_INITIAL_W
    if init == "random":
        return random_initial_gains(np.random.default_rng([seed, 1]))
    raise ParameterError(f"init must be 'chapter' or 'random', got {init!r}")
