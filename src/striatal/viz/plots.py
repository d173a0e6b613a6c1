"""Figures and animations only; no physics.

Every figure function returns a :class:`matplotlib.figure.Figure` built on the Agg
backend (no display needed) so tests can inspect its artists; :func:`save_figure`
and :func:`save_animation` write files atomically (temp file in the same folder,
then ``os.replace``). Trajectories come from :func:`striatal.sim.rollout.simulate`.
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
from striatal.io.rundir import read_history as read_history
from striatal.learners import History
from striatal.limits import count_of_steps

__all__ = [
    "BALANCING_COLOUR",
    "MAX_FRAMES",
    "MAX_SNAPSHOTS",
    "MAX_TRACK",
    "POSE_GAP",
    "ROW_HEIGHT",
    "ROW_SECONDS",
    "RULE_PANELS",
    "SNAPSHOT_EVERY",
    "SWINGUP_COLOUR",
    "VIEW_LIMIT",
    "Figure5Parts",
    "animation_frames",
    "check_image_path",
    "display_theta",
    "ffmpeg_path",
    "figure5",
    "figure5_caption",
    "final_upright",
    "frame_times",
    "gains_title",
    "learning_curves",
    "performance_profiles",
    "pole_tip",
    "running_mean",
    "save_animation",
    "save_figure",
    "snapshot_indices",
    "snapshot_layout",
    "switch_figure",
]

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from striatal.experiments.profiles import Profile
    from striatal.sim.rollout import Trajectory

#: The chapter: "each motion snapshot was recorded in every 0.2 second" (section 3).
SNAPSHOT_EVERY = 0.2
#: Figure 5's snapshots are laid out in rows of this many seconds each.
ROW_SECONDS = 10.0
#: Distance between successive poses along a row of snapshots, in pole lengths.
POSE_GAP = 0.6
#: Height of one row of snapshots, in pole lengths (a hanging and an upright pole fit).
ROW_HEIGHT = 2.6
#: Most stick figures one Figure 5 draws, and most frames one animation holds
#: (memory and file size); both counts are checked before anything is allocated.
MAX_SNAPSHOTS = 10_000
MAX_FRAMES = 5_000
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
    from striatal.io.files import check_no_dangling_link, replace_into

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
    from striatal.io.files import check_out_dir

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
    """theta(t) as the kernel records it (unwrapped), shifted by whole turns so that
    theta(0) lies in (-pi, pi]: the start reads the theta(0) of the run.

    A pole that swings up over the other side then ends near +-2 pi, which is upright
    too: Figure 5 marks the upright of the last turn (:func:`final_upright`).
    """
    theta = traj.column("theta")
    first = theta[0] if np.isfinite(theta[0]) else 0.0
    return theta - 2.0 * np.pi * np.round(first / (2.0 * np.pi))


def final_upright(theta: np.ndarray) -> float:
    """The upright angle 2 pi k [rad] nearest the last finite value of ``theta``
    (for a runaway: the last value whose size is at most VIEW_LIMIT)."""
    sane = np.nonzero(np.isfinite(theta) & (np.abs(theta) <= VIEW_LIMIT))[0]
    last = theta[sane[-1]] if len(sane) else 0.0
    return float(2.0 * np.pi * np.round(last / (2.0 * np.pi)))


def snapshot_layout(
    t: np.ndarray, every: float, row_seconds: float
) -> tuple[np.ndarray, np.ndarray]:
    """(row, slot) of snapshots taken at times ``t`` [s]: row r holds
    [r row_seconds, (r + 1) row_seconds), slot j is the j-th pose of its row.

    A last snapshot that would start a row of its own (t = 60 s with 10-s rows) ends
    the row before it instead.
    """
    if not (math.isfinite(row_seconds) and row_seconds >= every):
        raise ParameterError(f"row length must be >= the snapshot interval, got {row_seconds}")
    n_rows = max(1, int(math.ceil(float(t[-1]) / row_seconds - 1e-9)))
    row = np.minimum(np.floor(t / row_seconds + 1e-9).astype(int), n_rows - 1)
    slot = np.rint((t - row * row_seconds) / every).astype(int)
    return row, slot


def pole_tip(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(x + l sin theta, l cos theta) [m]: the pole tip in the x-y plane (theta = 0 up)."""
    x, theta = traj.column("x"), traj.column("theta")
    l = traj.plant.length
    return x + l * np.sin(theta), l * np.cos(theta)


