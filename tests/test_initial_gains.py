"""W1 <= 0 in W(0): ``--init-gains`` and ``--init random`` treat it the same way.

Both floor W1 at W1_FLOOR = 0.001 (docs/paper-notes.md section 11), so every random
starting point can also be given by hand and gives the same run.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import striatal
from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments.spec import floor_w1, initial_gains
from striatal.learners import W1_FLOOR

#: Seed 1's random draw has W1 = -0.336 (uniform in [-1, 1]^6 from default_rng([1, 1])).
SEED = 1


def raw_draw(seed: int) -> np.ndarray:
    """The draw of ``--init random`` before the floor."""
    return np.random.default_rng([seed, 1]).uniform(-1.0, 1.0, size=6)


def test_the_seed_draws_a_negative_w1() -> None:
    assert raw_draw(SEED)[0] < 0.0
    assert initial_gains("random", SEED)[0] == W1_FLOOR


@pytest.mark.parametrize("learner", ["chapter", "pgpe"])
def test_init_gains_with_negative_w1_equals_the_random_draw(learner: str) -> None:
    """train(init_gains=(-0.5, W2..W6 of the draw)) is the run of init="random", bit for bit."""
    hand = (-0.5, *raw_draw(SEED)[1:].tolist())
    a = striatal.train(learner, init="random", seed=SEED, max_trials=3)
    b = striatal.train(learner, init_gains=hand, seed=SEED, max_trials=3)
    assert a.settings["W0"] == b.settings["W0"]
    assert a.settings["W0"][0] == W1_FLOOR
    assert b.settings["w1_floored_from"] == -0.5
    assert "w1_floored_from" not in a.settings
    assert a.history.columns == b.history.columns
    np.testing.assert_array_equal(a.history.data, b.history.data)
    assert a.W == b.W and a.theta_c == b.theta_c
    assert a.state.rng_state == b.state.rng_state


def test_cli_train_accepts_w1_below_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``striatal train --init-gains -0.5 ...`` runs (it was exit 2) and records the floor."""
    hand = ["-0.5", *map(repr, raw_draw(SEED)[1:].tolist())]
    argv = ["train", "--json", "--no-progress", "--seed", str(SEED), "--max-trials", "2"]
    assert main([*argv, "--init-gains", *hand]) == 0
    by_hand = json.loads(capsys.readouterr().out)
    assert main([*argv, "--init", "random"]) == 0
    random = json.loads(capsys.readouterr().out)
    assert by_hand["W"] == random["W"]
    assert by_hand["settings"]["W0"] == random["settings"]["W0"]


def test_floor_w1_keeps_the_rest_and_still_checks_them() -> None:
    assert floor_w1([-3.0, 1, 2, 3, 4, 5]) == (W1_FLOOR, 1.0, 2.0, 3.0, 4.0, 5.0)
    assert floor_w1([0.5, 1, 2, 3, 4, 5])[0] == 0.5
    with pytest.raises(ParameterError, match="W5 must be finite"):
        floor_w1([1.0, 0, 0, 0, float("inf"), 0])
    with pytest.raises(ParameterError, match="six numbers"):
        floor_w1([1.0, 2.0])
