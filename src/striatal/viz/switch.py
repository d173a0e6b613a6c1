"""The cerebellar soft switch of section 4: the two controllers' weights against |theta|."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from striatal.errors import ParameterError
from striatal.viz.canvas import new_figure
from striatal.viz.trajectory import BALANCING_COLOUR, SWINGUP_COLOUR

__all__ = ["switch_figure"]

if TYPE_CHECKING:
    from matplotlib.figure import Figure


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
    fig = new_figure(max(6.0, 3.2 * n), 5.6)
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
