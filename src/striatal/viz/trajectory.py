"""Figure 5 of the chapter: one run as pole snapshots, the tip's path, x(t) and theta(t).

Every trajectory comes from :func:`striatal.sim.rollout.simulate`; nothing here
simulates.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from striatal.errors import ParameterError
from striatal.limits import count_of_steps
from striatal.viz.canvas import new_figure

__all__ = [
    "BALANCING_COLOUR",
    "MAX_SNAPSHOTS",
    "POSE_GAP",
    "ROW_HEIGHT",
    "ROW_SECONDS",
    "SETTLED_BAND",
    "SNAPSHOT_EVERY",
    "SWINGUP_COLOUR",
    "VIEW_LIMIT",
    "Figure5Parts",
    "display_theta",
    "drawn_snapshots",
    "figure5",
    "figure5_caption",
    "final_upright",
    "gains_title",
    "pole_tip",
    "settled_from",
    "snapshot_indices",
    "snapshot_layout",
]

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from striatal.sim.rollout import Trajectory

#: The chapter: "each motion snapshot was recorded in every 0.2 second" (section 3).
SNAPSHOT_EVERY = 0.2
#: Figure 5's snapshots are laid out in rows of this many seconds each.
ROW_SECONDS = 10.0
#: Distance between successive poses along a row of snapshots, in pole lengths.
POSE_GAP = 0.6
#: Height of one row of snapshots, in pole lengths (a hanging and an upright pole fit).
ROW_HEIGHT = 2.6
#: Most stick figures one Figure 5 draws (memory and file size), checked before anything
#: is allocated.
MAX_SNAPSHOTS = 10_000
#: Runs whose cart leaves |x| <= VIEW_LIMIT [m] (a runaway, e.g. the printed balancing sign)
#: are drawn clipped to that window, so the part before the runaway stays readable.
VIEW_LIMIT = 15.0
#: A pole balancing within this angle [rad] of the upright it ends at, from some time to
#: the end of the run, has settled: Figure 5 draws no snapshot rows after that.
SETTLED_BAND = 0.05
SWINGUP_COLOUR = "tab:orange"
BALANCING_COLOUR = "tab:blue"


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


def settled_from(traj: Trajectory, band: float = SETTLED_BAND) -> float | None:
    """The time [s] from which the pole stays balancing (balancing controller in charge)
    within ``band`` rad of the upright it ends at (:func:`final_upright`) to the end of
    the run; None when the run does not end so."""
    theta = display_theta(traj)
    off = ~np.isfinite(theta) | (np.abs(theta - final_upright(theta)) > band)
    off |= traj.column("mode") < 0.5
    if off[-1]:
        return None
    moved = np.nonzero(off)[0]
    return float(traj.t[moved[-1] + 1]) if len(moved) else float(traj.t[0])


def drawn_snapshots(traj: Trajectory, every: float = SNAPSHOT_EVERY) -> tuple[np.ndarray, float]:
    """(row indices, end [s]) of the snapshots Figure 5 draws: those of
    :func:`snapshot_indices` up to the end of the :data:`ROW_SECONDS` row in which the
    pole settles (:func:`settled_from`), when that leaves out at least one whole row;
    else all of them, ``end`` the run's last time."""
    idx = snapshot_indices(traj, every)
    t_end = float(traj.t[-1])
    settled = settled_from(traj)
    if settled is None:
        return idx, t_end
    end = ROW_SECONDS * max(1, math.ceil(settled / ROW_SECONDS - 1e-9))
    if end > t_end - ROW_SECONDS + 1e-9:
        return idx, t_end
    return idx[traj.t[idx] <= end + 1e-9], end


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
    idx, end = drawn_snapshots(traj, every)
    n = len(idx)
    t_end = float(traj.t[-1])
    upto, rest = "", ""
    if end < t_end:
        upto = f" up to {end:g} s"
        rest = (
            f"; from {end:g} s to {t_end:g} s it stays balanced within {SETTLED_BAND:g} rad "
            "of upright, not drawn"
        )
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
        + f". Top: the pole every {every:g} s{upto} ({n} poses{rest}), one row per "
        f"{ROW_SECONDS:g} s, "
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
    controller acts, blue while balancing, up to the row in which the pole settles
    (:func:`drawn_snapshots`; a note says so). Second: the path of the pole tip
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
    idx, end = drawn_snapshots(traj, every)
    row, slot = snapshot_layout(t[idx], every, ROW_SECONDS)
    n_rows = int(row.max()) + 1
    width_poses = float(slot.max()) * POSE_GAP + 2.4

    snap_height = 12.2 * (n_rows * ROW_HEIGHT + (0.8 if end < t[-1] else 0.0)) / width_poses
    fig = new_figure(13.0, snap_height + 8.2)
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
    bottom = -(n_rows - 1) * ROW_HEIGHT * l - 1.15 * l
    if end < t[-1]:
        ax_snap.text(
            0.0,
            bottom - 0.1 * l,
            f"{end:g}–{t[-1]:g} s: the pole stays balanced within {SETTLED_BAND:g} rad of "
            "upright (not drawn; the panels below show the whole run)",
            ha="left",
            va="top",
            fontsize=9,
            color="0.25",
            gid="settled_note",
        )
        bottom -= 0.8 * l
    ax_snap.set_xlim(-1.2 * l, float(slot.max()) * POSE_GAP * l + 1.2 * l)
    ax_snap.set_ylim(bottom, 1.3 * l)
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
        # the part within the view; a run that is never inside (started beyond it) is
        # shown where it is, bounded to what an axis can span
        inside = np.abs(x) <= VIEW_LIMIT
        shown = tx[inside] if inside.any() else np.clip(tx[np.isfinite(tx)], -1e12, 1e12)
        if not shown.size:
            shown = np.array([-VIEW_LIMIT, VIEW_LIMIT])
        ax_xy.set_xlim(shown.min() - 0.5, shown.max() + 0.5)
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
