"""The Brian2 simulator: its plant against the kernel, the same network as nengo's, the
dopamine update against the rate learner's, and the line a machine without Brian2 gets.

The compiled program (2 500 neurons, 30-s runs) is compiled once per test session and
machine (the cache); every test here reuses it through ``run_network``'s program.
"""

from __future__ import annotations

import json
import math
import shutil
import sys
from typing import Any

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.learners import default_config
from striatal.learners.chapter import ChapterConfig, chapter_gain_update
from striatal.learners.config import pick
from striatal.params import Controller, Hardware, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.rollout import simulate

pytestmark = pytest.mark.skipif(
    shutil.which("c++") is None and shutil.which("g++") is None,
    reason="Brian2's standalone mode compiles C++: needs a C++ compiler",
)
nengo = pytest.importorskip("nengo")
b2 = pytest.importorskip("brian2")
from brian2.devices.device import reset_device  # noqa: E402

from striatal.neural.brian import BRIAN2_INSTALL, FORCE_OF_U, PLANT_EQUATIONS  # noqa: E402
from striatal.neural.driver import NeuralLearning, learn_network  # noqa: E402
from striatal.neural.interpret import pathway_coefficients  # noqa: E402
from striatal.neural.learn import Eligibility, gain_eligibility  # noqa: E402
from striatal.neural.network import NetworkConfig  # noqa: E402
from striatal.neural.run import NeuralRun, frozen_at_fault, run_network  # noqa: E402
from striatal.neural.translate import translate  # noqa: E402

CTRL = Controller()
PLANT = Plant()
#: One run length for every compiled run here: one program to compile.
SIM = Simulation(theta0=3.12, duration=30.0, dt=0.01)
SEED = 1


@pytest.fixture(scope="module")
def brian_run() -> NeuralRun:
    """Seed 1 of the chapter's final gains on the Brian2 simulator, 30 s (compiles once)."""
    return run_network(CTRL, PLANT, SIM, NetworkConfig(), SEED, simulator="brian2")


def first_switch(run: NeuralRun) -> float:
    return run.switch_times[0] if run.switch_times else math.inf


def swing_gain(run: NeuralRun, until: float = 15.0) -> float:
    """Slope of the network's u on the rate controller's swing-up mean mu_2 (eq 23) along
    the run's own states, over the swing-up before ``until`` s: 1 for a lossless readout."""
    d = run.data
    keep = (d[:, 0] > 1.0) & (d[:, 0] < until) & (d[:, 7] == kernel.MODE_SWINGUP)
    x, xd, th, thd, u = (d[keep, k] for k in (1, 2, 3, 4, 5))
    c = pathway_coefficients(CTRL.gains, PLANT, CTRL.sign)
    m, length, g = PLANT.pole_mass, PLANT.length, PLANT.gravity
    energy = 0.5 * m * length**2 * thd**2 + m * g * length * (np.cos(th) - 1.0)
    mu_2 = c[4] * energy * thd * np.cos(th) + c[5] * x + c[6] * xd
    return float(np.polyfit(mu_2, u, 1)[0])


def test_missing_brian2_gets_one_line_naming_the_extra(
    cli: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "brian2", None)  # import brian2 raises ImportError
    code, out, err = cli(  # type: ignore[operator]
        "neural", "--simulator", "brian2", "--chapter-final", "--duration", "0.01"
    )
    assert code == 2 and out == ""
    assert err.strip().splitlines() == [f"striatal neural: error: {BRIAN2_INSTALL}"] or (
        len(err.strip().splitlines()) == 1 and "pip install 'striatal[neural]'" in err
    )


