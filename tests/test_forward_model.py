"""The cerebellar forward models (striatal.learners.forward.model): what they recover from
recorded real trials, how well they predict trials they were not fitted on, their doubt."""

from __future__ import annotations

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.learners.forward.model import (
    FAMILY_FLOOR,
    GENERIC_INPUTS,
    GENERIC_OUTPUTS,
    NARROW_SPAN,
    Transitions,
    fit_generic,
    fit_structured,
    generic_powers,
    rk4_force_step,
)
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim.learned import LearnedPlant
from striatal.sim.robust import ROBUST_HARDWARE
from striatal.sim.rollout import simulate

FINAL = Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
INITIAL = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
OTHER = Controller(gains=(1.0, -0.3, -0.9, 0.4, 0.5, 1.0), theta_c=0.8)
SIM = Simulation(duration=20.0)


def recorded(plant: Plant, controller: Controller = FINAL) -> Transitions:
    """One real trial under force hold, the controller believing the nominal plant."""
    return Transitions.of(
        [simulate(plant, controller, SIM, model=Plant(), hardware=ROBUST_HARDWARE)]
    )


def test_the_numpy_step_is_the_kernels_force_hold_step() -> None:
    data = recorded(Plant(pole_mass=0.12, length=0.9))
    pred = rk4_force_step(data.states, data.forces, data.dt, Plant(pole_mass=0.12, length=0.9))
    assert np.abs(pred - data.next_states).max() < 1e-12
    # and a wrong plant does not fit: the test can tell
    wrong = rk4_force_step(data.states, data.forces, data.dt, Plant())
    assert np.abs(wrong - data.next_states).max() > 1e-4


@pytest.mark.parametrize(("mass", "length"), [(0.12, 0.9), (0.08, 0.8), (0.12, 1.2), (0.1, 1.0)])
def test_structured_fit_recovers_the_plant_from_noise_free_trials(
    mass: float, length: float
) -> None:
    true = Plant(pole_mass=mass, length=length)
    fit = fit_structured(recorded(true))
    assert fit.plant.pole_mass == pytest.approx(mass, rel=1e-6)
    assert fit.plant.length == pytest.approx(length, rel=1e-6)
    assert fit.plant.cart_mass == pytest.approx(1.0, rel=1e-6)
    assert abs(fit.friction) < 1e-6
    assert fit.rms.max() < 1e-10


def test_structured_fit_within_tolerance_from_noisy_measurements() -> None:
    """Sensor noise of 1 mm and 1 mrad (and per s) on every recorded state: pole mass and
    length within 1 %, each within 4 of its standard errors of the truth."""
    true = Plant(pole_mass=0.12, length=0.9)
    clean = recorded(true)
    rng = np.random.default_rng(3)
    noisy = Transitions(
        clean.states + rng.normal(0.0, 1e-3, clean.states.shape),
        clean.forces,
        clean.next_states + rng.normal(0.0, 1e-3, clean.states.shape),
        clean.dt,
    )
    fit = fit_structured(noisy)
    assert fit.plant.pole_mass == pytest.approx(0.12, rel=0.01)
    assert fit.plant.length == pytest.approx(0.9, rel=0.01)
    assert abs(fit.plant.pole_mass - 0.12) < 4 * fit.std[1]
    assert abs(fit.plant.length - 0.9) < 4 * fit.std[2]
    assert (fit.std > 0).all()


def test_structured_fit_recovers_a_cart_friction() -> None:
    """Next states made by the model's own equations with b = 0.3 N s/m: b comes back."""
    true = Plant(pole_mass=0.12, length=0.9)
    base = recorded(true)
    next_states = rk4_force_step(base.states, base.forces, base.dt, true, friction=0.3)
    fit = fit_structured(Transitions(base.states, base.forces, next_states, base.dt))
    assert fit.friction == pytest.approx(0.3, rel=1e-6)
    assert fit.plant.pole_mass == pytest.approx(0.12, rel=1e-6)


def test_family_brackets_the_estimate_at_the_floor_when_the_data_are_exact() -> None:
    fit = fit_structured(recorded(Plant(pole_mass=0.12, length=0.9)))
    family = fit.family()
    assert len(family) == 4
    masses = sorted({p.pole_mass for p in family})
    lengths = sorted({p.length for p in family})
    assert masses == pytest.approx([0.12 * (1 - FAMILY_FLOOR), 0.12 * (1 + FAMILY_FLOOR)])
    assert lengths == pytest.approx([0.9 * (1 - FAMILY_FLOOR), 0.9 * (1 + FAMILY_FLOOR)])
    wide = fit.family(floor=0.2)
    assert max(p.length for p in wide) == pytest.approx(0.9 * 1.2)


