"""Closed-loop runs of the spiking controller on the project's one physics kernel."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np

from striatal.errors import ParameterError
from striatal.neural.network import NetworkConfig, build, require_nengo
from striatal.params import Controller, Plant, Simulation, check_seed
from striatal.sim import kernel

__all__ = [
    "NEURAL_TRAJ_COLUMNS",
    "SIMULATORS",
    "UPRIGHT_THETA",
    "UPRIGHT_WINDOW",
    "KernelPlant",
    "MotorExploration",
    "NeuralRun",
    "Simulator",
    "SpikeBins",
    "add_exploration",
    "frozen_at_fault",
    "held_state_response",
    "run_network",
    "upright_throughout",
]

#: Columns of the recorded trajectory (one row per control step of ``Simulation.dt``).
NEURAL_TRAJ_COLUMNS = ("t", "x", "x_dot", "theta", "theta_dot", "u", "force", "mode")
#: A looser upright test: |theta| below this [rad] throughout the last ``UPRIGHT_WINDOW`` s.
UPRIGHT_THETA = 0.1
UPRIGHT_WINDOW = 10.0


class KernelPlant:
    """The plant as a nengo Node function: one RK4 step of the kernel per network step.

    The commanded cart acceleration u (the filtered motor output) is held over the
    network step ``dt`` (eqs 13-14 through :func:`striatal.sim.kernel.rk4_step`). Returns
    the sensed state (x, x_dot, sin theta, cos theta, theta_dot). A state that blows up
    is frozen and flagged as a fault.
    """

    def __init__(self, state0: np.ndarray, plant: Plant, dt: float, n_steps: int) -> None:
        self.p = plant.as_array()
        self.dt = dt
        self.state = [float(v) for v in state0]
        self.states = np.full((n_steps + 1, 4), np.nan)
        self.u = np.zeros(n_steps + 1)
        self.states[0] = self.state
        self.k = 0
        self.fault = False

    def sensed(self) -> np.ndarray:
        x, xd, th, thd = self.state
        return np.array([x, xd, math.sin(th), math.cos(th), thd])

    def __call__(self, t: float, u: np.ndarray) -> np.ndarray:
        a = float(u[0])
        if not self.fault and self.k < self.u.shape[0] - 1:
            x, xd, th, thd = self.state
            nxt = kernel.rk4_step(x, xd, th, thd, a, self.dt, self.p, self.p, False)
            if all(math.isfinite(v) and abs(v) < kernel.BLOW_UP for v in nxt):
                self.state = list(nxt)
            else:
                self.fault = True
            self.u[self.k] = a
            self.k += 1
            self.states[self.k] = self.state
        return self.sensed()


class MotorExploration(Protocol):
    """What adds exploration to the motor command (see
    :class:`striatal.neural.learn.Eligibility`): called once per network step with the
    pathways' presynaptic signals, returns the exploration added to u. The nengo simulator
    calls it inside the network; the compiled simulator runs ``sigma * noise`` (one draw
    per ``every`` network steps) inside its program and makes the same calls after the
    run, with the pathway signals it recorded at each draw."""

    n_pre: int
    sigma: float
    noise: np.ndarray
    every: int

    def __call__(self, t: float, pre: np.ndarray) -> np.ndarray: ...


class SpikeBins:
    """A nengo Node function: mean firing rate [Hz] of each population per bin of steps."""

    def __init__(self, n_pop: int, steps_per_bin: int, n_steps: int) -> None:
        self.steps_per_bin = steps_per_bin
        self.sums = np.zeros((n_steps // steps_per_bin + 1, n_pop))
        self.k = 0

    def __call__(self, t: float, x: np.ndarray) -> None:
        # x holds the population-mean spike trains (amplitude 1 / dt per spike)
        self.sums[self.k // self.steps_per_bin] += x
        self.k += 1

    def rates(self) -> np.ndarray:
        """(n_bins, n_pop) mean rates [Hz] of the complete bins."""
        n = self.k // self.steps_per_bin
        return self.sums[:n] / self.steps_per_bin


#: The simulators ``run_network`` can use: nengo (the reference) or the Brian2 program.
Simulator = Literal["nengo", "brian2"]
SIMULATORS: tuple[str, ...] = ("nengo", "brian2")


@dataclass(frozen=True)
class NeuralRun:
    """One closed-loop run of the spiking network.

    ``data``: (n, 8) with columns :data:`NEURAL_TRAJ_COLUMNS`, sampled every
    ``sim.dt``; theta unwrapped. ``rates``: (n_rates, n_pop) mean firing rate [Hz] of
    each population (``populations``), sampled every ``sim.dt``. ``cpu_time``: of the
    simulation (nengo: this process; brian2: the compiled child process), building and
    compiling excluded; ``build_time`` [s] builds the network (nengo's builder), and
    ``compile_time`` [s] generates and compiles the Brian2 program (make finds nothing
    to do when it is cached).
    """

    data: np.ndarray
    rates: np.ndarray
    populations: tuple[str, ...]
    success: bool
    upright_last_10s: bool
    fault: bool
    neurons: int
    wall_time: float
    cpu_time: float
    build_time: float
    sim: Simulation
    config: NetworkConfig
    seed: int
    simulator: str = "nengo"
    compile_time: float = 0.0

    @property
    def wall_per_sim_second(self) -> float:
        """Wall-clock seconds of simulation per simulated second (build excluded)."""
        return self.wall_time / self.sim.duration

    @property
    def switch_times(self) -> list[float]:
        """Times [s] where |theta| crosses theta_c (the hard criterion), as in ``simulate``."""
        mode = self.data[:, 7]
        idx = np.nonzero(np.diff(mode) != 0)[0] + 1
        return [float(self.data[i, 0]) for i in idx]

    def summary(self) -> dict[str, object]:
        x, xd, th, thd = self.data[-1, 1:5]
        return {
            "success": self.success,
            "upright_last_10s": self.upright_last_10s,
            "fault": self.fault,
            "final_state": [float(x), float(xd), float(kernel.wrap_angle(th)), float(thd)],
            "switch_times": self.switch_times,
            "max_abs_x": float(np.max(np.abs(self.data[:, 1]))),
            "neurons": self.neurons,
            "wall_time_s": self.wall_time,
            "cpu_time_s": self.cpu_time,
            "build_time_s": self.build_time,
            "compile_time_s": self.compile_time,
            "wall_per_sim_second": self.wall_per_sim_second,
            "cpu_per_sim_second": self.cpu_time / self.sim.duration,
            "seed": self.seed,
            "simulator": self.simulator,
        }


def _simulator(nengo: Any, model: Any, net_dt: float, seed: int, config: NetworkConfig) -> Any:
    """The one way this package builds a ``nengo.Simulator``: no progress bar, the
    network seed, and nengo's operator merging as ``config.optimize`` says (off by
    default, so that one seed gives one trajectory to the last bit)."""
    return nengo.Simulator(
        model, dt=net_dt, progress_bar=False, seed=seed, optimize=config.optimize
    )


def upright_throughout(t: np.ndarray, theta: np.ndarray, window: float = UPRIGHT_WINDOW) -> bool:
    """True if |wrap(theta)| < :data:`UPRIGHT_THETA` at every sample of the last ``window`` s."""
    last = t >= t[-1] - window - 1e-9
    wrapped = np.array([kernel.wrap_angle(v) for v in theta[last]])
    return bool(np.all(np.abs(wrapped) < UPRIGHT_THETA))


def run_network(
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    *,
    net_dt: float = 0.001,
    record_rates: bool = True,
    on_progress: Callable[[float], None] | None = None,
    exploration: MotorExploration | None = None,
    simulator: Simulator = "nengo",
    on_compile: Callable[[Path], None] | None = None,
) -> NeuralRun:
    """Simulate the spiking controller on the plant from ``sim.initial_state``.

    The network (and the plant Node) steps every ``net_dt``; the trajectory and the
    population rates are sampled every ``sim.dt``. ``seed`` sets the network's random
    encoders, gains and biases (``nengo.Network(seed=...)``); the plant is
    deterministic. ``record_rates`` False leaves ``rates`` empty (a faster run).
    ``on_progress(t)`` is called with the simulated time [s] after each simulated
    second (a progress bar); stepping in chunks leaves the run unchanged.
    ``exploration`` (the dopamine stage, :mod:`striatal.neural.learn`): a Node function
    fed with each pathway's presynaptic signal (its decoded output in the term's units,
    filtered by the motor's synapse) whose output is added to the plant's u.
    Success is the chapter's test at T_f (``sim.success``, end of
    section 2.4) on the final state; ``upright_last_10s`` a looser test (|theta| <
    UPRIGHT_THETA over the last UPRIGHT_WINDOW s).
    ``simulator="brian2"`` runs the same network as a compiled Brian2 program with the
    plant inside it (:mod:`striatal.neural.brian`); ``on_compile(folder)`` is called
    before it compiles (once per network size and run length; ``folder`` is the cache).
    """
    config.check_work(sim.duration, net_dt)
    if simulator == "brian2":
        return _run_compiled(
            controller, plant, sim, config, seed, net_dt, exploration, on_compile, on_progress
        )
    if simulator != "nengo":
        raise ParameterError(f"simulator must be one of {', '.join(SIMULATORS)}, got {simulator!r}")
    nengo = require_nengo()
    seed = check_seed(seed)
    n_net = int(round(sim.duration / net_dt))
    every = max(1, int(round(sim.dt / net_dt)))
    t0 = time.perf_counter()
    h = build(controller, plant, config, seed)
    plant_fn = KernelPlant(sim.initial_state, plant, net_dt, n_net)
    names = tuple(h.populations)
    with h.model:
        node = nengo.Node(plant_fn, size_in=1, size_out=5, label="cart-pole (kernel RK4)")
        nengo.Connection(h.motor, node, synapse=None)
        nengo.Connection(node, h.sensor_input, synapse=None)
        counter = SpikeBins(len(names), every, n_net)
        rate_node = nengo.Node(counter, size_in=len(names), size_out=0, label="rates")
        if record_rates:
            # nengo seeds a network's objects type by type, connections before ensembles:
            # connections added to the model itself would change every ensemble's seed, so
            # the recording lives in a subnetwork and a seed is the same network either way
            with nengo.Network(label="rate recording"):
                for i, name in enumerate(names):
                    e = h.populations[name]
                    nengo.Connection(
                        e.neurons,
                        rate_node[i],
                        transform=np.full((1, e.n_neurons), 1.0 / e.n_neurons),
                        synapse=None,
                    )
        if exploration is not None:
            add_exploration(nengo, h, node, exploration, config.synapse)
    nengo_sim = _simulator(nengo, h.model, net_dt, seed, config)
    t1 = time.perf_counter()
    c1 = time.process_time()
    chunk = max(1, int(round(1.0 / net_dt)))
    with nengo_sim:
        for start in range(0, n_net, chunk):
            steps = min(chunk, n_net - start)
            nengo_sim.run_steps(steps)
            if on_progress is not None:
                on_progress((start + steps) * net_dt)
    t2 = time.perf_counter()
    cpu = time.process_time() - c1
    return _assemble(
        controller,
        plant,
        sim,
        config,
        seed,
        plant_fn.states,
        plant_fn.u,
        plant_fn.fault,
        counter.rates(),
        names,
        every,
        net_dt,
        neurons=h.n_neurons,
        wall=t2 - t1,
        cpu=cpu,
        build=t1 - t0,
    )


def _assemble(
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    net_states: np.ndarray,
    net_u: np.ndarray,
    fault: bool,
    rates: np.ndarray,
    names: tuple[str, ...],
    every: int,
    net_dt: float,
    *,
    neurons: int,
    wall: float,
    cpu: float,
    build: float,
    simulator: str = "nengo",
    compile_time: float = 0.0,
) -> NeuralRun:
    """A :class:`NeuralRun` from the plant's state at every network step (n_net + 1, 4)
    and u of every step: sampled every ``sim.dt``, the force of eq 12, the mode, the
    chapter's success test and the upright test. One reading for both simulators."""
    n_net = net_states.shape[0] - 1
    states = net_states[::every]
    u = net_u[::every]
    t = np.arange(states.shape[0]) * sim.dt
    p = plant.as_array()
    forces = np.array([kernel.force(s[2], s[3], a, p) for s, a in zip(states, u, strict=True)])
    mode = np.array(
        [
            kernel.MODE_BALANCE
            if abs(kernel.wrap_angle(s[2])) < controller.theta_c
            else kernel.MODE_SWINGUP
            for s in states
        ],
        dtype=float,
    )
    data = np.column_stack([t, states, u, forces, mode])
    final = net_states[-1].copy()
    final[2] = kernel.wrap_angle(final[2])
    return NeuralRun(
        data=data,
        rates=rates,
        populations=names,
        success=(not fault) and sim.success.passed(final),
        upright_last_10s=(not fault)
        and upright_throughout(np.arange(n_net + 1) * net_dt, net_states[:, 2]),
        fault=fault,
        neurons=neurons,
        wall_time=wall,
        cpu_time=cpu,
        build_time=build,
        sim=sim,
        config=config,
        seed=seed,
        simulator=simulator,
        compile_time=compile_time,
    )


