"""The spiking network compiled with Brian2 (``cpp_standalone``), the plant closed inside it.

nengo stays the reference: :func:`striatal.neural.translate.translate` builds the very
network of :func:`striatal.neural.network.build` with nengo's builder (its encoders,
gains, biases and solved decoders) and lays it out as arrays; :class:`CompiledNetwork`
runs those arrays as Brian2 groups in one compiled C++ program:

- **neurons**: every population in one group, nengo's LIF step written out (the
  voltage update ``v += (J - v)(1 - exp(-dt'/tau_rc))`` over the part ``dt'`` of the step
  outside the refractory period, the spike time interpolated into the refractory time);
- **signals**: one row per decoded connection, a low-pass filter of its synapse
  discretised as nengo does (``y <- a y + (1 - a) u``, a = exp(-dt/tau)), into which
  each spike adds its decoder; the sensed state and the tonic drive are rows too;
- **encoding**: each neuron's input current is the sum over the rows that drive it
  (scaled encoders for an ensemble's input, the transform for a connection into its
  neurons), a Brian2 summed variable;
- **plant**: the cart-pole as equations of a one-element group, eqs 8-9 with the
  pole a point mass (eq 10), integrated by RK4 with the force of eq 12 computed from
  the commanded acceleration u at the start of every network step and held over it;
  u = sum_i c_i s_i + sigma n(t), with s_i the seven pathways' filtered decoded signals
  (:data:`striatal.neural.learn.PATHWAYS`), c_i their coefficients and n(t) the
  exploration's standard normals, held per control step.

The coefficients c_i, sigma, the noise, the start state, the plant and every array of a
network seed are set per run through ``device.run(run_args=...)``: a learning run
compiles once and reruns the program with new weights. The program's structure (the
population sizes, the connections, the duration) is the compile-cache key; the cache
lives beside Numba's (:func:`cache_root`).
"""

from __future__ import annotations

import atexit
import hashlib
import os
import resource
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.neural.translate import Translation
from striatal.params import Plant

__all__ = [
    "BRIAN2_INSTALL",
    "FORCE_OF_U",
    "PLANT_EQUATIONS",
    "CompiledNetwork",
    "CompiledRun",
    "cache_root",
    "compiled_network",
    "require_brian2",
]

#: What a machine without Brian2 is told.
BRIAN2_INSTALL = "the Brian2 simulator needs brian2: pip install 'striatal[neural]'"
#: The sensed-state rows' names, in the order of ``SENSED`` of the network module.
_SENSED_VARS = ("x", "xd", "sin(th)", "cos(th)", "thd")


def require_brian2() -> Any:
    """Import brian2, or raise ParameterError naming the extra to install."""
    try:
        import brian2
    except ImportError:
        raise ParameterError(BRIAN2_INSTALL) from None
    return brian2


def cache_root() -> Path:
    """Where compiled programs live: ``$NUMBA_CACHE_DIR/striatal-brian2`` when Numba's cache
    is moved there, else ``__pycache__/brian2`` beside this module (as Numba caches beside
    the kernel), else ``~/.cache/striatal/brian2`` if the package folder is read-only."""
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        return Path(env) / "striatal-brian2"
    here = Path(__file__).resolve().parent / "__pycache__"
    if os.access(here if here.exists() else here.parent, os.W_OK):
        return here / "brian2"
    return Path.home() / ".cache" / "striatal" / "brian2"


@dataclass(frozen=True)
class CompiledRun:
    """What one run of the compiled program returns.

    ``states`` (n_net + 1, 4): the plant every network step from the start, theta not
    wrapped; ``u`` and ``force`` (n_net,): the commanded acceleration and the held force
    of each step; ``pre`` (n_control, 7): the pathways' filtered signals s_i at the start
    of each control step (what the eligibility reads); ``counts`` (n_control, n_pop):
    spikes per population per control step; ``cpu_time`` [s]: user + system time of the
    compiled child process; ``wall_time`` [s].
    """

    states: np.ndarray
    u: np.ndarray
    force: np.ndarray
    pre: np.ndarray
    counts: np.ndarray
    cpu_time: float
    wall_time: float


#: The plant of the compiled program: eqs 8-9 with the point-mass pole of eq 10. The
#: force f of eq 12 is computed from u once per network step, before the state update,
#: and held over the step; u = sum_i c_i s_i + sigma n(t) (s_i linked to the pathway rows).
PLANT_EQUATIONS = """
dx/dt = xd / second : 1
dxd/dt = xdd / second : 1
dth/dt = thd / second : 1
dthd/dt = (g_p * sin(th) - xdd * cos(th)) / l_p / second : 1
xdd = (f + m_p * l_p * thd**2 * sin(th) - m_p * g_p * sin(th) * cos(th)) / mass : 1
mass = M_p + m_p - m_p * cos(th)**2 : 1
f : 1
u : 1
sigma : 1 (shared)
M_p : 1 (shared)
m_p : 1 (shared)
l_p : 1 (shared)
g_p : 1 (shared)
"""

