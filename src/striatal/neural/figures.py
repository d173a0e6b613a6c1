"""Figures of the spiking controller: the circuit, the populations' activity over a run, and
the seeds that hold the pole against the neuron count."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from striatal.errors import ParameterError
from striatal.neural.interpret import balancing_terms, swingup_terms
from striatal.params import Controller, Plant
from striatal.sim import kernel
from striatal.viz.canvas import new_figure

__all__ = [
    "EXCITATORY",
    "INHIBITORY",
    "activity_figure",
    "circuit_figure",
    "upright_curve_figure",
]

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from striatal.neural.run import NeuralRun

EXCITATORY = "#1b7837"
INHIBITORY = "#b2182b"


def activity_figure(run: NeuralRun, theta_c: float) -> Figure:
    """The pole angle, the motor command and each population's mean rate over the run.

    Rates are 10-ms bins of the population-mean spike count [Hz]; the dashed line
    marks each crossing of |theta| = theta_c.
    """
    fig = new_figure(9.0, 7.5)
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [1.0, 0.8, 2.2]})
    t = run.data[:, 0]
    th = np.array([kernel.wrap_angle(v) for v in run.data[:, 3]])
    ax1.plot(t, th, lw=0.8, color="k", label="θ (wrapped)")
    ax1.axhspan(-theta_c, theta_c, color="0.9", label="|θ| < θ_c")
    ax1.set_ylabel("θ [rad]")
    ax1.legend(loc="upper right", fontsize=8)
    ax2.plot(t, run.data[:, 5], lw=0.6, color="C0")
    ax2.set_ylabel("u [m/s²]")
    rates = run.rates
    tr = (np.arange(rates.shape[0]) + 0.5) * run.sim.dt
    im = ax3.imshow(
        rates.T,
        aspect="auto",
        origin="lower",
        interpolation="nearest",
        extent=(0.0, tr[-1] + 0.5 * run.sim.dt if tr.size else 1.0, -0.5, rates.shape[1] - 0.5),
        cmap="magma",
        vmin=0.0,
        vmax=float(np.percentile(rates, 99.5)) if rates.size else 1.0,
    )
    ax3.set_yticks(range(len(run.populations)))
    ax3.set_yticklabels(run.populations, fontsize=7)
    ax3.set_xlabel("t [s]")
    # one colorbar beside all three panels keeps their time axes aligned
    fig.colorbar(im, ax=[ax1, ax2, ax3], label="mean rate [Hz]", fraction=0.04, pad=0.01)
    for ts in run.switch_times:
        for ax in (ax1, ax2, ax3):
            ax.axvline(ts, color="C1", ls="--", lw=0.8)
    fig.suptitle(
        f"spiking controller, {run.neurons} LIF neurons, seed {run.seed}: "
        f"upright last 10 s: {'yes' if run.upright_last_10s else 'no'}",
        fontsize=10,
    )
    return fig


def circuit_figure(controller: Controller, plant: Plant, selection: str = "cerebellum") -> Figure:
    """The circuit: cortex, the two channels with their pathway signs, the switch, the plant.

    Green arrows are excitatory projections (direct pathway, positive coefficient),
    red bars inhibitory ones (indirect pathway, negative coefficient, and the gates);
    each projection into mu_1 or mu_2 is labelled with its coefficient from
    :mod:`striatal.neural.interpret`.
    """
    from matplotlib.patches import FancyBboxPatch

    fig = new_figure(12.0, 6.6, layout=None)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_xlim(0, 11.2)
    ax.set_ylim(0.4, 6.6)
    ax.axis("off")

    def box(x: float, y: float, text: str, color: str, w: float = 1.3) -> None:
        ax.add_patch(
            FancyBboxPatch(
                (x - w / 2, y - 0.2), w, 0.4, boxstyle="round,pad=0.04", fc=color, ec="0.3"
            )
        )
        ax.text(x, y, text, ha="center", va="center", fontsize=8)

    def link(
        a: tuple[float, float],
        b: tuple[float, float],
        sign: float,
        label: str = "",
        *,
        color: str | None = None,
        at: float = 0.62,
    ) -> None:
        c = color or (EXCITATORY if sign > 0 else INHIBITORY)
        ax.annotate(
            "",
            xy=b,
            xytext=a,
            arrowprops={
                "arrowstyle": "-|>" if sign > 0 else "-[",
                "color": c,
                "lw": 1.2,
                "shrinkA": 1,
                "shrinkB": 1,
            },
        )
        if label:
            ax.text(
                a[0] + at * (b[0] - a[0]),
                a[1] + at * (b[1] - a[1]) + 0.07,
                label,
                color=c,
                fontsize=7,
                ha="center",
            )

    cortex_c = "#deebf7"
    bal_c = "#e5f5e0"
    swing_c = "#fde0dd"
    gate_c = "#bcbddc"
    ax.text(1.0, 6.3, "cortex: sensed state", fontsize=9, weight="bold", ha="center")
    cx = {"x": 5.4, "x_dot": 4.8, "sin": 4.2, "theta_dot": 3.6, "cos": 3.0}
    names = {"x": "x", "x_dot": "ẋ", "sin": "sin θ", "theta_dot": "dθ/dt", "cos": "cos θ"}
    for k, y in cx.items():
        box(1.0, y, names[k], cortex_c)
    box(3.0, 1.9, "Ẽ (eqs 15-16)", "#fee0b6")
    link((1.65, 3.0), (2.35, 1.95), 1, color="0.5")
    link((1.65, 3.6), (2.35, 2.0), 1, color="0.5")

    ax.text(5.0, 6.3, "balancing channel (eq 22)", fontsize=9, weight="bold", ha="center")
    bal = {"theta": 5.4, "theta_dot": 4.8, "x": 4.2, "x_dot": 3.6}
    bal_names = {"theta": "θ = arcsin(sin θ)", "theta_dot": "dθ/dt", "x": "x", "x_dot": "ẋ"}
    for k, y in bal.items():
        box(5.0, y, bal_names[k], bal_c, w=1.5)
    for src, dst in (("sin", "theta"), ("theta_dot", "theta_dot"), ("x", "x"), ("x_dot", "x_dot")):
        link((1.65, cx[src]), (4.25, bal[dst]), 1, color="0.5")
    ax.text(5.0, 0.55, "swing-up channel (eq 23)", fontsize=9, weight="bold", ha="center")
    swing = {"energy_pump": 2.2, "x": 1.6, "x_dot": 1.0}
    swing_names = {"energy_pump": "Ẽ (dθ/dt) cos θ (3-D)", "x": "x", "x_dot": "ẋ"}
    for k, y in swing.items():
        box(5.0, y, swing_names[k], swing_c, w=1.5)
    link((3.65, 1.9), (4.25, 2.15), 1, color="0.5")
    link((1.65, 5.35), (4.25, 1.65), 1, color="0.8")
    link((1.65, 4.75), (4.25, 1.05), 1, color="0.8")

    box(9.0, 4.5, "μ1", bal_c, w=0.7)
    box(9.0, 1.6, "μ2", swing_c, w=0.7)
    for t in balancing_terms(controller.gains, plant, controller.sign):
        link((5.75, bal[t.signal]), (8.65, 4.5), t.coefficient, f"{t.coefficient:+.3g} {t.pathway}")
    for t in swingup_terms(controller.gains):
        link(
            (5.75, swing[t.signal]), (8.65, 1.6), t.coefficient, f"{t.coefficient:+.3g} {t.pathway}"
        )

    gate = "Purkinje" if selection == "cerebellum" else "gate"
    box(7.1, 3.0, "fibres: γ(θ_c − |θ|)", "#f2f0f7", w=1.7)
    link((1.65, 2.95), (6.25, 2.95), 1, color="0.5")
    box(7.1, 3.75, f"{gate} (balancing)", gate_c, w=1.7)
    box(7.1, 2.3, f"{gate} (swing-up)", gate_c, w=1.7)
    if selection == "cerebellum":
        link((7.1, 3.2), (7.1, 3.55), -1)
        link((7.1, 2.8), (7.1, 2.5), -1)
        ax.text(7.95, 3.33, "suppressor\n|θ| < θ_c", fontsize=6.5, color=INHIBITORY)
        ax.text(7.95, 2.5, "suppressor\n|θ| > θ_c", fontsize=6.5, color=INHIBITORY)
    else:
        ax.text(7.95, 2.95, "via BasalGanglia\n+ Thalamus", fontsize=6.5, color=INHIBITORY)
    link((6.25, 3.75), (5.75, 3.75), -1)
    link((6.25, 2.3), (5.75, 2.3), -1)
    ax.text(
        5.0, 3.22, "gate inhibits all 4 populations", fontsize=6.5, ha="center", color=INHIBITORY
    )
    ax.text(
        5.0, 2.52, "gate inhibits all 3 populations", fontsize=6.5, ha="center", color=INHIBITORY
    )

    box(10.4, 3.0, "motor u", "#ffffff", w=1.0)
    link((9.35, 4.45), (10.1, 3.2), 1)
    link((9.35, 1.65), (10.1, 2.8), 1)
    box(10.4, 5.6, "plant\nkernel.rk4_step", "#ffffcc", w=1.3)
    link((10.4, 3.2), (10.4, 5.4), 1)
    ax.text(10.4, 6.0, "sensed state → cortex", fontsize=7, ha="center", color="0.3")
    ax.text(
        0.1,
        0.9,
        "green →: excitatory (direct pathway)\nred ⊣: inhibitory (indirect pathway, gates)",
        fontsize=7,
        va="top",
    )
    fig.tight_layout()
    return fig


def upright_curve_figure(rows: Sequence[Mapping[str, Any]]) -> Figure:
    """Fraction of network seeds with |θ| < 0.1 rad over the last 10 s against the neuron
    count, cerebellar switch only, with exact (Clopper-Pearson) 95 % intervals.

    ``rows``: one record per run, as ``benchmarks/neural_seeds.py`` writes them
    (``selection``, ``neurons``, ``upright_last_10s``). Each point is labelled k/n.
    """
    from scipy.stats import binomtest

    groups: dict[int, list[bool]] = {}
    for r in rows:
        if r["selection"] == "cerebellum":
            groups.setdefault(int(r["neurons"]), []).append(bool(r["upright_last_10s"]))
    if not groups:
        raise ParameterError("no run with the cerebellar switch to draw")
    ns = sorted(groups)
    k = np.array([sum(groups[n]) for n in ns])
    m = np.array([len(groups[n]) for n in ns])
    cis = [
        binomtest(int(a), int(b)).proportion_ci(0.95, method="exact")
        for a, b in zip(k, m, strict=True)
    ]
    frac = k / m
    low = frac - np.array([c.low for c in cis])
    high = np.array([c.high for c in cis]) - frac
    fig = new_figure(5.5, 3.5)
    ax = fig.subplots()
    ax.errorbar(ns, frac, yerr=[low, high], marker="o", capsize=3, gid="upright")
    for i, (n, f, a, b) in enumerate(zip(ns, frac, k, m, strict=True)):
        # the last label reads leftwards, inside the axes: to its right is the figure's edge
        last = i == len(ns) - 1
        ax.annotate(
            f"{a}/{b}",
            (n, f),
            textcoords="offset points",
            xytext=(-4 if last else 4, -12),
            ha="right" if last else "left",
            fontsize=8,
        )
    ax.set_xscale("log")
    ax.margins(x=0.08)
    ax.set_xticks(ns, [str(n) for n in ns])
    ax.minorticks_off()
    ax.set_xlabel("LIF neurons (cortex, channels, switch)")
    ax.set_ylabel("seeds with |θ| < 0.1 rad over the last 10 s")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title("chapter's final gains, 60-s runs, exact 95 % intervals", fontsize=9)
    return fig