def frozen_at_fault(states: np.ndarray) -> tuple[np.ndarray, bool]:
    """``states`` (n, 4) held at the last row before the first that is not finite or
    beyond ``kernel.BLOW_UP`` (as :class:`KernelPlant` freezes a state that blows up),
    and whether one was."""
    bad = ~np.all(np.isfinite(states) & (np.abs(states) < kernel.BLOW_UP), axis=1)
    if not bad.any():
        return states, False
    k = int(np.argmax(bad))
    out = states.copy()
    out[k:] = states[k - 1] if k > 0 else states[0]
    return out, True


def _run_compiled(
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    net_dt: float,
    exploration: MotorExploration | None,
    on_compile: Callable[[Path], None] | None,
    on_progress: Callable[[float], None] | None,
) -> NeuralRun:
    """:func:`run_network` on the Brian2 program (:mod:`striatal.neural.brian`)."""
    from striatal.neural.brian import compiled_network, require_brian2
    from striatal.neural.interpret import pathway_coefficients
    from striatal.neural.translate import translate

    require_brian2()
    seed = check_seed(seed)
    t0 = time.perf_counter()
    tr = translate(controller, plant, config, seed, net_dt)
    t1 = time.perf_counter()
    program = compiled_network(tr, sim.duration, sim.dt, on_compile=on_compile)
    coefficients = pathway_coefficients(controller.gains, plant, controller.sign)
    if exploration is None:
        r = program.run(tr, coefficients, plant, sim.initial_state)
    else:
        if exploration.every != program.every:
            raise ParameterError(
                f"exploration draws every {exploration.every} network steps, the program "
                f"every {program.every}"
            )
        r = program.run(
            tr,
            coefficients,
            plant,
            sim.initial_state,
            sigma=exploration.sigma,
            noise=exploration.noise[: program.n_control],
        )
        # the same calls the nengo Node gets: the pathway signals at each draw, held
        for k in range(program.n_control):
            for j in range(program.every):
                exploration((k * program.every + j) * net_dt, r.pre[k])
    if on_progress is not None:
        on_progress(sim.duration)
    states, fault = frozen_at_fault(r.states)
    sizes = np.array([size for _name, size in tr.pop_sizes], dtype=float)
    rates = r.counts / sizes / (program.every * net_dt)
    return _assemble(
        controller,
        plant,
        sim,
        config,
        seed,
        states,
        np.append(r.u, r.u[-1:]),
        fault,
        rates,
        tuple(name for name, _size in tr.pop_sizes),
        program.every,
        net_dt,
        neurons=tr.neurons,
        wall=r.wall_time,
        cpu=r.cpu_time,
        build=t1 - t0,
        simulator="brian2",
        compile_time=program.compile_time,
    )