def test_missing_brian2_on_the_runner_path_gets_one_line_and_writes_nothing(
    cli: object, monkeypatch: pytest.MonkeyPatch, tmp_path: object
) -> None:
    from pathlib import Path

    monkeypatch.setitem(sys.modules, "brian2", None)
    out = Path(str(tmp_path)) / "sweep"
    code, stdout, err = cli(  # type: ignore[operator]
        "neural", "--simulator", "brian2", "--chapter-initial", "--learn", "--seeds", "2",
        "--trials", "1", "--duration", "1", "--no-progress", "--out", str(out),
    )  # fmt: skip
    assert code == 2 and stdout == ""
    assert len(err.strip().splitlines()) == 1 and "pip install 'striatal[neural]'" in err
    assert not (out / "runs.csv").exists()


def test_basal_ganglia_selection_is_refused() -> None:
    with pytest.raises(ParameterError, match="cerebellar switch only"):
        translate(CTRL, PLANT, NetworkConfig(neurons=300, selection="basal-ganglia"), 0)


def test_a_seeds_translation_for_new_gains_and_theta_c_equals_a_full_build() -> None:
    """The process keeps a seed's build; another W and theta_c re-solves only the switch's
    decoders. Every array equals a full build at that W and theta_c (a fresh process's
    translation), and the switch's decoders did change."""
    from dataclasses import fields

    from striatal.neural.translate import forget_builds

    config = NetworkConfig(neurons=300)
    first = translate(CTRL, PLANT, config, 3)  # builds seed 3 at CTRL.theta_c
    other = Controller(gains=(0.9, -0.5, -0.7, 0.4, 0.6, 0.3), theta_c=0.83)
    fast = translate(other, PLANT, config, 3)
    forget_builds()
    full = translate(other, PLANT, config, 3)
    for f in fields(full):
        a, b = getattr(fast, f.name), getattr(full, f.name)
        assert np.array_equal(a, b), f.name
    assert not np.array_equal(first.spike_w, fast.spike_w)
    assert np.array_equal(first.enc_w, fast.enc_w) and np.array_equal(first.bias, fast.bias)
    back = translate(CTRL, PLANT, config, 3)  # and back to the first theta_c
    assert np.array_equal(back.spike_w, first.spike_w)
    with pytest.raises(ParameterError):
        translate(Controller(gains=(-0.1, 0, 0, 0, 0, 0.3), theta_c=0.6), PLANT, config, 3)


def test_brian2_plant_equals_the_kernel_over_60_s() -> None:
    """The program's plant equations (eqs 8-10, the force of eq 12 held per step) under the
    rate controller's mean (eqs 22-23, hard switch at theta_c), written as Brian2 code and
    run by Brian2's numpy target, against the kernel holding the force (Hardware(hold=
    "force")): the same gains, start and 10-ms step; 60 s within 1e-8."""
    sim = Simulation(theta0=3.12, duration=60.0, dt=0.01)
    ref = simulate(PLANT, CTRL, sim, hardware=Hardware(hold="force"))
    c = pathway_coefficients(CTRL.gains, PLANT, CTRL.sign)
    ns = {f"c{i}": float(v) for i, v in enumerate(c)}
    ns.update(theta_c=CTRL.theta_c, m=PLANT.pole_mass, l=PLANT.length, g=PLANT.gravity)
    control = f"""
    thw = th - 2 * pi * ceil((th - pi) / (2 * pi))
    bal = int(abs(thw) < theta_c)
    energy = 0.5 * m * l**2 * thd**2 + m * g * l * (cos(th) - 1)
    mu1 = c0 * thw + c1 * thd + c2 * x + c3 * xd
    mu2 = c4 * energy * thd * cos(th) + c5 * x + c6 * xd
    u = bal * mu1 + (1 - bal) * mu2
    {FORCE_OF_U}
    """
    prefs_target = b2.prefs.codegen.target
    b2.set_device("runtime")
    b2.prefs.codegen.target = "numpy"
    try:
        dt = sim.dt * b2.second
        plant = b2.NeuronGroup(
            1, PLANT_EQUATIONS, method="rk4", dt=dt, namespace=ns, name="kernel_check"
        )
        plant.run_regularly(control, when="before_groups", dt=dt)
        plant.M_p, plant.m_p = PLANT.cart_mass, PLANT.pole_mass
        plant.l_p, plant.g_p = PLANT.length, PLANT.gravity
        plant.th = sim.theta0
        mon = b2.StateMonitor(plant, ["x", "xd", "th", "thd"], record=0, when="end", dt=dt)
        b2.Network(plant, mon).run(sim.duration * b2.second, namespace=ns)
        got = np.column_stack([np.asarray(getattr(mon, k))[0] for k in ("x", "xd", "th", "thd")])
    finally:
        b2.prefs.codegen.target = prefs_target
        reset_device()
    want = ref.states[1:]
    assert got.shape == want.shape
    assert np.all(np.abs(got - want) < 1e-8), np.abs(got - want).max()
    # the run is not trivial: it swings up and balances
    assert abs(kernel.wrap_angle(got[-1, 2])) < 0.05 and ref.outcome.n_switches >= 1


