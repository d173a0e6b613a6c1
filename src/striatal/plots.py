"""Figures and animations only; no physics.

Every figure function returns a :class:`matplotlib.figure.Figure` built on the Agg
backend (no display needed) so tests can inspect its artists; :func:`save_figure`
and :func:`save_animation` write files atomically (temp file in the same folder,
then ``os.replace``). Trajectories come from :func:`striatal.rollout.simulate`.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from striatal.errors import DataFileError, ParameterError
from striatal.limits import count_of_steps

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from striatal.profiles import Profile
    from striatal.rollout import Trajectory

#: The chapter: "each motion snapshot was recorded in every 0.2 second" (section 3).
SNAPSHOT_EVERY = 0.2
#: Most stick figures one Figure 5 draws, and most frames one animation holds
#: (memory and file size); both counts are checked before anything is allocated.
MAX_SNAPSHOTS = 10_000
MAX_FRAMES = 5_000
#: Horizontal drift of the snapshot strip of Figure 5's top panel [m/s]: snapshot k is
#: drawn at x(t_k) + DRIFT t_k so that successive stick figures do not overlap.
DRIFT = 0.5
#: Runs whose cart leaves |x| <= VIEW_LIMIT [m] (a runaway, e.g. the printed balancing sign)
#: are drawn clipped to that window, so the part before the runaway stays readable.
VIEW_LIMIT = 15.0
SWINGUP_COLOUR = "tab:orange"
BALANCING_COLOUR = "tab:blue"


def _figure(width: float, height: float) -> Figure:
    """A Figure attached to the Agg canvas (never pyplot: no global state, no display)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _atomic(path: Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` on a temp file beside ``path``, then rename it onto ``path``."""
    from striatal.files import check_no_dangling_link, replace_into

    target = Path(path)
    check_no_dangling_link(target.parent)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{target.stem}.", suffix=target.suffix, dir=target.parent
        )
    except OSError as exc:
        raise DataFileError(f"cannot write {target}: {exc.strerror or exc}") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        # mkstemp makes the file private (0600); give it the mode a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        replace_into(tmp, target)
    except BaseException:
        if tmp.exists():
            tmp.unlink()
        raise


def check_image_path(path: Path, allowed: Sequence[str]) -> Path:
    """``path`` if its extension is one of ``allowed`` and its folder can be written."""
    p = Path(path)
    if p.suffix.lower() not in allowed:
        raise ParameterError(
            f"output {p} must end in one of {', '.join(allowed)} (got {p.suffix or 'none'})"
        )
    if p.is_dir():
        raise DataFileError(f"output {p} is a folder")
    from striatal.files import check_out_dir

    check_out_dir(p.parent if str(p.parent) else Path("."))
    return p


def save_figure(fig: Figure, path: Path, *, dpi: int = 120) -> None:
    """Write ``fig`` to ``path`` (format from the extension) atomically."""
    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    _atomic(Path(path), lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))


# --------------------------------------------------------------------------- Figure 5


def snapshot_indices(traj: Trajectory, every: float = SNAPSHOT_EVERY) -> np.ndarray:
    """Row indices of ``traj.data`` at t = 0, every, 2 every, ... up to the recorded end.

    A full run of duration T gives ``round(T / every) + 1`` snapshots.
    """
    if not every > 0 or not math.isfinite(every):
        raise ParameterError(f"snapshot interval must be > 0 s, got {every}")
    dt = traj.sim.dt
    t_end = float(traj.t[-1])
    n = count_of_steps(
        t_end, every, cap=MAX_SNAPSHOTS, what="snapshots", fix="raise the snapshot interval"
    )
    idx = np.rint(np.arange(n) * every / dt).astype(int)
    return idx[idx < len(traj.t)]


def display_theta(traj: Trajectory) -> np.ndarray:
    """theta(t) unwrapped, shifted by whole turns so that its last value lies in (-pi, pi]
    (for a runaway: its last value while |x| <= VIEW_LIMIT).

    The kernel records the continuous angle; a pole that swings up over the other
    side ends near 2 pi. The shift makes the final upright read 0 without the
    +-pi jumps a wrapped angle shows while the pole hangs near pi.
    """
    theta = traj.column("theta")
    # A runaway cart spins the pole: take the turns at the last instant still in view.
    sane = np.nonzero((np.abs(traj.column("x")) <= VIEW_LIMIT) & np.isfinite(theta))[0]
    last = theta[sane[-1]] if len(sane) else 0.0
    return theta - 2.0 * np.pi * np.round(last / (2.0 * np.pi))


def pole_tip(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(x + l sin theta, l cos theta) [m]: the pole tip in the x-y plane (theta = 0 up)."""
    x, theta = traj.column("x"), traj.column("theta")
    l = traj.plant.length
    return x + l * np.sin(theta), l * np.cos(theta)


def gains_title(gains: Sequence[float], theta_c: float) -> str:
    w = ", ".join(f"{g:.4f}" for g in gains)
    return f"W = [{w}],  θ_c = {theta_c:.4g} rad"


@dataclass(frozen=True)
class Figure5Parts:
    """Named handles on the artists of Figure 5 (for tests and callers)."""

    snapshots: object
    tip_path: object
    x_line: object
    theta_line: object
    switch_lines: tuple[object, ...]


def figure5(
    traj: Trajectory,
    *,
    every: float = SNAPSHOT_EVERY,
    drift: float = DRIFT,
    title: str | None = None,
) -> Figure:
    """The chapter's Figure 5 for one run: three panels.

    Top: a stick figure (cart and pole) every ``every`` seconds, the cart drawn at
    x(t) + ``drift`` t so that the strip reads left to right in time; orange while the
    swing-up controller acts, blue while balancing. Middle: the path of the pole tip
    (x + l sin theta, l cos theta). Bottom: x(t) and theta(t) (see :func:`display_theta`)
    with the switch times as vertical lines.
    The artists are on ``fig.figure5_parts`` (:class:`Figure5Parts`).
    """
    from matplotlib.collections import LineCollection

    fig = _figure(13.0, 9.0)
    ax_snap, ax_xy, ax_t = fig.subplots(3, 1, height_ratios=[0.8, 1.0, 1.1])
    t = traj.t
    x = traj.column("x")
    theta = traj.column("theta")
    mode = traj.column("mode")
    l = traj.plant.length
    idx = snapshot_indices(traj, every)

    base = x[idx] + drift * t[idx]
    tip_x = base + l * np.sin(theta[idx])
    tip_y = l * np.cos(theta[idx])
    segments = np.stack([np.stack([base, np.zeros_like(base)], 1), np.stack([tip_x, tip_y], 1)], 1)
    colours = [BALANCING_COLOUR if m > 0.5 else SWINGUP_COLOUR for m in mode[idx]]
    snaps = LineCollection(list(segments), colors=colours, linewidths=0.8, gid="snapshots")
    ax_snap.add_collection(snaps)
    ax_snap.plot(base, np.zeros_like(base), "s", ms=2.5, color="0.3", gid="carts")
    ax_snap.axhline(0.0, color="0.6", lw=0.5)
    pad = 0.3 * l
    near = np.abs(x[idx]) <= VIEW_LIMIT
    near[0] = True
    ax_snap.set_xlim(
        min(base[near].min(), tip_x[near].min()) - pad,
        max(base[near].max(), tip_x[near].max()) + pad,
    )
    ax_snap.set_ylim(-1.15 * l, 1.55 * l)
    ax_snap.set_aspect("equal", adjustable="box")
    ax_snap.set_xlabel(f"x(t) + {drift:g} m/s · t  [m]   (snapshot every {every:g} s)")
    ax_snap.set_ylabel("height [m]")
    ax_snap.set_title(
        f"motion snapshots every {every:g} s ({len(idx)}); "
        "orange: swing-up (eq 23), blue: balancing (eq 22)",
        fontsize=10,
    )
    # Time marks along the strip, every 10 s.
    for tk in np.arange(0.0, t[-1] + 1e-9, 10.0):
        k = int(round(tk / traj.sim.dt))
        if k < len(t):
            ax_snap.annotate(
                f"{tk:g} s",
                (x[k] + drift * t[k], 1.1 * l),
                ha="center",
                va="bottom",
                fontsize=8,
                color="0.3",
            )

    tx, ty = pole_tip(traj)
    (tip_line,) = ax_xy.plot(tx, ty, lw=0.6, color="tab:purple", gid="tip_path")
    ax_xy.plot(x, np.zeros_like(x), lw=2.0, color="0.5", alpha=0.5, label="cart x(t)")
    ax_xy.plot([tx[0]], [ty[0]], "o", color="tab:green", label="start")
    ax_xy.plot([tx[-1]], [ty[-1]], "*", ms=10, color="tab:red", label="end")
    runaway = not bool(np.all(np.abs(x) <= VIEW_LIMIT))
    if runaway:
        inside = np.abs(x) <= VIEW_LIMIT
        ax_xy.set_xlim(tx[inside].min() - 0.5, tx[inside].max() + 0.5)
        ax_xy.set_ylim(-1.2 * l, 1.2 * l)
    else:
        ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_xlabel("x + l sin θ  [m]")
    ax_xy.set_ylabel("l cos θ  [m]")
    ax_xy.set_title("pole tip in the x-y plane", fontsize=10)
    ax_xy.legend(loc="lower right", fontsize=8)

    th_plot = display_theta(traj)
    (x_line,) = ax_t.plot(t, x, color="tab:green", label="x [m]", gid="x")
    (th_line,) = ax_t.plot(t, th_plot, color="tab:purple", label="θ [rad]", gid="theta")
    many = len(traj.switch_times) > 20
    switch_lines = tuple(
        ax_t.axvline(
            ts,
            color="0.3",
            ls="--",
            lw=0.4 if many else 0.8,
            alpha=0.4 if many else 1.0,
            gid="switch",
        )
        for ts in traj.switch_times
    )
    theta_c = traj.controller.theta_c
    ax_t.axhline(theta_c, color="tab:purple", ls=":", lw=0.7)
    ax_t.axhline(-theta_c, color="tab:purple", ls=":", lw=0.7)
    ax_t.axhline(0.0, color="0.6", lw=0.5)
    ax_t.set_xlim(t[0], t[-1])
    if runaway or not bool(np.all(np.abs(th_plot) <= VIEW_LIMIT)):
        ax_t.set_ylim(-VIEW_LIMIT, VIEW_LIMIT)
        ax_t.text(
            0.01,
            0.03,
            f"clipped to ±{VIEW_LIMIT:g}: max |x| = {np.nanmax(np.abs(x)):.3g} m, "
            f"max |θ| = {np.nanmax(np.abs(th_plot)):.3g} rad",
            transform=ax_t.transAxes,
            fontsize=9,
            color="tab:red",
        )
    ax_t.set_xlabel("time t [s]")
    ax_t.set_ylabel("x [m],  θ [rad]")
    n_sw = len(switch_lines)
    sw_text = ", ".join(f"{s:.2f}" for s in traj.switch_times[:6]) + (" ..." if n_sw > 6 else "")
    ax_t.set_title(
        "cart position and pole angle (θ unwrapped, shifted by whole turns so the end reads "
        f"in (-π, π]; dotted: ±θ_c); dashed: switches at {sw_text or 'none'} s",
        fontsize=10,
    )
    ax_t.legend(loc="upper right", fontsize=8)

    ctrl = traj.controller
    o = traj.outcome
    default = (
        f"Figure 5: {gains_title(ctrl.gains, ctrl.theta_c)}\n"
        f"balance sign {ctrl.balance_sign}, {ctrl.switch} switch"
        + (f" (γ = {ctrl.inhibition:g})" if ctrl.soft else "")
        + f", θ(0) = {traj.sim.theta0:g} rad, dt = {traj.sim.dt:g} s, mean policy; "
        f"success test at {traj.sim.duration:g} s: {'passed' if o.success else 'failed'}"
        + (" (numerical fault)" if o.fault else "")
    )
    fig.suptitle(title or default, fontsize=11)
    fig.figure5_parts = Figure5Parts(  # type: ignore[attr-defined]
        snapshots=snaps,
        tip_path=tip_line,
        x_line=x_line,
        theta_line=th_line,
        switch_lines=switch_lines,
    )
    return fig


# --------------------------------------------------------------------------- curves


HISTORY_NUMERIC = ("trial", "reward", "W1", "W2", "W3", "W4", "W5", "W6", "theta_c", "sigma")
HISTORY_FLAGS = ("success", "fault", "early")


@dataclass(frozen=True)
class History:
    """history.csv of ``striatal train`` as arrays; W (n, 6) are the gains USED in each trial."""

    trial: np.ndarray
    reward: np.ndarray
    W: np.ndarray
    theta_c: np.ndarray
    sigma: np.ndarray
    success: np.ndarray

    def __len__(self) -> int:
        return len(self.trial)


def read_history(path: Path) -> History:
    """Parse history.csv (header of striatal.learn.HISTORY_COLUMNS) or raise DataFileError."""
    from striatal.files import read_csv

    rows = read_csv(path, what="history")
    if not rows:
        raise DataFileError(f"history {path} has no trials")
    missing = [c for c in (*HISTORY_NUMERIC, "success") if c not in rows[0]]
    if missing:
        raise DataFileError(f"history {path} lacks the column(s) {', '.join(missing)}")
    cols: dict[str, list[float]] = {c: [] for c in (*HISTORY_NUMERIC, "success")}
    for line, row in enumerate(rows, start=2):
        for c in cols:
            cell = row.get(c)
            try:
                v = float(cell)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise DataFileError(
                    f"history {path} line {line}: column {c} is not a number ({cell!r})"
                ) from None
            if not math.isfinite(v):
                raise DataFileError(f"history {path} line {line}: column {c} is not finite")
            cols[c].append(v)
    return History(
        trial=np.array(cols["trial"]),
        reward=np.array(cols["reward"]),
        W=np.array([cols[f"W{i}"] for i in range(1, 7)]).T,
        theta_c=np.array(cols["theta_c"]),
        sigma=np.array(cols["sigma"]),
        success=np.array(cols["success"]) > 0.5,
    )


def running_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Mean of the last ``window`` values at each index (fewer at the start)."""
    v = np.asarray(values, dtype=float)
    c = np.concatenate([[0.0], np.cumsum(v)])
    i = np.arange(1, len(v) + 1)
    lo = np.maximum(i - window, 0)
    return (c[i] - c[lo]) / (i - lo)


def learning_curves(history: History, *, window: int = 50, title: str | None = None) -> Figure:
    """Reward per trial with running rates, the six gains, theta_c and sigma over trials.

    Axes (in ``fig.axes`` order): reward, gains, theta_c, sigma, then the twin axis of
    the running rates (fraction of +10 rewards, fraction passing the success test).
    """
    if window < 1:
        raise ParameterError(f"window must be >= 1, got {window}")
    fig = _figure(11.0, 10.0)
    ax_r, ax_w, ax_c, ax_s = fig.subplots(4, 1, sharex=True, height_ratios=[1.0, 1.4, 0.8, 0.8])
    n = history.trial
    pos = history.reward > 0
    ax_r.plot(n[pos], history.reward[pos], ".", color="tab:green", ms=3, label="reward > 0")
    ax_r.plot(n[~pos], history.reward[~pos], ".", color="tab:red", ms=3, label="reward < 0")
    ax_r.set_ylabel("reward (eqs 24-25)")
    ax_r.set_title(
        f"reward per trial; running fractions over the last {window} trials", fontsize=10
    )
    ax_rate = ax_r.twinx()
    ax_rate.plot(n, running_mean(pos, window), color="tab:green", lw=1.2, label="fraction +10")
    ax_rate.plot(
        n,
        running_mean(history.success, window),
        color="black",
        lw=1.2,
        label="fraction passing success test",
    )
    ax_rate.set_ylim(-0.02, 1.02)
    ax_rate.set_ylabel("running fraction")
    h1, l1 = ax_r.get_legend_handles_labels()
    h2, l2 = ax_rate.get_legend_handles_labels()
    ax_rate.legend(
        h1 + h2, l1 + l2, loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize=8, frameon=False
    )

    for i in range(6):
        ax_w.plot(n, history.W[:, i], lw=1.0, label=f"W{i + 1}")
    ax_w.axhline(0.0, color="0.6", lw=0.5)
    ax_w.set_ylabel("gain (used in the trial)")
    ax_w.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax_w.set_title("W1..W6 (eqs 22-23)", fontsize=10)
    ax_c.plot(n, history.theta_c, color="tab:purple", lw=1.0)
    ax_c.set_ylabel("θ_c [rad]")
    ax_c.set_title("switching threshold (eq 21)", fontsize=10)
    ax_s.plot(n, history.sigma, color="tab:brown", lw=1.0)
    ax_s.set_ylabel("σ [m/s²]")
    ax_s.set_title("exploration σ = 0.1 + sigmoid(W6)", fontsize=10)
    ax_s.set_xlabel("trial")
    fig.suptitle(
        title
        or f"Learning curves: {len(history)} trials, {int(pos.sum())} with reward +10, "
        f"{int(history.success.sum())} passing the success test",
        fontsize=11,
    )
    return fig


# --------------------------------------------------------------------------- soft switch


def switch_figure(theta_c: float, gammas: Sequence[float], *, theta_max: float = math.pi) -> Figure:
    """The cerebellar soft switch of section 4 (NOTES section 4) against |theta|.

    Left: balancing weight clip(gamma (theta_c - |theta|), 0, 1) (solid) and swing-up
    weight clip(gamma (|theta| - theta_c), 0, 1) (dashed) for each gamma, with the hard
    switch in black. Right: their sum, which dips below 1 in a dead zone of half-width
    1/gamma around theta_c where neither pathway fully drives the cart.
    """
    from striatal.control import switch_weights

    if not gammas:
        raise ParameterError("give at least one inhibition strength gamma")
    for g in gammas:
        if not (math.isfinite(g) and g > 0):
            raise ParameterError(f"inhibition gamma must be a finite number > 0, got {g}")
    if not 0.0 < theta_c < math.pi:
        raise ParameterError(f"theta_c must be in (0, pi), got {theta_c}")
    a = np.linspace(0.0, theta_max, 2001)
    fig = _figure(12.0, 4.8)
    ax_w, ax_sum = fig.subplots(1, 2, width_ratios=[1.4, 1.0])
    wb, ws = switch_weights(a, theta_c, False, 1.0)
    ax_w.plot(a, wb, color="black", lw=2.0, alpha=0.35, label="hard switch (section 2.3)")
    ax_w.plot(a, ws, color="black", lw=2.0, alpha=0.35, ls="--")
    for k, g in enumerate(gammas):
        colour = f"C{k}"
        wb, ws = switch_weights(a, theta_c, True, g)
        ax_w.plot(a, wb, color=colour, lw=1.3, label=f"γ = {g:g} /rad", gid=f"balancing:{g:g}")
        ax_w.plot(a, ws, color=colour, lw=1.3, ls="--", gid=f"swingup:{g:g}")
        ax_sum.plot(a, wb + ws, color=colour, lw=1.3, label=f"γ = {g:g} /rad", gid=f"sum:{g:g}")
    for ax in (ax_w, ax_sum):
        ax.axvline(theta_c, color="0.4", ls=":", lw=0.8)
        ax.set_xlabel("|θ| [rad]")
        ax.set_xlim(0.0, theta_max)
        ax.set_ylim(-0.05, 1.1)
    ax_w.set_ylabel("weight")
    ax_w.set_title(
        "solid: balancing weight on μ₁, clip(γ(θ_c − |θ|), 0, 1)\n"
        "dashed: swing-up weight on μ₂, clip(γ(|θ| − θ_c), 0, 1)",
        fontsize=10,
    )
    ax_w.legend(fontsize=8, loc="center right")
    ax_sum.set_ylabel("balancing + swing-up weight")
    ax_sum.set_title("total drive: a dead zone of half-width 1/γ at θ_c", fontsize=10)
    fig.suptitle(
        "Cerebellar soft switch (section 4, labels read swapped: NOTES 4), "
        f"θ_c = {theta_c:.4g} rad",
        fontsize=11,
    )
    return fig


# --------------------------------------------------------------------------- animation


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


#: Widest track an animation shows [m]; a runaway cart is drawn clipped at its edge.
MAX_TRACK = 20.0


def animation_frames(
    traj: Trajectory, *, fps: float, speed: float, width: int = 720, height: int = 320
) -> list[np.ndarray]:
    """(H, W, 3) uint8 frames of ``traj`` from :func:`striatal.render.cartpole_frame`."""
    from striatal import render

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
        _atomic(p, lambda tmp: _write_mp4(frames, tmp, fps))
    else:
        _atomic(p, lambda tmp: _write_gif(frames, tmp, fps))


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


# --------------------------------------------------------------------------- performance profiles


def performance_profiles(
    profiles: Sequence[Profile], *, xlabel: str, note: str = "", title: str | None = None
) -> Figure:
    """Fraction of seeds solved against budget, one step line per arm with its 95 % band.

    ``profiles`` from :func:`striatal.profiles.sweep_profiles`; the band is the
    pointwise Wilson interval. ``note`` (e.g. the trials fallback) is printed
    under the axes.
    """
    fig = _figure(8.0, 5.0)
    ax = fig.subplots()
    for i, p in enumerate(profiles):
        colour = f"C{i % 10}"
        ax.fill_between(p.budget, p.low, p.high, step="post", color=colour, alpha=0.2, lw=0)
        ax.step(
            p.budget,
            p.solved,
            where="post",
            color=colour,
            lw=1.6,
            label=f"{p.arm}: {p.successes}/{p.runs} solved",
        )
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(left=0.0)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("fraction of seeds solved within budget")
    ax.grid(True, color="0.9", lw=0.5)
    ax.legend(loc="upper left", fontsize=9, frameon=False)
    ax.set_title(title or "Performance profiles (bands: pointwise Wilson 95 %)", fontsize=11)
    if note:
        fig.supxlabel(note, fontsize=7, color="0.35")
    return fig
