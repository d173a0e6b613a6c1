"""Sweeps in lockstep (``striatal sweep --engine batch|simd``): an arm's seeds as one batch.

The process engine (:func:`striatal.experiments.pool.execute`) runs each (arm, init, seed)
as its own :func:`striatal.learners.learn` loop. Here the runs of the arms that
differ only in their learning rate (``alpha``; for pgpe also ``sigma_rate``: a
learner and its no-learning control, an alpha grid) advance together: trial k of
every unfinished run is one batched kernel call, the learning updates (eqs 3-4 and
eq 21 for chapter; the prediction error, decay and floors for rpe and pgpe) are
NumPy operations over the run axis, and finished runs are masked out. A run that
stops (success or ``max_trials``) is evaluated as
:func:`striatal.experiments.runner.run_one` does (the noise-free re-simulation of its final
gains, the pass probabilities of W(0) and of the final gains, each a batch of its
noise draws) and its row is yielded at once, so the sweep writes it to runs.csv and
a rerun skips it. The W(0) evaluation that runs share (a learner and its control:
the same W(0), seed and draws) is run once; every row still counts it.

``trial_kernel`` "exact" (``--engine batch``): the same rows as the process engine,
bit for bit (apart from ``wall_seconds``). :func:`striatal.sim.kernel.run_trials_batch` is
a parallel loop over the scalar kernel and equals it bit for bit; every run keeps its
own generator (``default_rng(seed)``) and draws from it what the loop draws, in the
same order (rows filled on threads, :mod:`striatal.sim.noise`: the same numbers); and
every update does the scalar code's floating-point operations in the scalar code's
order, elementwise over runs (IEEE arithmetic gives the same result).
tests/test_lockstep_sweep.py compares whole sweeps.

``trial_kernel`` "lockstep" (``--engine simd``): every trial, the evaluation too, on
the SIMD kernel :func:`striatal.sim.kernel.run_trials_lockstep`, several times faster per
core. Its trials equal the scalar kernel's only within round-off (its polynomial
sin/cos are within 1 ulp of libm's), and a chaotic swing-up and learning over many
trials amplify that, so its rows are a different sample of the same experiment:
the arms' success rates agree within their intervals (tests/test_lockstep_sweep.py,
docs/performance.md), a given run's row need not.

``wall_seconds`` of a row is its share of the engine's time: each batched call's
wall time split evenly over the runs in it, plus its own evaluation, so the rows of
a sweep sum to its wall time.

Supported: learner arms (method "learn") of the rules in :data:`BATCH_LEARNERS`, with
the sparse reward of eqs 24-25 and the nominal plant (no ``plant_jitter``); anything
else (baselines, the shaped reward, which needs every trial recorded, other rules)
gets ParameterError naming it (:func:`check_specs`).
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numba
import numpy as np

from striatal.errors import ParameterError
from striatal.experiments.evaluate import check_draws
from striatal.experiments.spec import RunSpec, initial_gains
from striatal.learners import check_config, rule_of
from striatal.learners.common import THETA_C_FLOOR, THETA_C_RESET_ABOVE, THETA_C_RESET_TO
from striatal.learners.pgpe import EXPLORE_RANGE, THETA_C_LEARNED_RANGE, initial_explore
from striatal.params import N_GAINS, Simulation, check_seed, check_theta_c
from striatal.sim import kernel
from striatal.sim.noise import row_parts, run_parts
from striatal.sim.rollout import Protocol, batch_args

__all__ = [
    "BATCH_LEARNERS",
    "CHUNK",
    "TRIAL_KERNELS",
    "check_specs",
    "execute_batch",
    "unsupported",
]

#: The learning rules the batch engine runs (their updates vectorised below).
BATCH_LEARNERS: tuple[str, ...] = ("chapter", "rpe", "pgpe")
#: The kernels the learning trials may run on: run_trials_batch (equal to the scalar
#: kernel bit for bit) or run_trials_lockstep (equal within round-off).
TRIAL_KERNELS: tuple[str, ...] = ("exact", "lockstep")
#: Trials a kernel thread takes at a time (numba.set_parallel_chunksize).
CHUNK = 2
#: From this many normals in one draw (runs x draws each), the runs' rows are filled on
#: threads (:func:`striatal.sim.noise.run_parts`); fewer are drawn in turn.
PARALLEL_NORMALS = 50_000


def unsupported(specs: Sequence[RunSpec], engine: str = "batch") -> str | None:
    """Why the batch engine (``engine``: batch or simd) cannot run ``specs`` (one line),
    or None if it can."""
    baselines = sorted({s.method for s in specs if s.method != "learn"})
    if baselines:
        return (
            f"--engine {engine} runs learner arms only, not the baselines {', '.join(baselines)}; "
            "use --engine processes"
        )
    for s in specs:
        c = s.config
        if c.learner not in BATCH_LEARNERS:
            return (
                f"--engine {engine} runs the learners {', '.join(BATCH_LEARNERS)}, not "
                f"{c.learner!r}; use --engine processes"
            )
        if c.reward != "sparse":
            return (
                f"--engine {engine} needs the sparse reward of eqs 24-25, not {c.reward!r} "
                "(the shaped reward scores recorded trials); use --engine processes"
            )
        if c.plant_jitter > 0.0:
            return (
                f"--engine {engine} runs the nominal plant, not plant_jitter "
                f"{c.plant_jitter:g}; use --engine processes"
            )
        for limit in ("track", "max_force"):
            if getattr(c, limit) is not None:
                return (
                    f"--engine {engine} runs the chapter's endless track and unlimited motor, "
                    f"not --{limit.replace('_', '-')}; use --engine processes"
                )
        for flag in ("robust", "symmetric"):
            if getattr(c, flag):
                return (
                    f"--engine {engine} does not run --{flag} (its checks and pairs are "
                    "per-run); use --engine processes"
                )
    return None


def check_specs(specs: Sequence[RunSpec], engine: str = "batch") -> None:
    """ParameterError (one line) if the batch engine (batch or simd) cannot run ``specs``."""
    why = unsupported(specs, engine)
    if why is not None:
        raise ParameterError(why)
    for s in specs:
        check_config(s.config)


def _group_key(spec: RunSpec) -> tuple[Any, ...]:
    """What the runs of one batch share: all but alpha (and pgpe's sigma_rate)."""
    shared = replace(spec.config, alpha=0.0, sigma_rate=0.0)
    return (shared, spec.template, spec.plant, spec.sim, spec.eval_draws)


def execute_batch(
    specs: Sequence[RunSpec], *, trial_kernel: str = "exact"
) -> Iterator[dict[str, Any]]:
    """Rows of ``specs`` (RUN_COLUMNS), each yielded when its run is finished and evaluated.

    The rows equal :func:`striatal.experiments.runner.run_one`'s for the same specs except
    ``wall_seconds``. ParameterError if :func:`unsupported` says so.

    ``trial_kernel`` "lockstep" (``--engine simd``) runs every trial, the evaluation
    included, on :func:`striatal.sim.kernel.run_trials_lockstep` instead: its trials equal
    the scalar kernel's only within round-off, so its rows are not the process
    engine's, only the same experiment (module docstring).
    """
    if trial_kernel not in TRIAL_KERNELS:
        raise ParameterError(
            f"trial_kernel must be one of {', '.join(TRIAL_KERNELS)}, got {trial_kernel!r}"
        )
    check_specs(specs)
    groups: list[tuple[tuple[Any, ...], list[RunSpec]]] = []
    for s in specs:
        key = _group_key(s)
        for k, members in groups:
            if k == key:
                members.append(s)
                break
        else:
            groups.append((key, [s]))
    for _, members in groups:
        yield from _Batch(members, trial_kernel == "lockstep").run()


def _success(outs: np.ndarray, sim: Simulation) -> np.ndarray:
    """TrialOutcome.success of every summary row: no fault, early end or track end, and
    the final state (theta wrapped) inside the success box (eqs 22-23 test)."""
    final = outs[:, [kernel.OUT_X, kernel.OUT_X_DOT, kernel.OUT_THETA, kernel.OUT_THETA_DOT]]
    box = sim.success
    ok = (
        (outs[:, kernel.OUT_FAULT] == 0.0)
        & (outs[:, kernel.OUT_EARLY] == 0.0)
        & (outs[:, kernel.OUT_TRACK] == 0.0)
        & np.all(np.isfinite(final), axis=1)
    )
    with np.errstate(invalid="ignore"):
        inside = (
            (np.abs(final[:, 2]) < box.theta)
            & (np.abs(final[:, 0]) < box.x)
            & (np.abs(final[:, 3]) < box.theta_dot)
            & (np.abs(final[:, 1]) < box.x_dot)
        )
    return ok & inside


def _eq21(outs: np.ndarray, theta_c: np.ndarray, rule: str) -> np.ndarray:
    """:func:`striatal.learners.common.theta_c_rule` (eq 21) over rows."""
    if rule in ("fixed", "learned"):
        return theta_c.copy()
    col = kernel.OUT_MIN_ABS_THETA_SWINGUP if rule == "swingup" else kernel.OUT_MIN_ABS_THETA
    m = outs[:, col]
    with np.errstate(invalid="ignore"):
        reset = ~np.isfinite(m) | (m > THETA_C_RESET_ABOVE)
        floor = THETA_C_RESET_TO if rule == "clamped" else THETA_C_FLOOR
        return np.where(reset, THETA_C_RESET_TO, np.maximum(m, floor))


def _rows_finite(a: np.ndarray) -> np.ndarray:
    return np.all(np.isfinite(a), axis=1)


def _three_factor(
    params: np.ndarray, elig: np.ndarray, factor: np.ndarray, rate: np.ndarray, max_step: float
) -> np.ndarray:
    """:func:`striatal.learners.common.three_factor_update` over rows."""
    step = np.clip((rate * factor)[:, None] * elig, -max_step, max_step)
    new = params + step
    bad = ~_rows_finite(new)
    new[bad] = params[bad]
    return new


@dataclass
class _Baseline:
    """The tracked reward baseline b and mean square of its prediction error, per run."""

    mean: np.ndarray
    square: np.ndarray

    def step(
        self, idx: np.ndarray, first: np.ndarray, reward: np.ndarray, rate: float, normalise: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(factor, new b, new square) of :func:`striatal.learners.common.prediction_error`."""
        b = np.where(first, reward, self.mean[idx])
        delta = reward - b
        square = self.square[idx]
        new_square = np.where(
            square <= 0.0, delta * delta, (1.0 - rate) * square + rate * delta * delta
        )
        if normalise:
            ok = (new_square > 0.0) & np.isfinite(new_square)
            with np.errstate(invalid="ignore", divide="ignore"):
                factor = np.where(ok, delta / np.sqrt(np.where(ok, new_square, 1.0)), 0.0)
        else:
            factor = delta
        return factor, b + rate * (reward - b), new_square

    def store(self, idx: np.ndarray, b: np.ndarray, square: np.ndarray) -> None:
        """:func:`striatal.learners.common.baseline_memory`: non-finite values keep the old."""
        self.mean[idx] = np.where(np.isfinite(b), b, self.mean[idx])
        self.square[idx] = np.where(np.isfinite(square), square, self.square[idx])


class _Batch:
    """The runs of one group, advanced trial by trial together (state over the run axis)."""

    def __init__(self, specs: list[RunSpec], lockstep: bool = False) -> None:
        first = specs[0]
        self.lockstep = lockstep
        self.specs = specs
        self.config = first.config
        self.rule = rule_of(first.config)
        self.plant = first.plant
        self.sim = first.sim
        self.protocol = Protocol()
        self.template = first.template
        n = len(specs)
        self.W0 = np.array([initial_gains(s.init, s.seed) for s in specs], dtype=float)
        self.templates = [
            s.template.with_gains(tuple(w), s.template.theta_c)
            for s, w in zip(specs, self.W0, strict=True)
        ]
        self.theta_c0 = check_theta_c(first.template.theta_c)
        self.seeds = [check_seed(s.seed) for s in specs]
        self.rngs = [np.random.default_rng(seed) for seed in self.seeds]
        self.alpha = np.array([s.config.alpha for s in specs], dtype=float)
        self.sigma_rate = np.array([s.config.sigma_rate for s in specs], dtype=float)
        self.W = self.W0.copy()
        self.theta_c = np.full(n, float(self.theta_c0))
        self.trace = np.zeros((n, N_GAINS))
        self.trials = np.zeros(n, dtype=np.int64)
        self.simulations = np.zeros(n, dtype=np.int64)
        self.seconds = np.zeros(n)
        self.success = np.zeros(n, dtype=bool)
        self.done = np.zeros(n, dtype=bool)
        self.wall = np.zeros(n)
        self.baseline = _Baseline(np.zeros(n), np.zeros(n))
        self.explore = np.tile(initial_explore(self.config.explore), (n, 1))
        # the evaluation's noise per seed, and the W(0) pass counts per (seed, W(0)),
        # shared by the runs that have them in common (a learner and its control):
        # the same inputs give the same numbers, so each is computed once
        self.pending = Counter(self.seeds)
        self.eval_noise: dict[int, np.ndarray] = {}
        self.w0_passes: dict[tuple[Any, ...], int] = {}

    # ------------------------------------------------------------------ kernel calls
    def _kernel(
        self,
        W: np.ndarray,
        theta_c: np.ndarray,
        *,
        noise: np.ndarray | None,
        traces: np.ndarray | None = None,
        gamma: float = 0.0,
        action_every: int = 1,
        chapter_eligibility: bool = False,
    ) -> np.ndarray:
        args = batch_args(
            self.plant,
            self.template,
            self.sim,
            protocol=self.protocol,
            gains=W,
            theta_c=theta_c,
            noise=noise,
            action_every=action_every,
            chapter_eligibility=chapter_eligibility,
            gamma=gamma,
            traces=traces,
        )
        # dynamic chunks: a thread that the OS takes away (a shared machine) or that gets
        # the long trials does not hold up the others at the end of the call
        old = numba.set_parallel_chunksize(CHUNK)
        try:
            if self.lockstep:
                kernel.run_trials_lockstep(*args)
            else:
                kernel.run_trials_batch(*args)
        finally:
            numba.set_parallel_chunksize(old)
        return args[-1]

    def _normals(self, idx: np.ndarray, n: int) -> np.ndarray:
        """Row j: the next ``n`` standard normals of run idx[j]'s generator.

        Each run draws from its own generator, so the rows are filled on threads
        (:func:`striatal.sim.noise.run_parts`): the same numbers.
        """
        out = np.empty((len(idx), n))

        def part(rows: range) -> Callable[[], None]:
            def fill() -> None:
                for j in rows:
                    self.rngs[idx[j]].standard_normal(out=out[j])

            return fill

        if len(idx) * n < PARALLEL_NORMALS:
            part(range(len(idx)))()
            return out
        run_parts([part(rows) for rows in row_parts(len(idx))])
        return out

    # ------------------------------------------------------------------ one trial
    def _step(self, idx: np.ndarray) -> None:
        """Trial k of every run in ``idx``: plan, run, success test, update (loop.learning_step)."""
        c = self.config
        dt = self.sim.dt
        if self.rule.name == "pgpe":
            outs, W_trial, tc_trial, scratch = self._pgpe_trial(idx)
        else:
            n_draws = -(-self.sim.n_steps // c.action_every)
            noise = self._normals(idx, n_draws)
            traces = np.zeros((len(idx), N_GAINS)) if c.reset_trace else self.trace[idx].copy()
            W_trial = self.W[idx].copy()
            tc_trial = self.theta_c[idx].copy()
            outs = self._kernel(
                W_trial,
                tc_trial,
                noise=noise,
                traces=traces,
                gamma=c.gamma,
                action_every=c.action_every,
                chapter_eligibility=c.eligibility == "chapter",
            )
            scratch = {"trace": traces}
        reward = outs[:, kernel.OUT_REWARD].copy()
        seconds = outs[:, kernel.OUT_END_STEP] * dt
        sims = np.ones(len(idx), dtype=np.int64)
        if c.success_on == "noisy" or self.rule.judges_candidate:
            # pgpe's trial is the noise-free run of the candidate it judges
            success = _success(outs, self.sim)
        else:
            W_mean, tc_mean = self.W[idx].copy(), self.theta_c[idx].copy()
            check = self._kernel(W_mean, tc_mean, noise=None, action_every=c.action_every)
            sims += 1
            seconds = seconds + check[:, kernel.OUT_END_STEP] * dt
            success = _success(check, self.sim)
        if self.rule.name == "chapter":
            W_new, tc_new = self._chapter_update(idx, outs, reward, success, scratch["trace"])
        elif self.rule.name == "rpe":
            W_new, tc_new = self._rpe_update(idx, outs, reward, success, scratch["trace"])
        else:
            W_new, tc_new = self._pgpe_update(
                idx, outs, reward, success, W_trial, tc_trial, scratch
            )
        # the loop's backstop (loop._finite): non-finite numbers never replace the state
        keep = ~_rows_finite(W_new)
        W_new[keep] = self.W[idx][keep]
        tc_new = np.where(np.isfinite(tc_new), tc_new, self.theta_c[idx])
        self.W[idx] = W_new
        self.theta_c[idx] = tc_new
        self.trials[idx] += 1
        self.simulations[idx] += sims
        self.seconds[idx] = self.seconds[idx] + seconds
        self.success[idx] = success
        self.done[idx] = success | (self.trials[idx] >= c.max_trials)

    def _chapter_update(
        self,
        idx: np.ndarray,
        outs: np.ndarray,
        reward: np.ndarray,
        success: np.ndarray,
        trace: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """ChapterRule.update: chapter.gain_update (eqs 3-4) and eq 21 where not successful."""
        c = self.config
        W = self.W[idx]
        coef = self.alpha[idx] * (1.0 - c.gamma) * (reward - c.baseline)
        with np.errstate(invalid="ignore", over="ignore"):
            new = W + np.clip(coef[:, None] * trace, -c.max_step, c.max_step)
        new[:, 0] = np.maximum(new[:, 0], c.w1_floor)
        change = _rows_finite(trace) & _rows_finite(new) & ~success
        W_new = np.where(change[:, None], new, W)
        tc = self.theta_c[idx]
        tc_new = np.where(success, tc, _eq21(outs, tc, c.theta_c_rule))
        self.trace[idx] = np.where(_rows_finite(trace)[:, None], trace, 0.0)
        return W_new, tc_new

    def _rpe_update(
        self,
        idx: np.ndarray,
        outs: np.ndarray,
        reward: np.ndarray,
        success: np.ndarray,
        trace: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """RpeRule.update: the prediction-error factor, eq 4 with decay, eq 21."""
        c = self.config
        rate = self.alpha[idx] * (1.0 - c.gamma)
        factor, b, square = self.baseline.step(
            idx, self.trials[idx] == 0, reward, c.rpe_rate, c.normalise
        )
        W = self.W[idx]
        new = _three_factor(W, trace, factor, rate, c.max_step)
        new[:, :5] -= (rate * c.decay)[:, None] * W[:, :5]
        new[:, 0] = np.maximum(new[:, 0], c.w1_floor)
        change = _rows_finite(trace) & ~success
        W_new = np.where(change[:, None], new, W)
        tc = self.theta_c[idx]
        tc_new = np.where(success, tc, _eq21(outs, tc, c.theta_c_rule))
        self.trace[idx] = np.where(_rows_finite(trace)[:, None], trace, 0.0)
        self.baseline.store(idx, b, square)
        return W_new, tc_new

    def _pgpe_trial(
        self, idx: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """PgpeRule.plan over rows (p' = p + eps, clamped) and its noise-free trial."""
        c = self.config
        learned = c.theta_c_rule == "learned"
        p = np.concatenate([self.W[idx, :5], self.theta_c[idx, None]], axis=1)
        s = self.explore[idx].copy()
        z = self._normals(idx, 6)
        if not learned:
            z[:, 5] = 0.0
        p_trial = p + z * s
        if learned:
            p_trial[:, 0] = np.maximum(p_trial[:, 0], c.w1_floor)
            p_trial[:, 5] = np.minimum(
                np.maximum(p_trial[:, 5], THETA_C_LEARNED_RANGE[0]), THETA_C_LEARNED_RANGE[1]
            )
        p_trial[:, 0] = np.maximum(p_trial[:, 0], c.w1_floor)
        W_trial = np.concatenate([p_trial[:, :5], self.W[idx, 5:]], axis=1)
        tc_trial = p_trial[:, 5].copy()
        outs = self._kernel(W_trial, tc_trial, noise=None, action_every=c.action_every)
        return outs, W_trial, tc_trial, {"p": p, "eps": p_trial - p, "s": s, "z": z}

    def _pgpe_update(
        self,
        idx: np.ndarray,
        outs: np.ndarray,
        reward: np.ndarray,
        success: np.ndarray,
        W_trial: np.ndarray,
        tc_trial: np.ndarray,
        scratch: dict[str, np.ndarray],
    ) -> tuple[np.ndarray, np.ndarray]:
        """PgpeRule.update: on success the candidate p' itself, else the three-factor step."""
        c = self.config
        p, eps, s, z = (scratch[k] for k in ("p", "eps", "s", "z"))
        alpha = self.alpha[idx]
        factor, b, square = self.baseline.step(
            idx, self.trials[idx] == 0, reward, c.rpe_rate, c.normalise
        )
        new_p = _three_factor(p, eps, factor, alpha, c.max_step)
        new_p[:, :5] -= (alpha * c.decay)[:, None] * p[:, :5]
        if c.theta_c_rule == "learned":
            new_p[:, 0] = np.maximum(new_p[:, 0], c.w1_floor)
            new_p[:, 5] = np.minimum(
                np.maximum(new_p[:, 5], THETA_C_LEARNED_RANGE[0]), THETA_C_LEARNED_RANGE[1]
            )
        else:
            new_p[:, 5] = _eq21(outs, self.theta_c[idx], c.theta_c_rule)
        new_p[:, 0] = np.maximum(new_p[:, 0], c.w1_floor)
        # adapt_explore: unchanged where sigma_rate is 0 or the factor is not finite
        sr = self.sigma_rate[idx]
        s0 = initial_explore(c.explore)
        adapt = (sr != 0.0) & np.isfinite(factor) & ~success
        with np.errstate(invalid="ignore", over="ignore"):
            grown = s * kernel.exp_libm(np.clip((sr * factor)[:, None] * (z * z - 1.0), -1.0, 1.0))
        grown = np.clip(grown, EXPLORE_RANGE[0] * s0, EXPLORE_RANGE[1] * s0)
        new_s = np.where(adapt[:, None], grown, s)
        candidate = np.concatenate([W_trial[:, :5], tc_trial[:, None]], axis=1)
        new_p = np.where(success[:, None], candidate, new_p)
        self.explore[idx] = np.where(_rows_finite(new_s)[:, None], new_s, self.explore[idx])
        self.baseline.store(idx, b, square)
        W_new = np.concatenate([new_p[:, :5], self.W[idx, 5:]], axis=1)
        return W_new, new_p[:, 5].copy()

    # ------------------------------------------------------------------ finished runs
    def _evaluate(self, r: int) -> dict[str, Any]:
        """run_one's evaluation of finished run r, then its row."""
        spec = self.specs[r]
        t0 = time.perf_counter()
        W = tuple(float(w) for w in self.W[r])
        theta_c = float(self.theta_c[r])
        final = self.templates[r].with_gains(W, theta_c) if W[0] > 0 else None
        mean_ok = False
        evals = 0
        rate0 = rate = math.nan
        if final is not None:
            # the re-simulation of the final gains (simulate: mean policy, action_every 1)
            out = self._kernel(np.array([final.gains]), np.array([final.theta_c]), noise=None)
            mean_ok = bool(_success(out, self.sim)[0])
            evals = 1
        seed = self.seeds[r]
        if spec.eval_draws > 0:
            n = check_draws(spec.eval_draws)
            noise = self.eval_noise.get(seed)
            if noise is None:
                noise = np.random.default_rng(seed).standard_normal((n, self.sim.n_steps))
                self.eval_noise[seed] = noise
            w0_key = (seed, tuple(self.W0[r]))
            new_w0 = w0_key not in self.w0_passes
            ctrls = [self.templates[r]] if new_w0 else []
            if final is not None:
                ctrls.append(final)
            passes = np.zeros(0, dtype=np.int64)
            if ctrls:
                W_rows = np.array([ct.gains for ct in ctrls])
                tc_rows = np.array([ct.theta_c for ct in ctrls])
                # pass_probability: one mean-policy trial, then the draws (one generator each)
                self._kernel(W_rows, tc_rows, noise=None)
                outs = self._kernel(
                    np.repeat(W_rows, n, axis=0),
                    np.repeat(tc_rows, n),
                    noise=np.tile(noise, (len(ctrls), 1)),
                )
                passes = _success(outs, self.sim).reshape(len(ctrls), n).sum(axis=1)
            if new_w0:
                self.w0_passes[w0_key] = int(passes[0])
                passes = passes[1:]
            # counted in every row as the process engine runs it: n draws + the mean trial
            rate0, evals = self.w0_passes[w0_key] / n, evals + n + 1
            if final is not None:
                rate, evals = int(passes[0]) / n, evals + n + 1
        self.pending[seed] -= 1
        if self.pending[seed] == 0:
            self.eval_noise.pop(seed, None)
        cfg = spec.config
        row: dict[str, Any] = {
            "arm": spec.arm,
            "role": spec.role,
            "method": spec.method,
            "learner": cfg.learner,
            "init": spec.init,
            "seed": spec.seed,
            "alpha": cfg.alpha,
            "gamma": cfg.gamma,
            "success": bool(self.success[r]),
            "trials": int(self.trials[r]),
        }
        row.update({f"W{i + 1}": w for i, w in enumerate(W)})
        row["theta_c"] = theta_c
        row.update({f"W0_{i + 1}": float(w) for i, w in enumerate(self.W0[r])})
        row["theta_c0"] = float(self.theta_c0)
        row["mean_policy_success"] = mean_ok
        row["simulations"] = int(self.simulations[r])
        row["simulated_seconds"] = float(self.seconds[r])
        row["eval_simulations"] = evals
        row["pass_rate_W0"] = rate0
        row["pass_rate"] = rate
        row["robust"] = math.nan  # the robust re-check belongs to --robust, refused here
        row["wall_seconds"] = float(self.wall[r]) + time.perf_counter() - t0
        return row

    def run(self) -> Iterator[dict[str, Any]]:
        while True:
            idx = np.flatnonzero(~self.done)
            if idx.size == 0:
                return
            t0 = time.perf_counter()
            self._step(idx)
            self.wall[idx] += (time.perf_counter() - t0) / idx.size
            for r in idx[self.done[idx]]:
                yield self._evaluate(int(r))
