"""The online actor-critic ("ac"): its compiled trial against the kernel and by hand, the
critic's fixed point, and the rule in the shared loop (determinism, control, resume)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from striatal import learners
from striatal.errors import ParameterError
from striatal.learners import learn as train
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    Controller,
    Hardware,
    Plant,
    Simulation,
)
from striatal.sim import kernel, online
from striatal.sim.rollout import OnlineLearning, Protocol, TrialRequest, run_trial, simulate

RANDOM_W = (0.55, -0.06, 0.39, 0.63, 0.08, 0.03)
RANDOM_START = Controller(RANDOM_W, 0.6)
AC = learners.default_config("ac")


def _online(
    W: tuple[float, ...],
    theta_c: float,
    sim: Simulation,
    seed: int | None,
    *,
    critic: np.ndarray | None = None,
    alpha: float = 0.0,
    beta: float = 0.0,
    discount: float = 0.99,
    critic_decay: float = 0.0,
    gamma: float = 0.99,
    max_step: float = math.inf,
    **kwargs: object,
) -> tuple[online.OnlineTrial, np.ndarray, np.ndarray]:
    trace = np.zeros(6)
    v = np.zeros(online.N_FEATURES) if critic is None else critic
    square = kwargs.pop("square", None)
    learning = OnlineLearning(
        alpha=alpha,
        beta=beta,
        discount=discount,
        critic_decay=critic_decay,
        max_step=max_step,
        w1_floor=kwargs.pop("w1_floor", 1e-3),  # type: ignore[arg-type]
        normalise=kwargs.pop("normalise", False),  # type: ignore[arg-type]
        square_rate=kwargs.pop("square_rate", 0.001),  # type: ignore[arg-type]
        critic=v,
        critic_trace=np.zeros(online.N_FEATURES),
        square=np.zeros(1) if square is None else square,  # type: ignore[arg-type]
    )
    result = online.online_trial(
        TrialRequest(
            Plant(),
            Controller(W, theta_c),
            sim,
            Protocol(),
            rng=None if seed is None else np.random.default_rng(seed),
            gains=np.array(W),
            trace=trace,
            gamma=gamma,
            online=learning,
            **kwargs,  # type: ignore[arg-type]
        )
    )
    return result, trace, v


CASES = [
    # (gains, theta_c, seed, kernel options): an early end at 30 s, a success at 60 s
    # (the mean policy), a noisy run of the final gains, and the force hold with held
    # actions, the printed eligibility and a model mismatch
    (RANDOM_W, 0.6, 3, {}),
    (CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C, None, {}),
    (CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C, 1, {}),
    (
        CHAPTER_FINAL_W,
        CHAPTER_FINAL_THETA_C,
        2,
        {
            "action_every": 2,
            "chapter_eligibility": True,
            "model": Plant(pole_mass=0.12),
            "hardware": Hardware(hold="force", max_force=20.0),
        },
    ),
]


@pytest.mark.parametrize(("W", "theta_c", "seed", "options"), CASES)
def test_with_zero_rates_the_online_trial_is_the_kernels_bit_for_bit(
    W: tuple[float, ...], theta_c: float, seed: int | None, options: dict[str, object]
) -> None:
    sim = Simulation()
    trace = np.zeros(6)
    want = run_trial(
        TrialRequest(
            Plant(),
            Controller(W, theta_c),
            sim,
            protocol=Protocol(),
            trace=trace,
            gamma=0.99,
            rng=None if seed is None else np.random.default_rng(seed),
            gains=np.array(W),
            **options,  # type: ignore[arg-type]
        )
    )
    got, got_trace, _ = _online(W, theta_c, sim, seed, **options)
    assert got.outcome == want
    assert [v.hex() for v in got_trace] == [v.hex() for v in trace]
    assert tuple(got.W) == W


def test_the_cases_cover_success_failure_and_an_early_end() -> None:
    reasons = {_online(W, tc, Simulation(), s, **o)[0].outcome.end_reason for W, tc, s, o in CASES}
    assert {"success", "early"} <= reasons and len(reasons) >= 3


def _features(state: np.ndarray, check_x: float = 3.0) -> np.ndarray:
    """The critic's features, written again in NumPy from online.features' docstring."""
    x, x_dot, theta, theta_dot = state
    plant = Plant()
    th = kernel.wrap_angles(theta)
    m, length, g = plant.pole_mass, plant.length, plant.gravity
    e_tilde = 0.5 * m * length**2 * theta_dot**2 + m * g * length * (np.cos(th) - 1.0)
    e = e_tilde / (2.0 * m * g * length)

    def sat(q: float) -> float:
        return q / (1.0 + q)

    return np.array(
        [
            1.0,
            0.5 * (1.0 - np.cos(th)),
            sat(e * e),
            sat((x / check_x) ** 2),
            sat(x_dot**2),
            sat(theta_dot**2 * length / g),
        ]
    )


def _cost(phi: np.ndarray) -> float:
    w = online.COST_WEIGHTS
    return float(w[0] * phi[1] + w[1] * phi[2] + w[2] * phi[3])


def test_one_step_delta_and_updates_equal_their_formulas() -> None:
    """delta = r + gamma_v V(s') - V(s), then W += alpha delta D and v += beta delta phi(s)."""
    sim = Simulation(duration=0.01)
    s0 = np.array([0.3, -0.2, 0.4, 0.5])
    v0 = np.array([-0.5, -0.8, -0.3, -0.2, 0.1, 0.05])
    alpha, beta, gamma_v = 0.3, 0.2, 0.98
    got, got_trace, v = _online(
        RANDOM_W, 0.6, sim, 7, critic=v0.copy(), alpha=alpha, beta=beta, discount=gamma_v, state0=s0
    )
    # by hand: the action, the trace of eq 3 and the step of the kernel
    eps = kernel.sigma_of(RANDOM_W[5]) * np.random.default_rng(7).standard_normal(1)[0]
    grad = np.zeros(5)
    mu = kernel.policy_mean(
        *s0, np.array(RANDOM_W), 0.6, 1.0, False, 0.0, Plant().as_array(), False, grad
    )
    sigma = kernel.sigma_of(RANDOM_W[5])
    D = np.array([*(eps * grad), (eps**2 - sigma**2) * (1.1 - sigma)])
    s1 = np.array(
        kernel.rk4_step(*s0, mu + eps, 0.01, Plant().as_array(), Plant().as_array(), False)
    )
    phi0, phi1 = _features(s0), _features(s1)
    r = -0.01 * _cost(phi1)
    delta = r + gamma_v * v0 @ phi1 - v0 @ phi0
    assert got.stats[online.STAT_N] == 1
    assert got.stats[online.STAT_SUM_DELTA] == pytest.approx(delta, rel=1e-12)
    assert got.stats[online.STAT_RETURN] == pytest.approx(r, rel=1e-12)
    assert got.stats[online.STAT_VALUE0] == pytest.approx(v0 @ phi0, rel=1e-12)
    np.testing.assert_allclose(got_trace, D, rtol=1e-12)
    np.testing.assert_allclose(v, v0 + beta * delta * phi0, rtol=1e-12)
    np.testing.assert_allclose(got.W, np.array(RANDOM_W) + alpha * delta * D, rtol=1e-12)
    assert abs(delta) > 1e-3 and np.all(np.abs(D[:3]) + np.abs(D[3:]) > 0)
    # normalised: the first step's mean square is delta^2, the factor delta / |delta|
    square = np.zeros(1)
    normed, _, _ = _online(
        RANDOM_W,
        0.6,
        sim,
        7,
        critic=v0.copy(),
        alpha=alpha,
        discount=gamma_v,
        state0=s0,
        normalise=True,
        square=square,
    )
    assert square[0] == pytest.approx(delta**2, rel=1e-12)
    np.testing.assert_allclose(normed.W, np.array(RANDOM_W) + alpha * np.sign(delta) * D)
    # a running mean square carried in: (1 - rate) sq + rate delta^2
    square = np.array([4.0 * delta**2])
    normed, _, _ = _online(
        RANDOM_W,
        0.6,
        sim,
        7,
        critic=v0.copy(),
        alpha=alpha,
        discount=gamma_v,
        state0=s0,
        normalise=True,
        square=square,
        square_rate=0.25,
    )
    assert square[0] == pytest.approx(3.25 * delta**2, rel=1e-12)
    np.testing.assert_allclose(
        normed.W, np.array(RANDOM_W) + alpha * delta / math.sqrt(3.25 * delta**2) * D
    )


def test_max_step_bounds_each_step_and_w1_keeps_its_floor() -> None:
    sim = Simulation(duration=0.01)
    s0 = np.array([0.3, -0.2, 0.4, 0.5])
    v0 = np.array([-0.5, -0.8, -0.3, -0.2, 0.1, 0.05])
    big, _, _ = _online(
        RANDOM_W, 0.6, sim, 7, critic=v0.copy(), alpha=1e6, max_step=0.01, state0=s0
    )
    assert np.max(np.abs(big.W - np.array(RANDOM_W))) == pytest.approx(0.01)
    low = (0.002, *RANDOM_W[1:])
    floored, _, _ = _online(
        low, 0.6, sim, 7, critic=v0.copy(), alpha=1e6, w1_floor=0.001, state0=s0
    )
    assert floored.W[0] >= 0.001


def test_a_trial_off_the_track_ends_in_the_failure_value() -> None:
    """The track is terminal: the last delta bootstraps from failure_value, not V(s')."""
    sim = Simulation(duration=5.0)
    v0 = np.zeros(online.N_FEATURES)
    got, _, _ = _online(
        RANDOM_W,
        0.6,
        sim,
        None,
        critic=v0,
        hardware=Hardware(track=1.0),
        state0=np.array([0.95, 2.0, 3.12, 0.0]),
    )
    assert got.outcome.track
    n = got.stats[online.STAT_N]
    # with v = 0 every delta is its reward, the last one the terminal's
    last = got.stats[online.STAT_SUM_DELTA] - got.stats[online.STAT_RETURN]
    assert last == pytest.approx(0.99 * online.failure_value(0.01, 0.99))
    assert n == round(got.outcome.ended_at / 0.01)


def test_critic_converges_to_the_td0_fixed_point_of_a_fixed_policy() -> None:
    """A free swing (W = 0 but W1's floor, mean policy, alpha = 0): the trial is the same
    every time, and online TD(0) converges to the values of the v* with
    sum_k phi_k delta_k(v*) = 0 (features collinear here, so values, not weights)."""
    W = (0.001, 0.0, 0.0, 0.0, 0.0, 0.0)
    sim = Simulation(duration=10.0, theta0=math.pi - 1.0)
    gamma_v = 0.95
    traj = simulate(Plant(), Controller(W, 0.2), sim)
    assert np.ptp(traj.states[:, 2]) > 1.9  # it swings, +-1 rad about hanging
    phi = np.array([_features(s) for s in traj.states])
    r = -0.01 * np.array([_cost(p) for p in phi[1:]])
    A = phi[:-1].T @ (phi[:-1] - gamma_v * phi[1:])
    b = phi[:-1].T @ r
    v_star = np.linalg.lstsq(A, b, rcond=None)[0]
    assert np.linalg.norm(A @ v_star - b) < 1e-9
    v = np.zeros(online.N_FEATURES)
    for _ in range(60):
        _online(W, 0.2, sim, None, critic=v, beta=0.05, discount=gamma_v)
    values, values_star = phi @ v, phi @ v_star
    # within 10 % of the values' spread along the swing (the zero critic is 6 spreads off)
    assert np.max(np.abs(values - values_star)) < 0.1 * np.ptp(values_star)
    assert np.max(np.abs(values_star)) > 5 * np.ptp(values_star) > 0.02


def test_critic_at_rest_learns_the_monte_carlo_return() -> None:
    """Hanging at rest, the mean policy never moves: V = -dt cost / (1 - gamma_v) exactly."""
    sim = Simulation(duration=20.0, theta0=math.pi)
    v = np.zeros(online.N_FEATURES)
    for _ in range(30):
        got, _, _ = _online(RANDOM_W, 0.6, sim, None, critic=v, beta=0.05, discount=0.95)
    phi = _features(np.array(sim.initial_state))
    want = -0.01 * _cost(phi) / (1.0 - 0.95)
    assert phi @ v == pytest.approx(want, rel=1e-6)
    assert got.outcome.min_abs_theta == pytest.approx(math.pi)


def test_online_trial_refuses_bad_rates() -> None:
    with pytest.raises(ParameterError, match="discount"):
        _online(RANDOM_W, 0.6, Simulation(duration=0.1), 0, discount=1.0)
    with pytest.raises(ParameterError, match="trace decay"):
        _online(RANDOM_W, 0.6, Simulation(duration=0.1), 0, critic_decay=1.5)
    with pytest.raises(ParameterError, match="shape"):
        _online(RANDOM_W, 0.6, Simulation(duration=0.1), 0, critic=np.zeros(3))


# ------------------------------------------------------------------ the rule in the loop


def _history(config: learners.LearnerConfig, seed: int) -> list[object]:
    rows: list[object] = []
    r = train(Plant(), RANDOM_START, config, seed, on_trial=lambda s, rec: rows.append(rec.row()))
    return [r.W, r.theta_c, r.memory, rows]


def test_ac_same_seed_same_history() -> None:
    cfg = replace(AC, max_trials=6)
    assert _history(cfg, 3) == _history(cfg, 3)
    assert _history(cfg, 3) != _history(cfg, 4)


def test_ac_learns_within_the_trial_and_its_control_does_not() -> None:
    cfg = replace(AC, max_trials=4)
    rows: list[learners.TrialRecord] = []
    r = train(Plant(), RANDOM_START, cfg, seed=1, on_trial=lambda s, rec: rows.append(rec))
    assert RANDOM_START.gains != r.W
    # each trial's start W is the previous trial's end W
    assert len({rec.W for rec in rows}) == len(rows)
    control = learners.control_config(cfg)
    assert control.alpha == 0.0 and control.critic_rate == cfg.critic_rate
    c_rows: list[learners.TrialRecord] = []
    still = train(
        Plant(), RANDOM_START, control, seed=1, on_trial=lambda s, rec: c_rows.append(rec)
    )
    assert RANDOM_START.gains == still.W and not still.success
    # the critic learns in the control too, and the first trial is the learning run's
    norms = [dict(rec.extra)["critic_norm"] for rec in c_rows]
    assert norms[0] > 0 and len(set(norms)) == len(norms)
    assert c_rows[0].reward == rows[0].reward and c_rows[0].ended_at == rows[0].ended_at
    from striatal.experiments.runner import control_note

    assert control_note("ac").endswith("the critic still learns (it is not part of the controller)")
    assert "critic" not in control_note("chapter")


def test_ac_resume_from_state_equals_uninterrupted_run() -> None:
    cfg = replace(AC, max_trials=10)
    full = train(Plant(), RANDOM_START, cfg, seed=5)
    half = train(Plant(), RANDOM_START, replace(cfg, max_trials=4), seed=5)
    state = type(half).from_dict(json.loads(json.dumps(half.to_dict())))
    resumed = train(Plant(), RANDOM_START, cfg, seed=5, state=state)
    assert resumed.to_dict() == full.to_dict()
    assert len(full.get("critic")) == online.N_FEATURES


def test_ac_on_success_keeps_the_gains_it_was_judged_on() -> None:
    """Started from the chapter's final gains, the mean-policy check passes on trial 1:
    the result is that W, not the W the exploring trial drifted to."""
    start = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    r = train(Plant(), start, replace(AC, alpha=0.05, max_trials=3), seed=0)
    assert r.success and r.trials_done == 1
    assert r.W == CHAPTER_FINAL_W and r.theta_c == CHAPTER_FINAL_THETA_C
    assert r.simulations == 2


def test_ac_history_columns_and_options() -> None:
    assert learners.RULES["ac"].history_columns == (
        "sigma",
        "return",
        "mean_delta",
        "critic_norm",
    )
    rows: list[learners.TrialRecord] = []
    train(Plant(), RANDOM_START, replace(AC, max_trials=2), 0, on_trial=lambda s, r: rows.append(r))
    assert rows[0].columns[9:13] == learners.RULES["ac"].history_columns
    extra = dict(rows[0].extra)
    assert extra["return"] < 0 and math.isfinite(extra["mean_delta"])
    # the rule refuses the options it does not read, and the others refuse its own
    with pytest.raises(ParameterError, match="does not use"):
        learners.default_config("ac", reward="shaped")
    with pytest.raises(ParameterError, match="does not use critic_rate"):
        learners.default_config("pgpe", critic_rate=0.5)
    with pytest.raises(ParameterError, match="td_discount"):
        learners.default_config("ac", td_discount=1.0)


def test_cli_train_ac_writes_its_history(tmp_path: object) -> None:
    out = f"{tmp_path}/run"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "striatal",
            "train",
            "--learner",
            "ac",
            "--init",
            "random",
            "--seed",
            "2",
            "--max-trials",
            "3",
            "--critic-rate",
            "0.02",
            "--out",
            out,
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["learner"] == "ac" and result["trials"] == 3
    from striatal.io.rundir import read_history

    h = read_history(f"{out}/history.csv")
    assert len(h) == 3 and "critic_norm" in h.columns


def test_learning_curves_show_the_ac_columns(tmp_path: object) -> None:
    """striatal curves: a panel for each of ac's columns, holding the history's values."""
    pytest.importorskip("matplotlib")
    import striatal
    from striatal.viz import plots

    run = striatal.train(learner="ac", init="random", seed=0, max_trials=3, out=f"{tmp_path}/a")
    h = plots.read_history(f"{tmp_path}/a/history.csv")
    assert h.learner == "ac" and h.reward_kind == "sparse"
    fig = plots.learning_curves(h, window=2)
    panels = fig.axes[3:7]
    assert [ax.get_title() for ax in panels] == [
        plots.RULE_PANELS[c][1] for c in ("sigma", "return", "mean_delta", "critic_norm")
    ]
    np.testing.assert_allclose(
        panels[3].get_lines()[0].get_ydata(), run.history.column("critic_norm"), rtol=1e-12
    )
    assert np.all(run.history.column("critic_norm") > 0)
    assert set(h.reward) <= {10.0, 0.0, -5.0}


def test_ac_resumes_through_its_checkpoint_file_to_the_uninterrupted_run(
    tmp_path: object,
) -> None:
    """striatal.train(out=...) stopped after 5 trials, checkpointed every 2, then resumed:
    the critic, the rms of delta and the generator come back from checkpoint.json."""
    import striatal

    kw = {"learner": "ac", "init": "random", "seed": 6, "max_trials": 9, "checkpoint_every": 2}
    full = striatal.train(out=f"{tmp_path}/full", **kw)  # type: ignore[arg-type]
    n = {"trials": 0}

    def stop() -> bool:
        n["trials"] += 1
        return n["trials"] == 5

    cut = striatal.train(out=f"{tmp_path}/cut", should_stop=stop, **kw)  # type: ignore[arg-type]
    assert cut.interrupted and cut.trials == 5
    resumed = striatal.train(out=f"{tmp_path}/cut", resume=True)
    assert resumed.history == full.history and resumed.W == full.W
    from pathlib import Path

    assert '"critic"' in Path(f"{tmp_path}/cut/checkpoint.json").read_text(encoding="utf-8")
    with (
        open(f"{tmp_path}/cut/history.csv", "rb") as a,
        open(f"{tmp_path}/full/history.csv", "rb") as b,
    ):
        assert a.read() == b.read()