def add_exploration(
    nengo: Any, h: Any, plant_node: Any, exploration: MotorExploration, synapse: float
) -> None:
    """Wire ``exploration`` into ``h.model`` (inside ``with h.model``): one connection per
    pathway from its presynaptic population, with the pathway's function and its scale in
    place of the coefficient, into the Node; the Node's output into the plant's u. In a
    subnetwork, so that the main network's seeds (and so its neurons) do not change."""
    if exploration.n_pre != len(h.pathways):
        raise ParameterError(
            f"exploration takes {exploration.n_pre} signals, {len(h.pathways)} given"
        )
    with nengo.Network(label="dopamine: eligibility and exploration"):
        node = nengo.Node(
            exploration, size_in=exploration.n_pre, size_out=1, label="exploration + traces"
        )
        for i, ((_channel, term, conn), scale) in enumerate(
            zip(h.pathways, h.pathway_scales, strict=True)
        ):
            kw = {} if conn.function is None else {"function": conn.function}
            nengo.Connection(
                conn.pre_obj,
                node[i],
                transform=scale,
                synapse=synapse,
                label=f"pre {term.signal} -> trace",
                **kw,
            )
        nengo.Connection(node, plant_node, synapse=None)


def held_state_response(
    controller: Controller,
    plant: Plant,
    config: NetworkConfig,
    seed: int,
    states: np.ndarray,
    *,
    hold: float = 0.2,
    average: float = 0.1,
    net_dt: float = 0.001,
) -> dict[str, np.ndarray]:
    """Decoded mu_1, mu_2, u and the gates' values with each state held for ``hold`` s.

    ``states``: (n, 4) [m, m/s, rad, rad/s]. Each output is the mean over the last
    ``average`` s of each hold, so that the network settles after every jump.
    Returns arrays of shape (n,) keyed ``mu_1``, ``mu_2``, ``u``, ``gate_balancing``,
    ``gate_swing-up``.
    """
    nengo = require_nengo()
    S = np.asarray(states, dtype=float)
    n_hold = int(round(hold / net_dt))
    n_avg = int(round(average / net_dt))
    sensed = np.column_stack([S[:, 0], S[:, 1], np.sin(S[:, 2]), np.cos(S[:, 2]), S[:, 3]])
    h = build(controller, plant, config, check_seed(seed))
    with h.model:

        def source(t: float) -> np.ndarray:
            i = min(int(t / hold - 1e-9), S.shape[0] - 1)
            return sensed[i]

        src = nengo.Node(source, size_out=5)
        nengo.Connection(src, h.sensor_input, synapse=None)
        probes = {
            "mu_1": nengo.Probe(h.mu_1, synapse=config.synapse),
            "mu_2": nengo.Probe(h.mu_2, synapse=config.synapse),
            "u": nengo.Probe(h.motor, synapse=config.synapse),
        }
        for name, gate in h.gates.items():
            probes[f"gate_{name}"] = nengo.Probe(gate, synapse=config.synapse)
    with _simulator(nengo, h.model, net_dt, seed, config) as simulator:
        simulator.run_steps(n_hold * S.shape[0])
    out = {}
    for name, p in probes.items():
        v = np.asarray(simulator.data[p])[:, 0].reshape(S.shape[0], n_hold)
        out[name] = v[:, n_hold - n_avg :].mean(axis=1)
    return out
