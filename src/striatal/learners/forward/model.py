"""Cerebellar forward models: the cart-pole's next state from its state and the motor force.

A forward model is learned by supervised learning from recorded real trials
(:class:`Transitions`: state s_k, held motor force f_k, next state s_{k+1}, dt apart;
the motor holds the force over a step, ``Hardware(hold="force")``). Two variants,
declared by their prior knowledge:

- :func:`fit_structured` knows the equations: the cart-pole's eqs 8-10 with the cart
  mass M, the pole mass m, the length l and a viscous cart friction b unknown, gravity
  known. It fits them by nonlinear least squares on the one-step RK4 map
  (``scipy.optimize.least_squares``). Its uncertainty is the Gauss-Newton covariance of
  the fit, and :meth:`StructuredFit.family` gives the plants it cannot rule out.
- :func:`fit_generic` knows nothing of the cart-pole's equations: a bootstrap
  ensemble of scikit-learn regressors (ridge regression on the monomials of degree
  <= 3) from (x_dot, sin theta, cos theta, theta_dot, f) and, conditioned, the true
  plant's pole mass and length factors (known for every real run: the robustness
  set's corners are scaled plants) to the step's mean accelerations, a smooth
  function of these inputs. Its uncertainty is the ensemble's spread, and
  :meth:`GenericModel.plant` runs trials on it (a conditioned one on any factors).
  With ``readout="sparse"`` each member keeps only a few of the same monomials, of
  the raw inputs (:data:`SPARSE_TERMS` per output, chosen by orthogonal matching
  pursuit), the sparse regression of SINDy (Brunton, Proctor and Kutz 2016) bagged
  as in ensemble SINDy (Fasel et al. 2022): the library is the same generic one, the
  sparsity is the prior.

Both are pure: the same transitions give the same model.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy

from striatal.errors import ParameterError
from striatal.params import Plant
from striatal.sim.dynamics import rk4_force_step
from striatal.sim.kernel.learned import N_FEATURES, LearnedArgs
from striatal.sim.learned import ConditionedDynamics, LearnedDynamics, LearnedPlant
from striatal.sim.rollout import Trajectory

__all__ = [
    "DEGREE",
    "FORCE_TERMS",
    "GENERIC_INPUTS",
    "GENERIC_OUTPUTS",
    "NARROW_SPAN",
    "READOUTS",
    "RIDGE",
    "SPARSE_TERMS",
    "ForceTerm",
    "GenericModel",
    "Readout",
    "StructuredFit",
    "Transitions",
    "fit_generic",
    "fit_structured",
    "rk4_force_step",
]

#: The relative half-width of :meth:`StructuredFit.family` when the data leave less
#: doubt than that (noise-free transitions: the covariance is round-off).
FAMILY_FLOOR = 0.02


@dataclass(frozen=True)
class Transitions:
    """One-step transitions: ``states`` (n, 4) [m, m/s, rad, rad/s], ``forces`` (n,) [N]
    held over the step, ``next_states`` (n, 4), ``dt`` [s]; ``factors`` (n, 2): the
    true plant's pole mass and length factors of each (None: all 1, the nominal plant).
    """

    states: np.ndarray
    forces: np.ndarray
    next_states: np.ndarray
    dt: float
    factors: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.forces)
        if self.factors is None:
            object.__setattr__(self, "factors", np.ones((n, 2)))
        assert self.factors is not None
        if self.factors.shape != (n, 2) or not (self.factors > 0).all():
            raise ParameterError(f"factors must be ({n}, 2) and > 0, got {self.factors.shape}")
        if self.states.shape != (n, 4) or self.next_states.shape != (n, 4):
            raise ParameterError(
                f"transitions need states and next states of shape ({n}, 4), got "
                f"{self.states.shape} and {self.next_states.shape}"
            )
        if n == 0:
            raise ParameterError("a forward model needs at least one transition")
        if not (np.isfinite(self.states).all() and np.isfinite(self.next_states).all()):
            raise ParameterError("transitions must be finite")
        if not self.dt > 0:
            raise ParameterError(f"dt must be > 0, got {self.dt}")

    @classmethod
    def of(cls, trajectories: Sequence[Trajectory]) -> Transitions:
        """The transitions of recorded trials (row k's force acts from row k to row k+1)."""
        if not trajectories:
            raise ParameterError("a forward model needs at least one recorded trial")
        dts = {t.sim.dt for t in trajectories}
        if len(dts) != 1:
            raise ParameterError(f"recorded trials with different dt: {sorted(dts)}")
        keep = [t for t in trajectories if len(t.data) > 1]
        if not keep:
            raise ParameterError("the recorded trials hold no transition")
        return cls(
            states=np.concatenate([t.states[:-1] for t in keep]),
            forces=np.concatenate([t.column("force")[:-1] for t in keep]),
            next_states=np.concatenate([t.states[1:] for t in keep]),
            dt=dts.pop(),
        )

    def __len__(self) -> int:
        return len(self.forces)

    def split(self, every: int) -> tuple[Transitions, Transitions]:
        """(the rest, every ``every``-th transition): a held-out split without shuffling."""
        held = np.zeros(len(self), dtype=bool)
        held[::every] = True
        return self._pick(~held), self._pick(held)

    def _pick(self, rows: np.ndarray) -> Transitions:
        assert self.factors is not None
        return Transitions(
            self.states[rows],
            self.forces[rows],
            self.next_states[rows],
            self.dt,
            self.factors[rows],
        )


@dataclass(frozen=True)
class StructuredFit:
    """The fitted cart-pole: ``plant`` (M, m, l; gravity as given), ``friction`` b
    [N s/m], ``covariance`` (4, 4) of (M, m, l, b), ``rms`` the one-step residual per
    state component (4,), ``transitions`` the number fitted."""

    plant: Plant
    friction: float
    covariance: np.ndarray
    rms: np.ndarray
    transitions: int

    @property
    def std(self) -> np.ndarray:
        """Standard errors of (M, m, l, b)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    def family(self, k: float = 3.0, floor: float = FAMILY_FLOOR) -> tuple[Plant, ...]:
        """The plants the fit cannot rule out: the four corners of pole mass and length
        at +-max(k sigma, floor x value), cart mass at its estimate."""
        m, l = self.plant.pole_mass, self.plant.length
        dm = max(k * float(self.std[1]), floor * m)
        dl = max(k * float(self.std[2]), floor * l)
        return tuple(
            Plant(
                cart_mass=self.plant.cart_mass,
                pole_mass=m + sm * dm,
                length=l + sl * dl,
                gravity=self.plant.gravity,
            )
            for sm in (-1.0, 1.0)
            for sl in (-1.0, 1.0)
        )

    def predict(self, states: np.ndarray, forces: np.ndarray, dt: float) -> np.ndarray:
        """Next states (n, 4) under the fitted equations."""
        return rk4_force_step(states, forces, dt, self.plant, self.friction)


NOMINAL = Plant()


def fit_structured(data: Transitions, prior: Plant = NOMINAL) -> StructuredFit:
    """Least-squares cart mass, pole mass, length and cart friction from ``data``.

    Residuals: s_{k+1} - RK4(s_k, f_k) per component, each scaled by that component's
    spread over the data, so metres and radians weigh alike. Started from ``prior``
    (friction 0); gravity is ``prior.gravity``, known.
    """
    scale = np.std(data.next_states - data.states, axis=0)
    scale = np.where(scale > 0, scale, 1.0)

    def residual(p: np.ndarray) -> np.ndarray:
        plant = Plant(cart_mass=p[0], pole_mass=p[1], length=p[2], gravity=prior.gravity)
        pred = rk4_force_step(data.states, data.forces, data.dt, plant, p[3])
        return ((pred - data.next_states) / scale).ravel()

    x0 = np.array([prior.cart_mass, prior.pole_mass, prior.length, 0.0])
    lower = np.array([1e-3 * prior.cart_mass, 1e-3 * prior.pole_mass, 1e-3 * prior.length, -np.inf])
    sol = scipy.optimize.least_squares(
        residual, x0, bounds=(lower, np.inf), x_scale="jac", xtol=1e-14, ftol=1e-14
    )
    n, k = sol.fun.size, sol.x.size
    sigma2 = float(sol.fun @ sol.fun) / max(n - k, 1)
    JTJ = sol.jac.T @ sol.jac
    covariance = sigma2 * np.linalg.pinv(JTJ)
    rms = np.sqrt(np.mean(sol.fun.reshape(-1, 4) ** 2, axis=0)) * scale
    plant = Plant(cart_mass=sol.x[0], pole_mass=sol.x[1], length=sol.x[2], gravity=prior.gravity)
    return StructuredFit(plant, float(sol.x[3]), covariance, rms, len(data))


#: The generic model's inputs, in order: the state's velocities and the angle's sine and
#: cosine, the motor force held over the step, and (a conditioned model) the true
#: plant's pole mass and length factors. The cart position is left out (the track is flat).
GENERIC_INPUTS: tuple[str, ...] = (
    "x_dot",
    "sin theta",
    "cos theta",
    "theta_dot",
    "force",
    "pole mass factor",
    "length factor",
)
#: Its outputs: the step's mean accelerations [m/s^2, rad/s^2].
GENERIC_OUTPUTS: tuple[str, ...] = ("x_dot change / dt", "theta_dot change / dt")


def _features(
    states: np.ndarray, forces: np.ndarray, factors: np.ndarray | None = None
) -> np.ndarray:
    """The first five :data:`GENERIC_INPUTS` of each row, then the two factors if given."""
    th = states[:, 2]
    columns = [states[:, 1], np.sin(th), np.cos(th), states[:, 3], forces]
    if factors is not None:
        columns += [factors[:, 0], factors[:, 1]]
    return np.column_stack(columns)


def _monomials(z: np.ndarray, powers: np.ndarray) -> np.ndarray:
    """(n, F) the monomials prod_i z_i ** powers[j, i] of standardised inputs z (n, d)."""
    return np.prod(z[:, None, :] ** powers[None, :, :], axis=2)


@dataclass(frozen=True, eq=False)
class GenericModel:
    """A bootstrap ensemble of readouts from the monomials of the standardised
    :func:`_features` to the step's mean accelerations ((x_dot' - x_dot) / dt,
    (theta_dot' - theta_dot) / dt); the position and angle advance by the mean of the
    old and new velocities (a trapezoid). ``args``: the inputs' mean and scale, the
    monomials' exponents, and each member's readout (:class:`LearnedArgs`; the members
    share their standardisation and monomials). ``conditioned``: the pole mass and
    length factors are inputs too (all seven :data:`GENERIC_INPUTS`), so the model can
    be asked about another plant."""

    args: LearnedArgs
    dt: float
    conditioned: bool = False
    #: The (pole mass, length) factor pairs of the data it was fitted on.
    plants: tuple[tuple[float, float], ...] = ((1.0, 1.0),)

    def accelerations(
        self, states: np.ndarray, forces: np.ndarray, factors: tuple[float, float] = (1.0, 1.0)
    ) -> np.ndarray:
        """(n_members, n, 2) predicted mean accelerations [m/s^2, rad/s^2] on the plant
        with pole mass and length ``factors`` (ignored unless :attr:`conditioned`)."""
        s = np.asarray(states, float)
        f = np.asarray(forces, float)
        fac = np.tile(np.asarray(factors, float), (len(f), 1)) if self.conditioned else None
        a = self.args
        phi = _monomials((_features(s, f, fac) - a.mean) / a.scale, a.powers)
        return np.einsum("nf,kcf->knc", phi, a.coef) + a.intercept[:, None, :]

    def predict(
        self,
        states: np.ndarray,
        forces: np.ndarray,
        dt: float | None = None,
        factors: tuple[float, float] = (1.0, 1.0),
    ) -> np.ndarray:
        """Next states (n, 4) under the ensemble mean."""
        step = self.dt if dt is None else dt
        acc = self.accelerations(states, forces, factors).mean(axis=0)
        s = np.asarray(states, float)
        v = s[:, [1, 3]] + step * acc
        out = s.copy()
        out[:, [1, 3]] = v
        out[:, [0, 2]] = s[:, [0, 2]] + 0.5 * step * (s[:, [1, 3]] + v)
        return out

    def spread(
        self, states: np.ndarray, forces: np.ndarray, factors: tuple[float, float] = (1.0, 1.0)
    ) -> np.ndarray:
        """(n, 2) ensemble standard deviation of the accelerations: the model's doubt."""
        return self.accelerations(states, forces, factors).std(axis=0)

    def conditioned_dynamics(self) -> ConditionedDynamics:
        """The conditioned ensemble (:class:`~striatal.sim.learned.ConditionedDynamics`)."""
        if not self.conditioned:
            raise ParameterError("the model is not conditioned on the plant factors")
        return ConditionedDynamics(self.args)

    def dynamics(self, pole_mass: float = 1.0, length: float = 1.0) -> LearnedDynamics:
        """The ensemble as the compiled kernel's learned plant step
        (:mod:`striatal.sim.kernel.learned`), whose step is :meth:`predict`'s (the
        members' mean, the trapezoid); a conditioned model at the given factors."""
        if self.conditioned:
            return self.conditioned_dynamics().at(pole_mass, length)
        return LearnedDynamics(self.args)

    def plant(self, believed: Plant) -> LearnedPlant:
        """The ensemble's mean as a plant to run trials on (a conditioned one at the
        nominal factors, scalable), the controller believing ``believed``."""
        if self.conditioned:
            return LearnedPlant.conditioned_on(self.conditioned_dynamics().mean(), believed)
        return LearnedPlant.of(self.dynamics().mean(), believed)


#: The degree of the generic model's monomials.
DEGREE = 3
#: How much a plant factor's monomials are shrunk before the ridge readout (module
#: docstring of :func:`fit_generic`).
FACTOR_SHRINK = 0.1
#: The ridge penalty of its readout: the monomials of standardised inputs are collinear
#: (sin^2 + cos^2 = 1), so the penalty keeps the normal equations well posed.
RIDGE = 1e-3


#: The generic model's readouts: "ridge", every monomial of the inputs standardised on
#: the data; "sparse", a few monomials of the raw inputs per output and member.
Readout = Literal["ridge", "sparse"]
READOUTS: tuple[str, ...] = ("ridge", "sparse")
#: The monomials the sparse readout chooses per output and member (root 0: 2-8 compared
#: offline, 3, 4 and 6 in the loop; docs/results.md, "The generic forward model, round 6").
SPARSE_TERMS = 4
#: Which monomial holding the force the sparse readout puts in each output's support
#: before its pursuit picks the rest: "chosen", none (the pursuit alone); "linear", the
#: force f itself; "any", the monomial holding f that best matches the output.
ForceTerm = Literal["chosen", "linear", "any"]
FORCE_TERMS: tuple[str, ...] = ("chosen", "linear", "any")
#: The angle span [rad] below which data are narrow (``fit_generic``'s ``narrow_terms``):
#: a trial that barely left hanging (root 0's W(0) trials that barely move span 0.03-0.3
#: rad, those that swing 5-40; set before the loop comparison, not tuned).
NARROW_SPAN = 1.0


def generic_powers(degree: int, conditioned: bool) -> np.ndarray:
    """The monomials' exponents (F, 5) or, ``conditioned``, (F, 7): every monomial of
    degree <= ``degree`` of the five state and force inputs (scikit-learn's
    ``PolynomialFeatures`` order), then each of those of degree <= ``degree`` - 1 times
    the pole mass factor, then times the length factor: a model linear in each factor
    (physics aside, the smallest change that lets the plant's size move every term)."""
    from sklearn.preprocessing import PolynomialFeatures

    base = PolynomialFeatures(degree).fit(np.zeros((1, N_FEATURES))).powers_.astype(np.int64)
    if not conditioned:
        return np.ascontiguousarray(base)
    low = base[base.sum(axis=1) <= degree - 1]
    zeros, ones = np.zeros((len(low), 1), np.int64), np.ones((len(low), 1), np.int64)
    return np.ascontiguousarray(
        np.vstack(
            [
                np.hstack([base, np.zeros((len(base), 2), np.int64)]),
                np.hstack([low, ones, zeros]),
                np.hstack([low, zeros, ones]),
            ]
        )
    )


def fit_generic(
    data: Transitions,
    rng: np.random.Generator,
    *,
    members: int = 5,
    degree: int = DEGREE,
    ridge: float = RIDGE,
    conditioned: bool = False,
    readout: Readout = "ridge",
    terms: int = SPARSE_TERMS,
    force_term: ForceTerm = "chosen",
    narrow_terms: int | None = None,
) -> GenericModel:
    """A bootstrap ensemble of ``members`` regressors: scikit-learn's ``StandardScaler``
    and ``PolynomialFeatures`` (every monomial of degree <= ``degree`` of the standardised
    inputs: the seven :data:`GENERIC_INPUTS`, or the first five when not
    ``conditioned``), fitted once on ``data``, then a ``Ridge`` readout (penalty
    ``ridge``) per member, each on a bootstrap resample of ``data``. Data from one
    plant only leave the factors' monomials at zero (a factor of zero spread
    standardises to 0), so the conditioned model then predicts every plant alike.

    ``readout="sparse"`` (not ``conditioned``): the inputs are not standardised (mean
    0, scale 1: sine and cosine as they are, the velocities in m/s and rad/s, the force
    in N), so that a monomial is a fixed function of the state, not of one trial's
    spread; each member chooses, on its bootstrap resample, at most ``terms`` monomials
    per output with scikit-learn's ``OrthogonalMatchingPursuit`` (the constant among
    the candidates; columns scaled to unit norm for the choice), then both outputs are
    fitted by least squares on the union of the monomials chosen for either (no
    penalty, no intercept beside the constant): with a motor force that barely moved,
    the cart's acceleration reveals the force's monomial and the pole's then reads it
    too. Only the monomials some member chose are kept in ``args.powers``. The library is the
    generic one; its low-degree monomials contain the cart-pole's leading terms (sin
    theta, cos theta times the force), which is why a sparse choice can extrapolate
    from a swing to upright where the dense ridge does not (docs/results.md, round 6).
    ``force_term`` (sparse only, :data:`FORCE_TERMS`): a monomial holding the force put in
    each output's support before the pursuit picks the other ``terms`` - 1 ("chosen":
    none, the pursuit alone). ``narrow_terms`` (sparse only; None: ``terms`` always): the
    terms per output when the data's angle spans less than :data:`NARROW_SPAN`, data
    too narrow to tell more terms apart. Needs scikit-learn (the ``model`` extra)."""
    try:
        from sklearn.linear_model import Ridge
        from sklearn.preprocessing import StandardScaler
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ParameterError(
            "the generic forward model needs scikit-learn: pip install 'striatal[model]'"
        ) from exc
    if members < 1:
        raise ParameterError(f"members must be >= 1, got {members}")
    if not 1 <= degree <= 6:
        raise ParameterError(f"degree must be in [1, 6], got {degree}")
    if readout not in READOUTS:
        raise ParameterError(f"readout must be 'ridge' or 'sparse', got {readout!r}")
    if readout != "sparse" and (force_term != "chosen" or narrow_terms is not None):
        raise ParameterError("force_term and narrow_terms take the sparse readout")
    if readout == "sparse":
        if conditioned:
            raise ParameterError(
                "the sparse readout takes the plain generic model, not conditioned"
            )
        if narrow_terms is not None:
            if not 1 <= narrow_terms <= terms:
                raise ParameterError(
                    f"narrow_terms must be in [1, terms = {terms}], got {narrow_terms}"
                )
            if np.ptp(data.states[:, 2]) < NARROW_SPAN:
                terms = narrow_terms
        return _fit_sparse(
            data, rng, members=members, degree=degree, terms=terms, force_term=force_term
        )
    X = _features(data.states, data.forces, data.factors if conditioned else None)
    y = (data.next_states[:, [1, 3]] - data.states[:, [1, 3]]) / data.dt
    scaler = StandardScaler().fit(X)
    powers = generic_powers(degree, conditioned)
    # a factor's monomials enter shrunk, so the ridge penalty holds them FACTOR_SHRINK^-2
    # times harder: a plant seen on one trajectory moves the model only as far as needed
    shrink = np.where(powers[:, N_FEATURES:].sum(axis=1) > 0, FACTOR_SHRINK, 1.0)
    Phi = _monomials(scaler.transform(X), powers) * shrink
    coef, intercept = [], []
    for _ in range(members):
        rows = rng.integers(0, len(data), len(data))
        fitted = Ridge(alpha=ridge).fit(Phi[rows], y[rows])
        coef.append(fitted.coef_ * shrink)
        intercept.append(fitted.intercept_)
    args = LearnedArgs(
        mean=np.array(scaler.mean_, dtype=float),
        scale=np.array(scaler.scale_, dtype=float),
        powers=powers,
        coef=np.ascontiguousarray(np.stack(coef), dtype=float),
        intercept=np.ascontiguousarray(np.stack(intercept), dtype=float),
    )
    assert data.factors is not None
    plants = tuple((float(a), float(b)) for a, b in np.unique(data.factors, axis=0))
    return GenericModel(args, data.dt, conditioned, plants)


def _pursue(
    unit: np.ndarray, y: np.ndarray, terms: int, candidates: np.ndarray | None
) -> np.ndarray:
    """(2, F) whether each unit-norm monomial column of ``unit`` (n, F) is chosen for each
    output of ``y`` (n, 2) by orthogonal matching pursuit, at most ``terms`` each; with
    ``candidates`` (indices) one of them is chosen first (the one that best matches the
    output) and the pursuit picks the other ``terms`` - 1 on what it leaves."""
    from sklearn.linear_model import OrthogonalMatchingPursuit

    chosen = np.zeros((y.shape[1], unit.shape[1]), dtype=bool)
    for out in range(y.shape[1]):
        target, columns, rest = y[:, out], unit, terms
        if candidates is not None:
            first = candidates[np.argmax(np.abs(unit[:, candidates].T @ target))]
            chosen[out, first] = True
            # the pursuit's own step: the output and every column less their part along it
            along = unit[:, first]
            target = target - along * (along @ target)
            columns = unit - np.outer(along, along @ unit)
            norms = np.linalg.norm(columns, axis=0)
            columns = np.where(
                norms > 1e-9 * max(1.0, norms.max()), columns / np.where(norms > 0, norms, 1.0), 0.0
            )
            rest = terms - 1
        if rest == 0 or not np.any(target):
            continue
        with warnings.catch_warnings():
            # fewer independent monomials than terms on a narrow trial: it stops early
            warnings.simplefilter("ignore", RuntimeWarning)
            pursuit = OrthogonalMatchingPursuit(n_nonzero_coefs=rest, fit_intercept=False)
            pursuit.fit(columns, target)
        chosen[out] |= pursuit.coef_ != 0
    return chosen


def _fit_sparse(
    data: Transitions,
    rng: np.random.Generator,
    *,
    members: int,
    degree: int,
    terms: int,
    force_term: ForceTerm,
) -> GenericModel:
    """:func:`fit_generic`'s sparse readout (its docstring)."""
    powers = generic_powers(degree, False)
    if not 1 <= terms <= len(powers):
        raise ParameterError(f"terms must be in [1, {len(powers)}], got {terms}")
    if force_term not in FORCE_TERMS:
        raise ParameterError(
            f"force_term must be one of {', '.join(FORCE_TERMS)}, got {force_term!r}"
        )
    force = N_FEATURES - 1
    candidates = {
        "chosen": None,
        "linear": np.flatnonzero((powers[:, force] == 1) & (powers.sum(axis=1) == 1)),
        "any": np.flatnonzero(powers[:, force] > 0),
    }[force_term]
    Phi = _monomials(_features(data.states, data.forces), powers)
    y = (data.next_states[:, [1, 3]] - data.states[:, [1, 3]]) / data.dt
    coef = []
    for _ in range(members):
        rows = rng.integers(0, len(data), len(data))
        norms = np.linalg.norm(Phi[rows], axis=0)
        norms = np.where(norms > 0, norms, 1.0)
        # both outputs read the monomials either chose: least squares on their union
        support = np.any(_pursue(Phi[rows] / norms, y[rows], terms, candidates), axis=0)
        support[0] |= not support.any()  # the constant, when nothing moved
        unit = Phi[rows][:, support] / norms[support]
        chosen = np.zeros((2, len(powers)))
        chosen[:, support] = np.linalg.lstsq(unit, y[rows], rcond=None)[0].T
        coef.append(chosen / norms)
    stacked = np.stack(coef)
    kept = (stacked != 0).any(axis=(0, 1))
    kept[0] |= not kept.any()
    args = LearnedArgs(
        mean=np.zeros(N_FEATURES),
        scale=np.ones(N_FEATURES),
        powers=np.ascontiguousarray(powers[kept]),
        coef=np.ascontiguousarray(stacked[:, :, kept], dtype=float),
        intercept=np.zeros((members, 2)),
    )
    return GenericModel(args, data.dt)
