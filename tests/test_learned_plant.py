"""A plant whose motion is a learned model (striatal.sim.learned, striatal.sim.kernel.learned):
the compiled step against hand-computed steps and scikit-learn's predictions, the trial loop
on it, and what it refuses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import kernel
from striatal.sim.batch import TrialRequest
from striatal.sim.kernel.plant import _array_terms
from striatal.sim.learned import LearnedDynamics, LearnedPlant
from striatal.sim.robust import ROBUST_HARDWARE
from striatal.sim.rollout import NO_PROTOCOL, Protocol, batch_args, run_trial, simulate

FINAL = Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
INITIAL = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
DT = 0.01
PT = _array_terms(Plant().as_array(), Plant().as_array(), False, DT, True)


def hand_model(
    powers: list[list[int]], coef: list[list[float]], members: int = 1
) -> LearnedDynamics:
    """A model with unit standardisation: a_x = coef[0] . phi, a_theta = coef[1] . phi."""
    c = np.array(coef, dtype=float)
    return LearnedDynamics(
        kernel.LearnedArgs(
            mean=np.zeros(5),
            scale=np.ones(5),
            powers=np.array(powers, dtype=np.int64),
            coef=np.ascontiguousarray(np.stack([c] * members)),
            intercept=np.zeros((members, 2)),
        )
    )


def test_a_force_only_model_is_a_trapezoid_step_of_f_over_m() -> None:
    """x_ddot = f / M (M = 2 kg), theta_ddot = -3 theta_dot: one step by hand."""
    model = hand_model([[0, 0, 0, 0, 1], [0, 0, 0, 1, 0]], [[0.5, 0.0], [0.0, -3.0]])
    x, xd, th, thd, f = 0.2, -0.4, 1.0, 0.7, 3.0
    out = kernel.learned_step(
        (x, xd, th, thd), (math.sin(th), math.cos(th), 99.0, f), PT, model.args
    )
    v = xd + DT * f / 2.0
    w = thd + DT * (-3.0 * thd)
    assert out == pytest.approx((x + DT * (xd + v) / 2, v, th + DT * (thd + w) / 2, w), abs=1e-15)


def test_monomials_and_standardisation_are_as_written() -> None:
    """a_x = z0^2 z3 + 2 z1 z2 z4, a_theta = z4^3 - 1 (intercept), z = (q - mean) / scale."""
    args = kernel.LearnedArgs(
        mean=np.array([0.1, 0.0, 0.5, -0.2, 1.0]),
        scale=np.array([2.0, 1.0, 0.5, 1.5, 4.0]),
        powers=np.array([[2, 0, 0, 1, 0], [0, 1, 1, 0, 1], [0, 0, 0, 0, 3]], dtype=np.int64),
        coef=np.array([[[1.0, 2.0, 0.0], [0.0, 0.0, 1.0]]]),
        intercept=np.array([[0.0, -1.0]]),
    )
    q = np.array([0.7, math.sin(0.4), math.cos(0.4), 1.3, -2.0])
    z = (q - args.mean) / args.scale
    got = kernel.learned_accelerations(q[0], q[1], q[2], q[3], q[4], args)
    assert got == pytest.approx((z[0] ** 2 * z[3] + 2 * z[1] * z[2] * z[4], z[4] ** 3 - 1.0))


def test_members_mean_and_member_views() -> None:
    rng = np.random.default_rng(0)
    K, F = 3, 4
    powers = np.array([[0, 0, 0, 0, 0], [1, 0, 0, 0, 0], [0, 0, 0, 1, 1], [0, 2, 0, 0, 0]])
    args = kernel.LearnedArgs(
        mean=np.zeros(5),
        scale=np.ones(5),
        powers=powers.astype(np.int64),
        coef=rng.standard_normal((K, 2, F)),
        intercept=rng.standard_normal((K, 2)),
    )
    model = LearnedDynamics(args)
    q = (0.3, 0.2, 0.9, -0.5, 1.5)
    each = [kernel.learned_accelerations(*q, model.member(k).args) for k in range(K)]
    assert kernel.learned_accelerations(*q, args) == pytest.approx(np.mean(each, axis=0))
    assert kernel.learned_accelerations(*q, model.mean().args) == pytest.approx(
        np.mean(each, axis=0), abs=1e-14
    )
    with pytest.raises(ParameterError, match="member must be in"):
        model.member(K)


def test_the_trial_loop_on_a_learned_plant_steps_by_the_model_with_the_recorded_force() -> None:
    """Every recorded row k + 1 is learned_step of row k under row k's (held) force: the
    one trial loop, its force and its bookkeeping, drive the learned step."""
    model = hand_model(
        [[0, 0, 0, 0, 1], [0, 1, 0, 0, 0], [0, 0, 1, 0, 1]],
        [[1.0 / 1.1, 0.0, 0.0], [0.0, 9.8, -1.0 / 1.1]],
    )
    plant = LearnedPlant.of(model, Plant())
    tr = simulate(plant, FINAL, Simulation(duration=5.0), hardware=ROBUST_HARDWARE)
    rows = tr.data
    assert len(rows) == 501
    for k in range(0, 500, 37):
        x, xd, th, thd = rows[k, 1:5]
        inputs = (math.sin(th), math.cos(th), rows[k, 5], rows[k, 6])
        nxt = kernel.learned_step((x, xd, th, thd), inputs, PT, model.args)
        assert nxt == pytest.approx(tuple(rows[k + 1, 1:5]), abs=1e-12)
    # the physical plant moves differently from the same start
    real = simulate(Plant(), FINAL, Simulation(duration=5.0), hardware=ROBUST_HARDWARE)
    assert np.abs(real.data[-1, 1:5] - rows[-1, 1:5]).max() > 1e-3


def test_a_generic_model_runs_in_the_kernel_as_scikit_learn_predicts() -> None:
    pytest.importorskip("sklearn")
    from striatal.learners.forward.model import Transitions, fit_generic

    true = Plant(pole_mass=0.12, length=0.9)
    sim = Simulation(duration=20.0)
    data = Transitions.of(
        [simulate(true, c, sim, model=Plant(), hardware=ROBUST_HARDWARE) for c in (FINAL, INITIAL)]
    )
    model = fit_generic(data, np.random.default_rng(3))
    args = model.dynamics().args
    assert model.dynamics().members == 5
    held = data.split(9)[1]
    pred = model.predict(held.states, held.forces)
    got = np.array(
        [
            kernel.learned_step(
                (s[0], s[1], s[2], s[3]), (math.sin(s[2]), math.cos(s[2]), 0.0, f), PT, args
            )
            for s, f in zip(held.states, held.forces, strict=True)
        ]
    )
    assert np.abs(got - pred).max() < 1e-12
    # a short imagined run from the chapter's start tracks the real one (2 s, swing-up)
    short = Simulation(duration=2.0)
    imagined = simulate(model.plant(Plant()), FINAL, short, hardware=ROBUST_HARDWARE)
    real = simulate(true, FINAL, short, model=Plant(), hardware=ROBUST_HARDWARE)
    err = np.abs(imagined.data[:, 1:5] - real.data[:, 1:5]).max(axis=0)
    assert err[0] < 0.01 and err[2] < 0.01  # metres, radians


def test_a_learned_plant_refuses_what_it_cannot_be() -> None:
    model = hand_model([[0, 0, 0, 0, 1]], [[1.0], [0.0]])
    plant = LearnedPlant.of(model, Plant(pole_mass=0.2))
    assert plant.believed == Plant(pole_mass=0.2)
    assert plant != Plant(pole_mass=0.2) and plant == plant
    assert plant != LearnedPlant.of(hand_model([[0, 0, 0, 0, 1]], [[1.0], [0.0]]), Plant())
    hash(plant)
    with pytest.raises(ParameterError, match="cannot be scaled"):
        plant.scaled(pole_mass=0.8)
    request = TrialRequest(plant, FINAL, Simulation(duration=1.0), NO_PROTOCOL)
    # a learned plant shares a kernel call only with trials on the same model
    same = TrialRequest(
        LearnedPlant.of(model, Plant(pole_mass=0.2)), FINAL, request.sim, NO_PROTOCOL
    )
    other = TrialRequest(
        LearnedPlant.of(hand_model([[0, 0, 0, 0, 1]], [[1.0], [0.0]]), Plant(pole_mass=0.2)),
        FINAL,
        request.sim,
        NO_PROTOCOL,
    )
    assert request.batch_key() == same.batch_key() != other.batch_key()
    assert TrialRequest(plant, FINAL, request.sim, NO_PROTOCOL, record=True).batch_key() is None
    assert request.run() == run_trial(
        TrialRequest(
            plant,
            FINAL,
            Simulation(duration=1.0),
            protocol=NO_PROTOCOL,
            trace=np.zeros(6),
            gamma=0.0,
            rng=None,
        )
    )
    with pytest.raises(ParameterError, match="needs LearnedDynamics"):
        LearnedPlant()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"powers": np.zeros((2, 4), dtype=np.int64)}, "powers must be int64"),
        ({"powers": np.zeros((2, 5))}, "powers must be int64"),
        ({"powers": -np.ones((2, 5), dtype=np.int64)}, r"powers must be in \[0, 6\]"),
        ({"powers": np.full((2, 5), 7, dtype=np.int64)}, r"powers must be in \[0, 6\]"),
        ({"scale": np.zeros(5)}, "scales > 0"),
        ({"mean": np.full(5, np.nan)}, "mean must be finite"),
        ({"coef": np.zeros((1, 2, 3))}, r"coef must be \(1, 2, 2\)"),
        ({"intercept": np.zeros((2, 2))}, r"intercept must be \(1, 2\)"),
        ({"coef": np.zeros((0, 2, 2))}, "K >= 1"),
    ],
)
def test_bad_learned_arrays_are_refused(change: dict, message: str) -> None:
    good = kernel.LearnedArgs(
        mean=np.zeros(5),
        scale=np.ones(5),
        powers=np.zeros((2, 5), dtype=np.int64),
        coef=np.zeros((1, 2, 2)),
        intercept=np.zeros((1, 2)),
    )
    with pytest.raises(ParameterError, match=message):
        LearnedDynamics(good._replace(**change))


def _generic_plant(true: Plant) -> LearnedPlant:
    """The generic ensemble's mean fitted on two recorded trials of ``true``."""
    pytest.importorskip("sklearn")
    from striatal.learners.forward.model import Transitions, fit_generic

    sim = Simulation(duration=20.0)
    data = Transitions.of(
        [simulate(true, c, sim, model=Plant(), hardware=ROBUST_HARDWARE) for c in (FINAL, INITIAL)]
    )
    return fit_generic(data, np.random.default_rng(3)).plant(Plant())


