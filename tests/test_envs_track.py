"""The track (rails of half-length ``track``) and the float32 spaces of the Gymnasium ids."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import striatal  # noqa: F401  (registers the env ids)
from striatal.envs import (
    DENSE_ENV_ID,
    DM_CONTROL_TRACK,
    ENV_ID,
    CartPoleSwingUpEnv,
    CartPoleSwingUpVectorEnv,
    SwitchingController,
)
from striatal.errors import ParameterError
from striatal.params import Controller, Hardware, Plant, Simulation
from striatal.sim.rollout import Protocol, simulate


def _push(env: gym.Env, action: float, steps: int, seed: int = 0) -> list[tuple]:
    """(obs, reward, terminated, truncated, info) of each step of a constant action."""
    env.reset(seed=seed)
    out = []
    for _ in range(steps):
        step = env.step(np.array([action], dtype=np.float32))
        out.append(step)
        if step[2] or step[3]:
            break
    return out


# --------------------------------------------------------------------------- dtype


@pytest.mark.parametrize("env_id", [ENV_ID, DENSE_ENV_ID])
def test_registered_ids_have_float32_spaces_and_observations(env_id: str) -> None:
    env = gym.make(env_id)
    assert env.observation_space.dtype == np.float32
    assert env.action_space.dtype == np.float32
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    assert info["state"].dtype == np.float64  # the physics stays float64
    obs, *_ = env.step(env.action_space.sample())
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    assert vec.single_observation_space.dtype == np.float32
    assert vec.single_action_space.dtype == np.float32
    vobs, _ = vec.reset(seed=0)
    assert vobs.dtype == np.float32 and vobs.shape == (2, 5)
    vobs, *_ = vec.step(vec.action_space.sample())
    assert vobs.dtype == np.float32


@pytest.mark.parametrize("env_id", [ENV_ID, DENSE_ENV_ID])
def test_checkers_pass_without_a_dtype_warning(env_id: str) -> None:
    """Gymnasium's checker (and SB3's, if installed) raise no warning about the dtype."""
    env = gym.make(env_id).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*infinity.*")  # x, velocities unbounded
        if env_id == ENV_ID:  # the chapter's id acts in m/s^2 on purpose
            warnings.filterwarnings("ignore", message=".*symmetric and normalized.*")
        check_env(env)
    try:
        from stable_baselines3.common.env_checker import check_env as sb3_check_env
    except ImportError:
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sb3_check_env(gym.make(env_id).unwrapped)
    messages = [str(w.message) for w in caught]
    assert not [m for m in messages if "dtype" in m or "float" in m], messages
    if env_id == DENSE_ENV_ID:
        assert messages == []


def test_float64_dtype_is_the_kernels_precision() -> None:
    env = gym.make(DENSE_ENV_ID, dtype="float64")
    assert env.observation_space.dtype == np.float64 == env.action_space.dtype
    obs, info = env.reset(seed=0, options={"initial_state": [0.1, 0.2, 1.0 / 3.0, 0.4]})
    assert obs.dtype == np.float64 and obs[2] == math.sin(info["state"][2])
    assert CartPoleSwingUpEnv(dtype=np.float64).task.dtype == "float64"
    assert CartPoleSwingUpEnv(dtype=np.dtype("float32")).task.dtype == "float32"
    for bad in ("float16", "int64", None, 3):
        with pytest.raises(ParameterError, match="dtype must be 'float32' or 'float64'"):
            CartPoleSwingUpEnv(dtype=bad)


@pytest.mark.parametrize(
    "action", [np.array([0.5]), np.array([0.5], dtype=np.float32), [0.5], np.array([[1]]), 0.5]
)
def test_actions_of_any_real_dtype_are_accepted(action: object) -> None:
    env = gym.make(DENSE_ENV_ID)
    env.reset(seed=0)
    *_, info = env.step(action)
    expected = float(np.asarray(action, dtype=float).ravel()[0]) * env.unwrapped.task.u_max  # type: ignore[attr-defined]
    assert info["u"] == expected


# --------------------------------------------------------------------------- track


def test_dense_id_has_dm_control_rails() -> None:
    assert DM_CONTROL_TRACK == 1.8
    assert gym.make(DENSE_ENV_ID).unwrapped.task.track == 1.8  # type: ignore[attr-defined]
    # The chapter's id keeps the chapter's endless track.
    assert gym.make(ENV_ID).unwrapped.task.track is None  # type: ignore[attr-defined]


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_full_push_terminates_just_beyond_the_track(sign: float) -> None:
    """x = u t^2 / 2 from rest: at u = 50 m/s^2 the cart passes 1.8 m after 0.27 s."""
    env = gym.make(DENSE_ENV_ID)
    steps = _push(env, sign, 1000)
    *_, (obs, reward, terminated, truncated, info) = steps
    assert terminated and not truncated and not info["fault"]
    assert len(steps) == 27
    x, x_dot = info["state"][0], info["state"][1]
    dt = env.unwrapped.task.dt  # type: ignore[attr-defined]
    # Beyond the rails by less than one step's travel; still on them a step before.
    assert 1.8 < sign * x < 1.8 + abs(x_dot) * dt
    assert abs(steps[-2][4]["state"][0]) <= 1.8
    assert not any(s[2] for s in steps[:-1])
    # The step that leaves the rails still pays the dense reward of its state.
    assert 0.0 < float(reward) <= 1.0
    assert obs[0] == np.float32(x)


@pytest.mark.parametrize("track", [None, math.inf, float("inf")])
def test_no_track_never_terminates_on_x(track: float | None) -> None:
    env = gym.make(DENSE_ENV_ID, track=track)
    assert env.unwrapped.task.track is None  # type: ignore[attr-defined]
    steps = _push(env, 1.0, 1000)
    assert len(steps) == 1000
    assert not any(s[2] for s in steps)
    assert steps[-1][3]  # truncated at the time limit
    assert steps[-1][4]["state"][0] == pytest.approx(0.5 * 50.0 * 10.0**2)


def test_track_option_of_make_and_make_vec() -> None:
    env = gym.make(DENSE_ENV_ID, track=0.5)
    assert len(_push(env, -1.0, 1000)) == 15  # 25 t^2 > 0.5 at t = 0.15 s
    vec = gym.make_vec(DENSE_ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", track=0.5)
    assert vec.unwrapped.task.track == 0.5  # type: ignore[attr-defined]
    vec.reset(seed=0)
    actions = np.array([[1.0], [0.0], [-1.0]], dtype=np.float32)
    for k in range(1, 16):
        _, _, term, trunc, info = vec.step(actions)
        assert not trunc.any()
        if k < 15:
            assert not term.any()
    assert term.tolist() == [True, False, True]
    assert info["state"][0, 0] > 0.5 and info["state"][2, 0] < -0.5
    # The next step autoresets the rows that left the rails.
    _, reward, term, _, info = vec.step(actions)
    assert info["t"].tolist() == [0.0, 0.16, 0.0] and reward[0] == 0.0 and not term.any()


@pytest.mark.parametrize("bad", [0.0, -1.8, float("nan"), -math.inf, "far", True, [1.8], 1e400j])
def test_invalid_track_is_refused(bad: object) -> None:
    with pytest.raises(ParameterError, match="track must be") as err:
        gym.make(DENSE_ENV_ID, track=bad)
    assert "\n" not in str(err.value)
    with pytest.raises(ParameterError, match="track must be"):
        CartPoleSwingUpVectorEnv(num_envs=2, track=bad)
    with pytest.raises(ParameterError, match="track must be"):
        gym.make(ENV_ID, track=bad)


def test_sparse_id_with_a_track_is_the_kernels_track() -> None:
    """The chapter's controller carries the cart to about 6 m: on 3-m rails the episode
    ends where the kernel's trial with ``Hardware(track=3.0)`` ends (t = 20.44 s),
    bit for bit with float64 observations, terminated with eq 25's failure reward -5."""
    traj = simulate(
        Plant(), Controller(), Simulation(), protocol=Protocol(), hardware=Hardware(track=3.0)
    )
    assert traj.outcome.track and traj.outcome.reward == -5.0
    env = gym.make(ENV_ID, observation="raw", dtype="float64", track=3.0)
    policy = SwitchingController(observation="raw")
    obs, info = env.reset(seed=0)
    states, rewards = [info["state"]], []
    terminated = truncated = False
    while not (terminated or truncated):
        obs, r, terminated, truncated, info = env.step(policy(obs))
        states.append(info["state"])
        rewards.append(float(r))
    assert terminated and not truncated and not info["fault"]
    assert info["t"] == pytest.approx(traj.outcome.ended_at)
    assert np.array_equal(np.array(states), traj.states)
    assert rewards[-1] == -5.0 and sum(rewards) == -5.0
    # With the default float32 observations it also ends on the rails' end, at about the same time.
    env32 = gym.make(ENV_ID, track=3.0)
    policy32 = SwitchingController()
    obs, _ = env32.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        obs, r, terminated, truncated, info = env32.step(policy32(obs))
    assert terminated and r == -5.0 and abs(info["state"][0]) > 3.0
    assert info["t"] == pytest.approx(traj.outcome.ended_at, abs=0.05)


