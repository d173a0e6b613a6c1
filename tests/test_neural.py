"""The spiking controller: decoded means against the rate controller, pathway signs,
the gates against the hard switch, the plant Node against the kernel, a swing-up."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from striatal.cli import main
from striatal.errors import ParameterError
from striatal.neural.interpret import balancing_terms, swingup_terms
from striatal.params import Controller, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.rollout import simulate

nengo = pytest.importorskip("nengo")

from striatal.neural.network import NetworkConfig, build, criterion  # noqa: E402
from striatal.neural.run import (  # noqa: E402
    KernelPlant,
    held_state_response,
    run_network,
    upright_throughout,
)

CTRL = Controller()
PLANT = Plant()


def rate_mean(state: np.ndarray, controller: Controller = CTRL) -> float:
    """kernel.policy_mean with the hard switch: the rate controller's mean action."""
    p = PLANT.as_array()
    return kernel.policy_mean(
        state[0],
        state[1],
        state[2],
        state[3],
        np.array(controller.gains),
        controller.theta_c,
        controller.sign,
        False,
        50.0,
        p,
        False,
        np.zeros(5),
    )


def test_connection_signs_are_the_interpret_pathways() -> None:
    h = build(CTRL, PLANT, NetworkConfig(neurons=300), seed=0)
    expected = {("mu_1", t.signal): t for t in balancing_terms(CTRL.gains, PLANT, CTRL.sign)}
    expected.update({("mu_2", t.signal): t for t in swingup_terms(CTRL.gains)})
    seen = set()
    for channel, term, conn in h.pathways:
        want = expected[(channel, term.signal)]
        seen.add((channel, term.signal))
        transform = float(np.asarray(conn.transform.init).ravel()[0])
        # the sign of the projection is the pathway: excitatory = direct, inhibitory = indirect
        assert math.copysign(1.0, transform) == math.copysign(1.0, want.coefficient)
        assert ("direct" if transform > 0 else "indirect") == want.pathway
        assert want.pathway in conn.label
        assert conn.post_obj is (h.mu_1 if channel == "mu_1" else h.mu_2)
    assert seen == set(expected)
    # chapter's final gains, corrected sign: theta, theta_dot, x, x_dot all direct in mu_1;
    # mu_2's cart terms indirect
    labels = {(c, t.signal): t.pathway for c, t, _ in h.pathways}
    assert labels[("mu_1", "theta")] == "direct"
    assert labels[("mu_2", "x_dot")] == "indirect"


def test_printed_sign_flips_the_theta_pathways() -> None:
    printed = Controller(balance_sign="chapter")
    h = build(printed, PLANT, NetworkConfig(neurons=300), seed=0)
    labels = {(c, t.signal): t.pathway for c, t, _ in h.pathways}
    assert labels[("mu_1", "theta")] == "indirect"
    assert labels[("mu_1", "theta_dot")] == "indirect"


@pytest.fixture(scope="module")
def sampled_states() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    n = 8
    balancing = np.column_stack(
        [
            rng.uniform(-3, 3, n),
            rng.uniform(-2, 2, n),
            rng.uniform(-0.6, 0.6, n),
            rng.uniform(-1.5, 1.5, n),
        ]
    )
    swing = np.column_stack(
        [
            rng.uniform(-3, 3, n),
            rng.uniform(-2, 2, n),
            rng.uniform(1.4, math.pi, n) * rng.choice([-1.0, 1.0], n),
            rng.uniform(-5, 5, n),
        ]
    )
    return balancing, swing