def test_brian2_run_swings_up_and_holds(brian_run: NeuralRun) -> None:
    r = brian_run
    assert r.simulator == "brian2" and r.neurons == 2500 and not r.fault
    # caught within the 30 s and balancing at the end (60-s runs: docs/neural.md)
    assert first_switch(r) < 25.0
    assert r.data[-1, 7] == kernel.MODE_BALANCE and abs(kernel.wrap_angle(r.data[-1, 3])) < 0.1
    assert 0.0 < r.cpu_time < r.sim.duration  # the compiled child's time was counted
    assert r.rates.shape == (3000, 16) and np.all(r.rates >= 0.0)
    # the gates: the swing-up gate silent before the switch, the balancing one after
    before = r.rates[(r.data[:-1, 0] < first_switch(r) - 1.0)]
    names = list(r.populations)
    assert before[:, names.index("gate_swing")].mean() < 5.0
    assert before[:, names.index("gate_bal")].mean() > 100.0


def test_the_two_simulators_agree_on_one_seed(brian_run: NeuralRun) -> None:
    """The same network on nengo and on Brian2, seed 1, 30 s. Stated tolerance: both
    switch to balancing and hold |theta| < 0.1 at T_f, their first switches are within
    6 s (seeds of one simulator spread over 11 s, docs/neural.md), and the readout's gain
    on the swing-up law (:func:`swing_gain`) is within 0.15 on both."""
    ref = run_network(CTRL, PLANT, SIM, NetworkConfig(), SEED, record_rates=False)
    for r in (ref, brian_run):
        assert first_switch(r) < SIM.duration
        assert abs(kernel.wrap_angle(r.data[-1, 3])) < 0.1
    assert abs(first_switch(ref) - first_switch(brian_run)) < 6.0
    g_ref, g_b2 = swing_gain(ref), swing_gain(brian_run)
    assert 0.75 < g_ref < 1.1 and 0.75 < g_b2 < 1.1
    assert abs(g_ref - g_b2) < 0.15


def test_a_seed_reruns_to_the_same_bits(brian_run: NeuralRun) -> None:
    again = run_network(CTRL, PLANT, SIM, NetworkConfig(), SEED, simulator="brian2")
    assert np.array_equal(again.data, brian_run.data)
    other = run_network(CTRL, PLANT, SIM, NetworkConfig(), SEED + 1, simulator="brian2")
    assert not np.array_equal(other.data, brian_run.data)


def test_frozen_at_fault() -> None:
    s = np.zeros((5, 4))
    s[3, 2] = np.nan
    out, fault = frozen_at_fault(s)
    assert fault and np.all(out[3:] == s[2])
    assert frozen_at_fault(np.ones((3, 4)))[1] is False