#: Eq 12: the force that realises the cart acceleration u (the model is the plant).
FORCE_OF_U = (
    "f = (M_p + m_p - m_p * cos(th)**2) * u + m_p * g_p * cos(th) * sin(th)"
    " - m_p * l_p * thd**2 * sin(th)"
)

_SIGNAL_EQS = """
dy/dt = -y / tau : 1
tau : second (constant)
a0 : 1 (constant)
a1 : 1 (constant)
a2 : 1 (constant)
a3 : 1 (constant)
a4 : 1 (constant)
a5 : 1 (constant)
xp : 1 (linked)
xdp : 1 (linked)
thp : 1 (linked)
thdp : 1 (linked)
v : 1
"""
#: What a row carries: its filtered spikes, or the sensed state, or the tonic drive.
_SIGNAL_VALUE = "v = y + a0 * xp + a1 * xdp + a2 * sin(thp) + a3 * cos(thp) + a4 * thdp + a5"

#: nengo's LIF step (``nengo.neurons.LIF.step``): the voltage moves over the part of
#: the step outside the refractory period and never goes below 0; a spike sets the
#: refractory time to tau_ref plus the part of the step after the interpolated spike.
_LIF_STEP = """
ref = ref - dt
dtt = clip(dt - ref, 0 * second, dt)
v = v - (J + bias - v) * lif_decay(dtt, 1 / tau_rc)
v = v * int(v > 0)
"""
#: exp(-dtt / tau_rc) - 1 of the LIF step, as the generated code writes it, with the last
#: value kept: every neuron outside its refractory period has dtt = dt, so the exponential
#: is computed about once per step instead of once per neuron (the same bits).
_LIF_DECAY_CPP = """
double lif_decay(const double dtt, const double inv_tau)
{
    static double last_dtt = -1.0;
    static double last = 0.0;
    if (dtt != last_dtt) {
        last_dtt = dtt;
        last = (-1.0) + exp(inv_tau * (-dtt));
    }
    return last;
}
"""
_LIF_RESET = """
ref = tau_ref + dt + tau_rc * log(1 - (v - 1) / (J + bias - 1))
v = 0
"""


def _lif_decay_function(b2: Any) -> Any:
    """``lif_decay(dtt, 1 / tau_rc)`` = exp(-dtt / tau_rc) - 1 for Brian2's C++ code."""

    @b2.implementation("cpp", _LIF_DECAY_CPP)
    @b2.check_units(dtt=b2.second, inv_tau=b2.Hz, result=1)
    def lif_decay(dtt: Any, inv_tau: Any) -> Any:
        return np.expm1(-np.asarray(dtt) * np.asarray(inv_tau))

    return lif_decay


def _program_version() -> str:
    """The program's code and Brian2's version: a change to either is a new cache entry."""
    b2 = require_brian2()
    parts = (PLANT_EQUATIONS, FORCE_OF_U, _SIGNAL_EQS, _SIGNAL_VALUE, _LIF_STEP, _LIF_RESET)
    text = "".join((*parts, _LIF_DECAY_CPP))
    return hashlib.sha256((text + b2.__version__).encode()).hexdigest()[:12]


