"""The chapter's section-4 reading built as a spiking network (nengo, LIF neurons).

Cortex encodes the sensed state; two striatal channels decode the balancing mean
mu_1 (eq 22) and the swing-up mean mu_2 (eq 23) through one connection per term of
:mod:`striatal.neural.interpret`, excitatory (direct pathway) for a positive coefficient and
inhibitory (indirect pathway) for a negative one; a gate population per channel
silences it: Purkinje-like populations inhibited by suppressor parallel fibres that
carry the criterion theta_c - |theta| (the cerebellar switch of section 4,
``docs/paper-notes.md`` section 4), or, for comparison, the Gurney-Prescott-Redgrave
basal ganglia with a thalamus selecting between the two channels from the same
criterion. Nengo is imported here only: it is the ``[neural]`` extra.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from striatal.errors import ParameterError
from striatal.neural.interpret import Term, balancing_terms, swingup_terms
from striatal.params import Controller, Plant

__all__ = [
    "MIN_PER_POPULATION",
    "SENSED",
    "SHARES",
    "Handles",
    "NetworkConfig",
    "Selection",
    "build",
    "criterion",
    "require_nengo",
]

Selection = Literal["cerebellum", "basal-ganglia"]

#: Sensed-state layout of the plant Node's output and of the sensor input of the network.
SENSED = ("x", "x_dot", "sin_theta", "cos_theta", "theta_dot")

#: Share of the neuron budget per population (sums to 1): more where mu_1 needs precision
#: near upright (the angle and the balancing theta) and where swing-up multiplies.
SHARES: dict[str, float] = {
    "sin": 0.08,
    "cos": 0.06,
    "omega": 0.07,
    "cart_x": 0.05,
    "cart_v": 0.05,
    "energy": 0.05,
    "pump": 0.16,
    "bal_theta": 0.12,
    "bal_omega": 0.07,
    "bal_x": 0.05,
    "bal_v": 0.05,
    "swing_x": 0.04,
    "swing_v": 0.04,
    "fibres": 0.05,
    "gate_bal": 0.03,
    "gate_swing": 0.03,
}
MIN_PER_POPULATION = 10


def require_nengo() -> Any:
    """Import nengo, or raise ParameterError naming the extra to install."""
    try:
        import nengo
    except ImportError:
        raise ParameterError(
            "the spiking network needs nengo: pip install 'striatal[neural]'"
        ) from None
    return nengo


@dataclass(frozen=True)
class NetworkConfig:
    """Sizes, time constants and radii of the network.

    Attributes
    ----------
    neurons : total LIF neurons of cortex, channels and switch, split by :data:`SHARES`
        (the basal ganglia and thalamus of ``selection="basal-ganglia"`` come on top).
    selection : ``"cerebellum"`` (Purkinje gates inhibited by parallel fibres) or
        ``"basal-ganglia"`` (nengo's BasalGanglia + Thalamus drive the same gates).
    switch_gain : gamma [1/rad], the slope of the criterion clip(gamma (theta_c - |theta|))
        the fibres carry; high gain recovers the hard switch.
    synapse : time constant of every connection [s].
    gate_inhibition : current the active gate injects into its channel's neurons.
    radius_x, radius_v, radius_omega : cortex radii of x [m], x_dot [m/s], theta_dot [rad/s].
    radius_bal_theta, radius_bal_omega : balancing-channel radii of theta [rad] and
        theta_dot [rad/s] (matched to the range of the balancing phase).
    max_rates : (low, high) maximum firing rates [Hz].
    bg_neurons : neurons per BasalGanglia ensemble (5 ensembles x 2 channels) and per
        thalamus channel, when ``selection="basal-ganglia"``.
    optimize : nengo's operator merging (``nengo.Simulator(optimize=...)``). Off by
        default: the merge order follows the objects' memory addresses, so the sums into
        a signal are added in another order from run to run and one seed gave results
        that differ by round-off (which the swing-up amplifies: x_T 0.380 against
        0.377 m). On, the simulation takes about 0.6-0.7 of the time (docs/neural.md).
    """

    neurons: int = 2500
    selection: Selection = "cerebellum"
    switch_gain: float = 20.0
    synapse: float = 0.005
    gate_inhibition: float = 10.0
    radius_x: float = 12.0
    radius_v: float = 5.0
    radius_omega: float = 7.0
    radius_bal_theta: float = 1.2
    radius_bal_omega: float = 3.0
    max_rates: tuple[float, float] = (200.0, 400.0)
    bg_neurons: int = 30
    optimize: bool = False

    def check_work(self, duration: float, net_dt: float, trials: int = 1) -> None:
        """ParameterError (one line, with the estimate) if ``trials`` runs of ``duration``
        s, stepped every ``net_dt`` s, exceed the work limit
        (:func:`striatal.arguments.check_work`), counted in neuron updates: a network
        step costs about as much per neuron as a kernel step does."""
        from striatal.arguments import check_work

        if not 0 < net_dt <= 0.1:
            raise ParameterError(f"net_dt must be in (0, 0.1] s, got {net_dt!r}")
        steps = math.ceil(duration / net_dt)
        check_work(
            float(trials) * steps * self.neurons,
            "the network",
            f"{trials:,} trials x {steps:,} steps of {net_dt:g} s x {self.neurons:,} neurons",
        )

    def __post_init__(self) -> None:
        if not isinstance(self.optimize, bool):
            raise ParameterError(f"optimize must be True or False, got {self.optimize!r}")
        if isinstance(self.neurons, bool) or not isinstance(self.neurons, int | np.integer):
            raise ParameterError(f"neurons must be a whole number, got {self.neurons!r}")
        low = MIN_PER_POPULATION * len(SHARES)
        if not low <= self.neurons <= 100_000:
            raise ParameterError(f"neurons must be in [{low}, 100000], got {self.neurons}")
        if self.selection not in ("cerebellum", "basal-ganglia"):
            raise ParameterError(
                f"selection must be 'cerebellum' or 'basal-ganglia', got {self.selection!r}"
            )
        for name in (
            "switch_gain",
            "synapse",
            "gate_inhibition",
            "radius_x",
            "radius_v",
            "radius_omega",
            "radius_bal_theta",
            "radius_bal_omega",
        ):
            v = float(getattr(self, name))
            if not math.isfinite(v) or v <= 0.0:
                raise ParameterError(f"{name} must be a finite number > 0, got {v!r}")
        lo, hi = self.max_rates
        if not 0.0 < lo <= hi < 1000.0:
            raise ParameterError(f"max_rates must satisfy 0 < low <= high < 1000, got {lo, hi}")

    def sizes(self) -> dict[str, int]:
        """Neurons per population (cortex, channels, switch)."""
        return {k: max(MIN_PER_POPULATION, int(round(s * self.neurons))) for k, s in SHARES.items()}


@dataclass
class Handles:
    """The built network and the objects a caller connects to or probes."""

    model: Any
    sensor_input: Any  # Node(size_in=5): the sensed state enters here
    mu_1: Any  # Node(size_in=1): decoded balancing mean, eq 22 (unfiltered spikes)
    mu_2: Any  # Node(size_in=1): decoded swing-up mean, eq 23 (unfiltered spikes)
    motor: Any  # Node(size_in=1): u = mu_1 + mu_2, filtered by the synapse
    populations: dict[str, Any] = field(default_factory=dict)
    gates: dict[str, Any] = field(default_factory=dict)
    pathways: list[tuple[str, Term, Any]] = field(default_factory=list)
    extra_neurons: int = 0
    #: per pathway: transform / coefficient, the factor that turns the connection's decoded
    #: output into the term's signal in physical units (1, or the pump population's scale)
    pathway_scales: list[float] = field(default_factory=list)
    #: the connection cos -> fibres, the only one whose function depends on theta_c
    switch_criterion: Any = None

    @property
    def n_neurons(self) -> int:
        """All LIF neurons of the model, basal ganglia and thalamus included."""
        return int(sum(e.n_neurons for e in self.model.all_ensembles))


def criterion(abs_theta: float, theta_c: float, gain: float) -> float:
    """What the suppressor fibres carry: clip(gamma (theta_c - |theta|), -1, 1)."""
    return min(max(gain * (theta_c - abs_theta), -1.0), 1.0)


def criterion_of_cos(theta_c: float, gain: float) -> Any:
    """The function of the connection cos -> fibres: the criterion of |theta| = arccos(cos)."""
    return lambda c: criterion(math.acos(min(max(c[0], -1.0), 1.0)), theta_c, gain)


def build(
    controller: Controller,
    plant: Plant,
    config: NetworkConfig,
    seed: int,
) -> Handles:
    """Build the network for the gains and threshold of ``controller``.

    The controller's balancing law uses the plant's l and g (eq 22; the controller's
    model is the true plant here); its sign reading comes from ``controller.sign``.
    """
    nengo = require_nengo()
    W = controller.gains
    theta_c = controller.theta_c
    sizes = config.sizes()
    syn = config.synapse
    rates = nengo.dists.Uniform(*config.max_rates)
    m, length, g = plant.pole_mass, plant.length, plant.gravity
    mu1_terms = balancing_terms(W, plant, controller.sign)
    mu2_terms = swingup_terms(W)
    gain = config.switch_gain

    model = nengo.Network(label="striatal neural controller", seed=seed)
    h: Handles
    with model:
        sensor = nengo.Node(size_in=len(SENSED), label="sensed state")

        def ens(name: str, dims: int, radius: float, **kw: Any) -> Any:
            return nengo.Ensemble(
                sizes[name], dims, radius=radius, max_rates=rates, label=name, **kw
            )

        # cortex: the sensed state
        sin = ens("sin", 1, 1.0)
        cos = ens("cos", 1, 1.0)
        omega = ens("omega", 1, config.radius_omega)
        cart_x = ens("cart_x", 1, config.radius_x)
        cart_v = ens("cart_v", 1, config.radius_v)
        nengo.Connection(sensor[2], sin, synapse=None)
        nengo.Connection(sensor[3], cos, synapse=None)
        nengo.Connection(sensor[4], omega, synapse=None)
        nengo.Connection(sensor[0], cart_x, synapse=None)
        nengo.Connection(sensor[1], cart_v, synapse=None)
        # E~ of eqs 15-16 as the sum of a potential part (from cos theta) and a kinetic one
        e_max = 2.0 * m * g * length
        energy = ens("energy", 1, e_max)
        nengo.Connection(cos, energy, function=lambda c: m * g * length * (c[0] - 1.0), synapse=syn)
        nengo.Connection(
            omega, energy, function=lambda w: 0.5 * m * length**2 * w[0] ** 2, synapse=syn
        )
        # the energy pump E~ theta_dot cos theta of eq 23, from a product population
        pump = ens("pump", 3, math.sqrt(3.0))
        nengo.Connection(energy, pump[0], transform=1.0 / e_max, synapse=syn)
        nengo.Connection(omega, pump[1], transform=1.0 / config.radius_omega, synapse=syn)
        nengo.Connection(cos, pump[2], synapse=syn)
        pump_scale = e_max * config.radius_omega

        # balancing channel (eq 22): its own populations, radii of the balancing phase
        r_th = config.radius_bal_theta
        bal_theta = ens("bal_theta", 1, r_th)
        bal_omega = ens("bal_omega", 1, config.radius_bal_omega)
        bal_x = ens("bal_x", 1, config.radius_x)
        bal_v = ens("bal_v", 1, config.radius_v)
        # theta = arcsin(sin theta) while the channel is open (|theta| < theta_c < pi / 2)
        nengo.Connection(
            sin,
            bal_theta,
            function=lambda s: float(np.clip(math.asin(min(max(s[0], -1.0), 1.0)), -r_th, r_th)),
            synapse=syn,
        )
        nengo.Connection(omega, bal_omega, synapse=syn)
        nengo.Connection(cart_x, bal_x, synapse=syn)
        nengo.Connection(cart_v, bal_v, synapse=syn)
        # swing-up channel (eq 23)
        swing_x = ens("swing_x", 1, config.radius_x)
        swing_v = ens("swing_v", 1, config.radius_v)
        nengo.Connection(cart_x, swing_x, synapse=syn)
        nengo.Connection(cart_v, swing_v, synapse=syn)

        mu_1 = nengo.Node(size_in=1, label="mu_1")
        mu_2 = nengo.Node(size_in=1, label="mu_2")
        motor = nengo.Node(size_in=1, label="motor u")
        # decoded spikes are summed unfiltered into mu_1 and mu_2 and filtered once at the
        # motor: the same linear filter per term, fewer operators per step
        nengo.Connection(mu_1, motor, synapse=syn)
        nengo.Connection(mu_2, motor, synapse=syn)

        pathways: list[tuple[str, Term, Any]] = []
        scales: list[float] = []
        sources = {"theta": bal_theta, "theta_dot": bal_omega, "x": bal_x, "x_dot": bal_v}
        for t in mu1_terms:
            c = nengo.Connection(
                sources[t.signal],
                mu_1,
                transform=t.coefficient,
                synapse=None,
                label=f"mu_1 {t.signal} {t.pathway}",
            )
            pathways.append(("mu_1", t, c))
            scales.append(1.0)
        for t in mu2_terms:
            if t.signal == "energy_pump":
                c = nengo.Connection(
                    pump,
                    mu_2,
                    function=lambda v: v[0] * v[1] * v[2],
                    transform=t.coefficient * pump_scale,
                    synapse=None,
                    label=f"mu_2 {t.signal} {t.pathway}",
                )
            else:
                src = swing_x if t.signal == "x" else swing_v
                c = nengo.Connection(
                    src,
                    mu_2,
                    transform=t.coefficient,
                    synapse=None,
                    label=f"mu_2 {t.signal} {t.pathway}",
                )
            pathways.append(("mu_2", t, c))
            scales.append(pump_scale if t.signal == "energy_pump" else 1.0)

        # the switch: fibres carry clip(gamma (theta_c - |theta|), -1, 1), |theta| = arccos(cos)
        fibres = ens("fibres", 1, 1.0)
        switch_criterion = nengo.Connection(
            cos, fibres, function=criterion_of_cos(theta_c, gain), synapse=syn
        )
        # gate populations: tonically active, represent how closed their channel is
        gate_kw = {
            "encoders": nengo.dists.Choice([[1.0]]),
            "intercepts": nengo.dists.Uniform(0.05, 0.4),
            "eval_points": nengo.dists.Uniform(0.0, 1.2),
        }
        gate_bal = ens("gate_bal", 1, 1.0, **gate_kw)
        gate_swing = ens("gate_swing", 1, 1.0, **gate_kw)
        tonic = nengo.Node(1.0, label="tonic drive")
        nengo.Connection(tonic, gate_bal, synapse=None)
        nengo.Connection(tonic, gate_swing, synapse=None)
        extra = 0
        if config.selection == "cerebellum":
            # suppressor fibres inhibit the Purkinje-like gates: near upright (criterion > 0)
            # they silence the balancing gate, far from it the swing-up gate
            nengo.Connection(
                fibres,
                gate_bal.neurons,
                function=lambda c: max(c[0], 0.0),
                transform=-config.gate_inhibition * np.ones((sizes["gate_bal"], 1)),
                synapse=syn,
                label="fibres -| gate_bal",
            )
            nengo.Connection(
                fibres,
                gate_swing.neurons,
                function=lambda c: max(-c[0], 0.0),
                transform=-config.gate_inhibition * np.ones((sizes["gate_swing"], 1)),
                synapse=syn,
                label="fibres -| gate_swing",
            )
        else:
            bg = nengo.networks.BasalGanglia(
                dimensions=2, n_neurons_per_ensemble=config.bg_neurons, label="basal ganglia"
            )
            thal = nengo.networks.Thalamus(
                dimensions=2, n_neurons_per_ensemble=config.bg_neurons, label="thalamus"
            )
            # utilities in [0, 1] from the same criterion
            nengo.Connection(
                fibres,
                bg.input,
                function=lambda c: [0.5 + 0.5 * c[0], 0.5 - 0.5 * c[0]],
                synapse=syn,
            )
            nengo.Connection(bg.output, thal.input)
            # the selected channel's thalamic output inhibits that channel's gate
            nengo.Connection(thal.output, gate_bal, transform=[[-1.5, 0.0]])
            nengo.Connection(thal.output, gate_swing, transform=[[0.0, -1.5]])
            extra = 10 * config.bg_neurons + 2 * config.bg_neurons
        gates = {"balancing": gate_bal, "swing-up": gate_swing}
        for gate, channel in (
            (gate_bal, (bal_theta, bal_omega, bal_x, bal_v)),
            (gate_swing, (pump, swing_x, swing_v)),
        ):
            for e in channel:
                nengo.Connection(
                    gate,
                    e.neurons,
                    transform=-config.gate_inhibition * np.ones((e.n_neurons, 1)),
                    synapse=syn,
                    label=f"{gate.label} -| {e.label}",
                )
        pops = {
            e.label: e
            for e in (
                sin,
                cos,
                omega,
                cart_x,
                cart_v,
                energy,
                pump,
                bal_theta,
                bal_omega,
                bal_x,
                bal_v,
                swing_x,
                swing_v,
                fibres,
                gate_bal,
                gate_swing,
            )
        }
        h = Handles(
            model=model,
            sensor_input=sensor,
            mu_1=mu_1,
            mu_2=mu_2,
            motor=motor,
            populations=pops,
            gates=gates,
            pathways=pathways,
            extra_neurons=extra,
            pathway_scales=scales,
            switch_criterion=switch_criterion,
        )
    return h
