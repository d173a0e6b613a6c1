"""The lockstep batch kernel: its polynomial sin/cos, and its trials against the scalar kernel.

:func:`striatal.sim.kernel.run_trials_lockstep` advances all trials of a block together
with sin/cos from :func:`striatal.sim.kernel.sincos_poly` (no libm call, so the loops
over trials vectorise). It cannot equal the scalar kernel bit for bit; the tolerance
is stated here: same outcome (reward, end step, fault, early end, switch count) and
states, traces and statistics within 1e-8, for trials whose closed loop does not
amplify round-off. A trial that balances with the printed sign of eq 20 (unstable,
docs/paper-notes.md section 1) is chaotic: there, as between any two libm versions,
a 1-ulp difference grows to a different trajectory, and only the scalar kernel's
libm results are reproducible bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from striatal.params import CHAPTER_FINAL_W, CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.rollout import Protocol, TrialRequest, batch_args

SIM = Simulation(duration=35.0)  # past the 30-s check of eq 24
EXACT = [kernel.OUT_REWARD, kernel.OUT_END_STEP, kernel.OUT_FAULT, kernel.OUT_EARLY]
EXACT += [kernel.OUT_N_SWITCHES]
CLOSE = [kernel.OUT_X, kernel.OUT_X_DOT, kernel.OUT_THETA, kernel.OUT_THETA_DOT]
CLOSE += [kernel.OUT_MIN_ABS_THETA_SWINGUP, kernel.OUT_MIN_ABS_THETA]
CLOSE += [kernel.OUT_MAX_ABS_X, kernel.OUT_MAX_ABS_FORCE]
TOL = 1e-8


@pytest.mark.parametrize("span", [4.0, 100.0, 1.0e4])
def test_sincos_poly_is_libm_to_round_off(span: float) -> None:
    """Within 1 ulp of math.sin/cos for |x| <= 100 (2 ulp to 1e4) where |value| > 1e-8,
    within 2^-52 absolute everywhere (near multiples of pi); most values exact."""
    x = np.random.default_rng(1).uniform(-span, span, 20000)
    x = np.concatenate([x, [0.0, -0.0, math.pi, -math.pi, math.pi / 4, 3 * math.pi / 4]])
    got = np.array([kernel.sincos_poly(float(v)) for v in x])
    want = np.array([(math.sin(v), math.cos(v)) for v in x])
    err = np.abs(got - want)
    assert err.max() <= 2.0**-52
    big = np.abs(want) > 1e-8
    assert (err[big] / np.spacing(np.abs(want[big]))).max() <= (1.0 if span <= 100.0 else 2.0)
    assert np.mean(got == want) > 0.8
    assert kernel.sincos_poly(0.0) == (0.0, 1.0)


def _rows(B: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows that succeed, fail at 60 s or at the t = 30 s check, and fault."""
    rng = np.random.default_rng(seed)
    W = np.empty((B, 6))
    W[:] = CHAPTER_FINAL_W
    W[1::5] = CHAPTER_INITIAL_W
    W[2::5, 4] = 1.0e4  # swing-up cart gain far beyond RK4's stability: a blow-up
    W[3::5, 0] = -1.0  # sqrt of a negative W1 g once balancing: a NaN state
    W[4::5, 3] = 0.0  # no swing-up energy gain: still hanging at the eq-24 check
    W += rng.normal(0.0, 0.01, W.shape) * (np.abs(W) < 100) * (W != 0.0)
    theta_c = rng.uniform(0.5, 1.0, B)
    states0 = np.tile(SIM.initial_state, (B, 1))
    states0[:, 2] += rng.uniform(-0.05, 0.05, B)
    return states0, W, theta_c