def test_generic_model_predicts_a_held_out_trial() -> None:
    """Fitted on two trials (chapter W(0) and final W), it predicts a third controller's
    trial one step ahead: mean accelerations within 25 % of their spread, next
    velocities within 5 mm/s and 10 mrad/s (root mean square)."""
    pytest.importorskip("sklearn")
    true = Plant(pole_mass=0.12, length=0.9)
    train = Transitions.of(
        [simulate(true, c, SIM, model=Plant(), hardware=ROBUST_HARDWARE) for c in (FINAL, INITIAL)]
    )
    model = fit_generic(train, np.random.default_rng(1))
    held = recorded(true, OTHER)
    acc_true = (held.next_states[:, [1, 3]] - held.states[:, [1, 3]]) / held.dt
    acc = model.accelerations(held.states, held.forces).mean(axis=0)
    rms = np.sqrt(((acc - acc_true) ** 2).mean(axis=0))
    assert (rms < 0.25 * acc_true.std(axis=0)).all()
    err = np.sqrt(((model.predict(held.states, held.forces) - held.next_states) ** 2).mean(axis=0))
    assert err[1] < 5e-3 and err[3] < 1e-2
    assert (model.spread(held.states, held.forces) >= 0).all()


def test_generic_model_is_deterministic_under_a_seed() -> None:
    pytest.importorskip("sklearn")
    data = recorded(Plant()).split(4)[1]
    a = fit_generic(data, np.random.default_rng(5), members=2, degree=2)
    b = fit_generic(data, np.random.default_rng(5), members=2, degree=2)
    c = fit_generic(data, np.random.default_rng(6), members=2, degree=2)
    pa, pb, pc = (m.predict(data.states[:50], data.forces[:50]) for m in (a, b, c))
    assert np.array_equal(pa, pb)
    assert not np.array_equal(pa, pc)


def test_split_holds_out_every_kth_transition() -> None:
    data = recorded(Plant())
    rest, held = data.split(5)
    assert len(rest) + len(held) == len(data)
    assert np.array_equal(held.states, data.states[::5])


def test_bad_transitions_are_refused() -> None:
    z = np.zeros((3, 4))
    with pytest.raises(ParameterError, match="at least one"):
        Transitions(np.zeros((0, 4)), np.zeros(0), np.zeros((0, 4)), 0.01)
    with pytest.raises(ParameterError, match="shape"):
        Transitions(z, np.zeros(2), z, 0.01)
    with pytest.raises(ParameterError, match="finite"):
        Transitions(np.full((3, 4), np.nan), np.zeros(3), z, 0.01)
    with pytest.raises(ParameterError, match="dt"):
        Transitions(z, np.zeros(3), z, 0.0)
    with pytest.raises(ParameterError, match="recorded trial"):
        Transitions.of([])


def test_the_generic_model_holds_no_cart_pole_equation() -> None:
    """Its inputs are the seven listed here and its features are monomials of them, no
    more (the sparse readout keeps a subset of the same monomials): no mass, length,
    gravity or eq 8-10 term enters. The same code fits a plant
    under another gravity (which the cart-pole equations would need to be told)."""
    pytest.importorskip("sklearn")
    assert GENERIC_INPUTS == (
        "x_dot",
        "sin theta",
        "cos theta",
        "theta_dot",
        "force",
        "pole mass factor",
        "length factor",
    )
    assert GENERIC_OUTPUTS == ("x_dot change / dt", "theta_dot change / dt")
    plain, conditioned = generic_powers(3, False), generic_powers(3, True)
    assert plain.shape == (56, 5) and (plain.sum(axis=1) <= 3).all()  # C(5 + 3, 3) monomials
    # conditioned: those, then each of degree <= 2 times one factor (21 each)
    assert conditioned.shape == (56 + 2 * 21, 7)
    assert (conditioned[:, 5:].sum(axis=1) <= 1).all() and (conditioned.sum(axis=1) <= 3).all()
    for gravity in (9.81, 20.0):
        true = Plant(gravity=gravity)
        data = Transitions.of(
            [simulate(true, c, SIM, model=true, hardware=ROBUST_HARDWARE) for c in (FINAL, INITIAL)]
        )
        rest, held = data.split(7)
        model = fit_generic(rest, np.random.default_rng(0))
        assert model.args.powers.shape == plain.shape
        err = model.predict(held.states, held.forces) - held.next_states
        assert np.sqrt((err[:, 3] ** 2).mean()) < 1e-2  # rad/s, one step
        # the sparse readout: a subset of the same monomials of the same five inputs
        sparse = fit_generic(rest, np.random.default_rng(0), readout="sparse")
        library = {tuple(p) for p in plain}
        assert {tuple(p) for p in sparse.args.powers} <= library
        err = sparse.predict(held.states, held.forces) - held.next_states
        assert np.sqrt((err[:, 3] ** 2).mean()) < 1e-2


