"""One run of a sweep: its spec (arm, start, seed, settings), its seed and its W(0).

A sweep is a list of :class:`RunSpec` (frozen, picklable), one per (arm, init, seed).
Both engines read them: the process engine (:mod:`striatal.experiments.pool`) and
the lockstep engine (:mod:`striatal.experiments.lockstep_sweep`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.learners import W1_FLOOR, LearnerConfig, random_initial_gains
from striatal.params import (
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
    check_gains,
    check_seed,
)

if TYPE_CHECKING:
    from striatal.neural.network import NetworkConfig
    from striatal.neural.run import Simulator

__all__ = ["Init", "NetworkTrials", "RunSpec", "floor_w1", "initial_gains", "spawn_seeds"]

Init = Literal["chapter", "random"]


@dataclass(frozen=True)
class NetworkTrials:
    """Where a run's trials go when not on the kernel: the spiking network of ``config``
    on ``simulator`` ("nengo" or "brian2"), network seed = the run's seed
    (:func:`striatal.neural.driver.network_drive`)."""

    config: NetworkConfig
    simulator: Simulator

    def to_dict(self) -> dict[str, object]:
        from dataclasses import asdict

        return {**asdict(self.config), "simulator": self.simulator}


@dataclass(frozen=True)
class RunSpec:
    """One run: an arm (learner settings or a baseline), a start and a seed.

    ``template`` carries theta_c(0) and the readings (balance sign, switch,
    inhibition); its gains are replaced by W(0) of ``init``. ``network``: the trials
    run on the spiking network instead of the kernel (None: the kernel).
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
    network: NetworkTrials | None = None

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.arm, self.init, self.seed)


#: How a sweep's (and an ablation's) run seeds follow from its root seed, as recorded.
SEED_RULE = "SeedSequence(root_seed).spawn(seeds)[i].generate_state(1)[0]"


def spawn_seeds(root: int, n: int) -> tuple[int, ...]:
    """The n integer run seeds of root seed ``root``: SeedSequence(root).spawn(n)[i]."""
    if n < 1:
        raise ParameterError(f"the number of seeds must be >= 1, got {n}")
    if root < 0:
        raise ParameterError(f"the root seed must be >= 0, got {root}")
    return tuple(int(child.generate_state(1)[0]) for child in np.random.SeedSequence(root).spawn(n))


def floor_w1(gains: Sequence[float]) -> tuple[float, ...]:
    """The six gains with W1 floored at W1_FLOOR = 0.001, the guard of sqrt(W1 g) (eq 22).

    The one treatment of W1 <= 0 in W(0), for ``init_gains`` as for ``init="random"``
    (which draws W1 uniformly in [-1, 1] and floors it the same way; docs/paper-notes.md
    section 11). Other values of W are checked (finite, six of them) and kept.
    """
    w = check_gains(gains, need_positive_w1=False)
    return (max(w[0], W1_FLOOR), *w[1:])


def initial_gains(
    init: Init | str, seed: int, init_gains: Sequence[float] | None = None
) -> tuple[float, ...]:
    """W(0): ``init_gains``, the chapter's ("chapter") or uniform in [-1, 1]^6 ("random").

    W1 <= W1_FLOOR is floored at W1_FLOOR in both ``init_gains`` and the random draw
    (:func:`floor_w1`), so every random starting point can also be given by hand.
    """
    if init_gains is not None:
        return floor_w1(init_gains)
    if init == "chapter":
        return CHAPTER_INITIAL_W
    if init == "random":
        return random_initial_gains(np.random.default_rng([check_seed(seed), 1]))
    raise ParameterError(f"init must be 'chapter' or 'random', got {init!r}")
