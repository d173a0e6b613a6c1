"""pgpe's symmetric sampling (``--symmetric``, Sehnke et al. 2010): pairs p +/- eps."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.learners import LearnerState, default_config, initial_state, learning_step
from striatal.learners.pgpe import PGPE
from striatal.learners.rule import TrialContext
from striatal.params import Controller, Plant, Simulation
from striatal.sim.rollout import Protocol

W0 = (0.6, -0.4, -0.9, 0.9, 0.1, -1.2)


def _steps(config, n, state=None):  # type: ignore[no-untyped-def]
    state = state or initial_state(W0, 0.6, 11)
    out = []
    for _ in range(n):
        plan_state = state
        rng = np.random.default_rng()
        rng.bit_generator.state = state.rng_state
        template = Controller(gains=W0, theta_c=0.6)
        context = TrialContext(Plant(), template, Simulation(), Protocol(), config.hardware)
        plan = PGPE.plan(state, config, rng, context)
        state, record = learning_step(state, Plant(), template, Simulation(), Protocol(), config)
        out.append((plan_state, plan, state, record))
    return out


def test_a_pair_runs_p_plus_and_minus_eps_and_moves_p_after_the_second() -> None:
    config = default_config("pgpe", symmetric=True, max_trials=10)
    (s0, plan1, s1, r1), (_, plan2, s2, r2) = _steps(config, 2)
    p = np.array([*s0.W[:5], s0.theta_c])
    # p stays after the first trial of the pair
    assert s1.W == s0.W and s1.theta_c == s0.theta_c
    np.testing.assert_allclose(plan2.scratch["z"], -plan1.scratch["z"])
    np.testing.assert_allclose(plan2.scratch["p"], p)
    eps = plan1.scratch["z"] * plan1.scratch["s"]
    if not (r1.success or r2.success):
        d = 0.5 * (r1.reward - r2.reward)
        # the first pair's rms is |d|: the normalised factor is sign(d)
        step = np.clip(config.alpha * math.copysign(1.0, d) * eps, -1.0, 1.0)
        want = p + step
        want[:5] -= config.alpha * config.decay * p[:5]
        want[5] = min(max(want[5], 0.2), 1.4)
        want[0] = max(want[0], config.w1_floor)
        np.testing.assert_allclose([*s2.W[:5], s2.theta_c], want, rtol=1e-12)
        assert s2.get("pair_z") == ()


def test_with_jitter_both_trials_of_a_pair_run_on_the_same_plant() -> None:
    config = default_config("pgpe", symmetric=True, plant_jitter=0.2, max_trials=10)
    steps = _steps(config, 4)
    for first, second in (steps[0:2], steps[2:4]):
        assert first[1].plant is not None and first[1].plant == second[1].plant
    assert steps[0][1].plant != steps[2][1].plant


def test_resume_in_the_middle_of_a_pair_equals_the_uninterrupted_run() -> None:
    config = default_config("pgpe", symmetric=True, plant_jitter=0.2, max_trials=10)
    whole = _steps(config, 4)
    middle = LearnerState.from_dict(json.loads(json.dumps(whole[0][2].to_dict())))
    assert middle.get("pair_z")  # the checkpoint holds the pending half of the pair
    again = _steps(config, 3, state=middle)
    assert again[-1][2] == whole[-1][2]


def test_symmetric_refuses_an_adapted_exploration_and_other_learners() -> None:
    with pytest.raises(ParameterError, match="sigma_rate"):
        default_config("pgpe", symmetric=True, sigma_rate=0.1)
    with pytest.raises(ParameterError, match="symmetric"):
        default_config("chapter", symmetric=True)


def test_symmetric_is_stored_only_when_set() -> None:
    assert "symmetric" not in default_config("pgpe").to_dict()
    assert default_config("pgpe", symmetric=True).to_dict()["symmetric"] is True