def corner_trials(factors: tuple[float, float], starts: tuple[float, ...]) -> Transitions:
    """The final gains' trials on the plant scaled by ``factors``, from theta0 in
    ``starts``, the controller believing the nominal plant; ``factors`` recorded."""
    true = Plant().scaled(pole_mass=factors[0], length=factors[1])
    runs = [
        simulate(
            true,
            FINAL,
            Simulation(duration=20.0, theta0=t),
            model=Plant(),
            hardware=ROBUST_HARDWARE,
        )
        for t in starts
    ]
    data = Transitions.of(runs)
    return Transitions(
        data.states, data.forces, data.next_states, data.dt, np.tile(factors, (len(data), 1))
    )


def merged(*parts: Transitions) -> Transitions:
    return Transitions(
        *(
            np.concatenate([getattr(p, k) for p in parts])
            for k in ("states", "forces", "next_states")
        ),
        parts[0].dt,
        np.concatenate([p.factors for p in parts]),  # type: ignore[misc]
    )


def test_a_conditioned_model_predicts_a_held_out_corner_trial_better() -> None:
    """Fitted on nominal trials and one trial on the corner pole mass x1.2, length x0.8
    (as the real robust check runs it), the model conditioned on the factors predicts
    another start's trial on that corner better than the same ensemble without them."""
    pytest.importorskip("sklearn")
    corner = (1.2, 0.8)
    train = merged(
        corner_trials((1.0, 1.0), (3.12, np.pi - 0.3, np.pi + 0.3)), corner_trials(corner, (3.12,))
    )
    held = corner_trials(corner, (np.pi + 0.3,))
    acc_true = (held.next_states[:, [1, 3]] - held.states[:, [1, 3]]) / held.dt
    errors = {}
    for conditioned in (False, True):
        model = fit_generic(train, np.random.default_rng(0), conditioned=conditioned)
        acc = model.accelerations(held.states, held.forces, corner).mean(axis=0)
        errors[conditioned] = np.sqrt(((acc - acc_true) ** 2).mean(axis=0))
    assert (errors[True] < 0.5 * errors[False]).all()
    # and it runs in the kernel at those factors as it predicts
    model = fit_generic(train, np.random.default_rng(0), conditioned=True)
    assert model.plants == ((1.0, 1.0), corner)
    plant = model.plant(Plant()).scaled(pole_mass=corner[0], length=corner[1])
    assert isinstance(plant, LearnedPlant) and plant.factors == corner
    assert plant.believed == Plant()


def test_a_model_from_one_plant_is_the_same_at_every_factor() -> None:
    """Data from the nominal plant only give the factors zero spread: the conditioned
    model then predicts every plant alike (it does not invent a difference)."""
    pytest.importorskip("sklearn")
    data = corner_trials((1.0, 1.0), (3.12,))
    model = fit_generic(data, np.random.default_rng(0), conditioned=True)
    a = model.accelerations(data.states[:100], data.forces[:100], (1.0, 1.0))
    b = model.accelerations(data.states[:100], data.forces[:100], (0.7, 1.3))
    assert np.array_equal(a, b)


