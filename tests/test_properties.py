"""Property tests (hypothesis): random inputs never crash striatal or leak non-finite numbers.

- random valid parameters and gains: the kernel either returns finite outputs or
  sets its fault flag (and then the trial is a failure with the failure reward);
- random invalid parameters: always the typed ParameterError;
- random bytes, or a valid checkpoint with one value changed, as a file: the
  readers raise DataFileError (or return data), and ``striatal train --resume``
  exits 0 or with one line and code 2, never a traceback.

Examples are derandomized so CI sees the same ones every run; set
STRIATAL_HYPOTHESIS_EXAMPLES to explore more (``STRIATAL_HYPOTHESIS_RANDOM=1``
draws fresh ones).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import cli_in_process
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from striatal.errors import DataFileError, ParameterError
from striatal.io.files import read_csv, read_json
from striatal.learners import LearnerConfig
from striatal.learners.chapter import gain_update
from striatal.params import MAX_STEPS, Controller, Plant, Simulation, check_seed
from striatal.sim.rollout import Protocol, SensorNoise, TrialRequest, run_trial, simulate

N = int(os.environ.get("STRIATAL_HYPOTHESIS_EXAMPLES", "0"))
PROFILE = settings(
    deadline=None,
    derandomize=os.environ.get("STRIATAL_HYPOTHESIS_RANDOM") != "1",
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    database=None,
)


def examples(default: int) -> settings:
    return settings(PROFILE, max_examples=N or default)


def pos(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


wide = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
huge = st.floats(-1e300, 1e300, allow_nan=False, allow_infinity=False)
gain = st.one_of(wide, huge)
w1 = st.one_of(pos(1e-6, 1e6), pos(1e-300, 1e300))

plants = st.builds(
    Plant,
    cart_mass=pos(1e-3, 1e3),
    pole_mass=pos(1e-3, 1e3),
    length=pos(1e-2, 1e2),
    gravity=pos(1e-2, 1e3),
)
controllers = st.builds(
    Controller,
    gains=st.tuples(w1, gain, gain, gain, gain, gain),
    theta_c=pos(1e-3, math.pi - 1e-3),
    balance_sign=st.sampled_from(["corrected", "chapter"]),
    switch=st.sampled_from(["hard", "soft"]),
    inhibition=pos(1e-2, 1e4),
)
sims = st.builds(
    Simulation,
    theta0=st.floats(-20, 20, allow_nan=False),
    x0=st.floats(-1e3, 1e3, allow_nan=False),
    duration=pos(0.1, 3.0),
    dt=pos(0.005, 0.1),
)


def finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


@examples(300)
@given(
    plant=plants,
    model=st.one_of(st.none(), plants),
    controller=controllers,
    sim=sims,
    seed=st.one_of(st.none(), st.integers(0, 2**32 - 1)),
    action_every=st.integers(1, 5),
    gamma=pos(0.0, 0.9999),
    sensor=st.builds(SensorNoise, x_std=pos(0.0, 1.0), theta_std=pos(0.0, 1.0)),
    chapter_eligibility=st.booleans(),
)
def test_valid_inputs_give_finite_outputs_or_a_fault(
    plant: Plant,
    model: Plant | None,
    controller: Controller,
    sim: Simulation,
    seed: int | None,
    action_every: int,
    gamma: float,
    sensor: SensorNoise,
    chapter_eligibility: bool,
) -> None:
    rng = None if seed is None else np.random.default_rng(seed)
    if rng is None:
        sensor = SensorNoise()
    trace = np.zeros(6)
    o = run_trial(
        TrialRequest(
            plant,
            controller,
            sim,
            protocol=Protocol(check_time=sim.duration / 2),
            trace=trace,
            gamma=gamma,
            rng=rng,
            action_every=action_every,
            chapter_eligibility=chapter_eligibility,
            model=model,
            sensor=sensor,
        )
    )
    assert o.reward in (10.0, -5.0)
    assert 0.0 <= o.ended_at <= sim.n_steps * sim.dt
    if o.fault:
        assert o.reward == -5.0 and not o.success
        return
    assert finite(*o.final_state, o.max_abs_x, o.max_abs_force)
    assert finite(*trace)
    if o.ended_at == 0.0:  # the eq-24 check ended it before any step: nothing observed
        return
    assert 0.0 <= o.min_abs_theta <= math.pi
    # inf only when the swing-up controller never acted: then |theta| stayed below theta_c
    assert math.isfinite(o.min_abs_theta_swingup) or o.min_abs_theta < controller.theta_c


@examples(100)
@given(plant=plants, controller=controllers, sim=sims)
def test_recorded_trajectory_is_finite_until_a_fault(
    plant: Plant, controller: Controller, sim: Simulation
) -> None:
    traj = simulate(plant, controller, sim)
    if traj.outcome.fault:
        # the state is finite up to the step that blew up; that step's action may not be
        assert np.all(np.isfinite(traj.data[:-1, 1:5])) and np.all(np.isfinite(traj.data[:-2]))
    else:
        assert np.all(np.isfinite(traj.data))
    assert traj.data.shape[0] == round(traj.outcome.ended_at / sim.dt) + 1


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # then guarded
@examples(200)
@given(
    W=st.tuples(pos(1e-3, 1e300), huge, huge, huge, huge, huge),
    trace=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=6, max_size=6),
    reward=st.sampled_from([10.0, -5.0]),
    alpha=pos(0.0, 1e6),
    max_step=st.one_of(pos(1e-6, 1e3), st.just(math.inf)),
)
def test_gain_update_never_makes_finite_gains_non_finite(
    W: tuple[float, ...], trace: list[float], reward: float, alpha: float, max_step: float
) -> None:
    W0 = np.array(W)
    cfg = LearnerConfig(alpha=alpha, max_step=max_step)
    new = gain_update(
        W0,
        np.array(trace),
        reward,
        alpha=cfg.alpha,
        gamma=cfg.gamma,
        baseline=cfg.baseline,
        max_step=cfg.max_step,
        w1_floor=cfg.w1_floor,
    )
    assert np.all(np.isfinite(new))
    assert new[0] >= cfg.w1_floor
    if math.isfinite(max_step):
        rounding = 4 * np.spacing(np.abs(W0[1:]) + max_step)
        assert np.all(np.abs(new[1:] - W0[1:]) <= max_step + rounding)
    if not np.all(np.isfinite(trace)):
        np.testing.assert_array_equal(new, W0)


# ---------------------------------------------------------------- invalid parameters

non_finite = st.sampled_from([math.nan, math.inf, -math.inf])
not_positive = st.one_of(non_finite, st.floats(max_value=0.0, allow_nan=False))
not_a_number = st.one_of(st.none(), st.text(max_size=5), st.lists(st.integers(), max_size=2))


@examples(150)
@given(
    field=st.sampled_from(["cart_mass", "pole_mass", "length", "gravity"]),
    value=st.one_of(not_positive, not_a_number),
)
def test_invalid_plant_is_a_parameter_error(field: str, value: Any) -> None:
    if isinstance(value, str):
        try:
            if math.isfinite(float(value)) and float(value) > 0:
                return  # " 5" is a number
        except ValueError:
            pass
    with pytest.raises(ParameterError):
        Plant(**{field: value})


bad_gains = st.one_of(
    st.lists(wide, max_size=5),
    st.lists(wide, min_size=7, max_size=9),
    st.tuples(st.floats(max_value=0.0, allow_nan=False), wide, wide, wide, wide, wide),
    st.tuples(pos(1e-3, 10), wide, wide, non_finite, wide, wide),
    st.tuples(non_finite, wide, wide, wide, wide, wide),
)


@examples(150)
@given(
    gains=st.one_of(bad_gains, st.just((1.0, 0, 0, 0, 0, 0))),
    theta_c=st.one_of(
        st.floats(max_value=0.0),
        st.floats(min_value=math.pi),
        non_finite,
        pos(0.1, 3.0),
    ),
)
def test_invalid_controller_is_a_parameter_error(gains: Any, theta_c: float) -> None:
    valid_gains = gains == (1.0, 0, 0, 0, 0, 0)
    valid_theta = math.isfinite(theta_c) and 0 < theta_c < math.pi
    if valid_gains and valid_theta:
        Controller(gains=gains, theta_c=theta_c)
        return
    with pytest.raises(ParameterError):
        Controller(gains=gains, theta_c=theta_c)


@examples(150)
@given(
    dt=st.one_of(st.floats(), pos(1e-3, 0.1)),
    duration=st.one_of(st.floats(), pos(0.1, 100.0)),
)
def test_simulation_accepts_exactly_the_valid_settings(dt: float, duration: float) -> None:
    valid = (
        math.isfinite(dt)
        and 0 < dt <= 0.1
        and math.isfinite(duration)
        and duration > 0
        and duration / dt <= MAX_STEPS
        and round(duration / dt) >= 1
    )
    if valid:
        assert Simulation(dt=dt, duration=duration).n_steps >= 1
    else:
        with pytest.raises(ParameterError):
            Simulation(dt=dt, duration=duration)


@examples(150)
@given(
    alpha=st.one_of(st.floats(max_value=-1e-12), non_finite),
    gamma=st.one_of(st.floats(min_value=1.0), st.floats(max_value=-1e-12), non_finite),
    max_trials=st.integers(max_value=0),
    action_every=st.integers(max_value=0),
    which=st.sampled_from(["alpha", "gamma", "max_trials", "action_every"]),
)
def test_invalid_learner_config_is_a_parameter_error(
    alpha: float, gamma: float, max_trials: int, action_every: int, which: str
) -> None:
    bad = {"alpha": alpha, "gamma": gamma, "max_trials": max_trials, "action_every": action_every}
    with pytest.raises(ParameterError):
        LearnerConfig(**{which: bad[which]})


@examples(100)
@given(seed=st.one_of(st.integers(), st.floats(), st.text(max_size=3), st.none(), st.booleans()))
def test_check_seed_accepts_exactly_whole_numbers_from_0(seed: Any) -> None:
    if isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0:
        assert check_seed(seed) == seed
    else:
        with pytest.raises(ParameterError):
            check_seed(seed)


# ---------------------------------------------------------------- the command line

odd_float = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e308, -1e308, 1e-308]),
    st.floats(-1e3, 1e3),
)


def option(name: str, values: st.SearchStrategy[float]) -> st.SearchStrategy[list[str]]:
    return st.one_of(st.just([]), values.map(lambda v: [name, repr(v)]))


def gains_option(name: str) -> st.SearchStrategy[list[str]]:
    six = st.tuples(pos(1e-3, 100), *[st.floats(-100, 100)] * 5)
    return st.one_of(st.just([]), six.map(lambda g: [name, *map(repr, g)]))


def one_odd(names: list[str]) -> st.SearchStrategy[list[str]]:
    """Nothing, or one of ``names`` given an odd value (argparse: the last one wins)."""
    odd = st.tuples(st.sampled_from(names), odd_float).map(lambda t: [t[0], repr(t[1])])
    return st.one_of(st.just([]), odd)


SIMULATE_VALID = {
    "--cart-mass": pos(0.01, 100),
    "--pole-mass": pos(0.01, 10),
    "--length": pos(0.1, 10),
    "--gravity": pos(0.1, 100),
    "--dt": pos(1e-3, 0.1),
    "--duration": pos(0.1, 5),
    "--theta-c": pos(0.01, 3.1),
    "--theta0": st.floats(-10, 10),
    "--x0": st.floats(-10, 10),
    "--inhibition": pos(0.1, 1e3),
}
simulate_argv = st.tuples(
    *[option(name, values) for name, values in SIMULATE_VALID.items()],
    st.one_of(st.just([]), gains_option("--gains").map(lambda g: [*g, "--theta-c", "0.5"])),
    st.sampled_from([[], ["--switch", "soft"], ["--balance-sign", "chapter"]]),
    one_odd([*SIMULATE_VALID, "--gains"]),
)


@examples(150)
@given(parts=simulate_argv)
def test_simulate_with_any_numbers_runs_or_is_exit_2(parts: tuple[list[str], ...]) -> None:
    argv = ["simulate", "--json", *[a for part in parts for a in part]]
    if "--duration" not in argv:
        argv += ["--duration", "2"]
    rc, out, err = cli_in_process(*argv)
    event(f"exit {rc}")
    assert rc in (0, 2), err
    if rc == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("striatal simulate: error:"), err
        assert out == ""
    else:
        summary = json.loads(out, parse_constant=pytest.fail)  # no NaN/Infinity tokens
        assert summary["fault"] or all(math.isfinite(v) for v in summary["final_state"])


TRAIN_VALID = {
    "--alpha": pos(0, 1e3),
    "--gamma": pos(0, 0.999),
    "--reward-baseline": st.floats(-10, 10),
    "--max-step": pos(1e-3, 10),
    "--rpe-rate": pos(0.01, 1),
    "--explore": pos(0.01, 3),
    "--sigma-rate": pos(0, 1),
    "--theta-c0": pos(0.01, 3.1),
    "--dt": pos(5e-3, 0.1),
    "--duration": pos(0.1, 3),
}
train_argv = st.tuples(
    st.sampled_from([[], ["--learner", "rpe"], ["--learner", "pgpe"]]),
    *[option(name, values) for name, values in TRAIN_VALID.items()],
    gains_option("--init-gains"),
    st.one_of(st.just([]), st.integers(-2, 3).map(lambda n: ["--max-trials", str(n)])),
    st.sampled_from([[], ["--theta-c-rule", "learned"], ["--success-on", "mean"]]),
    one_odd([*TRAIN_VALID, "--init-gains"]),
)


@examples(100)
@given(parts=train_argv)
def test_train_with_any_numbers_runs_or_is_exit_2(parts: tuple[list[str], ...]) -> None:
    argv = ["train", "--json", "--no-progress", *[a for part in parts for a in part]]
    if "--max-trials" not in argv:
        argv += ["--max-trials", "2"]
    if "--duration" not in argv:
        argv += ["--duration", "2"]
    rc, out, err = cli_in_process(*argv)
    event(f"exit {rc}")
    assert rc in (0, 2), err
    if rc == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("striatal train: error:"), err
        assert out == ""
    else:
        result = json.loads(out, parse_constant=pytest.fail)
        assert all(math.isfinite(w) for w in result["W"])
        assert 0 < result["theta_c"] < math.pi


# ---------------------------------------------------------------- files


@examples(200)
@given(data=st.binary(max_size=400))
def test_random_bytes_as_json_or_csv(data: bytes, tmp_path: Path) -> None:
    path = tmp_path / "file"
    path.write_bytes(data)
    try:
        read_json(path)
    except DataFileError as exc:
        assert str(path) in str(exc)
    try:
        rows = read_csv(path)
    except DataFileError as exc:
        assert str(path) in str(exc)
    else:
        assert isinstance(rows, list)


@pytest.fixture(scope="module")
def checkpointed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished 5-trial train run, with its checkpoint.json and history.csv."""
    out = tmp_path_factory.mktemp("ckpt") / "run"
    rc, _, err = cli_in_process("train", "--max-trials", "5", "--seed", "1", "--out", str(out))
    assert rc == 0, err
    return out