def test_network_update_equals_the_rate_learners() -> None:
    """Given the same exploration and the pathway signals a rate controller would send
    (the closed channel's signals zero, as its gate silences them), the network's traces
    E, mapped to the gains (D = J^T E, with E_6), equal the rate learner's trace of eq 3
    (``kernel.trace_step`` on ``kernel.policy_mean``'s gradient), and the update is the
    chapter's one function of D and the reward."""
    rng = np.random.default_rng(3)
    W = np.array(CTRL.gains)
    sigma = kernel.sigma_of(W[5])
    gamma = 0.999
    n = 400
    states = np.column_stack(
        [
            rng.normal(0, 1, n),
            rng.normal(0, 1, n),
            rng.uniform(-np.pi, np.pi, n),
            rng.normal(0, 2, n),
        ]
    )
    noise = rng.standard_normal(n)
    elig = Eligibility(sigma, noise, gamma, every=1)
    d = np.zeros(6)
    m, length, g = PLANT.pole_mass, PLANT.length, PLANT.gravity
    for k, (x, xd, th, thd) in enumerate(states):
        grad = np.zeros(5)
        kernel.policy_mean(
            x, xd, th, thd, W, CTRL.theta_c, CTRL.sign, False, 50.0, PLANT.as_array(), False, grad
        )
        eps = sigma * noise[k]
        d = np.array(kernel.trace_step(eps, sigma, gamma, *grad, *d))
        energy = 0.5 * m * length**2 * thd**2 + m * g * length * (math.cos(th) - 1.0)
        balancing = abs(th) < CTRL.theta_c
        pre = np.array(
            [th, thd, x, xd, 0.0, 0.0, 0.0]
            if balancing
            else [0.0, 0.0, 0.0, 0.0, energy * thd * math.cos(th), x, xd]
        )
        assert elig(0.0, pre)[0] == eps
    D = gain_eligibility(elig.trace, elig.sigma_trace, W, PLANT, CTRL.sign)
    np.testing.assert_allclose(D, d, rtol=1e-10, atol=1e-12)
    chapter = pick(ChapterConfig, default_config("chapter"))
    for reward in (10.0, -5.0):
        np.testing.assert_allclose(
            chapter_gain_update(W, D, reward, chapter),
            chapter_gain_update(W, d, reward, chapter),
            rtol=1e-10,
        )


def test_learning_on_brian2_replays_the_traces_and_resumes_bit_for_bit(
    brian_run: NeuralRun,
) -> None:
    """Two learning trials on the program: the traces are filled, W moves by the chapter's
    update, the child's CPU time is counted; one trial resumed to two equals the two in
    one go (every recorded number but the times), and a resume of another seed is refused."""
    res = learn_network(CTRL, PLANT, SIM, NetworkConfig(), SEED, trials=2, simulator="brian2")
    first, second = res.trials
    assert tuple(CTRL.gains) == first.W and second.W != first.W
    assert np.any(np.array(first.pathway_trace) != 0.0)
    assert first.cpu_time > 0.0
    part = learn_network(CTRL, PLANT, SIM, NetworkConfig(), SEED, trials=1, simulator="brian2")
    resumed = learn_network(
        CTRL, PLANT, SIM, NetworkConfig(), SEED, trials=2, simulator="brian2", resume=part
    )

    def bits(r: NeuralLearning) -> list[dict[str, object]]:
        return [t.to_dict() | {"cpu_time_s": 0, "wall_time_s": 0} for t in r.trials]

    assert len(resumed.trials) == 2 and bits(resumed) == bits(res)
    assert resumed.W == res.W and resumed.theta_c == res.theta_c
    with pytest.raises(ParameterError, match="resume"):
        learn_network(CTRL, PLANT, SIM, NetworkConfig(), 5, trials=2, resume=part)


def test_cli_json_says_which_simulator_ran(cli: object, brian_run: NeuralRun) -> None:
    code, out, _err = cli(  # type: ignore[operator]
        "neural",
        "--simulator",
        "brian2",
        "--chapter-final",
        "--seed",
        "1",
        "--duration",
        "30",
        "--json",
    )
    assert code == 0
    summary = json.loads(out)
    assert summary["simulator"] == "brian2"
    assert summary["settings"]["network"]["simulator"] == "brian2"
    assert summary["cpu_time_s"] > 0.0 and summary["compile_time_s"] >= 0.0
    assert summary["final_state"] == pytest.approx(list(brian_run.summary()["final_state"]))


