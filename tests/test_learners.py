"""Learners beyond the chapter ("rpe", "pgpe"): determinism, update rules, guards, options."""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from striatal import learners
from striatal.cli.learner_options import (
    add_learner_arguments,
    learner_config_from,
    learner_defaults,
)
from striatal.errors import ParameterError
from striatal.learners import LearnerConfig, initial_state, learning_step
from striatal.learners import learn as train
from striatal.learners.common import SHAPED_WEIGHTS
from striatal.learners.pgpe import PGPE as PGPE_RULE
from striatal.learners.rule import TrialContext
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim.rollout import Protocol, TrialOutcome, simulate

START = Controller(CHAPTER_INITIAL_W, 0.6)
RANDOM_START = Controller((0.55, -0.06, 0.39, 0.63, 0.08, 0.03), 0.6)
LEARNER_DEFAULTS = learner_defaults()
RPE = LEARNER_DEFAULTS["rpe"]
PGPE = LEARNER_DEFAULTS["pgpe"]


def history(config: LearnerConfig, seed: int, start: Controller = RANDOM_START) -> list[object]:
    rows: list[object] = []
    r = train(Plant(), start, config, seed, on_trial=lambda s, rec: rows.append(rec.row()))
    return [r.W, r.theta_c, rows]


@pytest.mark.parametrize("learner", ["rpe", "pgpe"])
def test_same_seed_same_history(learner: str) -> None:
    cfg = replace(LEARNER_DEFAULTS[learner], max_trials=12)
    assert history(cfg, 3) == history(cfg, 3)
    assert history(cfg, 3) != history(cfg, 4)


@pytest.mark.parametrize("learner", ["rpe", "pgpe"])
def test_alpha_zero_leaves_gains_unchanged(learner: str) -> None:
    cfg = replace(LEARNER_DEFAULTS[learner], alpha=0.0, max_trials=20)
    r = train(Plant(), RANDOM_START, cfg, seed=1)
    assert RANDOM_START.gains == r.W
    if learner == "pgpe":
        assert r.theta_c == RANDOM_START.theta_c


def test_decay_alone_shrinks_the_gains_geometrically() -> None:
    """With a zero prediction error (max_step 0+) the decay acts: W_k = (1 - alpha d)^k W_0."""
    cfg = replace(PGPE, alpha=0.5, decay=0.2, max_step=1e-300, max_trials=3)
    r = train(Plant(), RANDOM_START, cfg, seed=0)
    np.testing.assert_allclose(r.W[1:5], 0.9**3 * np.array(RANDOM_START.gains[1:5]), rtol=1e-12)
    assert r.W[5] == RANDOM_START.gains[5]


def test_plant_jitter_needs_success_on_the_corner_plants() -> None:
    corners = learners.jitter_corners(Plant(), 0.2)
    got = sorted((c.pole_mass, c.length) for c in corners)
    np.testing.assert_allclose(got, [(0.08, 0.8), (0.08, 1.2), (0.12, 0.8), (0.12, 1.2)])
    robust = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)  # passes on all corners
    # pgpe judges the candidate it ran: a negligible exploration makes it the start
    cfg = replace(PGPE, plant_jitter=0.2, max_trials=3, explore=1e-9)
    assert train(Plant(), robust, cfg, seed=0).trials_done == 1
    # gains learned by pgpe (seed 0) that pass on the nominal plant but not at -20 %
    fragile = Controller(
        (
            2.755608068191568,
            -0.21023362464983728,
            -0.33116058773442564,
            2.516692637176916,
            2.6014090234219114,
            -0.5271986094008383,
        ),
        0.3641320237980639,
    )
    sim, protocol = Simulation(), Protocol()
    assert simulate(Plant(), fragile, sim, protocol=protocol).outcome.success
    short = Plant().scaled(pole_mass=0.8, length=0.8)
    assert not simulate(short, fragile, sim, protocol=protocol, model=Plant()).outcome.success
    state = initial_state(fragile.gains, fragile.theta_c, 0)
    assert not learning_step(state, Plant(), fragile, sim, protocol, cfg)[0].success
    nominal = replace(PGPE, explore=1e-9)
    assert learning_step(state, Plant(), fragile, sim, protocol, nominal)[0].success
    with pytest.raises(ParameterError, match="does not use plant_jitter"):
        learners.check_config(LearnerConfig(plant_jitter=0.2))


