"""The Gymnasium API details: frame rate, time limit, action scaling, reset options, rendering."""

from __future__ import annotations

import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import SyncVectorEnv

import striatal  # noqa: F401  (registers the env ids)
from striatal.envs import (
    DENSE_ENV_ID,
    ENV_ID,
    CartPoleSwingUpEnv,
    CartPoleSwingUpVectorEnv,
    SwitchingController,
)
from striatal.envs.cartpole import RENDER_WIDTH, env_frame, view
from striatal.errors import MissingExtraError, ParameterError
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W

# --------------------------------------------------------------------------- frame rate, time limit


@pytest.mark.parametrize(("dt", "fps"), [(0.01, 100), (0.02, 50), (0.004, 250)])
def test_render_fps_plays_in_real_time(dt: float, fps: int) -> None:
    """One frame per env step of dt seconds: a recording at render_fps lasts the episode."""
    env = CartPoleSwingUpEnv(dt=dt, duration=6.0)
    assert env.metadata["render_fps"] == fps
    assert env.task.n_steps / env.metadata["render_fps"] == pytest.approx(6.0)
    vec = CartPoleSwingUpVectorEnv(num_envs=2, dt=dt)
    assert vec.metadata["render_fps"] == fps
    # The class default is the default dt's, and instances do not write into it.
    assert CartPoleSwingUpEnv.metadata["render_fps"] == 100
    assert gym.make(ENV_ID, dt=dt).metadata["render_fps"] == fps


def test_render_fps_not_whole() -> None:
    env = CartPoleSwingUpEnv(dt=0.03, duration=3.0)
    assert env.metadata["render_fps"] == pytest.approx(1 / 0.03)


@pytest.mark.parametrize(
    ("env_id", "kwargs", "steps"),
    [
        (ENV_ID, {}, 6000),
        (ENV_ID, {"duration": 120.0}, 12000),
        (ENV_ID, {"duration": 5.0, "dt": 0.02}, 250),
        (DENSE_ENV_ID, {}, 1000),
    ],
)
def test_max_episode_steps_from_duration(env_id: str, kwargs: dict, steps: int) -> None:
    env = gym.make(env_id, **kwargs)
    assert env.spec is not None and env.spec.max_episode_steps == steps
    assert env.unwrapped.task.n_steps == steps  # type: ignore[attr-defined]


def test_time_limit_never_cuts_a_longer_episode_short() -> None:
    """The wrapper's limit is the env's own: a 0.5 s episode ends truncated at step 50."""
    env = gym.make(ENV_ID, duration=0.5)
    env.reset(seed=0)
    k = 0
    truncated = terminated = False
    while not (truncated or terminated):
        _, _, terminated, truncated, info = env.step(np.zeros(1))
        k += 1
    assert k == 50 and truncated and not terminated and info["t"] == pytest.approx(0.5)


# --------------------------------------------------------------------------- normalised actions


def test_dense_id_passes_check_env_and_is_normalised() -> None:
    env = gym.make(DENSE_ENV_ID)
    space = env.action_space
    assert isinstance(space, gym.spaces.Box)
    assert space.dtype == np.float32 and space.low[0] == -1.0 and space.high[0] == 1.0
    task = env.unwrapped.task  # type: ignore[attr-defined]
    assert task.reward == "dense" and task.duration == 10.0 and task.normalised_action
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # x and the velocities are unbounded on purpose; no other warning is allowed
        # (in particular none about the action space).
        warnings.filterwarnings("ignore", message=".*infinity.*")
        check_env(env.unwrapped)


def test_chapter_id_passes_check_env() -> None:
    env = gym.make(ENV_ID)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space.*")
        warnings.filterwarnings("ignore", message=".*infinity.*")
        check_env(env.unwrapped)


def test_normalised_action_is_scaled_by_u_max() -> None:
    """a in [-1, 1] applies u = a * u_max; the trajectory equals the physical-unit env's."""
    phys = CartPoleSwingUpEnv(observation="raw", u_max=40.0, duration=1.0)
    norm = CartPoleSwingUpEnv(observation="raw", u_max=40.0, duration=1.0, normalised_action=True)
    phys.reset(seed=0)
    norm.reset(seed=0)
    rng = np.random.default_rng(1)
    # Multiples of 1/8 are exact in float32 and in a * 40.
    for a in rng.integers(-12, 13, size=100) / 8.0:
        o1, r1, *_, i1 = phys.step(np.array([a * 40.0]))
        o2, r2, *_, i2 = norm.step(np.array([a], dtype=np.float32))
        assert i2["u"] == float(np.clip(a, -1, 1) * 40.0) == i1["u"]
        assert np.array_equal(o1, o2) and r1 == r2
    vec = CartPoleSwingUpVectorEnv(num_envs=2, normalised_action=True)
    vec.reset(seed=0)
    *_, info = vec.step(np.array([[0.5], [-3.0]], dtype=np.float32))
    assert np.array_equal(info["u"], [25.0, -50.0])