def _compare(
    controller: Controller,
    *,
    B: int,
    stochastic: bool = True,
    model: Plant | None = None,
    action_every: int = 1,
    chapter_eligibility: bool = False,
) -> np.ndarray:
    states0, W, theta_c = _rows(B, 2024)
    n_draws = -(-SIM.n_steps // action_every)
    noise = np.random.default_rng(7).standard_normal((B, n_draws)) if stochastic else None
    traces0 = np.random.default_rng(3).normal(0.0, 0.1, (B, 6))
    requests = [
        TrialRequest(
            Plant(),
            replace(controller, theta_c=theta_c[b]),
            SIM,
            Protocol(),
            gains=W[b],
            state0=states0[b],
            model=model,
            action_every=action_every,
            chapter_eligibility=chapter_eligibility,
            gamma=0.999,
            trace=traces0[b].copy(),
        )
        for b in range(B)
    ]
    args = batch_args(requests, noise)
    kernel.run_trials_lockstep(*args)
    outs, traces = args[-1], args[-2].trace
    for b in range(B):
        one = requests[b].args(None if noise is None else noise[b])
        kernel.run_trial(*one)
        out, trace = one[-1].out, one[-2].trace
        np.testing.assert_array_equal(outs[b, EXACT], out[EXACT], err_msg=f"row {b}")
        if out[kernel.OUT_FAULT]:
            continue  # a blown-up or NaN state: only the outcome is meaningful
        np.testing.assert_allclose(outs[b, CLOSE], out[CLOSE], rtol=TOL, atol=TOL)
        np.testing.assert_allclose(traces[b], trace, rtol=TOL, atol=TOL)
    if not stochastic:
        np.testing.assert_array_equal(traces, traces0)
    return outs


def test_lockstep_equals_scalar_on_mixed_outcomes() -> None:
    """B = 70: one full block of 64 and a padded one; every kind of ending is present."""
    outs = _compare(Controller(), B=70)
    faults = outs[:, kernel.OUT_FAULT] == 1.0
    early = outs[:, kernel.OUT_EARLY] == 1.0
    assert faults[2::5].all() and faults[3::5].any()  # NaN only if it reaches balancing
    assert early[4::5].all()
    rest = ~faults & ~early
    assert rest.any()
    assert set(np.unique(outs[rest, kernel.OUT_REWARD])) <= {10.0, -5.0}


@pytest.mark.parametrize(
    "kwargs",
    [
        {"stochastic": False},
        {"action_every": 3, "chapter_eligibility": True},
        {"model": Plant(pole_mass=1.2, length=0.9)},
    ],
)
def test_lockstep_equals_scalar_in_every_mode(kwargs: dict[str, object]) -> None:
    _compare(Controller(switch="soft"), B=10, **kwargs)  # type: ignore[arg-type]


def test_lockstep_single_trial() -> None:
    _compare(Controller(), B=1)


def _packing_requests(B: int) -> tuple[list[TrialRequest], np.ndarray]:
    """B noisy requests that end at the eq-24 check, on a fault and at 35 s; their noise."""
    states0, W, theta_c = _rows(B, 99)
    noise = np.random.default_rng(5).standard_normal((B, SIM.n_steps))
    requests = [
        TrialRequest(
            Plant(),
            replace(Controller(), theta_c=theta_c[b]),
            SIM,
            Protocol(),
            gains=W[b],
            state0=states0[b],
            gamma=0.999,
            trace=np.zeros(6),
        )
        for b in range(B)
    ]
    return requests, noise


def test_packed_lanes_give_each_trial_its_result_alone() -> None:
    """Trials that end at the eq-24 check or on a fault are written out and the running
    ones packed into the first lanes: each trial's row and trace equal, bit for bit, the
    same trial run alone (a block of one, where nothing is packed)."""
    B = 70
    requests, noise = _packing_requests(B)
    args = batch_args(requests, noise)
    kernel.run_trials_lockstep(*args)
    outs, traces = args[-1], args[-2].trace
    ended = outs[:, kernel.OUT_END_STEP] < SIM.n_steps
    assert ended[2::5].all() and ended[4::5].all() and not ended.all()  # packing happened
    for b in range(B):
        one = batch_args([replace(requests[b], trace=np.zeros(6))], noise[b : b + 1])
        kernel.run_trials_lockstep(*one)
        np.testing.assert_array_equal(outs[b], one[-1][0], err_msg=f"row {b}")
        np.testing.assert_array_equal(traces[b], one[-2].trace[0], err_msg=f"row {b}")


@pytest.mark.parametrize("block", [1, 3, 4, 7, 12, 20, 64])
def test_block_size_does_not_change_a_trial(block: int) -> None:
    """Blocks of any size (rounded up to whole vectors of VECTOR lanes, the idle lanes
    inactive) give every trial the same row and trace, bit for bit, as blocks of 64:
    a lane's arithmetic does not depend on its place, its block, or how many lanes
    its vector loop steps."""
    B = 21
    requests, noise = _packing_requests(B)
    want = batch_args(requests, noise)
    kernel.run_trials_lockstep(*want, 64)
    got = batch_args([replace(r, trace=np.zeros(6)) for r in requests], noise)
    kernel.run_trials_lockstep(*got, block)
    np.testing.assert_array_equal(got[-1], want[-1])
    np.testing.assert_array_equal(got[-2].trace, want[-2].trace)
    ended = want[-1][:, kernel.OUT_END_STEP] < SIM.n_steps
    assert ended.any() and not ended.all()  # packing happened
    assert kernel.lockstep.VECTOR % 4 == 0
