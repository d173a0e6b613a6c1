"""The lockstep batch: the trials of a block advance step k together, as arrays over
lanes, so that LLVM vectorises the loops over trials (no libm call inside them).

The same arguments and outputs as :func:`striatal.sim.kernel.trials.run_trials_batch`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from striatal.sim.kernel.libm import TWO_PI, sincos_poly
from striatal.sim.kernel.plant import (
    PlantArgs,
    PlantTerms,
    accelerations_terms,
    force_terms,
    plant_terms,
    rk4,
)
from striatal.sim.kernel.policy import (
    BatchGains,
    ControlArgs,
    PolicyTerms,
    balancing_roots,
    policy_gradient,
    sigma_of,
)
from striatal.sim.kernel.traces import TraceArgs, trace_step
from striatal.sim.kernel.trials import (
    BLOW_UP,
    STATUS_FAULT,
    STATUS_RUNNING,
    ProtocolArgs,
    Tally,
    judge,
    write_summary,
)

__all__ = [
    "LOCKSTEP_BLOCK",
    "VECTOR",
    "run_trials_lockstep",
]

#: Trials per lockstep block (one block per thread at a time).
LOCKSTEP_BLOCK = 64


#: Lanes a block steps at a time: LLVM vectorises the loops over lanes 8 doubles wide
#: where the CPU has AVX-512 (two AVX2 vectors elsewhere). A block steps its trials
#: rounded up to whole vectors: lanes left over would run one by one in the loops'
#: scalar remainder, each about as slow as a whole vector (benchmarks/lockstep_lanes.py).
VECTOR = 8


@njit(cache=True, inline="always")
def _lanes(n: int) -> int:
    """n lanes rounded up to whole vectors."""
    return (n + VECTOR - 1) // VECTOR * VECTOR


@njit(cache=True, inline="always")
def _poly_stage(theta: float, theta_dot: float, u: float, pt: PlantTerms) -> tuple[float, float]:
    """An RK4 stage of eqs 13-14 (u held) with the polynomial sin/cos (no libm call)."""
    s, c = sincos_poly(theta)
    return accelerations_terms(s, c, theta_dot, u, pt)


# Rows of the per-block state array of the lockstep kernel (fields x lanes).
_F_X, _F_XD, _F_TH, _F_THD, _F_A, _F_ACTIVE, _F_TC = 0, 1, 2, 3, 4, 5, 6
_F_W1, _F_W2, _F_W3, _F_W4, _F_W5, _F_ROOT, _F_INVROOT, _F_SIGMA = 7, 8, 9, 10, 11, 12, 13, 14
_F_EPS, _F_THW, _F_D0 = 15, 16, 17  # D0..D5: 17..22
_F_MINSW, _F_MINALL, _F_NSW, _F_PREV, _F_MAXX, _F_MAXF = 23, 24, 25, 26, 27, 28
_N_FIELDS = 29


@njit(cache=True, error_model="numpy")
def _lockstep_block(
    lo: int,
    hi: int,
    args: tuple[
        np.ndarray, BatchGains, PlantArgs, ControlArgs, ProtocolArgs, np.ndarray, TraceArgs
    ],
    outs: np.ndarray,
) -> None:
    """Trials lo..hi-1 of :func:`run_trials_lockstep`, advanced step by step together.

    The state array always has LOCKSTEP_BLOCK lanes (a compile-time row stride, so the
    loops over lanes vectorise without run-time alias checks); the loops step the
    trials rounded up to whole vectors (:data:`VECTOR`), the extra lanes idle copies of
    the first trial, inactive from the start. When trials end (at the eq-24 check, on a
    fault) and the running ones fit in fewer vectors, the ended ones are written out and
    the running ones packed into the first lanes (:func:`_pack`), so the loops step
    fewer lanes; a lane's arithmetic does not depend on its place, so the results
    are the same.
    """
    states0, gains, plant, control, protocol, noise, learning = args
    n = hi - lo
    # lanes actually stepped: the trials rounded up to whole vectors; the array keeps
    # LOCKSTEP_BLOCK lanes so its row stride is a constant
    L = min(LOCKSTEP_BLOCK, _lanes(n))
    # lane j holds trial lo + trial[j], for j < live (the lanes not yet written out)
    trial = np.arange(LOCKSTEP_BLOCK)
    live = n
    S = np.zeros((_N_FIELDS, LOCKSTEP_BLOCK))
    status = np.full(LOCKSTEP_BLOCK, STATUS_RUNNING)
    end_step = np.full(LOCKSTEP_BLOCK, protocol.n_steps)
    reward = np.zeros(LOCKSTEP_BLOCK)
    # parameters as plain floats: the loops over lanes read no parameter array
    pt = plant_terms(plant)
    length = pt.model_length
    g = pt.model_g
    m = pt.model_m
    gamma = learning.gamma
    stochastic = noise.shape[1] > 0
    n_steps = protocol.n_steps
    for j in range(L):
        b = lo + j if j < n else lo
        S[_F_X, j] = states0[b, 0]
        S[_F_XD, j] = states0[b, 1]
        S[_F_TH, j] = states0[b, 2]
        S[_F_THD, j] = states0[b, 3]
        S[_F_ACTIVE, j] = 1.0 if j < n else 0.0
        S[_F_MAXX, j] = abs(states0[b, 0])
        S[_F_TC, j] = gains.theta_c[b]
        w1 = gains.W[b, 0]
        S[_F_W1, j] = w1
        S[_F_W2, j] = gains.W[b, 1]
        S[_F_W3, j] = gains.W[b, 2]
        S[_F_W4, j] = gains.W[b, 3]
        S[_F_W5, j] = gains.W[b, 4]
        S[_F_ROOT, j], S[_F_INVROOT, j] = balancing_roots(w1, g)
        S[_F_SIGMA, j] = sigma_of(gains.W[b, 5])
        for i in range(6):
            S[_F_D0 + i, j] = learning.trace[b, i]
        S[_F_MINSW, j] = math.inf
        S[_F_MINALL, j] = math.inf
        S[_F_PREV, j] = -1.0
        if j < n and protocol.check_step == 0:
            st, rw = judge(S[_F_X, j], S[_F_XD, j], S[_F_TH, j], S[_F_THD, j], 0, protocol)
            if st != STATUS_RUNNING:
                status[j] = st
                reward[j] = rw
                end_step[j] = 0
                S[_F_ACTIVE, j] = 0.0
    n_active = 0
    for j in range(L):
        n_active += 1 if S[_F_ACTIVE, j] > 0.0 else 0
    hold = 0
    draw = 0
    k = 0
    while k < n_steps and n_active > 0:
        act = hold == 0
        if act:
            hold = control.action_every
            if stochastic:
                for j in range(live):
                    S[_F_EPS, j] = noise[lo + trial[j], draw]
            draw += 1
        hold -= 1
        # pass 1: switch and statistics
        for j in range(L):
            run = S[_F_ACTIVE, j] > 0.0
            t = S[_F_TH, j]
            tw = t - TWO_PI * np.ceil((t - math.pi) / TWO_PI)
            S[_F_THW, j] = tw
            abs_th = abs(tw)
            bal = abs_th < S[_F_TC, j]
            mode = 1.0 if bal else 0.0
            ms = S[_F_MINSW, j]
            S[_F_MINSW, j] = abs_th if (run and not bal and abs_th < ms) else ms
            ma = S[_F_MINALL, j]
            S[_F_MINALL, j] = abs_th if (run and abs_th < ma) else ma
            prev = S[_F_PREV, j]
            S[_F_NSW, j] += 1.0 if (run and prev >= 0.0 and mode != prev) else 0.0
            S[_F_PREV, j] = mode if run else prev
        # at a draw: the policy (eqs 5, 22-23, switch of section 2.3 or 4) and the trace
        # (eq 3), each lane by the scalar trial's own functions
        if act:
            for j in range(L):
                run = S[_F_ACTIVE, j] > 0.0
                tw = S[_F_THW, j]
                sg = S[_F_SIGMA, j]
                pol = PolicyTerms(
                    S[_F_W1, j],
                    S[_F_W2, j],
                    S[_F_W3, j],
                    S[_F_W4, j],
                    S[_F_W5, j],
                    S[_F_TC, j],
                    sg,
                    S[_F_ROOT, j],
                    S[_F_INVROOT, j],
                    control.sign,
                    control.soft,
                    control.inhibition,
                    control.chapter_eligibility,
                    m,
                    length,
                    g,
                )
                _, cth = sincos_poly(tw)
                mu, g1, g2, g3, g4, g5 = policy_gradient(
                    S[_F_X, j], S[_F_XD, j], tw, S[_F_THD, j], cth, True, pol
                )
                eps = sg * S[_F_EPS, j]
                t0 = S[_F_D0, j]
                t1 = S[_F_D0 + 1, j]
                t2 = S[_F_D0 + 2, j]
                t3 = S[_F_D0 + 3, j]
                t4 = S[_F_D0 + 4, j]
                t5 = S[_F_D0 + 5, j]
                d0, d1, d2, d3, d4, d5 = trace_step(
                    eps, sg, gamma, g1, g2, g3, g4, g5, t0, t1, t2, t3, t4, t5
                )
                upd = run and stochastic
                S[_F_D0, j] = d0 if upd else t0
                S[_F_D0 + 1, j] = d1 if upd else t1
                S[_F_D0 + 2, j] = d2 if upd else t2
                S[_F_D0 + 3, j] = d3 if upd else t3
                S[_F_D0 + 4, j] = d4 if upd else t4
                S[_F_D0 + 5, j] = d5 if upd else t5
                act_a = mu + eps if stochastic else mu
                S[_F_A, j] = act_a if run else S[_F_A, j]
        # pass 2: force (eq 12), one RK4 step (eqs 13-14), the fault prefilter of judge
        suspect = 0
        for j in range(L):
            u = S[_F_A, j]
            t = S[_F_TH, j]
            x0 = S[_F_X, j]
            xd0 = S[_F_XD, j]
            thd0 = S[_F_THD, j]
            s1, c1 = sincos_poly(t)
            f = abs(
                force_terms(
                    s1, c1, thd0, u, pt.model_cart_mass, pt.model_m, pt.model_length, pt.model_g
                )
            )
            a1, b1 = accelerations_terms(s1, c1, thd0, u, pt)
            nx, nxd, nth, nthd = rk4(_poly_stage, x0, xd0, t, thd0, a1, b1, u, pt)
            run = S[_F_ACTIVE, j] > 0.0
            mf = S[_F_MAXF, j]
            S[_F_MAXF, j] = f if (run and f > mf) else mf
            S[_F_X, j] = nx if run else x0
            S[_F_XD, j] = nxd if run else xd0
            S[_F_TH, j] = nth if run else t
            S[_F_THD, j] = nthd if run else thd0
            ok = abs(nx) < BLOW_UP and abs(nxd) < BLOW_UP
            ok = ok and abs(nth) < BLOW_UP and abs(nthd) < BLOW_UP
            suspect += 0 if (ok or not run) else 1
        k += 1
        # the trial rules (judge) where they can end a trial: a suspect state, the
        # eq-24 check step, the last step; elsewhere judge returns RUNNING
        if suspect > 0 or k == protocol.check_step or k >= n_steps:
            for j in range(L):
                if S[_F_ACTIVE, j] > 0.0:
                    st, rw = judge(S[_F_X, j], S[_F_XD, j], S[_F_TH, j], S[_F_THD, j], k, protocol)
                    if st != STATUS_RUNNING:
                        status[j] = st
                        reward[j] = rw
                        end_step[j] = k
                        S[_F_ACTIVE, j] = 0.0
                        n_active -= 1
                    if st != STATUS_FAULT and abs(S[_F_X, j]) > S[_F_MAXX, j]:
                        S[_F_MAXX, j] = abs(S[_F_X, j])
            if k < n_steps and _lanes(n_active) < L:
                live = _pack(
                    S, live, lo, trial, status, reward, end_step, outs, learning, stochastic
                )
                L = _lanes(live)
        else:
            for j in range(L):
                ax = abs(S[_F_X, j])
                mx = S[_F_MAXX, j]
                S[_F_MAXX, j] = ax if (S[_F_ACTIVE, j] > 0.0 and ax > mx) else mx
    for j in range(live):
        _write_lane(S, j, lo + trial[j], status, reward, end_step, outs, learning, stochastic)


@njit(cache=True, inline="always")
def _write_lane(
    S: np.ndarray,
    j: int,
    b: int,
    status: np.ndarray,
    reward: np.ndarray,
    end_step: np.ndarray,
    outs: np.ndarray,
    learning: TraceArgs,
    stochastic: bool,
) -> None:
    """Write lane j of a lockstep block's state ``S`` as trial b's summary row (and its
    trace, when the trials draw noise)."""
    tally = Tally(
        S[_F_MINSW, j], S[_F_MINALL, j], int(S[_F_NSW, j]), -1, S[_F_MAXX, j], S[_F_MAXF, j]
    )
    x, x_dot, theta, theta_dot = S[_F_X, j], S[_F_XD, j], S[_F_TH, j], S[_F_THD, j]
    write_summary(outs[b], status[j], reward[j], end_step[j], x, x_dot, theta, theta_dot, tally)
    if stochastic:
        for i in range(6):
            learning.trace[b, i] = S[_F_D0 + i, j]


@njit(cache=True)
def _pack(
    S: np.ndarray,
    m: int,
    lo: int,
    trial: np.ndarray,
    status: np.ndarray,
    reward: np.ndarray,
    end_step: np.ndarray,
    outs: np.ndarray,
    learning: TraceArgs,
    stochastic: bool,
) -> int:
    """Write out the ended trials of lanes 0..m-1 and move the running ones, in order, to
    the first lanes (state, outcome so far, ``trial``); the number of running lanes.
    The lanes after them up to the next whole vector are left inactive."""
    p = 0
    for j in range(m):
        if S[_F_ACTIVE, j] > 0.0:
            if p != j:
                for f in range(_N_FIELDS):
                    S[f, p] = S[f, j]
                status[p] = status[j]
                reward[p] = reward[j]
                end_step[p] = end_step[j]
                trial[p] = trial[j]
            p += 1
        else:
            _write_lane(S, j, lo + trial[j], status, reward, end_step, outs, learning, stochastic)
    for j in range(p, _lanes(p)):
        S[_F_ACTIVE, j] = 0.0
    return p


@njit(cache=True, parallel=True, nogil=True, error_model="numpy")
def run_trials_lockstep(
    states0: np.ndarray,
    gains: BatchGains,
    plant: PlantArgs,
    control: ControlArgs,
    protocol: ProtocolArgs,
    noise: np.ndarray,
    learning: TraceArgs,
    outs: np.ndarray,
    block: int = LOCKSTEP_BLOCK,
) -> None:
    """:func:`run_trials_batch` with all trials of a block advancing step k together.

    Same arguments (build them with :func:`striatal.sim.rollout.batch_args`) and outputs.
    State, trace and statistics are arrays over the trials of a block of
    :data:`LOCKSTEP_BLOCK`; the loops over trials call no libm function (sin/cos by
    :func:`sincos_poly`), so they vectorise; blocks run in parallel over cores. An
    ended trial is frozen by a mask. The trial rules are :func:`judge`'s. Results
    equal the scalar kernel's up to the round-off of the polynomial sin/cos, which
    the chaotic swing-up can amplify over a trial (tests/test_lockstep.py states the
    tolerance). It refuses (ValueError) the force hold, a force limit and a track:
    run those with :func:`run_trials_batch`. ``block``: trials per block (rounded up to
    whole vectors of :data:`VECTOR` lanes, at most :data:`LOCKSTEP_BLOCK`): a caller
    with few trials gives a smaller one, so that every thread gets a block.
    """
    if plant.hold_force or plant.max_force < math.inf or protocol.track < math.inf:
        raise ValueError(
            "run_trials_lockstep supports only u held, no force limit and no track: "
            "use run_trials_batch for hold force, max_force or track"
        )
    B = states0.shape[0]
    # blocks of ``block`` trials (VECTOR to LOCKSTEP_BLOCK, whole vectors); a lane's
    # result does not depend on its block
    size = min(LOCKSTEP_BLOCK, max(VECTOR, _lanes(block)))
    n_blocks = (B + size - 1) // size
    for i in prange(n_blocks):
        lo = i * size
        hi = min(lo + size, B)
        args = (states0, gains, plant, control, protocol, noise, learning)
        _lockstep_block(lo, hi, args, outs)
