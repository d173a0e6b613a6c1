"""The Gymnasium fronts run the one kernel: they equal ``simulate`` and each other."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode

import striatal
from striatal.envs import (
    ENV_ID,
    CartPoleSwingUpEnv,
    CartPoleSwingUpVectorEnv,
    SwitchingController,
    register_envs,
)
from striatal.errors import ParameterError
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim.rollout import Protocol, Trajectory, simulate


@pytest.fixture(scope="module")
def chapter_run() -> Trajectory:
    return simulate(Plant(), Controller(), Simulation())


def _rollout(
    env: gym.Env, policy: SwitchingController | None = None, *, seed: int = 0, n: int | None = None
) -> tuple[np.ndarray, np.ndarray, list[float], bool, bool]:
    """(states (k+1, 4), applied u (k,), rewards, terminated, truncated) until the episode ends."""
    obs, info = env.reset(seed=seed)
    states = [info["state"]]
    us: list[float] = []
    rewards: list[float] = []
    rng = np.random.default_rng(seed)
    terminated = truncated = False
    k = 0
    while not (terminated or truncated) and (n is None or k < n):
        action = policy(obs) if policy is not None else rng.uniform(-20, 20, size=1)
        obs, r, terminated, truncated, info = env.step(action)
        states.append(info["state"])
        us.append(info["u"])
        rewards.append(float(r))
        k += 1
    return np.array(states), np.array(us), rewards, terminated, truncated


# --------------------------------------------------------------------------- API


def test_registered_on_import_and_idempotent() -> None:
    assert striatal.__version__
    assert ENV_ID in gym.envs.registry
    register_envs()
    register_envs()
    env = gym.make(ENV_ID)
    assert isinstance(env.unwrapped, CartPoleSwingUpEnv)
    vec = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point")
    assert isinstance(vec, CartPoleSwingUpVectorEnv)
    assert vec.num_envs == 3


@pytest.mark.parametrize("observation", ["trig", "raw"])
@pytest.mark.parametrize("reward", ["chapter", "dense"])
def test_check_env_passes(observation: str, reward: str) -> None:
    env = gym.make(
        ENV_ID, observation=observation, reward=reward, render_mode="rgb_array"
    ).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # The action is in physical units (m/s^2) and x, velocities are unbounded on purpose.
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space.*")
        warnings.filterwarnings("ignore", message=".*infinity.*")
        check_env(env)
    assert env.observation_space.shape == ((5,) if observation == "trig" else (4,))
    assert env.action_space.shape == (1,)
    assert env.action_space.high[0] == 50.0


def test_default_start_is_the_chapters() -> None:
    env = CartPoleSwingUpEnv()
    obs, info = env.reset(seed=1)
    assert np.array_equal(info["state"], [0.0, 0.0, 3.12, 0.0])
    # The observation is the float64 one rounded once to float32.
    expected = np.array([0.0, 0.0, math.sin(3.12), math.cos(3.12), 0.0])
    assert obs.dtype == np.float32 and np.array_equal(obs, expected.astype(np.float32))
    obs64, _ = CartPoleSwingUpEnv(dtype="float64").reset(seed=1)
    assert obs64.dtype == np.float64 and np.array_equal(obs64, expected)
    obs, info = env.reset(options={"initial_state": [0.5, 0.0, 1.0, 0.2]})
    assert np.array_equal(info["state"], [0.5, 0.0, 1.0, 0.2])
    with pytest.raises(ParameterError):
        env.reset(options={"initial_state": [0.0, np.nan, 1.0, 0.0]})


def test_bad_options_raise() -> None:
    with pytest.raises(ParameterError, match="unknown environment option"):
        CartPoleSwingUpEnv(horizon=5)
    with pytest.raises(ParameterError):
        CartPoleSwingUpEnv(observation="pixels")
    with pytest.raises(ParameterError):
        CartPoleSwingUpEnv(u_max=-1.0)
    with pytest.raises(ParameterError):
        CartPoleSwingUpVectorEnv(num_envs=0)


def test_action_is_clipped_to_u_max() -> None:
    env = CartPoleSwingUpEnv(u_max=5.0)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([100.0]))
    assert info["u"] == 5.0


# --------------------------------------------------------------------------- determinism


def test_same_seed_same_episode_with_perturbation() -> None:
    env = CartPoleSwingUpEnv(perturbation=0.05, duration=2.0)
    a = _rollout(env, seed=7)
    b = _rollout(env, seed=7)
    c = _rollout(env, seed=8)
    assert np.array_equal(a[0], b[0]) and a[2] == b[2]
    assert not np.array_equal(a[0][0], c[0][0])
    assert np.all(np.abs(a[0][0] - np.array([0.0, 0.0, 3.12, 0.0])) <= 0.05)


# --------------------------------------------------------------------------- same kernel


def test_env_equals_simulate_bit_for_bit_raw(chapter_run: Trajectory) -> None:
    """Raw float64 observations: the env trajectory is simulate's, bit for bit (same
    rk4_step, u held)."""
    env = CartPoleSwingUpEnv(observation="raw", dtype="float64")
    states, us, rewards, terminated, truncated = _rollout(
        env, SwitchingController(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C, observation="raw")
    )
    assert truncated and not terminated
    assert np.array_equal(states, chapter_run.states)
    assert np.array_equal(us, chapter_run.column("u")[:-1])
    assert rewards[-1] == 10.0 and sum(rewards) == 10.0


@pytest.mark.parametrize(("dtype", "gap"), [("float64", 1e-12), ("float32", None)])
def test_env_equals_simulate_trig_and_chapter_success(
    chapter_run: Trajectory, dtype: str, gap: float | None
) -> None:
    """Trig float64 observations: theta from atan2(sin, cos) differs by rounding only
    (< 1e-12). With the default float32 observations the controller sees the state
    rounded to float32, and the trajectory departs from simulate's.

    Either way the chapter's final controller swings up and balances: the chapter's
    success test passes at 60 s in the environment.
    """
    env = gym.make(ENV_ID, dtype=dtype)
    states, us, rewards, terminated, truncated = _rollout(env, SwitchingController())
    assert truncated and not terminated
    assert states.shape == chapter_run.states.shape
    if gap is not None:
        assert np.max(np.abs(states - chapter_run.states)) < gap
        assert np.max(np.abs(us - chapter_run.column("u")[:-1])) < gap
    else:
        assert np.max(np.abs(states - chapter_run.states)) > 1e-9
    final = states[-1].copy()
    final[2] = math.remainder(final[2], 2 * math.pi)
    assert Simulation().success.passed(final)
    assert rewards[-1] == 10.0


def test_chapter_check_at_30s_terminates() -> None:
    """Eq 24: a pole still hanging at t = 30 s ends the episode with -5 (termination)."""
    env = CartPoleSwingUpEnv(observation="raw")
    env.reset(seed=0, options={"initial_state": [0.0, 0.0, math.pi, 0.0]})
    k = 0
    while True:
        _, r, terminated, truncated, info = env.step(np.zeros(1))
        k += 1
        if terminated or truncated:
            break
        assert r == 0.0
    assert terminated and not truncated and r == -5.0
    assert k == 3000 and info["t"] == pytest.approx(30.0)


@pytest.mark.parametrize(
    ("gains", "x0", "early"),
    [
        # balances, but a near-zero cart-position gain drifts: |x| = 2.5 m at 60 s (eq 25 fails)
        ((1.1736, -0.001, -0.8027, 0.5, 0.7, 0.4), 1.0, False),
        # no swing-up energy gain: still hanging at t = 30 s, the eq-24 check ends it
        ((0.6813, -0.3795, -0.8318, 0.0, 0.7095, 0.4289), 0.0, True),
    ],
)
def test_sparse_reward_matches_kernel_protocol(
    gains: tuple[float, ...], x0: float, early: bool
) -> None:
    """A failing and an early-ended trial: the env's eq-24/25 outcome equals the kernel's."""
    ctrl = Controller(gains=gains, theta_c=0.6)
    traj = simulate(Plant(), ctrl, Simulation(x0=x0), protocol=Protocol())
    assert traj.outcome.reward == -5.0 and traj.outcome.early == early
    assert not traj.outcome.fault
    env = CartPoleSwingUpEnv(observation="raw", initial_state=(x0, 0.0, 3.12, 0.0), dtype="float64")
    states, _, rewards, terminated, truncated = _rollout(
        env, SwitchingController.from_controller(ctrl, observation="raw")
    )
    assert np.array_equal(states, traj.states)
    assert len(rewards) == round(traj.outcome.ended_at / 0.01) == (3000 if early else 6000)
    assert rewards[-1] == traj.outcome.reward and sum(rewards) == -5.0
    assert terminated == early and truncated == (not early)


def test_blow_up_is_termination() -> None:
    env = CartPoleSwingUpEnv(observation="raw", u_max=1e300, dtype="float64")
    env.reset(seed=0, options={"initial_state": [0.0, 0.0, 0.0, 0.0]})
    _, r, terminated, truncated, info = env.step(np.array([1e300]))
    assert terminated and not truncated and info["fault"] and r == -5.0
    # In float32 the blown-up observation is inf, still a fault.
    env = CartPoleSwingUpEnv(observation="raw", u_max=1e300, normalised_action=True)
    env.reset(seed=0, options={"initial_state": [0.0, 0.0, 0.0, 0.0]})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        obs, r, terminated, truncated, info = env.step(np.ones(1))
    assert terminated and info["fault"] and r == -5.0 and np.isinf(obs[0])
    with pytest.raises(ParameterError, match="does not fit the float32"):
        CartPoleSwingUpEnv(u_max=1e300)


def test_dense_reward_is_in_unit_interval_and_prefers_upright() -> None:
    env = CartPoleSwingUpEnv(reward="dense", duration=1.0)
    _, _, rewards, terminated, truncated = _rollout(env)
    assert truncated and not terminated and len(rewards) == 100
    assert all(0.0 <= r <= 1.0 for r in rewards)
    env.reset(options={"initial_state": [0.0, 0.0, 0.0, 0.0]})
    _, r_up, *_ = env.step(np.zeros(1))
    env.reset(options={"initial_state": [0.0, 0.0, math.pi, 0.0]})
    _, r_down, *_ = env.step(np.zeros(1))
    assert float(r_up) > 0.99 and float(r_down) < 1e-3


def test_render_is_the_animation_picture() -> None:
    env = CartPoleSwingUpEnv(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame is not None and frame.shape == (400, 600, 3) and frame.dtype == np.uint8
    assert CartPoleSwingUpEnv().render() is None


# --------------------------------------------------------------------------- vector env


@pytest.mark.parametrize("observation", ["trig", "raw"])
def test_vector_with_one_env_equals_scalar(observation: str) -> None:
    """num_envs = 1 on kernel.step_batch reproduces the scalar env bit for bit, under a seed."""
    kw = {"observation": observation, "perturbation": 0.1, "reward": "dense", "duration": 1.0}
    env = CartPoleSwingUpEnv(**kw)
    vec = CartPoleSwingUpVectorEnv(num_envs=1, **kw)
    rng = np.random.default_rng(3)
    actions = rng.uniform(-30, 30, size=250)
    obs, _ = env.reset(seed=11)
    vobs, _ = vec.reset(seed=11)
    assert np.array_equal(vobs[0], obs)
    done = False
    n_resets = 0
    for a in actions:
        vobs, vr, vterm, vtrunc, vinfo = vec.step(np.array([[a]]))
        if done:
            # The vector env autoresets on the step after the episode ended; the scalar is reset.
            obs, info = env.reset()
            assert vr[0] == 0.0 and not vterm[0] and not vtrunc[0]
            n_resets += 1
            done = False
        else:
            obs, r, term, trunc, info = env.step(np.array([a]))
            assert vr[0] == r and vterm[0] == term and vtrunc[0] == trunc
            done = term or trunc
        assert np.array_equal(vinfo["state"][0], info["state"])
        assert np.array_equal(vobs[0], obs)
    assert n_resets == 2


def test_vector_rows_are_scalar_envs_and_autoreset() -> None:
    n = 3
    vec = CartPoleSwingUpVectorEnv(num_envs=n, perturbation=0.05, duration=0.5)
    assert vec.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert vec.observation_space.shape == (n, 5) and vec.action_space.shape == (n, 1)
    obs, info = vec.reset(seed=5)
    assert vec.observation_space.contains(obs)
    for b in range(n):
        _, sinfo = CartPoleSwingUpEnv(perturbation=0.05).reset(seed=5 + b)
        assert np.array_equal(info["state"][b], sinfo["state"])
    actions = np.linspace(-1, 1, n)[:, None]
    for _ in range(50):
        obs, r, term, trunc, info = vec.step(actions)
    assert trunc.all() and not term.any()
    obs, r, term, trunc, info = vec.step(actions)
    assert np.array_equal(r, np.zeros(n)) and not (term | trunc).any()
    assert np.array_equal(info["t"], np.zeros(n))
    assert vec.observation_space.contains(obs)
    # Partial reset of one row.
    vec.step(actions)
    before = vec.states
    vec.reset(options={"reset_mask": np.array([False, True, False])})
    after = vec.states
    assert np.array_equal(after[[0, 2]], before[[0, 2]])
    assert not np.array_equal(after[1], before[1])
    frames = CartPoleSwingUpVectorEnv(num_envs=2, render_mode="rgb_array")
    frames.reset(seed=0)
    out = frames.render()
    assert out is not None and len(out) == 2 and out[0].shape == (400, 600, 3)


def test_vector_controller_batch_balances() -> None:
    """The policy takes a batch; the chapter's controller swings up every perturbed start."""
    vec = gym.make_vec(
        ENV_ID, num_envs=4, vectorization_mode="vector_entry_point", perturbation=0.02
    )
    policy = SwitchingController()
    obs, _ = vec.reset(seed=0)
    for _ in range(6000):
        obs, r, term, trunc, _ = vec.step(policy(obs))
    assert trunc.all() and not term.any()
    assert np.all(r == 10.0)


def test_policy_samples_eq5_and_checks_shapes() -> None:
    """With a generator the policy draws a = mu + sigma(W6) N(0, 1) (eq 5)."""
    obs = np.array([0.1, 0.0, math.sin(0.2), math.cos(0.2), 0.0])
    mean = SwitchingController()(obs)
    noisy = SwitchingController(rng=np.random.default_rng(0))
    draws = np.array([noisy(obs)[0] for _ in range(4000)])
    assert draws.mean() == pytest.approx(mean[0], abs=4 * noisy.sigma / math.sqrt(4000))
    assert draws.std() == pytest.approx(noisy.sigma, rel=0.05)
    assert noisy.sigma == pytest.approx(0.1 + 1 / (1 + math.exp(-CHAPTER_FINAL_W[5])))
    assert SwitchingController()(np.stack([obs, obs])).shape == (2, 1)
    with pytest.raises(ParameterError):
        SwitchingController()(np.zeros(4))
    with pytest.raises(ParameterError):
        SwitchingController(observation="raw")(np.zeros(5))