def test_the_learning_loop_runs_its_trials_on_the_network(brian_run: NeuralRun) -> None:
    """The project's one learning loop (``learners.loop.learning_steps``) with its trial
    run on the Brian2 program: the chapter's rule draws its noise as the kernel would
    (the generator's state after trial 1 is default_rng(seed) after n_steps normals),
    and the W it moves to is its own update of the network's trace and reward."""
    from striatal.neural.driver import learn_with_rule, run_request
    from striatal.sim.batch import TrialRequest
    from striatal.sim.rollout import Protocol

    records = []
    state = learn_with_rule(
        "chapter",
        CTRL,
        PLANT,
        SIM,
        NetworkConfig(),
        SEED,
        trials=1,
        on_trial=lambda s, r: records.append(r),
    )
    rng = np.random.default_rng(SEED)
    rng.standard_normal(SIM.n_steps)
    assert state.rng_state == rng.bit_generator.state
    assert state.trials_done == 1 and state.simulations == 1 and len(records) == 1
    if not state.success:
        assert tuple(CTRL.gains) != state.W
    # the same trial through run_request fills the trace it is given
    req = TrialRequest(
        PLANT,
        CTRL,
        SIM,
        Protocol(),
        rng=np.random.default_rng(SEED),
        gamma=0.999,
    )
    out = run_request(req, NetworkConfig(), SEED, "brian2")
    assert out.reward in (10.0, -5.0) and np.any(req.trace != 0.0)
    with pytest.raises(ParameterError, match="chapter's trial only"):
        run_request(replace_model(req), NetworkConfig(), SEED, "brian2")


def replace_model(req: object) -> object:
    from dataclasses import replace

    return replace(req, model=Plant(pole_mass=0.2))  # type: ignore[type-var]


def test_lockstep_learning_stopped_and_rerun_equals_each_run_in_one_go(
    brian_run: NeuralRun,
    tmp_path: object,
    monkeypatch: pytest.MonkeyPatch,
    neural_learn_bench: Any,
) -> None:
    """benchmarks/neural_learn.py --lockstep runs trial k of every seed and alpha before
    trial k + 1; stopped after trial 1 and rerun to 2 on the same file, each (seed, alpha)
    equals its learning run in one go (every recorded number but the times)."""
    from pathlib import Path

    from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W

    bench = neural_learn_bench
    out = Path(str(tmp_path)) / "lock.jsonl"
    for trials in ("1", "2"):
        argv = ["neural_learn.py", "--side", "network", "--simulator", "brian2", "--lockstep"]
        argv += ["--neurons", "2500", "--seeds", "1", "--alpha", "5", "0", "--trials", trials]
        monkeypatch.setattr(sys, "argv", [*argv, "--duration", "30", "--out", str(out)])
        assert bench.main() == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    got = [r for r in rows if r["kind"] == "trial"]
    assert [(r["trial"], r["alpha"]) for r in got] == [(1, 5), (1, 0), (2, 5), (2, 0)]
    start = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
    for alpha in (5.0, 0.0):
        ref = learn_network(
            start, PLANT, SIM, NetworkConfig(), SEED, trials=2, alpha=alpha, simulator="brian2"
        )
        mine = [r for r in got if r["alpha"] == alpha]
        for r, t in zip(mine, ref.trials, strict=True):
            expect = t.to_dict() | {"cpu_time_s": 0, "wall_time_s": 0}
            assert {k: r[k] for k in expect} | {"cpu_time_s": 0, "wall_time_s": 0} == expect
    assert got[2]["W"] != got[0]["W"] and got[3]["W"] == got[1]["W"]