@pytest.mark.parametrize("noisy", [False, True], ids=["mean", "noisy"])
def test_the_learned_batch_kernel_equals_the_scalar_kernel_bit_for_bit(noisy: bool) -> None:
    """Trials on one learned model, run together (:func:`run_requests`, one call of
    run_learned_trials_batch) and one by one (TrialRequest.run): the same summary rows
    and traces to the last bit, successes, early checks, faults and track ends alike,
    and the same noise drawn from each generator."""
    from striatal.params import Hardware
    from striatal.sim.batch import run_requests

    plant = _generic_plant(Plant(pole_mass=0.12, length=0.9))
    rng = np.random.default_rng(7)
    starts = [(0.0, 0.0, math.pi, 0.0), (0.5, 0.0, 0.3, 0.0), (0.0, 1.0, -2.5, 1.0)]
    controllers = [
        FINAL,
        INITIAL,
        Controller(gains=tuple(rng.uniform(-1.0, 1.0, 6)), theta_c=0.7),
    ]
    hardware = Hardware(hold="force", track=4.0)

    def requests() -> list[TrialRequest]:
        seeds = iter(range(100))
        return [
            TrialRequest(
                plant,
                c,
                Simulation(duration=40.0),
                Protocol(),
                rng=np.random.default_rng(next(seeds)) if noisy else None,
                gamma=0.9,
                trace=np.full(6, 0.1),
                state0=np.array(s0),
                hardware=hardware,
            )
            for c in controllers
            for s0 in starts
        ]

    one, many = requests(), requests()
    alone = [r.run() for r in one]
    calls: list[int] = []
    real = kernel.run_learned_trials_batch

    def noting(*args: object) -> None:
        calls.append(args[1].shape[0])  # type: ignore[attr-defined]
        real(*args)

    mp = pytest.MonkeyPatch()
    mp.setattr(kernel, "run_learned_trials_batch", noting)
    try:
        together = run_requests(many)
    finally:
        mp.undo()
    assert calls == [len(many)]
    assert together == alone
    for a, b in zip(one, many, strict=True):
        assert np.array_equal(a.trace, b.trace)
        assert (a.rng is None) or a.rng.random() == b.rng.random()  # type: ignore[union-attr]
    reasons = {o.end_reason for o in alone}
    assert len(reasons) >= 2, reasons
    # a batch of one on the kernel directly equals the scalar kernel too
    r = requests()[4]
    noise = r.noise()[0]
    args = batch_args([r], noise[None, :] if noisy else None)
    kernel.run_learned_trials_batch(plant.dynamics.args, *args)  # type: ignore[union-attr]
    scalar = requests()[4]
    sa = scalar.args(scalar.noise()[0] if noisy else None)
    kernel.run_learned_trial(plant.dynamics.args, sa)  # type: ignore[union-attr]
    assert np.array_equal(args.outs[0], sa.buffers.out)


