"""The readings of eq 21 on real trials: ``swingup`` is a ratchet, ``trial`` collapses to its
floor, ``clamped`` does neither (docs/paper-notes.md, section 6; docs/results.md).

Each runs the alpha = 0 control from the chapter's W(0), theta_c(0) = 0.6, so only eq 21
moves; the readings differ only in which min |theta| they take and where they floor it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_chapter import outcome

from striatal.learners import TrialRecord, default_config, learn, theta_c_rule
from striatal.learners.common import THETA_C_FLOOR, THETA_C_RESET_ABOVE, THETA_C_RESET_TO
from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W, Controller, Plant

START = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
SEEDS = (1, 2, 3)


def control_records(rule: str, seed: int, trials: int) -> list[TrialRecord]:
    """The alpha = 0 control's history rows under eq-21 reading ``rule``."""
    config = default_config("chapter", alpha=0.0, theta_c_rule=rule, max_trials=trials)
    records: list[TrialRecord] = []
    learn(Plant(), START, config, seed, on_trial=lambda s, rec: records.append(rec))
    return records


@pytest.mark.parametrize("seed", SEEDS)
def test_swingup_reading_is_a_ratchet(seed: int) -> None:
    """Under the swing-up |theta| >= theta_c, so theta_c never falls except by eq 21's reset
    to 0.6 (min |theta| above 1.4), and it rises in almost every trial."""
    records = control_records("swingup", seed, 100)
    assert len(records) == 100  # these seeds pass no trial in 100
    for rec in records:
        assert rec.min_abs_theta_swingup >= rec.theta_c
    tc = np.array([rec.theta_c for rec in records])
    swing = np.array([rec.min_abs_theta_swingup for rec in records])
    for before, after, m in zip(tc[:-1], tc[1:], swing[:-1], strict=True):
        reset = not math.isfinite(m) or m > THETA_C_RESET_ABOVE
        assert after == THETA_C_RESET_TO if reset else after >= before
    steps = np.diff(tc)
    assert (steps > 0).sum() >= 95
    assert 0.001 < np.median(steps[steps > 0]) < 0.01  # a few thousandths of a radian
    assert tc[-1] > 1.0  # it has crept from 0.6 past 1 rad in 100 trials


@pytest.mark.parametrize("seed", SEEDS)
def test_trial_reading_collapses_to_its_floor(seed: int) -> None:
    """Over the whole trial the balancing law brings |theta| near 0, so theta_c is at the
    floor 0.01 by trial 2 and spends most trials there; at the floor, few trials earn +10."""
    records = control_records("trial", seed, 40)
    tc = np.array([rec.theta_c for rec in records])
    assert tc[0] == CHAPTER_INITIAL_THETA_C and tc[1] == THETA_C_FLOOR
    at_floor = tc == THETA_C_FLOOR
    assert at_floor.sum() >= 25
    assert tc.max() <= CHAPTER_INITIAL_THETA_C
    rewarded = np.array([rec.reward > 0 for rec in records])
    assert rewarded[at_floor].mean() < 0.25
    assert rewarded[at_floor].mean() < rewarded[~at_floor].mean() or (~at_floor).sum() <= 2


@pytest.mark.parametrize("seed", SEEDS)
def test_clamped_reading_neither_ratchets_nor_collapses_from_the_chapters_start(
    seed: int,
) -> None:
    """From W(0) every trial comes within 0.6 rad, so theta_c stays at 0.6: no creep, no floor."""
    tc = [rec.theta_c for rec in control_records("clamped", seed, 60)]
    assert tc == [CHAPTER_INITIAL_THETA_C] * 60


@pytest.mark.parametrize(
    ("min_swing", "min_all", "theta_c", "expected"),
    [
        (1.0, 0.8, 1.0, 0.8),  # a trial that comes closer than theta_c lowers it: no ratchet
        (1.0, 1e-9, 1.0, THETA_C_RESET_TO),  # the pole held upright: 0.6, not 0.01
        (1.2, 1.1, 0.9, 1.1),  # a trial that never came within 0.6 rad: its closest approach
        (1.5, 1.45, 0.9, THETA_C_RESET_TO),  # eq 21's reset above 1.4
        (math.inf, math.inf, 0.9, THETA_C_RESET_TO),
    ],
)
def test_clamped_reading_on_one_outcome(
    min_swing: float, min_all: float, theta_c: float, expected: float
) -> None:
    assert theta_c_rule(outcome(min_swing, min_all), theta_c, "clamped") == expected
    # the same outcomes under the other two readings: a ratchet and a collapse
    if min_all == 1e-9:
        assert theta_c_rule(outcome(min_swing, min_all), theta_c, "trial") == THETA_C_FLOOR
        assert theta_c_rule(outcome(min_swing, min_all), theta_c, "swingup") >= theta_c
