"""A plant whose equations of motion are a learned model.

:class:`LearnedPlant` is a :class:`~striatal.params.Plant` whose dynamics are
:class:`LearnedDynamics` (the polynomial regression of
:mod:`striatal.sim.kernel.learned`) instead of eqs 8-9. Its own parameters (cart mass,
pole mass, length, gravity) are what the controller believes, for eq 12 and the
energy of eqs 15-16: the learned model has none. Every trial on it holds the motor
force over a step, as the model was fitted. :func:`striatal.sim.rollout.run_trial`,
:func:`~striatal.sim.rollout.simulate` and :class:`~striatal.sim.rollout.TrialRequest`
run it on :func:`striatal.sim.kernel.run_learned_trial`, and
:func:`striatal.sim.batch.run_requests` runs trials on the same model in one call of
:func:`striatal.sim.kernel.run_learned_trials_batch`.

A model may also be *conditioned* on the plant's pole mass and length factors
(:class:`ConditionedDynamics`: two more inputs, constant over a trial). At given
factors it is an ordinary :class:`LearnedDynamics` (:meth:`ConditionedDynamics.at`
sums the monomials that differ only in the factors' powers), so the kernel's step is
the same; a :class:`LearnedPlant` carrying one can be :meth:`~LearnedPlant.scaled`
like a physical plant, the controller still believing the same parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from striatal.errors import ParameterError
from striatal.params import Plant
from striatal.sim.kernel.learned import MAX_POWER, N_FEATURES, LearnedArgs

__all__ = ["ConditionedDynamics", "LearnedDynamics", "LearnedPlant"]


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

    def gained(self, theta: float) -> LearnedDynamics:
        """The model with its angular acceleration (theta_ddot: readout and intercept)
        multiplied by ``theta`` > 0: a pole that answers the same inputs more or less
        strongly than the data say. No cart-pole equation enters."""
        if not (math.isfinite(theta) and theta > 0):
            raise ParameterError(f"the gain must be finite and > 0, got {theta}")
        a = self.args
        coef, intercept = a.coef.copy(), a.intercept.copy()
        coef[:, 1, :] *= theta
        intercept[:, 1] *= theta
        return LearnedDynamics(a._replace(coef=coef, intercept=intercept))

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


@dataclass(frozen=True, eq=False)
class ConditionedDynamics:
    """A learned model with two inputs more than :class:`LearnedDynamics`: the true
    plant's pole mass and length factors (c_m, c_l), after the N_FEATURES inputs.

    ``args``: the arrays of :class:`LearnedArgs` with the two columns more (``mean``
    and ``scale`` (N_FEATURES + 2,), ``powers`` (F, N_FEATURES + 2)). Equal only to
    itself."""

    args: LearnedArgs

    def __post_init__(self) -> None:
        a, width = self.args, N_FEATURES + 2
        if a.powers.ndim != 2 or a.powers.shape[1] != width:
            raise ParameterError(f"conditioned powers must be (F, {width}), got {a.powers.shape}")
        if a.mean.shape != (width,) or a.scale.shape != (width,):
            raise ParameterError(f"conditioned mean and scale must be ({width},)")
        if a.coef.ndim != 3 or a.coef.shape[2] != a.powers.shape[0]:
            raise ParameterError(f"conditioned coef must be (K, 2, F), got {a.coef.shape}")

    @property
    def members(self) -> int:
        return int(self.args.coef.shape[0])

    def member(self, k: int) -> ConditionedDynamics:
        """Member k alone."""
        if not 0 <= k < self.members:
            raise ParameterError(f"member must be in [0, {self.members}), got {k}")
        a = self.args
        return ConditionedDynamics(
            a._replace(coef=a.coef[k : k + 1], intercept=a.intercept[k : k + 1])
        )

    def mean(self) -> ConditionedDynamics:
        """The members' mean as one member (as :meth:`LearnedDynamics.mean`)."""
        a = self.args
        return ConditionedDynamics(
            a._replace(
                coef=a.coef.mean(axis=0, keepdims=True),
                intercept=a.intercept.mean(axis=0, keepdims=True),
            )
        )

    def at(self, pole_mass: float = 1.0, length: float = 1.0) -> LearnedDynamics:
        """The model with the factors fixed: each monomial's factor part
        z_m^P[j, 5] z_l^P[j, 6] (z standardised as the inputs) multiplies its readout,
        and monomials with equal powers of the N_FEATURES inputs are summed."""
        if not (pole_mass > 0 and length > 0):
            raise ParameterError(f"factors must be > 0, got {pole_mass}, {length}")
        a = self.args
        z = (np.array([pole_mass, length]) - a.mean[N_FEATURES:]) / a.scale[N_FEATURES:]
        weight = np.prod(z ** a.powers[:, N_FEATURES:], axis=1)
        kept, group = np.unique(a.powers[:, :N_FEATURES], axis=0, return_inverse=True)
        onehot = np.zeros((len(weight), len(kept)))
        onehot[np.arange(len(weight)), group.ravel()] = 1.0
        coef = (a.coef * weight) @ onehot
        return LearnedDynamics(
            LearnedArgs(
                mean=np.ascontiguousarray(a.mean[:N_FEATURES], dtype=float),
                scale=np.ascontiguousarray(a.scale[:N_FEATURES], dtype=float),
                powers=np.ascontiguousarray(kept, dtype=np.int64),
                coef=np.ascontiguousarray(coef),
                intercept=np.ascontiguousarray(a.intercept, dtype=float),
            )
        )