def test_the_monomials_read_from_their_non_zero_powers_are_the_full_products_bit_for_bit() -> None:
    """learned_step_of lists each cubic monomial's table entries at its non-zero powers;
    the product of those equals the product over all five inputs (the z^0 = 1 entries
    change no bit), for one member and for several; a monomial of four inputs makes the
    step read all five."""
    rng = np.random.default_rng(2)
    pytest.importorskip("sklearn")
    from striatal.learners.forward.model import generic_powers

    powers = generic_powers(3, conditioned=False)
    for members in (1, 3):
        args = kernel.LearnedArgs(
            mean=rng.normal(size=5),
            scale=rng.uniform(0.5, 2.0, 5),
            powers=powers,
            coef=rng.normal(size=(members, 2, len(powers))),
            intercept=rng.normal(size=(members, 2)),
        )
        fast = kernel.learned_step_of(args)
        assert fast.factors.shape == (len(powers), kernel.N_FACTORS)
        full = fast._replace(factors=np.zeros((0, kernel.N_FACTORS), dtype=np.int64))
        for q in rng.normal(size=(200, 5)) * 3.0:
            a = kernel.accelerations_into(*q, fast)
            b = kernel.accelerations_into(*q, full)
            assert a == b
    wide = kernel.LearnedArgs(
        mean=np.zeros(5),
        scale=np.ones(5),
        powers=np.array([[1, 1, 1, 1, 0], [0, 0, 0, 0, 1]], dtype=np.int64),
        coef=np.array([[[2.0, 1.0], [0.0, 1.0]]]),
        intercept=np.zeros((1, 2)),
    )
    assert kernel.learned_step_of(wide).factors.shape == (0, kernel.N_FACTORS)
    q = (0.5, -0.3, 0.8, 1.5, 2.0)
    assert kernel.learned_accelerations(*q, wide) == pytest.approx(
        (2.0 * 0.5 * -0.3 * 0.8 * 1.5 + 2.0, 2.0)
    )
