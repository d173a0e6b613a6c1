"""The trial rules of eqs 24-25 and the fault test: :func:`striatal.sim.kernel.judge`.

One compiled function states them; the kernel's trial and the Gymnasium task both
call it (tests/test_envs.py compares the two on failing and early-ended trials).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from striatal.params import Controller, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.rollout import Protocol, protocol_args, simulate

ARGS = protocol_args(Protocol(), 0.01, 6000)  # check at step 3000, end at step 6000
UP = (0.0, 0.0, 0.0, 0.0)


def _judge(state: tuple[float, float, float, float], step: int) -> tuple[int, float]:
    return kernel.judge(*state, step, ARGS)


def test_protocol_in_steps() -> None:
    assert (ARGS.n_steps, ARGS.check_step) == (6000, 3000)
    assert ARGS.check_theta == math.pi / 6 and ARGS.goal_theta == math.pi / 9


@pytest.mark.parametrize("step", [1, 2999, 3001, 5999])
def test_running_between_check_and_end_whatever_the_state(step: int) -> None:
    assert _judge((2.9, 0.0, math.pi, 0.0), step) == (kernel.STATUS_RUNNING, 0.0)
    assert _judge((50.0, 0.0, 1.0, 0.0), step) == (kernel.STATUS_RUNNING, 0.0)


@pytest.mark.parametrize(
    ("state", "status"),
    [
        ((3.0, 0.0, 0.0, 0.0), kernel.STATUS_RUNNING),  # |x| = 3 m is not > 3 m
        ((3.0001, 0.0, 0.0, 0.0), kernel.STATUS_EARLY),
        ((-3.0001, 0.0, 0.0, 0.0), kernel.STATUS_EARLY),
        ((0.0, 0.0, math.pi / 6 + 1e-9, 0.0), kernel.STATUS_EARLY),
        ((0.0, 0.0, 2.0 * math.pi + 0.1, 0.0), kernel.STATUS_RUNNING),  # wrapped: 0.1 rad
        ((0.0, 0.0, -2.0 * math.pi - 0.6, 0.0), kernel.STATUS_EARLY),
    ],
)
def test_eq24_check_at_30s(state: tuple[float, float, float, float], status: int) -> None:
    got, reward = _judge(state, 3000)
    assert got == status
    assert reward == (-5.0 if status == kernel.STATUS_EARLY else 0.0)


@pytest.mark.parametrize(
    ("state", "status", "reward"),
    [
        (UP, kernel.STATUS_SUCCESS, 10.0),
        ((0.0999, 0.0, 4.0 * math.pi + 0.3, 0.0), kernel.STATUS_SUCCESS, 10.0),
        ((0.1, 0.0, 0.0, 0.0), kernel.STATUS_FAILURE, -5.0),  # |x| < 0.1 is strict
        ((0.0, 0.0, -math.pi / 9, 0.0), kernel.STATUS_FAILURE, -5.0),
        ((0.0, 5.0, 0.0, -5.0), kernel.STATUS_SUCCESS, 10.0),  # eq 25 ignores velocities
    ],
)
def test_eq25_reward_at_the_end(
    state: tuple[float, float, float, float], status: int, reward: float
) -> None:
    assert _judge(state, 6000) == (status, reward)


@pytest.mark.parametrize(
    "state",
    [
        (math.nan, 0.0, 0.0, 0.0),
        (0.0, math.inf, 0.0, 0.0),
        (0.0, 0.0, 1.0e8, 0.0),
        (0.0, 0.0, 0.0, -1.0e9),
    ],
)
@pytest.mark.parametrize("step", [1, 3000, 6000])
def test_fault_comes_first(state: tuple[float, float, float, float], step: int) -> None:
    assert _judge(state, step) == (kernel.STATUS_FAULT, -5.0)


def test_check_on_the_last_step_is_no_check() -> None:
    """A check step equal to n_steps is the end: eq 25 decides, not eq 24."""
    args = protocol_args(Protocol(check_time=1.0), 0.01, 100)
    assert kernel.judge(0.0, 0.0, 0.0, 0.0, 100, args) == (kernel.STATUS_SUCCESS, 10.0)
    assert kernel.judge(2.0, 0.0, 0.0, 0.0, 100, args) == (kernel.STATUS_FAILURE, -5.0)


def test_check_at_time_zero_ends_the_trial_before_any_step() -> None:
    t = simulate(Plant(), Controller(), Simulation(duration=2.0), protocol=Protocol(check_time=0.0))
    assert t.outcome.early and t.outcome.ended_at == 0.0 and t.outcome.reward == -5.0
    assert t.data.shape[0] == 1
    np.testing.assert_array_equal(t.states[0], Simulation().initial_state)


def test_batch_judge_equals_scalar() -> None:
    rng = np.random.default_rng(0)
    states = rng.normal(0.0, 2.0, (64, 4))
    states[::7, 1] = np.nan
    steps = rng.choice([1, 3000, 6000], 64)
    status = np.empty(64, dtype=np.int64)
    reward = np.empty(64)
    kernel.judge_batch(states, steps, ARGS, status, reward)
    for b in range(64):
        assert (status[b], reward[b]) == kernel.judge(*states[b], int(steps[b]), ARGS)
    assert len(set(status.tolist())) >= 3