def test_loop_lockstep_stopped_and_rerun_equals_pgpe_in_one_go(
    brian_run: NeuralRun,
    tmp_path: object,
    monkeypatch: pytest.MonkeyPatch,
    neural_learn_bench: Any,
) -> None:
    """--side loop --lockstep (pgpe on the network through the learning loop): stopped
    after trial 1 and rerun to 2 on the same file, each (seed, alpha) equals
    ``learn_with_rule`` in one go; alpha 0 is pgpe's declared control (sigma_rate 0);
    a state row of other settings (another --theta-c-rule) is not resumed."""
    from pathlib import Path

    from striatal.neural.driver import learn_with_rule
    from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W

    bench = neural_learn_bench
    out = Path(str(tmp_path)) / "loop.jsonl"
    argv = ["neural_learn.py", "--side", "loop", "--learner", "pgpe", "--simulator", "brian2"]
    argv += ["--lockstep", "--neurons", "2500", "--seeds", "1", "--alpha", "0.3", "0"]
    for trials in ("1", "2"):
        rest = ["--trials", trials, "--duration", "30", "--out", str(out)]
        monkeypatch.setattr(sys, "argv", [*argv, *rest])
        assert bench.main() == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    got = [r for r in rows if r["kind"] == "trial"]
    assert [(r["trial"], r["alpha"]) for r in got] == [(1, 0.3), (1, 0), (2, 0.3), (2, 0)]
    assert {r["side"] for r in got} == {"loop-pgpe"}
    start = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
    for alpha, control in ((0.3, {}), (0.0, {"sigma_rate": 0.0})):
        recs: list[object] = []
        ref = learn_with_rule(
            "pgpe", start, PLANT, SIM, NetworkConfig(), SEED, trials=2,
            on_trial=lambda _s, r, got=recs: got.append(r), alpha=alpha, **control,
        )  # fmt: skip
        mine = [r for r in got if r["alpha"] == alpha]
        assert [(r["W"], r["theta_c"], r["reward"]) for r in mine] == [
            (list(r.W), r.theta_c, r.reward)  # type: ignore[attr-defined]
            for r in recs
        ]
        states = [r for r in rows if r["kind"] == "state" and r["alpha"] == alpha]
        assert states[-1]["state"] == ref.to_dict()
    # the same file with another eq-21 reading starts its own runs
    rest = ["--trials", "1", "--duration", "30", "--out", str(out), "--theta-c-rule", "fixed"]
    monkeypatch.setattr(sys, "argv", [*argv[:-2], "0", *rest])
    assert bench.main() == 0
    new = [json.loads(line) for line in out.read_text().splitlines()][len(rows) :]
    assert [(r["kind"], r.get("trial")) for r in new] == [
        ("trial", 1),
        ("state", None),
    ]
    assert new[0]["theta_c_rule"] == "fixed"


def test_the_runner_says_once_that_it_compiles_and_writes_each_trial(
    brian_run: NeuralRun, cli: object, tmp_path: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``neural --learn --seeds`` on Brian2 with the program not in the cache: one notice
    naming the cache on stderr, before the runs; trials.csv holds each run's trials."""
    from pathlib import Path

    from striatal.experiments.network import read_trials
    from striatal.neural import brian

    monkeypatch.setattr(brian, "_ACTIVE", None)
    monkeypatch.setattr(brian.CompiledNetwork, "cached", property(lambda self: False))
    out = Path(str(tmp_path)) / "sweep"
    code, _out, err = cli(  # type: ignore[operator]
        "neural", "--simulator", "brian2", "--chapter-initial", "--learn", "--seeds", "1",
        "--trials", "1", "--duration", "30", "--no-progress", "--out", str(out),
    )  # fmt: skip
    assert code == 0, err
    assert err.count("compiling the Brian2 network") == 1 and str(brian.cache_root()) in err
    trials = read_trials(out / "trials.csv")
    assert sorted(k[0] for k in trials) == ["control", "learner"]
    assert all(len(v) == 1 for v in trials.values())