@pytest.fixture(scope="module")
def responses(sampled_states: tuple[np.ndarray, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
    balancing, swing = sampled_states
    states = np.vstack([balancing, swing])
    r = held_state_response(CTRL, PLANT, NetworkConfig(neurons=1500), 2, states)
    n = balancing.shape[0]
    return {
        "balancing": {k: v[:n] for k, v in r.items()},
        "swing": {k: v[n:] for k, v in r.items()},
    }


def test_decoded_mu_1_matches_the_rate_controller(sampled_states, responses) -> None:
    balancing, _ = sampled_states
    want = np.array([rate_mean(s) for s in balancing])
    got = responses["balancing"]["mu_1"]
    # mu_1 spans about +-25 m/s^2 here; the network decodes it within 1.2 m/s^2 (rms)
    rms = float(np.sqrt(np.mean((got - want) ** 2)))
    assert rms < 1.2, (got, want)
    assert np.corrcoef(got, want)[0, 1] > 0.98
    # the closed swing-up channel contributes nothing while balancing
    assert np.all(np.abs(responses["balancing"]["mu_2"]) < 0.1)


def test_decoded_mu_2_matches_the_rate_controller(sampled_states, responses) -> None:
    _, swing = sampled_states
    want = np.array([rate_mean(s) for s in swing])
    got = responses["swing"]["mu_2"]
    rms = float(np.sqrt(np.mean((got - want) ** 2)))
    assert rms < 0.4, (got, want)
    assert np.corrcoef(got, want)[0, 1] > 0.9
    assert np.all(np.abs(responses["swing"]["mu_1"]) < 0.1)


def test_gates_follow_the_hard_switch() -> None:
    # |theta| away from theta_c by more than the criterion's width 1/gamma
    theta_c = CTRL.theta_c
    thetas = np.array([0.0, 0.3, 0.7, -0.75, 1.1, -1.5, 2.5, math.pi - 0.05])
    states = np.column_stack([np.zeros(8), np.zeros(8), thetas, np.zeros(8)])
    for selection in ("cerebellum", "basal-ganglia"):
        r = held_state_response(
            CTRL, PLANT, NetworkConfig(neurons=600, selection=selection), 0, states, hold=0.3
        )
        balancing = np.abs(thetas) < theta_c
        # the gate of the open channel is silent, the other one active
        assert np.all(r["gate_balancing"][balancing] < 0.15), (selection, r)
        assert np.all(r["gate_balancing"][~balancing] > 0.5), (selection, r)
        assert np.all(r["gate_swing-up"][~balancing] < 0.15), (selection, r)
        assert np.all(r["gate_swing-up"][balancing] > 0.5), (selection, r)


def test_criterion_is_the_hard_switch_at_high_gain() -> None:
    for a in np.linspace(0.0, math.pi, 50):
        c = criterion(a, 0.9, 1e6)
        if abs(a - 0.9) > 1e-3:
            assert c == (1.0 if a < 0.9 else -1.0)
    assert criterion(0.9, 0.9, 20.0) == 0.0
    assert criterion(0.85, 0.9, 20.0) == pytest.approx(1.0)


def test_plant_node_is_the_kernel() -> None:
    p = PLANT.as_array()
    node = KernelPlant(np.array([0.1, 0.0, 3.0, 0.2]), PLANT, 0.001, 50)
    x = [0.1, 0.0, 3.0, 0.2]
    for k in range(50):
        u = 0.5 * math.sin(k)
        out = node(k * 0.001, np.array([u]))
        x = list(kernel.rk4_step(*x, u, 0.001, p, p, False))
        np.testing.assert_array_equal(node.states[k + 1], x)
        np.testing.assert_array_equal(out, [x[0], x[1], math.sin(x[2]), math.cos(x[2]), x[3]])


def test_upright_throughout() -> None:
    t = np.arange(0, 20.001, 0.01)
    th = np.full_like(t, 2 * math.pi + 0.05)  # wraps to 0.05
    assert upright_throughout(t, th)
    th[-500] = 0.2
    assert not upright_throughout(t, th)
    th[-500] = 0.05
    th[100] = 3.0  # before the last 10 s: does not count
    assert upright_throughout(t, th)


def test_config_rejects_bad_values() -> None:
    with pytest.raises(ParameterError):
        NetworkConfig(neurons=10)
    with pytest.raises(ParameterError):
        NetworkConfig(synapse=0.0)
    with pytest.raises(ParameterError):
        NetworkConfig(selection="thalamus")  # type: ignore[arg-type]
    with pytest.raises(ParameterError):
        NetworkConfig(optimize=1)  # type: ignore[arg-type]
    assert sum(NetworkConfig(neurons=2000).sizes().values()) == pytest.approx(2000, abs=5)


def test_balancing_near_upright_follows_the_rate_controller() -> None:
    """From theta = 0.3 the balancing channel brings the pole up as the rate law does."""
    sim = Simulation(theta0=0.3, duration=8.0)
    r = run_network(CTRL, PLANT, sim, NetworkConfig(neurons=1000), seed=0)
    rate = simulate(PLANT, CTRL, sim).data
    assert not r.fault
    assert r.neurons == sum(NetworkConfig(neurons=1000).sizes().values())
    # same angle trajectory within 0.06 rad (decoding error and synaptic lag)
    assert np.max(np.abs(r.data[:, 3] - rate[:, 3])) < 0.06
    assert np.all(np.abs(r.data[-200:, 3]) < 0.05)
    assert np.all(r.data[:, 7] == kernel.MODE_BALANCE)


def test_printed_sign_network_drops_the_pole() -> None:
    """The printed balancing sign (docs/paper-notes.md section 1) does not hold the pole."""
    sim = Simulation(theta0=0.3, duration=4.0)
    r = run_network(
        Controller(balance_sign="chapter"), PLANT, sim, NetworkConfig(neurons=600), seed=0
    )
    assert np.max(np.abs(r.data[:, 3])) > CTRL.theta_c


@pytest.mark.slow
def test_swing_up_reaches_upright() -> None:
    """The chapter's final gains swing the pole up from 3.12 rad and balance it (30 s)."""
    r = run_network(CTRL, PLANT, Simulation(duration=30.0), NetworkConfig(neurons=1500), seed=1)
    assert r.switch_times, "never reached theta_c"
    assert 15.0 < r.switch_times[0] < 25.0
    th = np.array([kernel.wrap_angle(v) for v in r.data[-500:, 3]])
    assert np.all(np.abs(th) < 0.1)


def test_cli_json_and_files(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    rc = main(
        [
            "neural",
            "--duration",
            "1",
            "--neurons",
            "300",
            "--seed",
            "2",
            "--json",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    assert data["neurons"] == sum(NetworkConfig(neurons=300).sizes().values())
    assert data["upright_last_10s"] is False
    assert {"success", "wall_per_sim_second", "settings"} <= set(data)
    assert data["settings"]["network"]["nengo_optimize"] is False  # one seed, one result
    assert data["simulator"] == data["settings"]["network"]["simulator"] == "nengo"
    assert "backend" not in data and "backend" not in data["settings"]["network"]
    assert data["settings"]["integrator"].startswith("kernel.rk4_step")
    rows = (out / "trajectory.csv").read_text().splitlines()
    assert rows[0] == "t,x,x_dot,theta,theta_dot,u,force,mode"
    assert len(rows) == 1 + 101
    assert (out / "activity.png").stat().st_size > 1000
    assert json.loads((out / "summary.json").read_text())["seed"] == 2


@pytest.mark.parametrize(
    "argv",
    [
        ["--neurons", "3"],
        ["--gains", "1", "0", "0", "0", "0", "0"],
        ["--duration", "0"],
        ["--seed", "-1"],
        ["--synapse", "-0.1"],
        ["--chapter-final", "--result", "r.json"],
    ],
)
def test_cli_bad_input_exits_2(argv, capsys) -> None:
    assert main(["neural", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error" in err


def test_recording_rates_does_not_change_the_network() -> None:
    """A seed names one network whether or not the populations' rates are recorded."""
    sim = Simulation(duration=0.5)
    a, b = (
        run_network(CTRL, PLANT, sim, NetworkConfig(neurons=300), seed=4, record_rates=rec)
        for rec in (True, False)
    )
    np.testing.assert_allclose(a.data, b.data, rtol=0, atol=1e-12)
    assert a.rates.shape == (50, len(a.populations)) and a.rates.sum() > 0
    assert b.rates.sum() == 0


def test_a_seed_gives_the_same_bits_run_after_run() -> None:
    """nengo's operator merging orders a signal's sums by the objects' memory addresses;
    with it on (optimize=True) two of three runs like these differed from the first by
    1e-16..1e-15 within milliseconds. Off (the default), one seed is one trajectory."""
    sim = Simulation(duration=3.0)
    cfg = NetworkConfig(neurons=300)
    runs = [run_network(CTRL, PLANT, sim, cfg, seed=1, record_rates=False) for _ in range(4)]
    for r in runs[1:]:
        assert np.array_equal(r.data, runs[0].data)
    other = run_network(CTRL, PLANT, sim, cfg, seed=2, record_rates=False)
    assert not np.array_equal(other.data, runs[0].data)


# --------------------------------------------------------------------------- dopamine stage

from striatal.learners.chapter import gain_update  # noqa: E402
from striatal.neural.driver import learn_network  # noqa: E402
from striatal.neural.learn import (  # noqa: E402
    PATHWAYS,
    Eligibility,
    coefficient_jacobian,
    gain_eligibility,
    gains_from_transforms,
    network_transforms,
    pathway_coefficients,
)
from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W  # noqa: E402

START = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
SHORT = Simulation(duration=0.6)


def test_eligibility_node_accumulates_pre_times_exploration_per_draw() -> None:
    # two draws of two network steps each: eps = sigma n_k, held; E <- eps pre + gamma E
    node = Eligibility(sigma=0.5, noise=np.array([1.0, -2.0]), gamma=0.9, every=2)
    pre = [np.arange(1.0, 8.0), np.full(7, 9.0), -np.arange(1.0, 8.0), np.full(7, 9.0)]
    eps = [float(node(0.001 * (k + 1), p)[0]) for k, p in enumerate(pre)]
    assert eps == [0.5, 0.5, -1.0, -1.0]
    # the trace samples pre at each draw (steps 0 and 2), not in between
    want = -1.0 * pre[2] + 0.9 * (0.5 * pre[0])
    np.testing.assert_allclose(node.trace, want, rtol=1e-12)
    s = 0.5
    want6 = (1.0 - s * s) * (1.1 - s) + 0.9 * ((0.25 - s * s) * (1.1 - s))
    assert node.sigma_trace == pytest.approx(want6, rel=1e-12)
    # past the last draw the exploration stops and the trace stays
    assert float(node(0.005, pre[0])[0]) == 0.0
    np.testing.assert_allclose(node.trace, want, rtol=1e-12)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_pathway_traces_give_the_rate_learners_eligibility(sign: float) -> None:
    # J^T applied to the terms' signals is kernel.policy_mean's d mu / d W (eq 3's e / eps)
    W = np.array(CHAPTER_INITIAL_W)
    p = PLANT.as_array()
    for state, theta_c in (([0.3, -0.2, 0.1, 0.4], 0.6), ([0.5, 0.7, 2.5, -1.5], 0.6)):
        x, xd, th, thd = state
        grad = np.zeros(5)
        kernel.policy_mean(x, xd, th, thd, W, theta_c, sign, False, 50.0, p, False, grad)
        balancing = abs(th) < theta_c
        e = kernel.energy_error(th, thd, p)
        s = np.array(
            [th, thd, x, xd, 0.0, 0.0, 0.0]
            if balancing
            else [0.0, 0.0, 0.0, 0.0, e * thd * math.cos(th), x, xd]
        )
        D = gain_eligibility(s, 0.0, W, PLANT, sign)
        np.testing.assert_allclose(D[:5], grad, rtol=1e-12, atol=1e-12)
    # and J is the derivative of c(W) (central differences)
    J = coefficient_jacobian(W, PLANT, sign)
    for j in range(5):
        d = np.zeros(6)
        d[j] = 1e-6
        fd = pathway_coefficients(W + d, PLANT, sign) - pathway_coefficients(W - d, PLANT, sign)
        np.testing.assert_allclose(J[:, j], fd / 2e-6, rtol=1e-6, atol=1e-8)


def test_network_transforms_and_gains_round_trip() -> None:
    for W, sign in ((CHAPTER_INITIAL_W, 1.0), (CTRL.gains, -1.0)):
        ctrl = Controller(gains=W, theta_c=0.6, balance_sign="corrected" if sign > 0 else "chapter")
        h = build(ctrl, PLANT, NetworkConfig(neurons=300), seed=0)
        assert tuple((ch, t.signal) for ch, t, _ in h.pathways) == PATHWAYS
        c = network_transforms(h)
        np.testing.assert_allclose(c, pathway_coefficients(W, PLANT, sign), rtol=1e-12)
        back = gains_from_transforms(c, W[5], PLANT, sign)
        np.testing.assert_allclose(back, W, rtol=1e-12, atol=1e-12)
    # transforms that no W produces are refused (c_thetadot inconsistent with c_theta)
    bad = pathway_coefficients(CHAPTER_INITIAL_W, PLANT)
    bad[1] *= 1.1
    with pytest.raises(ParameterError, match="not the coefficients of one W"):
        gains_from_transforms(bad, 0.0, PLANT)


def test_update_is_alpha_times_dopamine_times_eligibility() -> None:
    # hand-made traces: a positive dopamine (r - b > 0) moves W along D, a dip against it
    W = np.array(CHAPTER_INITIAL_W)
    E = np.array([0.2, -0.1, 0.3, 0.05, 2.0, -0.4, 0.6])
    D = gain_eligibility(E, -0.3, W, PLANT)
    J = coefficient_jacobian(W, PLANT)
    np.testing.assert_allclose(D, [*(J.T @ E), -0.3])
    for reward, baseline in ((10.0, 0.0), (-5.0, 0.0), (10.0, 12.0)):
        new = gain_update(
            W, D, reward, alpha=5.0, gamma=0.999, baseline=baseline, max_step=1.0, w1_floor=1e-3
        )
        np.testing.assert_allclose(new - W, 5.0 * 0.001 * (reward - baseline) * D, rtol=1e-12)
        assert np.all(np.sign(new - W) == np.sign(reward - baseline) * np.sign(D))


def test_network_learning_trial_updates_by_its_own_trace_and_reward() -> None:
    r = learn_network(START, PLANT, SHORT, NetworkConfig(neurons=300), 2, trials=2)
    assert len(r.trials) == 2
    t1, t2 = r.trials
    assert START.gains == t1.W
    assert t1.reward == -5.0  # 0.6 s from the bottom: eq 25's failure
    step = 5.0 * (1.0 - 0.999) * (t1.reward - 0.0) * np.array(t1.eligibility)
    np.testing.assert_allclose(np.array(t2.W) - np.array(t1.W), np.clip(step, -1.0, 1.0))
    assert np.any(np.abs(step) > 1e-6)  # the trace is not empty: learning happened
    # the transforms the second trial ran with are c(W(2))
    np.testing.assert_allclose(t2.transforms, pathway_coefficients(t2.W, PLANT), rtol=1e-12)
    # the pump trace is what moved W4 (eq 23's E~ theta_dot cos theta, swing-up channel open)
    assert t1.pathway_trace[4] != 0.0


def test_no_dopamine_leaves_the_weights() -> None:
    r = learn_network(START, PLANT, SHORT, NetworkConfig(neurons=300), 2, trials=2, alpha=0.0)
    for t in r.trials:
        assert START.gains == t.W
        np.testing.assert_allclose(t.transforms, pathway_coefficients(START.gains, PLANT))
    assert START.gains == r.W


def test_network_learning_is_deterministic_under_a_seed() -> None:
    cfg = NetworkConfig(neurons=300)
    a = learn_network(START, PLANT, SHORT, cfg, 4, trials=2)
    b = learn_network(START, PLANT, SHORT, cfg, 4, trials=2)
    c = learn_network(START, PLANT, SHORT, cfg, 5, trials=2)
    assert [t.W for t in a.trials] == [t.W for t in b.trials]
    assert [t.pathway_trace for t in a.trials] == [t.pathway_trace for t in b.trials]
    assert a.W == b.W
    assert a.W != c.W


def test_exploration_subnetwork_leaves_the_network_unchanged() -> None:
    # zero exploration: the same trajectory as the plain run, so the wiring changes no seed
    sim = Simulation(theta0=0.3, duration=0.4)
    cfg = NetworkConfig(neurons=300)
    plain = run_network(START, PLANT, sim, cfg, 3, record_rates=False)

    class Quiet(Eligibility):
        def __init__(self, *args: object) -> None:
            super().__init__(*args)  # type: ignore[arg-type]
            self.seen: list[np.ndarray] = []

        def __call__(self, t: float, pre: np.ndarray) -> np.ndarray:
            self.seen.append(np.array(pre))
            return super().__call__(t, pre)

    quiet = Quiet(0.5, np.zeros(sim.n_steps), 0.999, 10)
    wired = run_network(START, PLANT, sim, cfg, 3, record_rates=False, exploration=quiet)
    np.testing.assert_allclose(wired.data[:, 1:5], plain.data[:, 1:5], rtol=0, atol=1e-12)
    # the presynaptic signals did reach the Node: near upright the balancing theta
    # pathway carries theta (0.3 rad, the balancing channel open), the swing-up one ~0
    late = np.mean(quiet.seen[-50:], axis=0)
    assert late[0] == pytest.approx(wired.data[-1, 3], abs=0.1)
    assert abs(late[4]) < 0.2


def test_learning_rejects_long_trials_and_bad_counts() -> None:
    with pytest.raises(ParameterError, match="at most 30 s"):
        learn_network(
            START, PLANT, Simulation(duration=31.0), NetworkConfig(neurons=300), 0, trials=1
        )
    with pytest.raises(ParameterError, match="trials"):
        learn_network(START, PLANT, SHORT, NetworkConfig(neurons=300), 0, trials=0)


def test_cli_learn_json_and_files(tmp_path, capsys) -> None:
    out = tmp_path / "learn"
    argv = [
        "neural",
        "--chapter-initial",
        "--learn",
        "--trials",
        "2",
        "--duration",
        "0.6",
        "--neurons",
        "300",
        "--seed",
        "2",
        "--json",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["trials_run"] == 2 and got["W0"] == list(CHAPTER_INITIAL_W)
    assert got["history"][1]["W"] != got["history"][0]["W"]  # the first update happened
    rows = (out / "learn_history.csv").read_text().splitlines()
    assert rows[0].startswith("trial,reward,W1") and len(rows) == 3
    assert json.loads((out / "learn_summary.json").read_text())["W"] == got["W"]


@pytest.mark.parametrize(
    "argv",
    [
        ["--chapter-initial", "--learn", "--duration", "40"],
        ["--chapter-initial", "--learn", "--trials", "0", "--duration", "1"],
        ["--chapter-initial", "--alpha", "1"],
        ["--chapter-initial", "--learn", "--alpha", "-1", "--duration", "1"],
    ],
)
def test_cli_learn_bad_input_exits_2(argv, capsys) -> None:
    try:  # the parser's refusals (--trials 0) exit from it, the command's return 2
        code = main(["neural", *argv])
    except SystemExit as stop:
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1


def test_a_request_runs_on_the_network_with_its_own_gains_and_threshold(monkeypatch) -> None:
    """The learning loop passes a trial's W and theta_c in the request (``gains``,
    ``theta_c``), not in its controller template: the network runs with those."""
    from striatal.neural import driver
    from striatal.sim.rollout import Protocol, TrialRequest

    class RanError(Exception):
        pass

    seen: list[Controller] = []

    def fake_run(controller: Controller, *args: object, **kwargs: object) -> None:
        seen.append(controller)
        raise RanError

    monkeypatch.setattr(driver, "run_network", fake_run)
    W = (0.9, -0.2, -0.7, 0.4, 0.6, 0.3)
    r = TrialRequest(PLANT, START, SHORT, Protocol(), gains=np.array(W), theta_c=0.75)
    with pytest.raises(RanError):
        driver.run_request(r, NetworkConfig(neurons=300), 0, "nengo")
    assert seen[0].gains == W and seen[0].theta_c == 0.75
    moved = TrialRequest(PLANT, START, SHORT, Protocol(), state0=np.zeros(4))
    with pytest.raises(ParameterError, match="chapter's trial only"):
        driver.run_request(moved, NetworkConfig(neurons=300), 0, "nengo")