def test_normalised_action_must_be_bool() -> None:
    with pytest.raises(ParameterError, match="normalised_action"):
        CartPoleSwingUpEnv(normalised_action="yes")


# --------------------------------------------------------------------------- reset options


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"perturbation": 1e308}, "perturbation"),
        ({"perturbation": -0.1}, "perturbation"),
        ({"perturbation": float("nan")}, "perturbation"),
        ({"perturbation": "a lot"}, "perturbation"),
        ("x", "must be a dict"),
        ([("perturbation", 0.1)], "must be a dict"),
        ({"initial_sate": [0, 0, 3, 0]}, "unknown reset option"),
        ({"initial_state": [0, 0, 3]}, "initial_state"),
    ],
)
def test_bad_reset_options_raise_parameter_error(options: object, match: str) -> None:
    env = CartPoleSwingUpEnv()
    env.reset(seed=0)
    before = env.state
    with pytest.raises(ParameterError, match=match):
        env.reset(options=options)  # type: ignore[arg-type]
    assert np.array_equal(env.state, before)
    vec = CartPoleSwingUpVectorEnv(num_envs=2)
    vec.reset(seed=0)
    vbefore = vec.states
    with pytest.raises(ParameterError, match=match):
        vec.reset(options=options)  # type: ignore[arg-type]
    assert np.array_equal(vec.states, vbefore)


def test_make_rejects_what_reset_rejects() -> None:
    with pytest.raises(ParameterError, match="perturbation"):
        gym.make(ENV_ID, perturbation=1e308)
    # The largest accepted half-width still draws a finite start.
    env = CartPoleSwingUpEnv(perturbation=9.9e7)
    _, info = env.reset(seed=0)
    assert np.all(np.isfinite(info["state"]))


def test_vector_reset_checks_every_row_before_changing_any() -> None:
    vec = CartPoleSwingUpVectorEnv(num_envs=3)
    vec.reset(seed=0)
    before = vec.states
    rows = np.array([[0.1, 0, 3.0, 0], [0.2, 0, 3.0, 0], [np.nan, 0, 3.0, 0]])
    with pytest.raises(ParameterError, match="initial_state"):
        vec.reset(options={"initial_state": rows})
    with pytest.raises(ParameterError, match="initial_state"):
        vec.reset(options={"initial_state": rows[:2]})
    with pytest.raises(ParameterError, match="reset_mask"):
        vec.reset(options={"reset_mask": [1, 0, 1]})
    assert np.array_equal(vec.states, before)


@pytest.mark.parametrize("observation", ["trig", "raw"])
def test_vector_rows_equal_sync_vector_env_across_autoresets(observation: str) -> None:
    """Options of reset() hold for that reset only, as in Gymnasium's SyncVectorEnv.

    Row b restarts at the task's start state (theta = 3.12, perturbed from row b's
    generator) after an autoreset, not at the options' theta = 0.1.
    """
    n = 3
    kw = {"observation": observation, "perturbation": 0.05, "duration": 0.3, "reward": "dense"}
    vec = CartPoleSwingUpVectorEnv(num_envs=n, **kw)
    sync = SyncVectorEnv([lambda: CartPoleSwingUpEnv(**kw) for _ in range(n)])
    options = {"initial_state": [0.0, 0.0, 0.1, 0.0]}
    vobs, vinfo = vec.reset(seed=4, options=options)
    sobs, sinfo = sync.reset(seed=4, options=options)
    assert np.array_equal(vobs, sobs) and np.array_equal(vinfo["state"], sinfo["state"])
    rng = np.random.default_rng(0)
    autoresets = 0
    for _ in range(100):
        a = rng.uniform(-30, 30, size=(n, 1))
        vout = vec.step(a)
        sout = sync.step(a)
        for v, s in zip(vout[:4], sout[:4], strict=True):
            assert np.array_equal(v, s)
        assert np.array_equal(vout[4]["state"], sout[4]["state"])
        restarted = vout[4]["t"] == 0.0
        if restarted.any():
            autoresets += 1
            assert np.all(np.abs(vout[4]["state"][restarted, 2] - 3.12) <= 0.05)
    assert autoresets == 3  # 100 steps of 30-step episodes + the autoreset step


