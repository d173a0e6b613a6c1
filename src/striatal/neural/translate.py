"""A nengo-built network as arrays: what the Brian2 program (:mod:`.brian`) runs.

:func:`translate` builds :func:`striatal.neural.network.build`'s network with nengo's
own builder and lays out its encoders, gains, biases and solved decoders as the arrays
of :class:`Translation`. nengo is the reference; nothing of the network is written twice.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.neural.network import NetworkConfig, build, criterion_of_cos, require_nengo
from striatal.params import Controller, Plant, check_gains, check_theta_c

__all__ = ["Translation", "forget_builds", "translate"]


@dataclass(frozen=True)
class Translation:
    """A built nengo network as the arrays of the compiled program.

    Structure (what the program is compiled for): ``pop_sizes`` (name -> neurons, in
    order), ``n_rows`` signal rows with ``row_kind`` (0 decoded, 1 sensed, 2 tonic,
    3 pathway) and ``row_sensor`` (index into x, x_dot, sin, cos, theta_dot, or -1);
    ``spike_pre``/``spike_row``: the spike synapses (neuron -> row);
    ``enc_row``/``enc_post``: the summed synapses (row -> neuron); ``pathway_rows`` (7,).
    Values (what a seed sets, through run_args): ``bias`` (N,), ``spike_w``, ``enc_w``,
    ``row_tau`` [s], ``v0`` (N,) initial voltages; ``tau_rc``, ``tau_ref`` [s].
    """

    pop_sizes: tuple[tuple[str, int], ...]
    row_kind: np.ndarray
    row_sensor: np.ndarray
    row_tau: np.ndarray
    spike_pre: np.ndarray
    spike_row: np.ndarray
    spike_w: np.ndarray
    enc_row: np.ndarray
    enc_post: np.ndarray
    enc_w: np.ndarray
    pathway_rows: np.ndarray
    bias: np.ndarray
    v0: np.ndarray
    tau_rc: float
    tau_ref: float
    net_dt: float
    neurons: int

    @property
    def n_rows(self) -> int:
        return int(self.row_kind.shape[0])

    def structure_key(self, *extra: object) -> str:
        """A hash of what the compiled program depends on (not the weights)."""
        h = hashlib.sha256()
        for a in (self.row_kind, self.row_sensor, self.spike_pre, self.spike_row):
            h.update(np.ascontiguousarray(a).tobytes())
        for a in (self.enc_row, self.enc_post, self.pathway_rows):
            h.update(np.ascontiguousarray(a).tobytes())
        h.update(repr((self.pop_sizes, self.tau_rc, self.tau_ref, self.net_dt, extra)).encode())
        return h.hexdigest()[:16]


def _tau(synapse: Any) -> float | None:
    if synapse is None:
        return None
    tau = getattr(synapse, "tau", None)
    if tau is None:
        raise ParameterError(f"the Brian2 simulator takes low-pass synapses only, got {synapse}")
    return float(tau)


@dataclass(frozen=True)
class _Built:
    """A seed's translation at one theta_c, and what re-solving the switch needs: the
    connection cos -> fibres, a model holding its presynaptic ensemble's build (nengo's
    :func:`nengo.builder.connection.build_decoders` reads it) and its rows in ``spike_w``."""

    theta_c: float
    translation: Translation
    conn: Any
    model: Any
    spikes: slice


#: The last seeds' builds (a learning run alternates a few seeds; theta_c moves every trial).
_BUILT: OrderedDict[tuple[object, ...], _Built] = OrderedDict()
_BUILT_MAX = 64


def forget_builds() -> None:
    """Drop the kept builds: the next translation of every seed is a full build."""
    _BUILT.clear()


def translate(
    controller: Controller, plant: Plant, config: NetworkConfig, seed: int, net_dt: float = 0.001
) -> Translation:
    """Build ``striatal.neural.network.build``'s network with nengo's builder and lay it out.

    The seven pathway connections are built with their scale as transform (a coefficient
    of 1): their decoders do not depend on the transform, and the coefficients c(W)
    enter the compiled program as numbers of the run. ``v0``: initial voltages
    U(0, 1), as nengo's LIF draws them, from ``default_rng(seed)``.

    So a seed's translation depends on W only through its checks, and on theta_c only
    through the decoders of the switch's connection cos -> fibres (its function is the
    criterion of theta_c). The process keeps the last seeds' builds: another W or
    theta_c of a built seed re-solves only those decoders, with nengo's own
    ``build_decoders`` and the connection's seed (the same arrays as a full build, tested).
    """
    check_gains(controller.gains)
    theta_c = check_theta_c(controller.theta_c)
    key = (seed, config, plant, float(net_dt), float(controller.sign))
    got = _BUILT.get(key)
    if got is None:
        got = _build(controller, plant, config, seed, net_dt)
        _BUILT[key] = got
        while len(_BUILT) > _BUILT_MAX:
            _BUILT.popitem(last=False)
    else:
        _BUILT.move_to_end(key)
    if got.theta_c == theta_c:
        return got.translation
    require_nengo()
    from nengo.builder.connection import build_decoders

    got.conn.function = criterion_of_cos(theta_c, config.switch_gain)
    rng = np.random.RandomState(got.model.seeds[got.conn])
    with got.model.decoder_cache:
        _eval, decoders, _info = build_decoders(got.model, got.conn, rng)
    if np.any(np.asarray(getattr(got.conn.transform, "init", 1.0)) != 1.0):
        raise ParameterError("the switch's connection must have no transform")
    # with no transform the full build's weights are the decoders
    spike_w = got.translation.spike_w.copy()
    spike_w[got.spikes] = np.asarray(decoders, dtype=float).reshape(-1)
    return replace(got.translation, spike_w=spike_w)


def _build(
    controller: Controller, plant: Plant, config: NetworkConfig, seed: int, net_dt: float
) -> _Built:
    """:func:`translate` in full: nengo's builder on the whole network."""
    if config.selection != "cerebellum":
        raise ParameterError(
            "the Brian2 simulator builds the cerebellar switch only (--selection cerebellum)"
        )
    nengo = require_nengo()
    from nengo.builder import Model
    from nengo.cache import get_default_decoder_cache

    h = build(controller, plant, config, seed)
    pathway_conns = {id(c): k for k, (_ch, _t, c) in enumerate(h.pathways)}
    for (_ch, _t, c), scale in zip(h.pathways, h.pathway_scales, strict=True):
        c.transform = scale
    # nengo's decoder cache, as nengo.Simulator uses it: a learning run solves only the
    # decoders whose targets changed (the fibres' criterion when theta_c moves)
    model = Model(dt=net_dt, label="striatal brian2", decoder_cache=get_default_decoder_cache())
    model.build(h.model)

    ensembles = list(h.model.all_ensembles)
    offset: dict[int, int] = {}
    n = 0
    for e in ensembles:
        if not isinstance(e.neuron_type, nengo.LIF):
            raise ParameterError(f"the Brian2 simulator takes LIF neurons, got {e.neuron_type}")
        offset[id(e)] = n
        n += e.n_neurons
    lif = ensembles[0].neuron_type
    bias = np.concatenate([model.params[e].bias for e in ensembles])

    kinds: list[int] = []
    sensors: list[int] = []
    taus: list[float] = []
    spike_pre: list[np.ndarray] = []
    spike_row: list[np.ndarray] = []
    spike_w: list[np.ndarray] = []
    enc_row: list[np.ndarray] = []
    enc_post: list[np.ndarray] = []
    enc_w: list[np.ndarray] = []
    pathway_rows = np.full(len(h.pathways), -1)
    sensed_row: dict[int, int] = {}
    tonic_row = -1
    motor_tau = None
    switch_spikes: slice | None = None

    def new_row(kind: int, sensor: int = -1, tau: float = 1.0) -> int:
        kinds.append(kind)
        sensors.append(sensor)
        taus.append(tau)
        return len(kinds) - 1

    def drive(row: int, post: Any, post_slice: Any, transform: np.ndarray) -> None:
        """Row -> the neurons of ``post``: scaled encoders (an ensemble), or the transform
        times the neurons' gains (a connection into ``post.neurons``)."""
        if isinstance(post, nengo.ensemble.Neurons):
            # nengo multiplies a connection into neurons by their gains
            e = post.ensemble
            t = np.broadcast_to(np.asarray(transform, dtype=float).reshape(-1), (e.n_neurons,))
            w = t * model.params[e].gain
        else:
            e = post
            enc = model.params[e].scaled_encoders  # (n, d): gain * encoder / radius
            dims = np.arange(e.dimensions)[post_slice]
            t = np.asarray(transform, dtype=float).reshape(-1)
            w = enc[:, dims] @ np.broadcast_to(t, dims.shape)
        idx = offset[id(e)] + np.arange(e.n_neurons)
        enc_row.append(np.full(idx.shape, row))
        enc_post.append(idx)
        enc_w.append(np.array(w, dtype=float))

    for conn in h.model.all_connections:
        pre, post = conn.pre_obj, conn.post_obj
        transform = np.asarray(getattr(conn.transform, "init", 1.0), dtype=float)
        if pre is h.mu_1 or pre is h.mu_2:
            if post is not h.motor:
                raise ParameterError(f"unexpected connection {conn}")
            motor_tau = _tau(conn.synapse)
            continue
        if post is h.motor or (isinstance(post, nengo.Node) and post not in (h.mu_1, h.mu_2)):
            raise ParameterError(f"the Brian2 simulator cannot translate {conn}")
        if isinstance(pre, nengo.Ensemble):
            if conn.size_mid != 1:
                raise ParameterError(f"decoded connections must be 1-D, got {conn}")
            weights = np.asarray(model.params[conn].weights, dtype=float)
            k = pathway_conns.get(id(conn))
            if k is not None:
                # weights = scale * decoders (the transform was set to the scale above)
                row = new_row(3)
                pathway_rows[k] = row
                d = weights.reshape(-1)
            else:
                tau = _tau(conn.synapse)
                if tau is None:
                    raise ParameterError(f"decoded connections need a synapse, got {conn}")
                row = new_row(0, tau=tau)
                # weights = transform @ decoders; the transform goes to the drive
                t = transform.reshape(-1)
                nz = int(np.flatnonzero(t)[0]) if t.size > 1 else 0
                d = weights[nz] / t[nz] if t.size > 1 else weights.reshape(-1) / t.item()
                drive(row, post, conn.post_slice, transform)
            if conn is h.switch_criterion:
                start = sum(a.shape[0] for a in spike_w)
                switch_spikes = slice(start, start + pre.n_neurons)
            spike_pre.append(offset[id(pre)] + np.arange(pre.n_neurons))
            spike_row.append(np.full(pre.n_neurons, row))
            spike_w.append(d)
        elif pre is h.sensor_input:
            if conn.synapse is not None:
                raise ParameterError(f"sensed inputs take no synapse, got {conn}")
            sensor = int(np.arange(pre.size_out)[conn.pre_slice].item())
            if sensor not in sensed_row:
                sensed_row[sensor] = new_row(1, sensor=sensor)
            drive(sensed_row[sensor], post, conn.post_slice, transform)
        elif isinstance(pre, nengo.Node) and pre.size_in == 0 and not callable(pre.output):
            if np.any(np.asarray(pre.output, dtype=float) != 1.0) or conn.synapse is not None:
                raise ParameterError(f"only a tonic drive of 1 without synapse, got {conn}")
            if tonic_row < 0:
                tonic_row = new_row(2)
            drive(tonic_row, post, conn.post_slice, transform)
        else:
            raise ParameterError(f"the Brian2 simulator cannot translate {conn}")
    if motor_tau is None or np.any(pathway_rows < 0) or switch_spikes is None:
        raise ParameterError("the network has no motor output or no switch")
    tau_arr = np.array(taus)
    tau_arr[pathway_rows] = motor_tau
    rng = np.random.default_rng(seed)
    tr = Translation(
        pop_sizes=tuple((str(e.label), int(e.n_neurons)) for e in ensembles),
        row_kind=np.array(kinds, dtype=np.int32),
        row_sensor=np.array(sensors, dtype=np.int32),
        row_tau=tau_arr,
        spike_pre=np.concatenate(spike_pre).astype(np.int32),
        spike_row=np.concatenate(spike_row).astype(np.int32),
        spike_w=np.concatenate(spike_w),
        enc_row=np.concatenate(enc_row).astype(np.int32),
        enc_post=np.concatenate(enc_post).astype(np.int32),
        enc_w=np.concatenate(enc_w),
        pathway_rows=pathway_rows.astype(np.int32),
        bias=np.asarray(bias, dtype=float),
        v0=rng.uniform(0.0, 1.0, n),
        tau_rc=float(lif.tau_rc),
        tau_ref=float(lif.tau_ref),
        net_dt=float(net_dt),
        neurons=n,
    )
    # what re-solving the switch reads of the build: its presynaptic ensemble's parameters
    conn = h.switch_criterion
    small = Model(dt=net_dt, label="striatal switch", decoder_cache=model.decoder_cache)
    small.params[conn.pre_obj] = model.params[conn.pre_obj]
    small.seeds[conn] = model.seeds[conn]
    small.seeded[conn] = model.seeded[conn]
    return _Built(float(controller.theta_c), tr, conn, small, switch_spikes)
