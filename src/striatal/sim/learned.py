"""A plant whose equations of motion are a learned model.

:class:`LearnedPlant` is a :class:`~striatal.params.Plant` whose dynamics are
:class:`LearnedDynamics` (the polynomial regression of
:mod:`striatal.sim.kernel.learned`) instead of eqs 8-9. Its own parameters (cart mass,
pole mass, length, gravity) are what the controller believes, for eq 12 and the
energy of eqs 15-16: the learned model has none. Every trial on it holds the motor
force over a step, as the model was fitted. :func:`striatal.sim.rollout.run_trial`,
:func:`~striatal.sim.rollout.simulate` and :class:`~striatal.sim.rollout.TrialRequest`
run it on :func:`striatal.sim.kernel.run_learned_trial`; the batch kernels do not take it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from striatal.errors import ParameterError
from striatal.params import Plant
from striatal.sim.kernel.learned import MAX_POWER, N_FEATURES, LearnedArgs

__all__ = ["LearnedDynamics", "LearnedPlant"]


@dataclass(frozen=True, eq=False)
class LearnedDynamics:
    """The arrays of a learned model (:class:`~striatal.sim.kernel.learned.LearnedArgs`),
    checked: K members linear in F monomials of the N_FEATURES standardised inputs. Equal
    only to itself (the arrays are not compared)."""

    args: LearnedArgs

    def __post_init__(self) -> None:
        a = self.args
        if a.powers.ndim != 2 or a.powers.shape[1] != N_FEATURES or a.powers.dtype != np.int64:
            raise ParameterError(
                f"learned powers must be int64 (F, {N_FEATURES}), got {a.powers.shape}"
            )
        if a.coef.ndim != 3 or a.coef.shape[0] < 1:
            raise ParameterError(f"learned coef must be (K, 2, F) with K >= 1, got {a.coef.shape}")
        K, F = a.coef.shape[0], a.powers.shape[0]
        shapes = {
            "mean": (a.mean, (N_FEATURES,)),
            "scale": (a.scale, (N_FEATURES,)),
            "coef": (a.coef, (K, 2, F)),
            "intercept": (a.intercept, (K, 2)),
        }
        for name, (value, shape) in shapes.items():
            if value.shape != shape:
                raise ParameterError(f"learned {name} must be {shape}, got {value.shape}")
            if value.dtype != np.float64 or not np.isfinite(value).all():
                raise ParameterError(f"learned {name} must be finite float64")
        if (a.powers < 0).any() or (a.powers > MAX_POWER).any() or not (a.scale > 0).all():
            raise ParameterError(f"learned powers must be in [0, {MAX_POWER}] and scales > 0")
        if not all(v.flags.c_contiguous for v in a):
            raise ParameterError("learned model arrays must be C-contiguous")

    @property
    def members(self) -> int:
        return int(self.args.coef.shape[0])

    def member(self, k: int) -> LearnedDynamics:
        """Member k alone (a model of one member)."""
        if not 0 <= k < self.members:
            raise ParameterError(f"member must be in [0, {self.members}), got {k}")
        a = self.args
        return LearnedDynamics(
            a._replace(
                coef=np.ascontiguousarray(a.coef[k : k + 1]),
                intercept=np.ascontiguousarray(a.intercept[k : k + 1]),
            )
        )

    def mean(self) -> LearnedDynamics:
        """The members' mean as one member (the same predictions, one evaluation a step:
        the members share their monomials)."""
        a = self.args
        return LearnedDynamics(
            a._replace(
                coef=a.coef.mean(axis=0, keepdims=True),
                intercept=a.intercept.mean(axis=0, keepdims=True),
            )
        )


@dataclass(frozen=True)
class LearnedPlant(Plant):
    """A plant that moves by ``dynamics``; the four parameters of :class:`Plant` are the
    ones the controller believes (eq 12) and do not enter the motion."""

    dynamics: LearnedDynamics | None = field(default=None, kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.dynamics, LearnedDynamics):
            raise ParameterError(f"a learned plant needs LearnedDynamics, got {self.dynamics!r}")

    @classmethod
    def of(cls, dynamics: LearnedDynamics, believed: Plant) -> LearnedPlant:
        """``dynamics`` with the controller believing ``believed``."""
        return cls(**believed.to_dict(), dynamics=dynamics)

    @property
    def believed(self) -> Plant:
        """The physical plant the controller believes."""
        return Plant(**self.to_dict())

    def scaled(self, *, pole_mass: float = 1.0, length: float = 1.0) -> Plant:
        """Refused: a learned plant has no pole mass or length to scale."""
        raise ParameterError("a learned plant cannot be scaled: its motion has no pole mass")