def gains_title(gains: Sequence[float], theta_c: float) -> str:
    """``W = [W1, ..., W6],  θ_c = ... rad`` with four decimals."""
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
    caption: str


def figure5_caption(traj: Trajectory, *, every: float = SNAPSHOT_EVERY) -> str:
    """The caption of Figure 5 for ``traj``: the run's parameters and how to read the panels."""
    ctrl = traj.controller
    o = traj.outcome
    n = len(snapshot_indices(traj, every))
    switches = ", ".join(f"{s:.2f}" for s in traj.switch_times[:6])
    if len(traj.switch_times) > 6:
        switches += f" ... ({len(traj.switch_times)} in all)"
    return (
        f"Figure 5. One run with the mean policy: {gains_title(ctrl.gains, ctrl.theta_c)}; "
        f"balance sign {ctrl.balance_sign}, {ctrl.switch} switch"
        + (f" (γ = {ctrl.inhibition:g} /rad)" if ctrl.soft else "")
        + f"; θ(0) = {traj.sim.theta0:g} rad, dt = {traj.sim.dt:g} s; "
        f"success test at {traj.sim.duration:g} s: {'passed' if o.success else 'failed'}"
        + (" (numerical fault: the state blew up)" if o.fault else "")
        + f". Top: the pole every {every:g} s ({n} poses), one row per {ROW_SECONDS:g} s, "
        "time running left to right; orange while the swing-up controller acts (eq 23), "
        "blue while balancing (eq 22); each pose is drawn at its own place in the row, "
        "the cart's position is in the third panel. Second: the path of the pole tip "
        "(x + l sin θ, l cos θ). Third: the cart position x(t). Bottom: the pole angle "
        "θ(t), unwrapped from θ(0); the grey line is the upright the run ends at "
        "(2π k), the dotted lines ±θ_c about it. Dashed vertical lines: switches "
        f"between the controllers at {switches or 'none'} s."
    )