def test_tracked_baseline_converges_to_the_mean_reward() -> None:
    rng = np.random.default_rng(0)
    b = 0.0
    for r in rng.normal(3.0, 2.0, size=4000):
        b = learners.tracked_baseline(b, float(r), 0.01)
    assert b == pytest.approx(3.0, abs=0.15)


def test_prediction_error_factor_normalises_by_running_rms() -> None:
    f, sq = learners.prediction_error_factor(2.0, 0.0, 0.1, normalise=True)
    assert (f, sq) == (1.0, 4.0)
    f, sq = learners.prediction_error_factor(-1.0, 4.0, 0.1, normalise=True)
    assert sq == pytest.approx(0.9 * 4.0 + 0.1)
    assert f == pytest.approx(-1.0 / math.sqrt(sq))
    assert learners.prediction_error_factor(-1.0, 4.0, 0.1, normalise=False)[0] == -1.0


def test_pgpe_update_equals_its_formula() -> None:
    """p <- p + alpha * delta / rms * eps, eps the perturbation of the trial (the eligibility)."""
    cfg = replace(PGPE, max_step=math.inf)
    plant, sim, protocol = Plant(), Simulation(), Protocol()
    s1, rec1 = learning_step(
        initial_state(RANDOM_START.gains, 0.6, 5), plant, RANDOM_START, sim, protocol, cfg
    )
    # the first trial only sets the prediction b to its reward (and the gains decay)
    shrink = 1 - cfg.alpha * cfg.decay
    np.testing.assert_allclose(s1.W[:5], shrink * np.array(RANDOM_START.gains[:5]), rtol=1e-12)
    assert s1.theta_c == 0.6
    (b1,), (square1,) = s1.get("reward_mean"), s1.get("rpe_square")
    assert b1 == rec1.reward
    rng = np.random.default_rng()
    rng.bit_generator.state = s1.rng_state
    context = TrialContext(plant, RANDOM_START, sim, protocol, cfg.hardware)
    eps = PGPE_RULE.plan(s1, cfg, rng, context).scratch["eps"]
    s2, rec2 = learning_step(s1, plant, RANDOM_START, sim, protocol, cfg)
    delta = rec2.reward - b1
    factor = delta / math.sqrt((1 - cfg.rpe_rate) * square1 + cfg.rpe_rate * delta**2)
    if square1 == 0.0:
        factor = math.copysign(1.0, delta) if delta else 0.0
    p1 = np.array([*s1.W[:5], s1.theta_c])
    p2 = np.array([*s2.W[:5], s2.theta_c])
    decay = cfg.alpha * cfg.decay * np.array([*p1[:5], 0.0])
    expected = cfg.alpha * factor * eps - decay
    np.testing.assert_allclose(p2 - p1, expected, atol=1e-12)
    assert s2.W[5] == s1.W[5]
    assert s2.get("reward_mean")[0] == pytest.approx(b1 + cfg.rpe_rate * delta)
    assert rec2.extra == (("explore", cfg.explore),)


def test_rpe_update_is_the_chapter_rule_with_the_prediction_error() -> None:
    cfg = replace(RPE, normalise=False, max_step=math.inf, decay=2.0)
    s1, _rec1 = learning_step(
        initial_state(START.gains, 0.6, 2), Plant(), START, Simulation(), Protocol(), cfg
    )
    s2, rec2 = learning_step(s1, Plant(), START, Simulation(), Protocol(), cfg)
    delta = rec2.reward - s1.get("reward_mean")[0]
    expected = cfg.alpha * (1 - cfg.gamma) * delta * np.array(s2.get("trace"))
    expected[:5] -= cfg.alpha * (1 - cfg.gamma) * cfg.decay * np.array(s1.W[:5])
    np.testing.assert_allclose(np.array(s2.W) - np.array(s1.W), expected, atol=1e-12)


