"""Learning curves of one training run: reward, gains, theta_c and the rule's own columns."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from striatal.errors import ParameterError
from striatal.learners import History
from striatal.viz.canvas import new_figure

__all__ = [
    "DRAWN_COLUMNS",
    "DRAWN_LIMIT",
    "RULE_PANELS",
    "drawn",
    "learning_curves",
    "running_mean",
]

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def running_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Mean of the last ``window`` values at each index (fewer at the start)."""
    v = np.asarray(values, dtype=float)
    c = np.concatenate([[0.0], np.cumsum(v)])
    i = np.arange(1, len(v) + 1)
    lo = np.maximum(i - window, 0)
    return (c[i] - c[lo]) / (i - lo)


#: Largest magnitude drawn: a value beyond (a gain of a run without a step bound) is
#: drawn at the edge, and the figure says so (an axis cannot span +-1e308).
DRAWN_LIMIT = 1e100
#: Most columns of points a curve is drawn with: more than a figure has pixels across
#: at any --dpi it takes (at most 1000 dpi on an 8-inch axis).
DRAWN_COLUMNS = 8192


def drawn(
    x: np.ndarray, y: np.ndarray, columns: int = DRAWN_COLUMNS
) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) as drawn: ``x`` (ascending) cut into ``columns`` equal intervals, the points
    of each by their first x with their smallest and then their largest y (NaN-only
    intervals stay NaN, a gap).

    A line or dot plot of a million trials looks the same, since a pixel column shows
    only the extent of its points, but the figure holds at most ``2 * columns`` points
    instead of one per trial: its memory does not grow with the history.
    """
    x = np.asarray(x, dtype=float)
    y = np.clip(np.asarray(y, dtype=float), -DRAWN_LIMIT, DRAWN_LIMIT)
    if len(x) <= 2 * columns:
        return x, y
    edges = np.linspace(x[0], x[-1], columns, endpoint=False)
    starts = np.unique(np.searchsorted(x, edges, side="left"))
    low, high = np.fmin.reduceat(y, starts), np.fmax.reduceat(y, starts)
    return np.repeat(x[starts], 2), np.stack([low, high], axis=1).ravel()


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
    critic_norm for ac: :data:`RULE_PANELS`) that changed during the run (one that
    never did, e.g. pgpe's exploration std without adaptation, is stated in the
    title instead of drawn flat), then the
    twin axis of the running rates. The sparse reward (eqs 24-25) is drawn as +10,
    0 and -5 with the running fraction of +10; the shaped reward as its values and
    running mean. W1..W5 are what the controller acted with (pgpe: the mean of its
    exploration), W6 sets the per-step sigma (not used by pgpe).
    """
    if window < 1:
        raise ParameterError(f"window must be >= 1, got {window}")
    own = [c for c in history.rule_columns if c in RULE_PANELS]
    # a column that never changed gets a line of the title, not a flat panel
    extra = [c for c in own if len(history) and np.ptp(history.column(c)) > 0]
    flat = [
        f"{RULE_PANELS[c][0].split(' ')[0]} = {history.column(c)[0]:.4g} in every trial"
        for c in own
        if c not in extra and len(history)
    ]
    fig = new_figure(11.0, 7.6 + 1.2 * len(extra))
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
        ax_r.plot(*drawn(n[pos], reward[pos]), ".", color="tab:green", ms=3, label="reward > 0")
        if zero.any():
            ax_r.plot(*drawn(n[zero], reward[zero]), ".", color="0.5", ms=3, label="reward 0")
        ax_r.plot(*drawn(n[neg], reward[neg]), ".", color="tab:red", ms=3, label="reward < 0")
        ax_r.set_ylabel("reward (eqs 24-25)")
        ax_rate.plot(
            *drawn(n, running_mean(pos, window)), color="tab:green", lw=1.2, label="fraction > 0"
        )
    else:
        ax_r.plot(*drawn(n, reward), ".", color="tab:blue", ms=3, label="shaped reward")
        ax_r.plot(
            *drawn(n, running_mean(reward, window)), color="tab:blue", lw=1.0, label="running mean"
        )
        ax_r.set_ylabel("shaped reward")
    ax_r.set_title(
        f"reward per trial; running fractions over the last {window} trials", fontsize=10
    )
    ax_rate.plot(
        *drawn(n, running_mean(success, window)),
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
        ax_w.plot(*drawn(n, W[:, i]), lw=1.0, label=label)
    ax_w.axhline(0.0, color="0.6", lw=0.5)
    ax_w.set_ylabel("gain (used in the trial)")
    ax_w.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax_w.set_title("W1..W6 (eqs 22-23)", fontsize=10)
    ax_c.plot(*drawn(n, history.theta_c), color="tab:purple", lw=1.0)
    ax_c.set_ylabel("θ_c [rad]")
    ax_c.set_title("switching threshold (eq 21)", fontsize=10)
    for ax, name in zip(axes[3:], extra, strict=True):
        label, panel_title = RULE_PANELS[name]
        ax.plot(*drawn(n, history.column(name)), color="tab:brown", lw=1.0)
        ax.set_ylabel(label)
        ax.set_title(panel_title, fontsize=10)
    axes[-1].set_xlabel("trial")
    counted = f"{int((reward > 0).sum())} with reward > 0, " if sparse else ""
    unchanged = f"\n{history.learner}'s " + ", ".join(flat) + " (not drawn)" if flat else ""
    if np.nanmax(np.abs(history.data), initial=0.0) > DRAWN_LIMIT:
        unchanged += f"\nvalues beyond +-{DRAWN_LIMIT:.0e} drawn at +-{DRAWN_LIMIT:.0e}"
    fig.suptitle(
        title
        or f"Learning curves ({history.learner}): {len(history)} trials, {counted}"
        f"{int(success.sum())} passing the success test{unchanged}",
        fontsize=11,
    )
    return fig