def figure5(
    traj: Trajectory,
    *,
    every: float = SNAPSHOT_EVERY,
    title: str | None = None,
) -> Figure:
    """The chapter's Figure 5 for one run: four panels, and its caption.

    Top: a stick figure of the pole every ``every`` seconds, in rows of
    :data:`ROW_SECONDS` (:func:`snapshot_layout`), orange while the swing-up
    controller acts, blue while balancing. Second: the path of the pole tip
    (x + l sin theta, l cos theta). Third: x(t). Bottom: theta(t) (see
    :func:`display_theta`) with +-theta_c about the final upright. The switch times
    are vertical lines in the last two. The title is short; the parameters of the
    run are in the caption (:func:`figure5_caption`), on ``fig.figure5_parts``
    (:class:`Figure5Parts`) with the artists.
    """
    from matplotlib.collections import LineCollection

    t = traj.t
    x = traj.column("x")
    theta = traj.column("theta")
    mode = traj.column("mode")
    l = traj.plant.length
    idx = snapshot_indices(traj, every)
    row, slot = snapshot_layout(t[idx], every, ROW_SECONDS)
    n_rows = int(row.max()) + 1
    width_poses = float(slot.max()) * POSE_GAP + 2.4

    snap_height = 12.2 * n_rows * ROW_HEIGHT / width_poses
    fig = _figure(13.0, snap_height + 8.2)
    ax_snap, ax_xy, ax_x, ax_th = fig.subplots(
        4, 1, height_ratios=[snap_height, 3.2, 1.9, 2.1], gridspec_kw={"hspace": 0.08}
    )

    # Snapshots: pivot of pose k at (slot POSE_GAP l, -row ROW_HEIGHT l).
    piv_x = slot * POSE_GAP * l
    piv_y = -row * ROW_HEIGHT * l
    tip_x = piv_x + l * np.sin(theta[idx])
    tip_y = piv_y + l * np.cos(theta[idx])
    segments = np.stack([np.stack([piv_x, piv_y], 1), np.stack([tip_x, tip_y], 1)], 1)
    colours = [BALANCING_COLOUR if m > 0.5 else SWINGUP_COLOUR for m in mode[idx]]
    snaps = LineCollection(list(segments), colors=colours, linewidths=1.1, gid="snapshots")
    ax_snap.add_collection(snaps)
    ax_snap.plot(piv_x, piv_y, "s", ms=2.0, color="0.3", gid="carts")
    for r in range(n_rows):
        y0 = -r * ROW_HEIGHT * l
        ax_snap.axhline(y0, color="0.85", lw=0.5, zorder=0)
        in_row = row == r
        t_row = t[idx][in_row]
        ax_snap.text(
            -1.3 * l,
            y0,
            f"{t_row[0]:g}–{t_row[-1]:g} s",
            ha="right",
            va="center",
            fontsize=9,
            color="0.25",
        )
    ax_snap.set_xlim(-1.2 * l, float(slot.max()) * POSE_GAP * l + 1.2 * l)
    ax_snap.set_ylim(-(n_rows - 1) * ROW_HEIGHT * l - 1.15 * l, 1.3 * l)
    ax_snap.set_aspect("equal", adjustable="box")
    ax_snap.set_xticks([])
    ax_snap.set_yticks([])
    for side in ("top", "right", "left", "bottom"):
        ax_snap.spines[side].set_visible(False)
    ax_snap.set_title(
        f"the pole every {every:g} s, one row per {ROW_SECONDS:g} s "
        f"(orange: swing-up, eq 23; blue: balancing, eq 22)",
        fontsize=10,
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
    ax_xy.set_title("path of the pole tip", fontsize=10)
    ax_xy.legend(loc="lower right", fontsize=8)

    many = len(traj.switch_times) > 20
    switch_lines: list[object] = []
    for ax in (ax_x, ax_th):
        switch_lines.extend(
            ax.axvline(
                ts,
                color="0.3",
                ls="--",
                lw=0.4 if many else 0.8,
                alpha=0.4 if many else 1.0,
                gid="switch",
            )
            for ts in traj.switch_times
        )
        ax.set_xlim(t[0], t[-1])

    (x_line,) = ax_x.plot(t, x, color="tab:green", gid="x")
    ax_x.axhline(0.0, color="0.6", lw=0.5)
    ax_x.set_ylabel("x [m]")
    ax_x.tick_params(labelbottom=False)
    ax_x.sharex(ax_th)

    th_plot = display_theta(traj)
    (th_line,) = ax_th.plot(t, th_plot, color="tab:purple", gid="theta")
    upright = final_upright(th_plot)
    theta_c = traj.controller.theta_c
    ax_th.axhline(upright, color="0.5", lw=0.8, gid="upright")
    ax_th.axhline(upright + theta_c, color="tab:purple", ls=":", lw=0.8, gid="theta_c")
    ax_th.axhline(upright - theta_c, color="tab:purple", ls=":", lw=0.8, gid="theta_c")
    ax_th.set_ylabel("θ [rad]")
    ax_th.set_xlabel("time t [s]")

    if np.all(np.isfinite(th_plot)):
        lo = min(float(th_plot.min()), upright - theta_c)
        hi = max(float(th_plot.max()), upright + theta_c)
        ax_th.set_ylim(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo))
    for ax, series, unit in ((ax_x, x, "m"), (ax_th, th_plot, "rad")):
        if runaway or not bool(np.all(np.abs(series) <= VIEW_LIMIT)):
            ax.set_ylim(-VIEW_LIMIT, VIEW_LIMIT)
            ax.text(
                0.01,
                0.05,
                f"clipped to ±{VIEW_LIMIT:g} {unit}: max = {np.nanmax(np.abs(series)):.3g} {unit}",
                transform=ax.transAxes,
                fontsize=9,
                color="tab:red",
            )

    o = traj.outcome
    default = (
        "Figure 5: swing-up and balancing, mean policy "
        f"(success test {'passed' if o.success else 'failed'})"
    )
    fig.suptitle(title or default, fontsize=12)
    fig.figure5_parts = Figure5Parts(  # type: ignore[attr-defined]
        snapshots=snaps,
        tip_path=tip_line,
        x_line=x_line,
        theta_line=th_line,
        switch_lines=tuple(switch_lines),
        caption=figure5_caption(traj, every=every),
    )
    return fig


