"""The cart-pole picture: right shape, and the pole is where the state says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.params import Plant
from striatal.viz.render import cartpole_frame


def _pole_pixels(img: np.ndarray) -> np.ndarray:
    """(n, 2) row, col of the pole/tip colours (orange-brown: red high, blue low)."""
    r = img[..., 0].astype(int)
    g = img[..., 1].astype(int)
    b = img[..., 2].astype(int)
    mask = (r > 150) & (b < 60) & (g > 40) & (g < 140)
    return np.argwhere(mask)


def test_frame_shape_and_dtype(plant: Plant) -> None:
    img = cartpole_frame(np.array([0.0, 0.0, 3.12, 0.0]), plant, mode=0, t=1.5, theta_c=0.9)
    assert img.shape == (400, 600, 3)
    assert img.dtype == np.uint8
    small = cartpole_frame(np.zeros(4), plant, width=240, height=160)
    assert small.shape == (160, 240, 3)


def test_pole_moves_with_theta(plant: Plant) -> None:
    up = _pole_pixels(cartpole_frame(np.array([0.0, 0.0, 0.0, 0.0]), plant))
    down = _pole_pixels(cartpole_frame(np.array([0.0, 0.0, math.pi, 0.0]), plant))
    right = _pole_pixels(cartpole_frame(np.array([0.0, 0.0, math.pi / 2, 0.0]), plant))
    assert len(up) > 50 and len(down) > 50 and len(right) > 50
    track_row = 0.72 * 400
    # Upright: pole above the track (smaller row index); hanging: below.
    assert up[:, 0].mean() < track_row - 20
    assert down[:, 0].mean() > track_row + 20
    # theta = pi/2 tips clockwise: to the right of the pivot (image centre column 300).
    assert right[:, 1].mean() > 300 + 20
    assert abs(up[:, 1].mean() - 300) < 5


def test_cart_moves_with_x(plant: Plant) -> None:
    left = _pole_pixels(cartpole_frame(np.array([-2.0, 0.0, 0.0, 0.0]), plant))
    right = _pole_pixels(cartpole_frame(np.array([2.0, 0.0, 0.0, 0.0]), plant))
    # 600 px across 8 m of track: 75 px per metre, 4 m apart = 300 px.
    assert right[:, 1].mean() - left[:, 1].mean() == pytest.approx(300.0, abs=3.0)


def test_frame_is_pure(plant: Plant) -> None:
    s = np.array([0.3, 0.0, 2.0, 0.0])
    a = cartpole_frame(s, plant, mode=1, t=3.0, theta_c=0.9)
    cartpole_frame(np.array([-1.0, 0.0, 0.1, 0.0]), plant, mode=0)
    b = cartpole_frame(s, plant, mode=1, t=3.0, theta_c=0.9)
    assert np.array_equal(a, b)
    # The label changes the picture: swing-up vs balancing text differ.
    c = cartpole_frame(s, plant, mode=0, t=3.0, theta_c=0.9)
    assert not np.array_equal(a, c)


def test_nonfinite_state_still_draws(plant: Plant) -> None:
    img = cartpole_frame(np.array([np.nan, 0.0, 1.0, 0.0]), plant, mode=0)
    assert img.shape == (400, 600, 3)
    far = cartpole_frame(np.array([1e9, 0.0, 1.0, 0.0]), plant)
    assert far.shape == (400, 600, 3)


def test_bad_arguments(plant: Plant) -> None:
    with pytest.raises(ParameterError):
        cartpole_frame(np.zeros(2), plant)
    with pytest.raises(ParameterError):
        cartpole_frame(np.zeros(4), plant, width=4)
    with pytest.raises(ParameterError):
        cartpole_frame(np.zeros(4), plant, x_limit=0.0)