def resume_on(template: Path, checkpoint: bytes) -> tuple[int, str, str, bytes]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        shutil.copytree(template, out)
        (out / "checkpoint.json").write_bytes(checkpoint)
        rc, stdout, err = cli_in_process("train", "--resume", "--out", str(out), "--no-progress")
        return rc, stdout, err, (out / "checkpoint.json").read_bytes()


def assert_clear_error(rc: int, err: str) -> None:
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("striatal train: error:"), err


@examples(80)
@given(data=st.binary(max_size=300))
def test_random_bytes_as_checkpoint_is_exit_2(data: bytes, checkpointed: Path) -> None:
    rc, stdout, err, after = resume_on(checkpointed, data)
    if rc == 0:  # the bytes happened to be a valid finished checkpoint: impossible in practice
        pytest.fail(f"random bytes accepted as a checkpoint: {data!r}")
    assert_clear_error(rc, err)
    assert stdout == "" and after == data


# Values a corrupted or hand-edited file might hold in place of one entry.
ODD_VALUES = st.sampled_from(
    [None, True, "x", "", -1, 0, 3, 0.5, -0.5, 1e308, -1e308, [], {}, [1, 2], {"a": 1}]
)


def leaves(obj: Any, path: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    if isinstance(obj, dict):
        return [path] + [p for k, v in obj.items() for p in leaves(v, (*path, k))]
    if isinstance(obj, list):
        return [path] + [p for i, v in enumerate(obj) for p in leaves(v, (*path, i))]
    return [path]


def replaced(obj: Any, path: tuple[str | int, ...], value: Any, delete: bool) -> Any:
    if not path:
        return value
    copy = json.loads(json.dumps(obj))
    parent = copy
    for key in path[:-1]:
        parent = parent[key]
    if delete and isinstance(parent, dict):
        del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return copy


@examples(150)
@given(data=st.data(), value=ODD_VALUES, delete=st.booleans())
def test_one_changed_checkpoint_entry_runs_or_is_exit_2(
    data: st.DataObject, value: Any, delete: bool, checkpointed: Path
) -> None:
    good = json.loads((checkpointed / "checkpoint.json").read_text())
    path = data.draw(st.sampled_from(leaves(good)))
    text = json.dumps(replaced(good, path, value, delete)).encode()
    rc, _, err, _ = resume_on(checkpointed, text)
    assert rc in (0, 2), err
    assert "Traceback" not in err
    if rc == 2:
        assert_clear_error(rc, err)


@pytest.fixture(scope="module")
def result_file(checkpointed: Path) -> bytes:
    return (checkpointed / "result.json").read_bytes()


def robustness_on(data: bytes) -> tuple[int, str, str]:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "result.json"
        path.write_bytes(data)
        return cli_in_process("robustness", str(path), "--repeats", "1", "--json")


@examples(60)
@given(data=st.binary(max_size=300))
def test_random_bytes_as_result_file_is_exit_2(data: bytes) -> None:
    rc, out, err = robustness_on(data)
    assert rc == 2 and out == "", err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("striatal robustness: error:"), err


@examples(60)
@given(data=st.data(), value=ODD_VALUES, delete=st.booleans())
def test_one_changed_result_entry_runs_or_is_exit_2(
    data: st.DataObject, value: Any, delete: bool, result_file: bytes
) -> None:
    good = json.loads(result_file)
    path = data.draw(st.sampled_from(leaves(good)))
    rc, _, err = robustness_on(json.dumps(replaced(good, path, value, delete)).encode())
    event(f"exit {rc}")
    assert rc in (0, 2), err
    if rc == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("striatal robustness: error:"), err
