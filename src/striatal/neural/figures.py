"""Figures of the spiking controller: the circuit, and the populations' activity over a run."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from striatal import kernel
from striatal.interpret import balancing_terms, swingup_terms
from striatal.params import Controller, Plant

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from striatal.neural.run import NeuralRun

EXCITATORY = "#1b7837"
INHIBITORY = "#b2182b"


def _figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    return fig


def activity_figure(run: NeuralRun, theta_c: float) -> Figure:
    """The pole angle, the motor command and each population's mean rate over the run.

    Rates are 10-ms bins of the population-mean spike count [Hz]; the dashed line
    marks each crossing of |theta| = theta_c.
    """
    fig = _figure(9.0, 7.5)
    ax1, ax2, ax3 = fig.subplots(
        3, 1, sharex=True, gridspec_kw={"height_ratios": [1.0, 0.8, 2.2]}
    )
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
    fig.colorbar(im, ax=ax3, label="mean rate [Hz]", fraction=0.04, pad=0.01)
    for ts in run.switch_times:
        for ax in (ax1, ax2, ax3):
            ax.axvline(ts, color="C1", ls="--", lw=0.8)
    fig.suptitle(
        f"spiking controller, {run.neurons} LIF neurons, seed {run.seed}: "
        f"upright last 10 s: {'yes' if run.upright_last_10s else 'no'}",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


def circuit_figure(controller: Controller, plant: Plant, selection: str = "cerebellum") -> Figure:
    """The circuit: cortex, the two channels with their pathway signs, the switch, the plant.

    Green arrows are excitatory projections (direct pathway, positive coefficient),
    red bars inhibitory ones (indirect pathway, negative coefficient, and the gates);
    each projection is labelled with its coefficient from :mod:`striatal.interpret`.
    """
    from matplotlib.patches import FancyBboxPatch

    fig = _figure(11.0, 6.2)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_xlim(0, 11)
    ax.set_ylim(0, 6.2)
    ax.axis("off")

    def box(x: float, y: float, text: str, color: str = "#deebf7", w: float = 1.5) -> None:
        ax.add_patch(
            FancyBboxPatch(
                (x - w / 2, y - 0.25), w, 0.5, boxstyle="round,pad=0.05", fc=color, ec="0.3"
            )
        )
        ax.text(x, y, text, ha="center", va="center", fontsize=8)

    def arrow(a: tuple[float, float], b: tuple[float, float], sign: float, label: str = "") -> None:
        color = EXCITATORY if sign > 0 else INHIBITORY
        style = "-|>" if sign > 0 else "-["
        ax.annotate(
            "",
            xy=b,
            xytext=a,
            arrowprops={"arrowstyle": style, "color": color, "lw": 1.3, "shrinkA": 2, "shrinkB": 2},
        )
        if label:
            ax.text(
                0.5 * (a[0] + b[0]),
                0.5 * (a[1] + b[1]) + 0.08,
                label,
                color=color,
                fontsize=7,
                ha="center",
            )

    ax.text(0.9, 5.9, "cortex (sensed state)", fontsize=9, weight="bold")
    cortex = {"x": 5.2, "x_dot": 4.5, "sin": 3.8, "cos": 3.1, "theta_dot": 2.4}
    for name, y in cortex.items():
        box(0.9, y, {"sin": "sin θ", "cos": "cos θ"}.get(name, name.replace("_dot", " dot")))
    box(2.9, 1.4, "E~ (eqs 15-16)", "#fee0b6")
    arrow((1.65, 3.1), (2.2, 1.55), 1)
    arrow((1.65, 2.4), (2.2, 1.45), 1)
    box(2.9, 0.6, "fibres: θ_c - |θ|", "#f2f0f7", w=1.8)
    arrow((1.65, 3.0), (2.0, 0.7), 1)

    ax.text(4.3, 5.9, "balancing channel μ1 (eq 22)", fontsize=9, weight="bold")
    b_src = {"theta": (4.5, 5.2), "theta_dot": (4.5, 4.5), "x": (4.5, 3.8), "x_dot": (4.5, 3.1)}
    for name, (x, y) in b_src.items():
        box(x, y, f"bal {name.replace('_dot', ' dot')}", "#e5f5e0", w=1.4)
    arrow((1.65, 3.8), (3.8, 5.2), 1)
    arrow((1.65, 2.4), (3.8, 4.5), 1)
    arrow((1.65, 5.2), (3.8, 3.8), 1)
    arrow((1.65, 4.5), (3.8, 3.1), 1)
    box(7.6, 4.2, "μ1", "#e5f5e0", w=0.8)
    for t in balancing_terms(controller.gains, plant, controller.sign):
        x, y = b_src[t.signal]
        arrow((5.2, y), (7.2, 4.2), t.coefficient, f"{t.coefficient:+.3g} ({t.pathway})")

    ax.text(4.3, 2.35, "swing-up channel μ2 (eq 23)", fontsize=9, weight="bold")
    s_src = {"energy_pump": (4.5, 1.8), "x": (4.5, 1.1), "x_dot": (4.5, 0.4)}
    for name, (x, y) in s_src.items():
        box(x, y, "E~ θ dot cos θ" if name == "energy_pump" else f"swing {name}", "#fde0dd", w=1.4)
    arrow((3.65, 1.4), (3.8, 1.8), 1)
    box(7.6, 1.1, "μ2", "#fde0dd", w=0.8)
    for t in swingup_terms(controller.gains):
        x, y = s_src[t.signal]
        arrow((5.2, y), (7.2, 1.1), t.coefficient, f"{t.coefficient:+.3g} ({t.pathway})")

    gate_label = "Purkinje" if selection == "cerebellum" else "gate (BG+thalamus)"
    box(6.3, 2.75, f"{gate_label} (bal)", "#bcbddc", w=1.7)
    box(8.6, 2.75, f"{gate_label} (swing)", "#bcbddc", w=1.7)
    arrow((3.8, 0.55), (5.6, 2.65), -1, "suppressor: |θ| < θ_c")
    arrow((3.8, 0.65), (8.0, 2.6), -1, "suppressor: |θ| > θ_c")
    arrow((6.3, 3.0), (5.3, 3.3), -1)
    arrow((8.6, 2.5), (5.3, 1.6), -1)
    box(9.6, 2.75 + 1.0, "motor u", "#ffffff", w=1.0)
    arrow((8.0, 4.2), (9.3, 3.85), 1)
    arrow((8.0, 1.1), (9.3, 3.65), 1)
    box(9.6, 5.2, "plant: kernel.rk4_step", "#ffffcc", w=2.0)
    arrow((9.6, 4.0), (9.6, 4.95), 1)
    ax.text(
        9.6, 5.7, "sensed state -> cortex", fontsize=7, ha="center", color="0.3"
    )
    fig.tight_layout()
    return fig
