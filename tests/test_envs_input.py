"""What the envs do with input a Gymnasium user can give by mistake: bad actions, numpy
seeds, steps after the episode ended, a huge ``num_envs``."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import striatal  # noqa: F401  (registers the env ids)
from striatal.envs import ENV_ID, CartPoleSwingUpEnv, CartPoleSwingUpVectorEnv
from striatal.envs.vector import MAX_NUM_ENVS
from striatal.errors import ParameterError

BAD_ACTIONS = ["abc", object(), None, np.array(["1.0"]), [[1.0], [2.0, 3.0]]]


@pytest.mark.parametrize(
    "action", BAD_ACTIONS, ids=lambda a: "object" if type(a) is object else repr(a)
)
def test_an_action_that_is_not_a_real_number_names_itself_and_the_space(action: object) -> None:
    env = CartPoleSwingUpEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"must be a real number in the action space Box\("):
        env.step(action)  # type: ignore[arg-type]
    vec = CartPoleSwingUpVectorEnv(num_envs=2)
    vec.reset(seed=0)
    with pytest.raises(ParameterError, match=r"2 real numbers in the action space Box\("):
        vec.step(action)  # type: ignore[arg-type]


@pytest.mark.parametrize("action", [np.array([1 + 2j]), 1j, np.array([3 + 0j])], ids=repr)
def test_a_complex_action_is_refused_not_cut_to_its_real_part(action: object) -> None:
    env = CartPoleSwingUpEnv()
    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning would be a drop
        with pytest.raises(ParameterError, match="real number"):
            env.step(action)  # type: ignore[arg-type]


@pytest.mark.parametrize("action", [1.5, np.float32(1.5), np.array([1.5]), [1.5], 1, True])
def test_real_actions_of_any_type_still_step(action: object) -> None:
    env = CartPoleSwingUpEnv()
    env.reset(seed=0)
    *_, info = env.step(action)  # type: ignore[arg-type]
    assert info["u"] == float(np.asarray(action, dtype=float).reshape(()))


# --------------------------------------------------------------------------- seeds


def test_numpy_integer_seeds_seed_as_the_same_python_int() -> None:
    kw = {"perturbation": 0.05}
    vec = CartPoleSwingUpVectorEnv(num_envs=3, **kw)
    want, _ = vec.reset(seed=3)
    got, _ = vec.reset(seed=np.int64(3))
    np.testing.assert_array_equal(got, want)
    listed, _ = vec.reset(seed=[np.int64(3), np.uint8(4), 5])
    np.testing.assert_array_equal(listed, want)
    arrayed, _ = vec.reset(seed=np.array([3, 4, 5]))
    np.testing.assert_array_equal(arrayed, want)
    other, _ = vec.reset(seed=(4, 5, 6))
    np.testing.assert_array_equal(other[:2], want[1:])
    env = CartPoleSwingUpEnv(**kw)
    np.testing.assert_array_equal(env.reset(seed=np.int64(4))[0], env.reset(seed=4)[0])
    np.testing.assert_array_equal(env.reset(seed=4)[0], want[1])


@pytest.mark.parametrize(
    ("seed", "says"),
    [
        (-1, "whole number >= 0"),
        ([1, -2, 3], "whole number >= 0"),
        ([1, 2.5, 3], "whole number >= 0"),
        (2.0, "a list of 3"),
        (True, "a list of 3"),
        ("3", "a list of 3"),
        ([1, 2], "need 3 seeds"),
        (np.zeros((3, 1), dtype=int), "a list of 3"),
    ],
    ids=repr,
)
def test_a_bad_vector_seed_is_one_clear_error(seed: object, says: str) -> None:
    vec = CartPoleSwingUpVectorEnv(num_envs=3)
    with pytest.raises(ParameterError, match=says):
        vec.reset(seed=seed)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- after the end


def _run_to_end(env: gym.Env, action: float) -> tuple:
    """The last step of an episode of a constant action."""
    env.reset(seed=0)
    while True:
        step = env.step(np.array([action], dtype=np.float32))
        if step[2] or step[3]:
            return step


@pytest.mark.parametrize(
    ("kw", "action", "ended"),
    [({"duration": 0.05}, 0.0, "truncated"), ({"track": 0.2}, 50.0, "terminated")],
)
def test_steps_after_the_end_warn_once_and_repeat_the_terminal_step(
    kw: dict, action: float, ended: str, caplog: pytest.LogCaptureFixture
) -> None:
    env = CartPoleSwingUpEnv(**kw)
    obs, _, terminated, truncated, info = _run_to_end(env, action)
    assert (terminated, truncated) == ((ended == "terminated"), (ended == "truncated"))
    with pytest.warns(UserWarning, match=f"already returned {ended} = True; call reset") as rec:
        again = [env.step(np.array([action], dtype=np.float32)) for _ in range(3)]
    assert len(rec) == 1  # once, not once a step
    for o, r, te, tr, inf in again:
        np.testing.assert_array_equal(o, obs)
        assert (r, te, tr) == (0.0, terminated, truncated)
        np.testing.assert_array_equal(inf["state"], info["state"])
        assert inf["t"] == info["t"]
    # A new episode starts afresh, and warns again only once it too has ended.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _run_to_end(env, action)
    with pytest.warns(UserWarning, match="already returned"):
        env.step(np.array([action], dtype=np.float32))


def test_a_bad_action_after_the_end_is_still_refused() -> None:
    env = CartPoleSwingUpEnv(duration=0.05)
    _run_to_end(env, 0.0)
    with pytest.raises(ParameterError, match="real number"):
        env.step("abc")  # type: ignore[arg-type]


# --------------------------------------------------------------------------- num_envs


def test_num_envs_is_bounded_before_anything_is_allocated() -> None:
    with pytest.raises(ParameterError, match=f"num_envs must be at most {MAX_NUM_ENVS}"):
        gym.make_vec(ENV_ID, num_envs=10**8, vectorization_mode="vector_entry_point")
    with pytest.raises(ParameterError, match="at most"):
        CartPoleSwingUpVectorEnv(num_envs=np.int64(MAX_NUM_ENVS + 1))
    vec = CartPoleSwingUpVectorEnv(num_envs=MAX_NUM_ENVS)
    assert vec.observation_space.shape == (MAX_NUM_ENVS, 5)