def test_three_factor_update_keeps_non_finite_numbers_out() -> None:
    p = np.array([1.0, 2.0, 3.0])
    for bad in (np.nan, np.inf):
        out = learners.three_factor_update(p, np.array([1.0, bad, 0.0]), 1.0, 1.0, math.inf)
        np.testing.assert_array_equal(out, p)
    out = learners.three_factor_update(p, np.array([1.0, -1.0, 0.0]), 1e9, 1.0, 0.5)
    np.testing.assert_array_equal(out, p + np.array([0.5, -0.5, 0.0]))


@pytest.mark.parametrize("learner", ["rpe", "pgpe"])
def test_absurd_rates_stay_finite(learner: str) -> None:
    cfg = replace(LEARNER_DEFAULTS[learner], alpha=1e6, max_step=math.inf, max_trials=25, decay=0)
    r = train(Plant(), RANDOM_START, cfg, seed=0)
    assert all(math.isfinite(w) for w in (*r.W, r.theta_c)) and r.W[0] > 0
    assert 0 < r.theta_c < math.pi


def test_shaped_reward_ranks_upright_at_rest_above_hanging() -> None:
    sim, protocol, plant = Simulation(duration=5.0), Protocol(), Plant()
    n = sim.n_steps + 1

    def score(theta: float) -> float:
        data = np.zeros((n, 8))
        data[:, 3] = theta
        out = TrialOutcome(
            10.0, 5.0, (0.0, 0.0, theta, 0.0), 0.0, 0.0, False, False, 0, 0.0, 0.0, True
        )
        return learners.shaped_reward(data, out, plant, sim, protocol)

    assert score(0.0) == pytest.approx(sum(SHAPED_WEIGHTS))
    assert 0.0 < score(math.pi) < 2.0


def test_invalid_combinations_raise() -> None:
    for kw in (
        {"learner": "x"},
        {"reward": "x"},
        {"rpe_rate": 0.0},
        {"explore": 0.0},
        {"sigma_rate": -1.0},
        {"theta_c_rule": "learned"},
        {"learner": "pgpe"},  # success on the noisy trial
        {"learner": "pgpe", "success_on": "mean", "gamma": 0.9},  # pgpe has no trace
        {"learner": "rpe", "baseline": 1.0},  # rpe tracks its own baseline
        {"reward": "shaped"},  # the chapter's rule has the sparse reward only
        {"explore": 1e308},
    ):
        with pytest.raises(ParameterError):
            learners.check_config(LearnerConfig(**kw))  # type: ignore[arg-type]


def parse(*argv: str) -> LearnerConfig:
    parser = argparse.ArgumentParser()
    add_learner_arguments(parser)
    return learner_config_from(parser.parse_args(list(argv)))


def test_options_keep_the_chapter_learner_and_take_per_learner_defaults() -> None:
    assert parse() == LearnerConfig()
    assert parse("--learner", "pgpe") == PGPE
    assert parse("--learner", "pgpe", "--alpha", "0.1", "--no-normalise") == replace(
        PGPE, alpha=0.1, normalise=False
    )
    assert parse("--carry-trace").reset_trace is False