def generic_inputs(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """States and forces drawn over the whole circle and a wide range of speeds and
    forces: generic data, from no controller."""
    states = np.column_stack(
        [
            rng.uniform(-2, 2, n),
            rng.uniform(-3, 3, n),
            rng.uniform(-np.pi, np.pi, n),
            rng.uniform(-6, 6, n),
        ]
    )
    return states, rng.uniform(-10, 10, n)


def test_the_sparse_readout_recovers_a_sparse_function_with_few_terms() -> None:
    """Accelerations that are a few monomials of the inputs (x_ddot = 0.9 f - 0.5 sin cos,
    theta_ddot = 10 sin - cos f + 0.2 theta_dot): from the full generic library (56
    cubic monomials) the sparse readout keeps those five monomials only, each output
    with its coefficients (and zero on the other output's), and predicts new inputs
    exactly."""
    pytest.importorskip("sklearn")
    rng = np.random.default_rng(3)
    states, forces = generic_inputs(600, rng)
    sn, cs = np.sin(states[:, 2]), np.cos(states[:, 2])
    acc = np.column_stack(
        [0.9 * forces - 0.5 * sn * cs, 10 * sn - cs * forces + 0.2 * states[:, 3]]
    )
    dt = 0.01
    after = states.copy()
    after[:, [1, 3]] += dt * acc
    data = Transitions(states, forces, after, dt)
    model = fit_generic(data, np.random.default_rng(0), readout="sparse", terms=4)
    # the true monomials, in the order of GENERIC_INPUTS[:5]: f, s c / s, c f, theta_dot
    expected = {
        0: {(0, 0, 0, 0, 1): 0.9, (0, 1, 1, 0, 0): -0.5},
        1: {(0, 1, 0, 0, 0): 10.0, (0, 0, 1, 0, 1): -1.0, (0, 0, 0, 1, 0): 0.2},
    }
    # exactly the five true monomials were chosen, of the 56
    assert {tuple(p) for p in model.args.powers} == {k for t in expected.values() for k in t}
    assert (model.args.mean == 0).all() and (model.args.scale == 1).all()  # fixed, raw inputs
    for out, terms in expected.items():
        for member in model.args.coef[:, out, :]:
            found = dict(zip(map(tuple, model.args.powers), member, strict=True))
            # the other output's monomials are read too (the union), at zero
            assert [found.get(k, 0.0) for k in found] == pytest.approx(
                [terms.get(k, 0.0) for k in found], abs=1e-9
            )
    new_states, new_forces = generic_inputs(50, np.random.default_rng(4))
    s2, c2 = np.sin(new_states[:, 2]), np.cos(new_states[:, 2])
    truth = 10 * s2 - c2 * new_forces + 0.2 * new_states[:, 3]
    pred = model.accelerations(new_states, new_forces)[:, :, 1]
    assert np.abs(pred - truth).max() < 1e-8


def test_from_one_swing_the_sparse_readout_predicts_upright_better_than_the_ridge() -> None:
    """Fitted on one failing 20-s swing of the chapter's W(0) (the data a run's first
    real trial gives), the sparse readout predicts the angular acceleration of the final
    gains' balancing near upright (|theta| < 0.5, a trajectory it was not fitted on)
    within a tenth of its spread, and at least 20 times better than the dense ridge on
    the same data, whose inputs are standardised on the swing's spread."""
    pytest.importorskip("sklearn")
    swing = recorded(Plant(), INITIAL)
    held = Transitions.of(
        [
            simulate(
                Plant(), FINAL, Simulation(duration=60.0), model=Plant(), hardware=ROBUST_HARDWARE
            )
        ]
    )
    upright = np.abs(np.angle(np.exp(1j * held.states[:, 2]))) < 0.5
    truth = (held.next_states[upright, 3] - held.states[upright, 3]) / held.dt
    errors = {}
    for readout in ("ridge", "sparse"):
        model = fit_generic(swing, np.random.default_rng(0), readout=readout)  # type: ignore[arg-type]
        pred = model.accelerations(held.states[upright], held.forces[upright]).mean(axis=0)
        errors[readout] = float(np.sqrt(np.mean((pred[:, 1] - truth) ** 2)))
    assert errors["sparse"] < 0.1 * truth.std()
    assert errors["sparse"] < errors["ridge"] / 20


def faint(scale: float) -> Transitions:
    """One real trial of the chapter's W(0) with every gain times ``scale``: a first
    trial that barely leaves hanging, as some random W(0) give."""
    gains = tuple(scale * w for w in CHAPTER_INITIAL_W)
    return recorded(Plant(), Controller(gains=gains, theta_c=CHAPTER_INITIAL_THETA_C))


def force_response(model: object, theta: float) -> np.ndarray:
    """(members,) d theta_ddot / d f at rest at angle ``theta`` [rad/s^2 per N]."""
    states = np.array([[0.0, 0.0, theta, 0.0]] * 2)
    acc = model.accelerations(states, np.array([-0.5, 0.5]))  # type: ignore[attr-defined]
    return acc[:, 1, 1] - acc[:, 0, 1]


def test_on_a_faint_trial_the_force_term_keeps_the_force_acting_on_the_pole() -> None:
    """A first trial that spans 0.7 rad: the pursuit alone fits the pole without the force
    (its response to f is 0), with the force's monomial in each support (``force_term``
    "linear") every member's response at hanging is within 10 % of the plant's,
    1 / (l (M + m sin^2 theta)) = 1 rad/s^2 per N."""
    pytest.importorskip("sklearn")
    data = faint(0.3)
    assert 0.5 < np.ptp(data.states[:, 2]) < NARROW_SPAN
    alone = fit_generic(data, np.random.default_rng(0), readout="sparse")
    assert np.abs(force_response(alone, np.pi)).max() < 1e-9
    forced = fit_generic(data, np.random.default_rng(0), readout="sparse", force_term="linear")
    p = Plant()
    truth = 1.0 / (p.length * p.cart_mass)
    assert force_response(forced, np.pi) == pytest.approx(np.full(5, truth), rel=0.1)


@pytest.mark.parametrize("scale", [0.2, 0.1, 0.05])
def test_on_a_faint_trial_fewer_terms_extrapolate_to_a_swing_better(scale: float) -> None:
    """Fitted on a first trial that barely moves (angle span < NARROW_SPAN), the sparse
    readout with the force's monomial and 2 terms an output (``narrow_terms``, sparse-affine)
    predicts the angular acceleration of the chapter's W(0) swing (5.9 rad, never seen)
    better than with 4 terms, with or without the force's monomial, and within a third of
    its spread."""
    pytest.importorskip("sklearn")
    data, swing = faint(scale), recorded(Plant(), INITIAL)
    assert np.ptp(data.states[:, 2]) < NARROW_SPAN < np.ptp(swing.states[:, 2])
    truth = (swing.next_states[:, 3] - swing.states[:, 3]) / swing.dt
    errors = {}
    for name, options in {
        "alone": {},
        "forced": {"force_term": "linear"},
        "narrow": {"force_term": "linear", "narrow_terms": 2},
    }.items():
        model = fit_generic(data, np.random.default_rng(0), readout="sparse", **options)  # type: ignore[arg-type]
        pred = model.accelerations(swing.states, swing.forces).mean(axis=0)[:, 1]
        errors[name] = float(np.sqrt(np.mean((pred - truth) ** 2)))
    assert errors["narrow"] < min(errors["alone"], errors["forced"])
    assert errors["narrow"] < truth.std() / 3


def test_narrow_terms_leave_wide_data_alone() -> None:
    """On a swing (angle span > NARROW_SPAN) ``narrow_terms`` changes nothing; on a faint
    trial each member keeps at most 2 monomials an output, so 3 in all (f in both)."""
    pytest.importorskip("sklearn")
    swing = recorded(Plant(), INITIAL)
    wide = [
        fit_generic(swing, np.random.default_rng(0), readout="sparse", force_term="linear", **kw)
        for kw in ({}, {"narrow_terms": 2})
    ]
    assert np.array_equal(wide[0].args.coef, wide[1].args.coef)
    narrow = fit_generic(
        faint(0.1), np.random.default_rng(0), readout="sparse", force_term="linear", narrow_terms=2
    )
    assert ((narrow.args.coef != 0).sum(axis=2) <= 3).all()
    force = [tuple(p) for p in narrow.args.powers].index((0, 0, 0, 0, 1))
    assert (narrow.args.coef[:, :, force] != 0).all()


def test_the_sparse_readout_is_deterministic_under_a_seed() -> None:
    pytest.importorskip("sklearn")
    data = recorded(Plant(), INITIAL)
    a, b, c = (
        fit_generic(data, np.random.default_rng(s), readout="sparse", members=3) for s in (5, 5, 6)
    )
    pa, pb, pc = (m.accelerations(data.states[:50], data.forces[:50]) for m in (a, b, c))
    assert np.array_equal(pa, pb) and np.array_equal(a.args.powers, b.args.powers)
    assert not np.array_equal(pa, pc)  # other bootstrap resamples


def test_bad_readout_settings_are_refused() -> None:
    pytest.importorskip("sklearn")
    data = recorded(Plant()).split(4)[1]
    rng = np.random.default_rng(0)
    with pytest.raises(ParameterError, match="readout must be 'ridge' or 'sparse', got 'lasso'"):
        fit_generic(data, rng, readout="lasso")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"terms must be in \[1, 56\], got 0"):
        fit_generic(data, rng, readout="sparse", terms=0)
    with pytest.raises(ParameterError, match="force_term must be one of chosen, linear, any"):
        fit_generic(data, rng, readout="sparse", force_term="cubic")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"narrow_terms must be in \[1, terms = 4\], got 5"):
        fit_generic(data, rng, readout="sparse", narrow_terms=5)
    with pytest.raises(ParameterError, match=r"narrow_terms must be in \[1, terms = 4\], got 0"):
        fit_generic(data, rng, readout="sparse", narrow_terms=0)
    with pytest.raises(ParameterError, match="take the sparse readout"):
        fit_generic(data, rng, force_term="linear")
    with pytest.raises(ParameterError, match="not conditioned"):
        fit_generic(data, rng, readout="sparse", conditioned=True)
