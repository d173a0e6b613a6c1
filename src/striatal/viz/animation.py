"""Animations of one run: frame times, frames from :mod:`striatal.viz.render`, GIF and MP4."""

from __future__ import annotations

import math
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from striatal.errors import DataFileError, ParameterError
from striatal.io.files import atomic_write_file
from striatal.limits import count_of_steps

__all__ = [
    "MAX_FRAMES",
    "MAX_FRAME_BYTES",
    "MAX_TRACK",
    "animation_frames",
    "check_animation",
    "ffmpeg_path",
    "frame_times",
    "save_animation",
]

if TYPE_CHECKING:
    from striatal.sim.rollout import Trajectory

#: Most frames one animation holds (memory and file size), checked before anything
#: is allocated.
MAX_FRAMES = 5_000


def frame_times(t_end: float, fps: float, speed: float) -> np.ndarray:
    """Simulation times [s] shown by an animation at ``fps`` frames per second of video
    that runs ``speed`` times faster than the simulation: 0, speed/fps, ... <= t_end.

    At most :data:`MAX_FRAMES`, checked before the array is built."""
    if not (math.isfinite(fps) and fps > 0):
        raise ParameterError(f"fps must be > 0, got {fps}")
    if not (math.isfinite(speed) and speed > 0):
        raise ParameterError(f"speed must be > 0, got {speed}")
    step = speed / fps
    n = count_of_steps(
        t_end, step, cap=MAX_FRAMES, what="frames", fix="raise the speed or lower the fps"
    )
    return np.arange(n) * step


#: Most bytes the frames of one animation hold (they are all in memory before the file
#: is encoded): 2 GiB, about 3 100 frames of the default 720 x 320 px.
MAX_FRAME_BYTES = 2 * 2**30
#: Frame sizes an animation takes [px].
FRAME_PX = (16, 4096)
#: Frame rates an animation takes [1/s]: a GIF's delay is a 16-bit count of 10 ms
#: (at most 655.35 s, and at least 10 ms), so 0.1 fps (10 s a frame) leaves room for
#: the identical frames Pillow merges into one.
FPS_RANGE = (0.1, 100.0)


def check_animation(t_end: float, fps: float, speed: float, width: int, height: int) -> int:
    """The number of frames of an animation of ``t_end`` s (:func:`frame_times`), or
    ParameterError if a side is outside :data:`FRAME_PX`, ``fps`` outside
    :data:`FPS_RANGE`, or the frames would hold
    more than :data:`MAX_FRAME_BYTES`; checked before the run is simulated."""
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer):
            raise ParameterError(f"--{name} must be a whole number of px, got {v!r}")
        if not FRAME_PX[0] <= v <= FRAME_PX[1]:
            raise ParameterError(f"--{name} must be in [{FRAME_PX[0]}, {FRAME_PX[1]}] px, got {v}")
    if not (isinstance(fps, int | float) and FPS_RANGE[0] <= fps <= FPS_RANGE[1]):
        raise ParameterError(
            f"--fps must be in [{FPS_RANGE[0]:g}, {FPS_RANGE[1]:g}] (a GIF's delay is a "
            f"16-bit count of 10 ms), got {fps}"
        )
    frame_times(0.0, fps, speed)  # fps and speed > 0
    n = count_of_steps(
        t_end, speed / fps, cap=MAX_FRAMES, what="frames", fix="raise --speed or lower --fps"
    )
    size = n * width * height * 3
    if size > MAX_FRAME_BYTES:
        raise ParameterError(
            f"the animation would hold {n:,} frames of {width} x {height} px = "
            f"{size / 2**30:.3g} GiB, more than {MAX_FRAME_BYTES / 2**30:g} GiB; lower "
            "--width or --height, raise --speed or lower --fps"
        )
    return n


#: Widest track an animation shows [m]; a runaway cart is drawn clipped at its edge.
MAX_TRACK = 20.0


def animation_frames(
    traj: Trajectory, *, fps: float, speed: float, width: int = 720, height: int = 320
) -> list[np.ndarray]:
    """(H, W, 3) uint8 frames of ``traj`` from :func:`striatal.viz.render.cartpole_frame`."""
    from striatal.viz import render

    check_animation(float(traj.t[-1]), fps, speed, width, height)
    times = frame_times(float(traj.t[-1]), fps, speed)
    idx = np.minimum(np.rint(times / traj.sim.dt).astype(int), len(traj.t) - 1)
    states = traj.states
    mode = traj.column("mode")
    # The track shown must hold the whole run (the chapter's capture travels ~6 m).
    reach = float(np.nanmax(np.abs(states[idx, 0]))) + 1.05 * traj.plant.length
    x_limit = min(max(4.0, math.ceil(2.0 * reach) / 2.0), MAX_TRACK)
    frames = []
    for k in idx:
        frames.append(
            render.cartpole_frame(
                states[k],
                traj.plant,
                mode=int(mode[k]),
                t=float(traj.t[k]),
                theta_c=traj.controller.theta_c,
                width=width,
                height=height,
                x_limit=x_limit,
            )
        )
    return frames


def save_animation(frames: Sequence[np.ndarray], path: Path, *, fps: float) -> None:
    """Write ``frames`` as a GIF (Pillow) or, for ``.mp4``, through ffmpeg; atomically."""
    p = Path(path)
    if not frames:
        raise ParameterError("no frames to write")
    if p.suffix.lower() == ".mp4":
        atomic_write_file(p, lambda tmp: _write_mp4(frames, tmp, fps))
    else:
        atomic_write_file(p, lambda tmp: _write_gif(frames, tmp, fps))


def _write_gif(frames: Sequence[np.ndarray], tmp: Path, fps: float) -> None:
    from PIL import Image

    images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    palette = [im.convert("P", palette=Image.Palette.ADAPTIVE, colors=64) for im in images]
    # GIF delays are in 10-ms units; Pillow merges identical consecutive frames,
    # so frames that differ only by nothing collapse (their delays add up).
    duration = max(20, int(round(1000.0 / fps / 10.0)) * 10)
    palette[0].save(
        tmp,
        format="GIF",
        save_all=True,
        append_images=palette[1:],
        duration=duration,
        loop=0,
        optimize=False,
    )


def ffmpeg_path() -> str | None:
    return shutil.which("ffmpeg")


def _write_mp4(frames: Sequence[np.ndarray], tmp: Path, fps: float) -> None:
    exe = ffmpeg_path()
    if exe is None:
        raise ParameterError("writing .mp4 needs ffmpeg on PATH; write a .gif instead")
    h, w = frames[0].shape[:2]
    cmd = [
        exe,
        "-y",
        "-loglevel",
        "error",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "rgb24",
        "-s",
        f"{w}x{h}",
        "-r",
        f"{fps:g}",
        "-i",
        "-",
        "-vf",
        "pad=ceil(iw/2)*2:ceil(ih/2)*2",
        "-pix_fmt",
        "yuv420p",
        "-f",
        "mp4",
        str(tmp),
    ]
    data = b"".join(np.ascontiguousarray(f, dtype=np.uint8).tobytes() for f in frames)
    proc = subprocess.run(cmd, input=data, capture_output=True, check=False)
    if proc.returncode != 0:
        msg = proc.stderr.decode(errors="replace").strip().splitlines()
        raise DataFileError(f"ffmpeg failed: {msg[-1] if msg else proc.returncode}")