# --------------------------------------------------------------------------- curves


def running_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Mean of the last ``window`` values at each index (fewer at the start)."""
    v = np.asarray(values, dtype=float)
    c = np.concatenate([[0.0], np.cumsum(v)])
    i = np.arange(1, len(v) + 1)
    lo = np.maximum(i - window, 0)
    return (c[i] - c[lo]) / (i - lo)


#: Panel of each learner-specific history column: (y label, title).
RULE_PANELS = {
    "sigma": ("σ [m/s²]", "policy std σ = 0.1 + sigmoid(W6) of eq 5 (per step)"),
    "explore": ("s (W1..W5)", "parameter-exploration std s of pgpe (per trial)"),
    "return": ("Σ r_k", "return of the dense per-step reward r = -dt cost (ac)"),
    "mean_delta": ("mean δ", "mean TD error δ = r + γ_v V(s') - V(s) over the trial (ac)"),
    "critic_norm": ("|v|", "norm of the critic's weights after the trial (ac)"),
}


def learning_curves(history: History, *, window: int = 50, title: str | None = None) -> Figure:
    """Reward per trial with running rates, the six gains, theta_c and the learner's own columns.

    Axes (in ``fig.axes`` order): reward, gains, theta_c, one per learner column
    (sigma for chapter and rpe, explore for pgpe, sigma, return, mean_delta and
    critic_norm for ac: :data:`RULE_PANELS`), then the
    twin axis of the running rates. The sparse reward (eqs 24-25) is drawn as +10,
    0 and -5 with the running fraction of +10; the shaped reward as its values and
    running mean. W1..W5 are what the controller acted with (pgpe: the mean of its
    exploration), W6 sets the per-step sigma (not used by pgpe).
    """
    if window < 1:
        raise ParameterError(f"window must be >= 1, got {window}")
    extra = [c for c in history.rule_columns if c in RULE_PANELS]
    fig = _figure(11.0, 7.6 + 1.2 * len(extra))
    axes = fig.subplots(
        3 + len(extra), 1, sharex=True, height_ratios=[1.0, 1.4, 0.8] + [0.8] * len(extra)
    )
    ax_r, ax_w, ax_c = axes[0], axes[1], axes[2]
    n = history.trial
    reward = history.reward
    success = history.success
    sparse = history.reward_kind == "sparse"
    ax_rate = ax_r.twinx()
    if sparse:
        pos, zero, neg = reward > 0, reward == 0, reward < 0
        ax_r.plot(n[pos], reward[pos], ".", color="tab:green", ms=3, label="reward > 0")
        if zero.any():
            ax_r.plot(n[zero], reward[zero], ".", color="0.5", ms=3, label="reward 0")
        ax_r.plot(n[neg], reward[neg], ".", color="tab:red", ms=3, label="reward < 0")
        ax_r.set_ylabel("reward (eqs 24-25)")
        ax_rate.plot(n, running_mean(pos, window), color="tab:green", lw=1.2, label="fraction > 0")
    else:
        ax_r.plot(n, reward, ".", color="tab:blue", ms=3, label="shaped reward")
        ax_r.plot(n, running_mean(reward, window), color="tab:blue", lw=1.0, label="running mean")
        ax_r.set_ylabel("shaped reward")
    ax_r.set_title(
        f"reward per trial; running fractions over the last {window} trials", fontsize=10
    )
    ax_rate.plot(
        n,
        running_mean(success, window),
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

    W = history.W
    w6_unused = "explore" in history.rule_columns  # pgpe acts with the mean policy
    for i in range(6):
        label = f"W{i + 1}" + (" (unused)" if i == 5 and w6_unused else "")
        ax_w.plot(n, W[:, i], lw=1.0, label=label)
    ax_w.axhline(0.0, color="0.6", lw=0.5)
    ax_w.set_ylabel("gain (used in the trial)")
    ax_w.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax_w.set_title("W1..W6 (eqs 22-23)", fontsize=10)
    ax_c.plot(n, history.theta_c, color="tab:purple", lw=1.0)
    ax_c.set_ylabel("θ_c [rad]")
    ax_c.set_title("switching threshold (eq 21)", fontsize=10)
    for ax, name in zip(axes[3:], extra, strict=True):
        label, panel_title = RULE_PANELS[name]
        ax.plot(n, history.column(name), color="tab:brown", lw=1.0)
        ax.set_ylabel(label)
        ax.set_title(panel_title, fontsize=10)
    axes[-1].set_xlabel("trial")
    counted = f"{int((reward > 0).sum())} with reward > 0, " if sparse else ""
    fig.suptitle(
        title
        or f"Learning curves ({history.learner}): {len(history)} trials, {counted}"
        f"{int(success.sum())} passing the success test",
        fontsize=11,
    )
    return fig


# --------------------------------------------------------------------------- soft switch


def switch_figure(theta_c: float, gammas: Sequence[float], *, theta_max: float = math.pi) -> Figure:
    """The cerebellar soft switch of section 4 against |theta| (docs/paper-notes.md section 4).

    One column per gamma, so that no two curves lie on each other. Top: balancing
    weight clip(gamma (theta_c - |theta|), 0, 1) on mu_1 (solid) and swing-up weight
    clip(gamma (|theta| - theta_c), 0, 1) on mu_2 (dashed); the hard switch of section
    2.3 hands over at theta_c (dotted). Bottom: their sum, the total drive, which dips
    below 1 in a dead zone of half-width 1/gamma around theta_c (shaded) where neither
    pathway fully drives the cart.
    """
    from striatal.sim.control import switch_weights

    if not gammas:
        raise ParameterError("give at least one inhibition strength gamma")
    for g in gammas:
        if not (math.isfinite(g) and g > 0):
            raise ParameterError(f"inhibition gamma must be a finite number > 0, got {g}")
    if not 0.0 < theta_c < math.pi:
        raise ParameterError(f"theta_c must be in (0, pi), got {theta_c}")
    a = np.linspace(0.0, theta_max, 2001)
    n = len(gammas)
    fig = _figure(max(6.0, 3.2 * n), 5.6)
    axes = fig.subplots(2, n, sharex=True, sharey="row", height_ratios=[1.6, 1.0], squeeze=False)
    for k, g in enumerate(gammas):
        ax_w, ax_sum = axes[0, k], axes[1, k]
        wb, ws = switch_weights(a, theta_c, True, g)
        ax_w.plot(
            a, wb, color=BALANCING_COLOUR, lw=1.6, label="balancing (μ₁)", gid=f"balancing:{g:g}"
        )
        ax_w.plot(
            a,
            ws,
            color=SWINGUP_COLOUR,
            lw=1.6,
            ls="--",
            label="swing-up (μ₂)",
            gid=f"swingup:{g:g}",
        )
        total = wb + ws
        ax_sum.plot(a, total, color="black", lw=1.3, gid=f"sum:{g:g}")
        ax_sum.fill_between(a, total, 1.0, where=total < 1.0, color="0.8", lw=0, label="dead zone")
        ax_w.set_title(f"γ = {g:g} /rad (dead zone ±{1.0 / g:.2g} rad)", fontsize=10)
        for ax in (ax_w, ax_sum):
            ax.axvline(theta_c, color="0.4", ls=":", lw=0.9, label="hard switch at θ_c")
            ax.set_xlim(0.0, theta_max)
        ax_w.set_ylim(-0.05, 1.1)
        ax_sum.set_ylim(-0.05, 1.1)
        ax_sum.set_xlabel("|θ| [rad]")
    axes[0, 0].set_ylabel("weight")
    axes[1, 0].set_ylabel("total drive")
    axes[0, 0].legend(fontsize=8, loc="center right")
    fig.suptitle(
        "Cerebellar soft switch (section 4): weights of the two controllers, "
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
    """(H, W, 3) uint8 frames of ``traj`` from :func:`striatal.viz.render.cartpole_frame`."""
    from striatal.viz import render

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

    ``profiles`` from :func:`striatal.experiments.profiles.sweep_profiles`; the band is the
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