class CompiledNetwork:
    """One compiled Brian2 program for a network structure and a run length.

    :meth:`build` generates and compiles it (once per structure: the cache keeps it,
    and a lock serialises processes that build at once) and copies the binary into a
    private working folder; :meth:`run` reruns the binary with a translation's values,
    the pathway coefficients, the exploration and the start state as ``run_args``.
    One process holds one program at a time (Brian2's device is global).
    """

    def __init__(self, tr: Translation, duration: float, control_dt: float) -> None:
        self.n_net = int(round(duration / tr.net_dt))
        self.every = max(1, int(round(control_dt / tr.net_dt)))
        self.n_control = self.n_net // self.every
        self.duration = duration
        self.control_dt = control_dt
        self.structure = tr
        self.key = tr.structure_key(self.n_net, self.every, _program_version())
        self.project = cache_root() / self.key
        self.compile_time = 0.0
        self.compiled_now = False
        self._o: dict[str, Any] = {}
        self._work: Path | None = None
        self._device: Any = None

    @property
    def cached(self) -> bool:
        """True if the program is already compiled in the cache."""
        return (self.project / ".complete").exists()

    def build(self) -> None:
        """Generate the program and compile it (make finds nothing to do if it is cached)."""
        b2 = require_brian2()
        from filelock import FileLock

        tr = self.structure
        self.project.parent.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        was_cached = self.cached
        # a fresh standalone project (the device is one object per process: reinit it)
        b2.set_device("cpp_standalone", build_on_run=False, directory=str(self.project))
        device = b2.get_device()
        device.reinit()
        device.activate(build_on_run=False, directory=str(self.project))
        b2.prefs.devices.cpp_standalone.openmp_threads = 0
        b2.defaultclock.dt = tr.net_dt * b2.second
        second = b2.second
        ns = {
            "tau_rc": tr.tau_rc * second,
            "tau_ref": tr.tau_ref * second,
            "lif_decay": _lif_decay_function(b2),
        }
        n_path = int(tr.pathway_rows.shape[0])

        noise = b2.TimedArray(np.zeros(self.n_control + 1), dt=self.control_dt * second)
        links = "".join(f"s{i} : 1 (linked)\nc{i} : 1 (shared)\n" for i in range(n_path))
        plant = b2.NeuronGroup(
            1, PLANT_EQUATIONS + links, method="rk4", name="plant", order=0, namespace={}
        )
        u_code = " + ".join(f"c{i} * s{i}" for i in range(n_path))
        plant.run_regularly(
            f"u = {u_code} + sigma * noise(t)\n{FORCE_OF_U}",
            when="before_groups",
            name="plant_motor",
        )
        signals = b2.NeuronGroup(
            tr.n_rows, _SIGNAL_EQS, method="exact", name="signals", order=5, namespace={}
        )
        # nengo's low-pass y[n+1] = a y[n] + (1 - a) u[n] is read before it decays: the
        # rows' values are taken after the plant's update, the neurons' inputs summed and
        # stepped, and only then do the filters decay (order 5) and take this step's spikes
        signals.run_regularly(_SIGNAL_VALUE, when="groups", order=2, name="signals_value")
        zeros = np.zeros(tr.n_rows, dtype=np.int64)
        signals.xp = b2.linked_var(plant, "x", index=zeros)
        signals.xdp = b2.linked_var(plant, "xd", index=zeros)
        signals.thp = b2.linked_var(plant, "th", index=zeros)
        signals.thdp = b2.linked_var(plant, "thd", index=zeros)
        for i, row in enumerate(tr.pathway_rows):
            setattr(
                plant,
                f"s{i}",
                b2.linked_var(signals, "y", index=np.array([int(row)], dtype=np.int64)),
            )
        neurons = b2.NeuronGroup(
            tr.neurons,
            "J : 1\nbias : 1 (constant)\nv : 1\nref : second",
            threshold="v > 1",
            reset=_LIF_RESET,
            name="neurons",
            order=4,
            namespace=ns,
        )
        neurons.run_regularly(_LIF_STEP, when="groups", order=4, name="neurons_lif")
        encode = b2.Synapses(
            signals, neurons, "w : 1\nJ_post = w * v_pre : 1 (summed)", name="encode"
        )
        encode.connect(i=tr.enc_row, j=tr.enc_post)
        decode = b2.Synapses(neurons, signals, "w : 1", on_pre="y_post += w", name="decode")
        decode.connect(i=tr.spike_pre, j=tr.spike_row)
        pops = np.concatenate(
            [np.full(size, k, dtype=np.int32) for k, (_n, size) in enumerate(tr.pop_sizes)]
        )
        counts = b2.NeuronGroup(len(tr.pop_sizes), "n : 1", name="counts")
        count = b2.Synapses(neurons, counts, on_pre="n_post += 1", name="count")
        count.connect(i=np.arange(tr.neurons, dtype=np.int32), j=pops)
        mon_plant = b2.StateMonitor(
            plant, ["x", "xd", "th", "thd", "u", "f"], record=[0], when="end", name="mon_plant"
        )
        mon_pre = b2.StateMonitor(
            signals,
            "y",
            record=tr.pathway_rows,
            dt=self.control_dt * second,
            when="start",
            name="mon_pre",
        )
        mon_counts = b2.StateMonitor(
            counts, "n", record=True, dt=self.control_dt * second, when="end", name="mon_counts"
        )
        self._o = {
            "plant": plant,
            "signals": signals,
            "neurons": neurons,
            "encode": encode,
            "decode": decode,
            "noise": noise,
            "mon_plant": mon_plant,
            "mon_pre": mon_pre,
            "mon_counts": mon_counts,
        }
        net = b2.Network(
            plant, signals, neurons, encode, decode, counts, count, mon_plant, mon_pre, mon_counts
        )
        net.run(self.duration * second, namespace={"noise": noise, **ns})
        with FileLock(str(self.project) + ".lock"):
            device.build(directory=str(self.project), compile=True, run=False, with_output=False)
            (self.project / ".complete").touch()
        self.compile_time = time.perf_counter() - t0
        self.compiled_now = not was_cached
        self._device = device
        self._work = Path(tempfile.mkdtemp(prefix="striatal-brian2-"))
        # the private copy and its results go with the process
        atexit.register(shutil.rmtree, self._work, True)
        shutil.copy2(self.project / "main", self._work / "main")
        shutil.copytree(self.project / "static_arrays", self._work / "static_arrays")
        b2.get_device().project_dir = str(self._work)

    def run(
        self,
        tr: Translation,
        coefficients: np.ndarray,
        plant: Plant,
        state0: np.ndarray,
        *,
        sigma: float = 0.0,
        noise: np.ndarray | None = None,
    ) -> CompiledRun:
        """Run the compiled program with ``tr``'s values (a network seed of the same
        structure), the pathway ``coefficients`` (7,), ``plant`` and the start ``state0``
        (4,); exploration sigma n_k with ``noise`` (n_control,) standard normals."""
        b2 = require_brian2()
        if self._work is None:
            raise ParameterError("build the compiled network before running it")
        if tr.structure_key(self.n_net, self.every, _program_version()) != self.key:
            raise ParameterError("the translation is not of the compiled network's structure")
        o = self._o
        second = b2.second
        if b2.get_device() is not self._device:
            # another Brian2 device was set since the build (a runtime simulation)
            b2.set_device(self._device, build_on_run=False)
        c = np.asarray(coefficients, dtype=float)
        n_path = int(tr.pathway_rows.shape[0])
        if c.shape != (n_path,) or not np.all(np.isfinite(c)):
            raise ParameterError(f"need {n_path} finite pathway coefficients, got {c!r}")
        z = np.zeros(self.n_control + 1)
        if noise is not None:
            nz = np.asarray(noise, dtype=float)
            if nz.shape != (self.n_control,):
                raise ParameterError(f"noise must have {self.n_control} draws, got {nz.shape}")
            z[: self.n_control] = nz
        decay = 1.0 - np.exp(-tr.net_dt / tr.row_tau)
        one_hot = {f"a{k}": (tr.row_sensor == k).astype(float) for k in range(5)}
        one_hot["a5"] = (tr.row_kind == 2).astype(float)
        pl, sg, ne = o["plant"], o["signals"], o["neurons"]
        x0 = [float(v) for v in state0]
        args: dict[Any, Any] = {
            pl.x: x0[0],
            pl.xd: x0[1],
            pl.th: x0[2],
            pl.thd: x0[3],
            pl.sigma: float(sigma),
            pl.M_p: plant.cart_mass,
            pl.m_p: plant.pole_mass,
            pl.l_p: plant.length,
            pl.g_p: plant.gravity,
            sg.tau: tr.row_tau * second,
            ne.bias: tr.bias,
            ne.v: tr.v0,
            o["encode"].w: tr.enc_w,
            o["decode"].w: tr.spike_w * decay[tr.spike_row] / tr.net_dt,
            o["noise"]: z,
        }
        for i in range(n_path):
            args[getattr(pl, f"c{i}")] = float(c[i])
        for name, a in one_hot.items():
            args[getattr(sg, name)] = a
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        self._device.run(
            directory=str(self._work),
            results_directory="results",
            with_output=False,
            run_args=args,
        )
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        for name in self._device.run_args_arrays:
            (self._work / "static_arrays" / name).unlink(missing_ok=True)
        mp = o["mon_plant"]
        traj = np.column_stack([np.asarray(getattr(mp, k))[0] for k in ("x", "xd", "th", "thd")])
        states = np.vstack([np.asarray(x0)[None, :], traj])
        pre = np.asarray(o["mon_pre"].y).T[: self.n_control]
        counts = np.diff(np.asarray(o["mon_counts"].n), axis=1, prepend=0.0).T
        return CompiledRun(
            states=states,
            u=np.asarray(mp.u)[0],
            force=np.asarray(mp.f)[0],
            pre=pre,
            counts=counts[: self.n_control],
            cpu_time=(after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime),
            wall_time=wall,
        )


_ACTIVE: CompiledNetwork | None = None


def compiled_network(
    tr: Translation, duration: float, control_dt: float, *, on_compile: Any = None
) -> CompiledNetwork:
    """The process's compiled program for ``tr``'s structure and this run length: the one
    already built if it fits, else a new build. ``on_compile(path)`` is called before a
    build that will compile (a cache miss)."""
    global _ACTIVE
    probe = CompiledNetwork(tr, duration, control_dt)
    if _ACTIVE is not None and _ACTIVE.key == probe.key:
        return _ACTIVE
    if not probe.cached and on_compile is not None:
        on_compile(probe.project)
    probe.build()
    _ACTIVE = probe
    return probe
