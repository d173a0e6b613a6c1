"""One picture of the cart-pole, shared by the animation and the Gymnasium env.

Drawn with Pillow on a fresh canvas each call: a pure function of its arguments,
no state kept between calls. No physics here: the pole tip is placed at
(x + l sin theta, l cos theta) from the state alone (theta = 0 upright, clockwise).
"""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from striatal.errors import ParameterError
from striatal.params import Plant

__all__ = [
    "MODE_LABELS",
    "cartpole_frame",
    "follow_camera",
]

#: Text shown for the active controller, by kernel mode (0 swing-up, 1 balancing).
MODE_LABELS = {0: "swing-up", 1: "balancing"}

_BACKGROUND = (255, 255, 255)
_TRACK = (90, 90, 90)
_CART = (60, 90, 160)
_POLE = (200, 120, 40)
_TIP = (170, 60, 30)
_ZONE = (175, 205, 175)
_TEXT = (20, 20, 20)
_MODE_COLOURS = {0: (200, 80, 40), 1: (40, 140, 60)}


def cartpole_frame(
    state: np.ndarray,
    plant: Plant,
    *,
    mode: int | None = None,
    t: float | None = None,
    theta_c: float | None = None,
    width: int = 600,
    height: int = 400,
    x_limit: float = 4.0,
    camera_x: float = 0.0,
) -> np.ndarray:
    """(height, width, 3) uint8 RGB image of the cart-pole in ``state``.

    Parameters
    ----------
    state : (4,) [x, x_dot, theta, theta_dot] in [m, m/s, rad, rad/s]; only x and
        theta are drawn (theta may be unwrapped).
    plant : gives the pole length l [m].
    mode : active controller, 0 swing-up or 1 balancing (kernel.MODE_*); labelled
        in the top-left corner when given.
    t : time [s], written under the label when given.
    theta_c : switching threshold [rad] (eq 21); when given, the balancing zone
        |theta| < theta_c is shaded as a wedge at the pivot.
    width, height : image size [px].
    x_limit : half-width of the view [m]: the track shown spans
        [camera_x - x_limit, camera_x + x_limit]; a cart beyond it is drawn clipped
        at the image edge.
    camera_x : centre of the view on the track [m]; :func:`follow_camera` gives a
        centre that keeps the cart in the picture.
    """
    s = np.asarray(state, dtype=float).ravel()
    if s.shape[0] < 3:
        raise ParameterError(f"state must be [x, x_dot, theta, theta_dot], got shape {s.shape}")
    if int(width) < 16 or int(height) < 16:
        raise ParameterError(f"image must be at least 16 x 16 px, got {width} x {height}")
    if not (math.isfinite(x_limit) and x_limit > 0.0):
        raise ParameterError(f"x_limit must be a finite number > 0, got {x_limit!r}")
    if not math.isfinite(camera_x):
        raise ParameterError(f"camera_x must be a finite number, got {camera_x!r}")
    width = int(width)
    height = int(height)
    x = float(s[0])
    theta = float(s[2])
    length = plant.length

    # Metres to pixels: the whole track fits across, the upright pole fits above it.
    track_y = 0.72 * height
    scale = min(width / (2.0 * x_limit), 0.55 * height / length)
    cx = 0.5 * width
    camera_x = float(camera_x)

    def px(xm: float, ym: float) -> tuple[float, float]:
        return cx + scale * (xm - camera_x), track_y - scale * ym

    img = Image.new("RGB", (width, height), _BACKGROUND)
    draw = ImageDraw.Draw(img)
    line_w = max(1, round(height / 130))
    small_font = ImageFont.load_default(size=max(8, round(height / 32)))

    # The track across the whole view, a tick every metre, labelled every 2 m, so
    # that a moving camera still shows where the cart is.
    x_left = camera_x - width / (2.0 * scale)
    x_right = camera_x + width / (2.0 * scale)
    draw.line([px(x_left, 0.0), px(x_right, 0.0)], fill=_TRACK, width=line_w)
    for mark in range(int(math.ceil(x_left)), int(math.floor(x_right)) + 1):
        mx, my = px(float(mark), 0.0)
        draw.line([(mx, my), (mx, my + 2 * line_w)], fill=_TRACK, width=1)
        if mark % 2 == 0:
            draw.text((mx, my + 3 * line_w), f"{mark} m", fill=_TRACK, font=small_font, anchor="mt")

    finite = math.isfinite(x) and math.isfinite(theta)
    if finite:
        # Keep the drawing coordinates bounded for absurd states (Pillow wants sane ints).
        x_draw = min(max(x, camera_x - 10.0 * x_limit), camera_x + 10.0 * x_limit)
        pivot = px(x_draw, 0.0)
        if theta_c is not None and 0.0 < theta_c < math.pi:
            r = 1.15 * scale * length
            box = [pivot[0] - r, pivot[1] - r, pivot[0] + r, pivot[1] + r]
            # Pillow angles: degrees clockwise from +x (screen); upright is -90.
            deg = math.degrees(theta_c)
            draw.pieslice(box, -90.0 - deg, -90.0 + deg, fill=_ZONE)
        cart_w = 0.5 * scale
        cart_h = 0.3 * scale
        draw.rectangle(
            [
                pivot[0] - cart_w / 2,
                pivot[1] - cart_h / 2,
                pivot[0] + cart_w / 2,
                pivot[1] + cart_h / 2,
            ],
            fill=_CART,
        )
        tip = px(x_draw + length * math.sin(theta), length * math.cos(theta))
        draw.line([pivot, tip], fill=_POLE, width=max(2, 2 * line_w))
        r_tip = max(3.0, 0.06 * scale)
        draw.ellipse([tip[0] - r_tip, tip[1] - r_tip, tip[0] + r_tip, tip[1] + r_tip], fill=_TIP)

    font = ImageFont.load_default(size=max(10, round(height / 22)))
    lines: list[tuple[str, tuple[int, int, int]]] = []
    if mode is not None:
        label = MODE_LABELS.get(int(mode), f"mode {int(mode)}")
        lines.append((label, _MODE_COLOURS.get(int(mode), _TEXT)))
    if t is not None:
        lines.append((f"t = {t:6.2f} s", _TEXT))
    if not finite:
        lines.append(("state not finite", _TEXT))
    y_text = 0.03 * height
    step = max(12, round(height / 18))
    for text, colour in lines:
        draw.text((0.03 * width, y_text), text, fill=colour, font=font)
        y_text += step

    return np.asarray(img, dtype=np.uint8)


def follow_camera(x: float, x_limit: float, margin: float) -> float:
    """Centre of a view of half-width ``x_limit`` [m] that keeps a cart at ``x`` in it.

    The view stays at 0 while |x| <= x_limit - margin and otherwise slides with
    the cart, keeping it ``margin`` [m] from the edge (give at least the pole length
    so the pole fits too). A pure function of x: no camera state between frames.
    A non-finite x gives 0.
    """
    if not math.isfinite(x):
        return 0.0
    free = max(x_limit - margin, 0.0)
    return math.copysign(max(abs(x) - free, 0.0), x)