def test_train_pgpe_from_random_gains_learns_gains_that_simulate_confirms() -> None:
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "striatal",
            "train",
            "--learner",
            "pgpe",
            "--init",
            "random",
            "--seed",
            "2",
            "--max-trials",
            "300",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result["success"] and result["mean_policy_success"]
    assert result["learner"] == "pgpe"
    learned = START.with_gains(result["W"], result["theta_c"])
    assert simulate(Plant(), learned, Simulation(), protocol=Protocol()).outcome.success
    again = subprocess.run(
        [
            sys.executable,
            "-m",
            "striatal",
            "simulate",
            "--json",
            "--theta-c",
            repr(result["theta_c"]),
            "--gains",
            *(repr(w) for w in result["W"]),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert again.returncode == 0, again.stderr
    assert json.loads(again.stdout)["success"] is True


@pytest.mark.parametrize("learner", ["rpe", "pgpe"])
def test_resume_from_state_equals_uninterrupted_run(learner: str) -> None:
    cfg = replace(LEARNER_DEFAULTS[learner], max_trials=30)
    full = train(Plant(), RANDOM_START, cfg, seed=5)
    half = train(Plant(), RANDOM_START, replace(cfg, max_trials=13), seed=5)
    state = type(half).from_dict(json.loads(json.dumps(half.to_dict())))
    resumed = train(Plant(), RANDOM_START, cfg, seed=5, state=state)
    assert (resumed.W, resumed.theta_c, resumed.trials_done) == (
        full.W,
        full.theta_c,
        full.trials_done,
    )
    assert resumed.to_dict() == full.to_dict()


def test_pgpe_control_explores_the_same_and_changes_nothing() -> None:
    """pgpe's no-learning control: the same perturbations, no update of p or s."""
    cfg = replace(PGPE, sigma_rate=0.5, max_trials=8)
    control = learners.control_config(cfg)
    assert (control.alpha, control.sigma_rate) == (0.0, 0.0)
    assert learners.control_config(RPE).alpha == 0.0
    rows: list[learners.TrialRecord] = []
    r = train(Plant(), RANDOM_START, control, seed=3, on_trial=lambda s, rec: rows.append(rec))
    assert RANDOM_START.gains == r.W and r.theta_c == RANDOM_START.theta_c
    assert {rec.extra for rec in rows} == {(("explore", cfg.explore),)}
    # the same draws as the learning run: its first trial (before any update) is identical
    first: list[learners.TrialRecord] = []
    train(Plant(), RANDOM_START, cfg, seed=3, on_trial=lambda s, rec: first.append(rec))
    assert first[0].reward == rows[0].reward


def test_history_columns_say_what_each_learner_records() -> None:
    for name, column in (("chapter", "sigma"), ("rpe", "sigma"), ("pgpe", "explore")):
        rows: list[learners.TrialRecord] = []
        cfg = learners.default_config(name, max_trials=2)
        train(
            Plant(), RANDOM_START, cfg, seed=0, on_trial=lambda s, rec, rows=rows: rows.append(rec)
        )
        assert rows[0].columns[9] == column
        assert learners.RULES[name].history_columns == (column,)


def test_a_rule_registered_by_the_recipe_runs_in_the_shared_loop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """docs/architecture.md's recipe: a rule with a config, preset, control, column, memory."""
    from dataclasses import dataclass
    from types import MappingProxyType

    from striatal.learners.config import pick

    @dataclass(frozen=True)
    class HillConfig:
        alpha: float
        explore: float

    class HillClimb(learners.Rule):
        """Keep a random perturbation of W1..W5 if it scored better than the best so far."""

        name = "hill"
        summary = "hill climbing on W1..W5"
        config_type = HillConfig
        preset = MappingProxyType({"success_on": "mean", "explore": 0.2, "alpha": 1.0})
        control = MappingProxyType({"alpha": 0.0})
        history_columns = ("best",)
        memory_names = ("best",)

        def plan(self, state, config, rng, context):  # type: ignore[no-untyped-def]
            c = pick(HillConfig, config)
            W = np.array(state.W)
            eps = np.zeros(6)
            eps[:5] = c.explore * rng.standard_normal(5)
            return learners.TrialPlan(
                W=W + eps, theta_c=state.theta_c, trace=np.zeros(6), gamma=0.0, rng=None
            )

        def update(self, state, config, trial, context):  # type: ignore[no-untyped-def]
            plan, reward, success = trial.plan, trial.reward, trial.success
            best = state.get("best")[0] if state.get("best") else -math.inf
            keep = not success and config.alpha > 0 and reward > best
            W = tuple(float(w) for w in plan.W) if keep else state.W
            extra = (("best", best if state.get("best") else math.nan),)
            return learners.Update(W, state.theta_c, (("best", (max(best, reward),)),), extra)

    monkeypatch.setitem(learners.RULES, "hill", HillClimb())
    cfg = learners.default_config("hill", max_trials=6)
    rows: list[learners.TrialRecord] = []
    r = train(Plant(), RANDOM_START, cfg, seed=1, on_trial=lambda s, rec: rows.append(rec))
    assert len(rows) == 6 and rows[0].columns[9] == "best"
    assert [rec.extra[0][1] for rec in rows[1:]] == sorted(rec.extra[0][1] for rec in rows[1:])
    assert RANDOM_START.gains != r.W
    still = train(Plant(), RANDOM_START, learners.control_config(cfg), seed=1)
    assert RANDOM_START.gains == still.W
    with pytest.raises(ParameterError, match="does not use gamma"):
        learners.default_config("hill", gamma=0.5)