def test_same_seed_same_episode_with_the_track() -> None:
    """Under a seed: the same perturbed starts, the same steps, the same end at the track."""

    def episodes(seed: int) -> list[tuple[np.ndarray, list[float], int]]:
        env = gym.make(DENSE_ENV_ID, perturbation=0.05)
        rng = np.random.default_rng(seed)
        env.reset(seed=seed)
        runs = []
        for _ in range(3):
            obs, _ = env.reset()
            observations, rewards = [obs], []
            done = False
            while not done:
                a = rng.uniform(0.2, 1.0, size=1)  # mostly one way: reaches the rails' end
                obs, r, terminated, truncated, _ = env.step(a)
                observations.append(obs)
                rewards.append(float(r))
                done = terminated or truncated
            assert terminated
            runs.append((np.array(observations), rewards, len(rewards)))
        return runs

    a, b, c = episodes(3), episodes(3), episodes(4)
    for (oa, ra, na), (ob, rb, nb) in zip(a, b, strict=True):
        assert na == nb and ra == rb and np.array_equal(oa, ob)
    assert not np.array_equal(a[0][0][0], c[0][0][0])


def test_vector_with_one_env_equals_scalar_across_track_ends() -> None:
    kw = {"perturbation": 0.1, "track": 0.3}
    env = gym.make(DENSE_ENV_ID, **kw)
    vec = CartPoleSwingUpVectorEnv(num_envs=1, **{**gym.spec(DENSE_ENV_ID).kwargs, **kw})
    rng = np.random.default_rng(5)
    obs, _ = env.reset(seed=2)
    vobs, _ = vec.reset(seed=2)
    assert np.array_equal(vobs[0], obs)
    done, ends = False, 0
    for a in rng.uniform(-1.0, 1.0, size=300):
        vobs, vr, vterm, vtrunc, vinfo = vec.step(np.array([[a]]))
        if done:
            obs, info = env.reset()
            done = False
        else:
            obs, r, term, trunc, info = env.step(np.array([a]))
            assert vr[0] == r and vterm[0] == term and vtrunc[0] == trunc
            ends += int(term)
            done = term or trunc
        assert np.array_equal(vobs[0], obs) and np.array_equal(vinfo["state"][0], info["state"])
    assert ends >= 2