# --------------------------------------------------------------------------- rendering


def _cart_columns(frame: np.ndarray) -> np.ndarray:
    """Columns holding the cart's colour (render._CART = (60, 90, 160))."""
    mask = np.all(np.abs(frame.astype(int) - [60, 90, 160]) <= 2, axis=2)
    return np.nonzero(mask.any(axis=0))[0]


def test_camera_keeps_the_chapter_final_cart_in_every_frame() -> None:
    """The chapter's final gains carry the cart to about 6 m, beyond a fixed +-4 m view."""
    env = CartPoleSwingUpEnv(render_mode="rgb_array")
    policy = SwitchingController(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    obs, info = env.reset(seed=0)
    xs = []
    missing = []
    k = 0
    done = False
    while not done:
        x = info["state"][0]
        xs.append(x)
        if k % 50 == 0 or abs(x) > 5.9:
            frame = env.render()
            assert frame is not None
            cols = _cart_columns(frame)
            # The whole cart (0.5 m = 37 px wide) inside the picture.
            if len(cols) < 30 or cols.min() == 0 or cols.max() == RENDER_WIDTH - 1:
                missing.append((k, x))
        obs, _, terminated, truncated, info = env.step(policy(obs))
        done = terminated or truncated
        k += 1
    assert max(np.abs(xs)) > 5.9  # the run this test is about does leave +-4 m
    assert missing == []


def test_camera_is_still_near_the_centre_and_follows_beyond() -> None:
    env = CartPoleSwingUpEnv()
    state = np.array([2.0, 0.0, 0.0, 0.0])
    assert view(state, env.task) == (4.0, 0.0)
    far = np.array([6.0, 0.0, 0.0, 0.0])
    x_limit, camera = view(far, env.task)
    # 1.7 m between the cart and the edge of the view: the pole (1 m) fits.
    assert far[0] - camera == pytest.approx(x_limit - 1.7)
    assert view(-far, env.task)[1] == -camera


def test_human_mode_without_pygame_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pygame", None)  # import pygame -> ImportError
    with pytest.raises(MissingExtraError, match=r"\[render\] extra") as err:
        gym.make(ENV_ID, render_mode="human")
    assert "\n" not in str(err.value)
    assert isinstance(err.value, ImportError)


def test_human_mode_shows_frames_with_pygame(monkeypatch: pytest.MonkeyPatch) -> None:
    pygame = pytest.importorskip("pygame", reason="needs the [render] extra (pygame)")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = gym.make(ENV_ID, render_mode="human", duration=0.05)
    assert isinstance(env.unwrapped, CartPoleSwingUpEnv)  # no HumanRendering fallback
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(np.zeros(1))
        done = terminated or truncated
    assert env.render() is None
    surface = pygame.display.get_surface()
    assert surface.get_size() == (600, 400)
    # The window shows the env's picture of the last state.
    pixels = pygame.surfarray.array3d(surface).transpose(1, 0, 2)
    base = env.unwrapped
    assert np.array_equal(pixels, env_frame(base.state, base.task, base.t))  # type: ignore[attr-defined]
    env.close()
    assert not pygame.display.get_init()


def test_instance_lists_human_only_with_pygame(monkeypatch: pytest.MonkeyPatch) -> None:
    """check_env makes every listed mode: without pygame an instance does not list "human"."""
    assert "human" in CartPoleSwingUpEnv.metadata["render_modes"]
    monkeypatch.setitem(sys.modules, "pygame", None)
    env = gym.make(ENV_ID)
    assert env.metadata["render_modes"] == ["rgb_array"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env.unwrapped)


@pytest.mark.parametrize(
    "code",
    [
        "import striatal.envs",
        "from striatal.envs import SwitchingController",
        "import striatal.envs.task",
        "import striatal, gymnasium; gymnasium.make('striatal/CartPoleSwingUp-v0')",
        "import gymnasium, striatal; gymnasium.make('striatal/CartPoleSwingUpDense-v0')",
    ],
)
def test_envs_import_in_a_fresh_process_in_any_order(code: str) -> None:
    """The hook that registers the ids when Gymnasium loads must not run into a half
    imported striatal.envs (its cartpole module is what imports Gymnasium)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", f"{code}; print('ok')"], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