def _parameters(plant: Plant) -> tuple[float, float, float, float]:
    """(cart mass, pole mass, length, gravity): what a controller believes of ``plant``."""
    return plant.cart_mass, plant.pole_mass, plant.length, plant.gravity


@dataclass(frozen=True)
class LearnedPlant(Plant):
    """A plant that moves by ``dynamics``; the four parameters of :class:`Plant` are the
    ones the controller believes (eq 12) and do not enter the motion."""

    dynamics: LearnedDynamics | None = field(default=None, kw_only=True)
    #: A conditioned model ``dynamics`` is taken from, at :attr:`factors` (None: fixed).
    conditioned: ConditionedDynamics | None = field(default=None, kw_only=True)
    factors: tuple[float, float] = field(default=(1.0, 1.0), kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.dynamics, LearnedDynamics):
            raise ParameterError(f"a learned plant needs LearnedDynamics, got {self.dynamics!r}")

    @classmethod
    def of(cls, dynamics: LearnedDynamics, believed: Plant) -> LearnedPlant:
        """``dynamics`` with the controller believing ``believed``."""
        return cls(*_parameters(believed), dynamics=dynamics)

    @classmethod
    def conditioned_on(
        cls,
        model: ConditionedDynamics,
        believed: Plant,
        pole_mass: float = 1.0,
        length: float = 1.0,
    ) -> LearnedPlant:
        """``model`` at factors (``pole_mass``, ``length``), the controller believing
        ``believed``; :meth:`scaled` moves the factors."""
        return cls(
            *_parameters(believed),
            dynamics=model.at(pole_mass, length),
            conditioned=model,
            factors=(float(pole_mass), float(length)),
        )

    @property
    def believed(self) -> Plant:
        """The physical plant the controller believes."""
        return Plant(**self.to_dict())

    def scaled(self, *, pole_mass: float = 1.0, length: float = 1.0) -> Plant:
        """The conditioned model at the factors times ``pole_mass`` and ``length``, the
        controller believing the same; refused for a model that is not conditioned (its
        motion has no pole mass to scale)."""
        if self.conditioned is None:
            raise ParameterError(
                "a learned plant cannot be scaled: its motion has no pole mass "
                "(a model conditioned on the factors can)"
            )
        return LearnedPlant.conditioned_on(
            self.conditioned,
            self.believed,
            self.factors[0] * pole_mass,
            self.factors[1] * length,
        )
