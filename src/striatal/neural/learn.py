"""Dopamine, the second stage: the chapter's rule (eqs 1-5) on the network's pathway weights.

The weights that learn are the transforms of the seven pathway projections of
:func:`striatal.neural.network.build` (``Handles.pathways``): c_theta, c_thetadot,
c_x, c_xdot into mu_1 (eq 22) and c_pump, c_x, c_xdot into mu_2 (eq 23), each a
function c_i(W) of the gains (:func:`pathway_coefficients`). One learning trial:

1. **Exploration.** A Node adds a = sigma n_k to the motor command, a new standard
   normal n_k every control step dt (the Gaussian policy of eq 5 with sigma of W6),
   held over the step, as the rate learner draws it.
2. **Eligibility, online, per pathway.** At each draw the same Node takes, per
   pathway, the presynaptic signal s_i (the pathway's decoded output in the term's
   units, through the motor's synapse: what the pathway contributes to u, over c_i)
   and the postsynaptic exploration eps, and accumulates
   E_i <- eps s_i + gamma E_i (pre x post, eq 3 per connection). For an NEF
   connection of weights omega_jk = alpha_k e_k c_i d_j, the change Delta c_i that
   pre x post gives is the neuron-level three-factor rule: presynaptic activity a_j
   (through its decoder d_j) x the postsynaptic neurons' exploratory drive x the
   dopamine below. The sigma trace of eq 3 accumulates in the same Node:
   E_6 <- (eps^2 - sigma^2)(1.1 - sigma) + gamma E_6.
3. **Dopamine at the end of the trial.** The sparse reward of eq 25 (+10 if |x| < 0.1
   and |theta| < pi/9 at T_f, else -5; a numerical fault -5) minus the baseline b
   (0 in the chapter): delta = r - b, one release per trial.
4. **The update, between trials.** The gains' eligibility is the chain rule through
   the transforms, D = J^T E with J = d c / d W (:func:`coefficient_jacobian`;
   exactly the D of eq 3 the rate learner accumulates, since d mu / d W_j =
   sum_i s_i d c_i / d W_j), and W <- W + clip(alpha (1 - gamma)(r - b) D) with W1
   floored: the rate learner's own :func:`striatal.learners.chapter.gain_update`.
   theta_c follows eq 21 (min |theta| under the swing-up). The next trial's network
   is rebuilt with the same seed (the same neurons, encoders and decoders) and the
   transforms c(W): a rebuild is how nengo changes a connection's transform.
   :func:`gains_from_transforms` reads W back from a built network's transforms.

A trial that passes the chapter's success test (on the noisy trial, as the chapter
learner judges it) keeps W and theta_c and ends the run, as ``striatal train`` does.
Trials are at most 30 s: the check of eq 24 at 30 s is not applied to the network.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.learners import default_config
from striatal.learners.chapter import ChapterConfig, chapter_gain_update
from striatal.learners.common import theta_c_rule
from striatal.learners.config import LearnerConfig, pick
from striatal.neural.interpret import pathway_coefficients
from striatal.neural.network import NetworkConfig
from striatal.neural.run import NeuralRun, Simulator, run_network
from striatal.params import Controller, Plant, Simulation, check_gains, check_seed
from striatal.sim import kernel
from striatal.sim.rollout import Protocol, TrialOutcome

__all__ = [
    "N_PATHWAYS",
    "PATHWAYS",
    "Eligibility",
    "NeuralLearning",
    "NeuralTrial",
    "coefficient_jacobian",
    "gain_eligibility",
    "gains_from_transforms",
    "learn_network",
    "network_transforms",
    "pathway_coefficients",
    "trial_outcome",
    "trial_reward",
]

#: The pathways in the order of ``Handles.pathways``: (channel, signal).
PATHWAYS: tuple[tuple[str, str], ...] = (
    ("mu_1", "theta"),
    ("mu_1", "theta_dot"),
    ("mu_1", "x"),
    ("mu_1", "x_dot"),
    ("mu_2", "energy_pump"),
    ("mu_2", "x"),
    ("mu_2", "x_dot"),
)
N_PATHWAYS = len(PATHWAYS)


def coefficient_jacobian(W: object, plant: Plant, sign: float = 1.0) -> np.ndarray:
    """J = d c / d W1..W5, (7, 5): how each pathway's transform moves with each gain.

    c_theta = s (1 + W1 l) g, c_thetadot = s 2 l sqrt(W1 g), c_x = -W2, c_xdot = -W3,
    c_pump = W4, c_x2 = -W5^2 / 4, c_xdot2 = -W5 (eqs 22-23).
    """
    w = check_gains(W)
    l, g = plant.length, plant.gravity
    J = np.zeros((N_PATHWAYS, 5))
    J[0, 0] = sign * l * g
    J[1, 0] = sign * l * math.sqrt(g / w[0])
    J[2, 1] = -1.0
    J[3, 2] = -1.0
    J[4, 3] = 1.0
    J[5, 4] = -0.5 * w[4]
    J[6, 4] = -1.0
    return J


def gain_eligibility(
    pathway_trace: np.ndarray, sigma_trace: float, W: object, plant: Plant, sign: float = 1.0
) -> np.ndarray:
    """The gains' trace D of eq 3 from the pathways' traces E: (J^T E, E_6), (6,)."""
    E = np.asarray(pathway_trace, dtype=float)
    if E.shape != (N_PATHWAYS,):
        raise ParameterError(f"pathway trace must have {N_PATHWAYS} entries, got {E.shape}")
    return np.concatenate([coefficient_jacobian(W, plant, sign).T @ E, [float(sigma_trace)]])


def network_transforms(handles: Any) -> np.ndarray:
    """A built network's pathway coefficients: each transform over its pathway scale, (7,)."""
    got = [(ch, t.signal) for ch, t, _c in handles.pathways]
    if tuple(got) != PATHWAYS:
        raise ParameterError(f"unexpected pathways {got}")
    return np.array(
        [
            float(np.asarray(c.transform.init).ravel()[0]) / s
            for (_ch, _t, c), s in zip(handles.pathways, handles.pathway_scales, strict=True)
        ]
    )


def gains_from_transforms(
    coefficients: np.ndarray, w6: float, plant: Plant, sign: float = 1.0, *, rtol: float = 1e-9
) -> tuple[float, ...]:
    """W from the seven pathway coefficients (the inverse of :func:`pathway_coefficients`).

    W1 from c_theta, W2, W3 from the mu_1 cart terms, W4 from the pump, W5 from
    c_xdot of mu_2; W6 (the exploration's sigma, not a connection) is given. The two
    coefficients that W fixes twice (c_thetadot from W1, c_x of mu_2 from W5) must
    agree within ``rtol``, else ParameterError: the transforms are not of any W.
    """
    c = np.asarray(coefficients, dtype=float)
    if c.shape != (N_PATHWAYS,) or not np.all(np.isfinite(c)):
        raise ParameterError(f"need {N_PATHWAYS} finite coefficients, got {c!r}")
    l, g = plant.length, plant.gravity
    w1 = (c[0] / (sign * g) - 1.0) / l
    W = check_gains((w1, -c[2], -c[3], c[4], -c[6], w6))
    back = pathway_coefficients(W, plant, sign)
    if not np.allclose(back, c, rtol=rtol, atol=rtol):
        raise ParameterError(
            f"the transforms are not the coefficients of one W (mismatch {back - c})"
        )
    return W


class Eligibility:
    """The dopamine stage's Node function: exploration out, the eligibility traces in.

    Called once per network step of ``net_dt`` with the pathways' presynaptic signals
    ``pre`` (7,). Every ``every`` steps (one control step dt) it draws the next
    exploration eps = sigma * noise[k] (eq 5), held until the next draw, and updates
    the traces, E <- eps pre + gamma E and E_6 <- (eps^2 - sigma^2)(1.1 - sigma) +
    gamma E_6 (eq 3, the rate learner's score reading, docs/paper-notes.md section 2).
    Returns [eps], added to the motor command u.
    """

    n_pre = N_PATHWAYS

    def __init__(self, sigma: float, noise: np.ndarray, gamma: float, every: int) -> None:
        self.sigma = float(sigma)
        self.noise = np.asarray(noise, dtype=float)
        self.gamma = float(gamma)
        self.every = int(every)
        self.trace = np.zeros(N_PATHWAYS)
        self.sigma_trace = 0.0
        self.eps = 0.0
        self.k = 0

    def __call__(self, t: float, pre: np.ndarray) -> np.ndarray:
        if self.k % self.every == 0:
            draw = self.k // self.every
            if draw < self.noise.shape[0]:
                self.eps = self.sigma * float(self.noise[draw])
                self.trace = self.eps * np.asarray(pre, dtype=float) + self.gamma * self.trace
                self.sigma_trace = (self.eps**2 - self.sigma**2) * (
                    1.1 - self.sigma
                ) + self.gamma * self.sigma_trace
            else:
                self.eps = 0.0
        self.k += 1
        return np.array([self.eps])


def trial_reward(run: NeuralRun, protocol: Protocol) -> float:
    """Eq 25 at T_f on the run's final state (a numerical fault: the failure reward)."""
    if run.fault:
        return protocol.reward_failure
    x, _xd, th, _thd = run.data[-1, 1:5]
    if abs(x) < protocol.goal_x and abs(kernel.wrap_angle(th)) < protocol.goal_theta:
        return protocol.reward_success
    return protocol.reward_failure


def trial_outcome(run: NeuralRun, reward: float, theta_c: float) -> TrialOutcome:
    """The run as a :class:`TrialOutcome` (what eq 21 reads: min |theta| under the swing-up)."""
    th = np.abs(np.array([kernel.wrap_angle(v) for v in run.data[:, 3]]))
    swing = th[th >= theta_c]
    x, xd, tw, thd = run.data[-1, 1:5]
    return TrialOutcome(
        reward=reward,
        ended_at=float(run.data[-1, 0]),
        final_state=(float(x), float(xd), float(kernel.wrap_angle(tw)), float(thd)),
        min_abs_theta_swingup=float(swing.min()) if swing.size else math.inf,
        min_abs_theta=float(th.min()),
        fault=run.fault,
        early=False,
        n_switches=len(run.switch_times),
        max_abs_x=float(np.max(np.abs(run.data[:, 1]))),
        max_abs_force=float(np.max(np.abs(run.data[:, 6]))),
        success=run.success,
    )


@dataclass(frozen=True)
class NeuralTrial:
    """One learning trial: the gains it ran with, what it earned, the traces it left."""

    trial: int
    W: tuple[float, ...]
    theta_c: float
    transforms: tuple[float, ...]
    reward: float
    success: bool
    upright_last_10s: bool
    fault: bool
    final_state: tuple[float, float, float, float]
    first_switch: float
    pathway_trace: tuple[float, ...]
    eligibility: tuple[float, ...]
    cpu_time: float
    wall_time: float

    def to_dict(self) -> dict[str, object]:
        return {
            "trial": self.trial,
            "W": list(self.W),
            "theta_c": self.theta_c,
            "transforms": list(self.transforms),
            "reward": self.reward,
            "success": self.success,
            "upright_last_10s": self.upright_last_10s,
            "fault": self.fault,
            "final_state": list(self.final_state),
            "first_switch": self.first_switch,
            "pathway_trace": list(self.pathway_trace),
            "eligibility": list(self.eligibility),
            "cpu_time_s": self.cpu_time,
            "wall_time_s": self.wall_time,
        }


@dataclass(frozen=True)
class NeuralLearning:
    """A learning run of the network: its trials, and the W and theta_c it ended with."""

    trials: tuple[NeuralTrial, ...]
    W: tuple[float, ...]
    theta_c: float
    W0: tuple[float, ...]
    theta_c0: float
    solved: bool
    seed: int
    neurons: int
    config: LearnerConfig
    settings: dict[str, object] = field(default_factory=dict)

    def to_dict(self) -> dict[str, object]:
        return {
            "W0": list(self.W0),
            "theta_c0": self.theta_c0,
            "W": list(self.W),
            "theta_c": self.theta_c,
            "solved": self.solved,
            "trials_run": len(self.trials),
            "successes": sum(t.success for t in self.trials),
            "rewards": [t.reward for t in self.trials],
            "seed": self.seed,
            "neurons": self.neurons,
            "learner": {
                k: self.config.to_dict()[k]
                for k in ("alpha", "gamma", "baseline", "max_step", "w1_floor", "theta_c_rule")
            },
            "reward": "sparse (eq 25: +10 / -5 at T_f)",
            "history": [t.to_dict() for t in self.trials],
            **self.settings,
        }


def learn_network(
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    *,
    trials: int,
    alpha: float | None = None,
    protocol: Protocol | None = None,
    on_trial: Callable[[NeuralTrial], None] | None = None,
    net_dt: float = 0.001,
    simulator: Simulator = "nengo",
    on_compile: Callable[[Path], None] | None = None,
    resume: NeuralLearning | None = None,
) -> NeuralLearning:
    """Run ``trials`` learning trials of the network from ``controller``'s W and theta_c.

    The chapter learner's options (``striatal.learners.default_config("chapter")``:
    alpha 5, gamma 0.999 per draw, b = 0, max step 1, eq 21 under the swing-up) with
    ``alpha`` replaced if given (alpha = 0: no learning, W stays). ``seed`` fixes the
    network (the same neurons every trial) and the exploration noise
    (``numpy.random.default_rng(seed)``, one standard normal per control step).
    ``resume``: an earlier run of the same start, seed and options, continued up to
    ``trials`` trials in all: its trials are kept, its W and theta_c go on, and the
    noise generator skips the draws its trials used, so that the continued run equals
    one run of ``trials`` trials.
    """
    seed = check_seed(seed)
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise ParameterError(f"trials must be a whole number >= 1, got {trials!r}")
    config.check_work(sim.duration, net_dt, trials)
    protocol = Protocol() if protocol is None else protocol
    if 0.0 <= protocol.check_time < sim.duration:
        raise ParameterError(
            f"learning trials of the network must be at most {protocol.check_time:g} s "
            f"(the eq-24 check is not applied to it), got {sim.duration:g}"
        )
    lc = default_config("chapter") if alpha is None else default_config("chapter", alpha=alpha)
    chapter = pick(ChapterConfig, lc)
    every = max(1, int(round(sim.dt / net_dt)))
    rng = np.random.default_rng(seed)
    W = np.array(controller.gains, dtype=float)
    theta_c = controller.theta_c
    sign = controller.sign
    history: list[NeuralTrial] = []
    solved = False
    neurons = 0
    if resume is not None:
        same = (
            resume.seed == seed
            and tuple(float(w) for w in controller.gains) == resume.W0
            and resume.theta_c0 == float(controller.theta_c)
            and resume.config.to_dict() == lc.to_dict()
        )
        if not same:
            raise ParameterError(
                "the run to resume has another seed, start or learner options than this one"
            )
        if resume.solved or len(resume.trials) >= trials:
            return resume
        history = list(resume.trials)
        neurons = resume.neurons
        for _ in history:
            rng.standard_normal(sim.n_steps)
        W = np.array(resume.W, dtype=float)
        theta_c = resume.theta_c
    for k in range(len(history) + 1, trials + 1):
        ctrl = controller.with_gains(W, theta_c)
        sigma = kernel.sigma_of(W[5])
        elig = Eligibility(sigma, rng.standard_normal(sim.n_steps), chapter.gamma, every)
        t0 = time.perf_counter()
        run = run_network(
            ctrl,
            plant,
            sim,
            config,
            seed,
            net_dt=net_dt,
            record_rates=False,
            exploration=elig,
            simulator=simulator,
            on_compile=on_compile,
        )
        wall = time.perf_counter() - t0
        neurons = run.neurons
        reward = trial_reward(run, protocol)
        D = gain_eligibility(elig.trace, elig.sigma_trace, W, plant, sign)
        x, xd, th, thd = (float(v) for v in run.data[-1, 1:5])
        sw = run.switch_times
        rec = NeuralTrial(
            trial=k,
            W=tuple(float(w) for w in W),
            theta_c=float(theta_c),
            transforms=tuple(float(c) for c in pathway_coefficients(W, plant, sign)),
            reward=reward,
            success=run.success,
            upright_last_10s=run.upright_last_10s,
            fault=run.fault,
            final_state=(x, xd, float(kernel.wrap_angle(th)), thd),
            first_switch=sw[0] if sw else math.nan,
            pathway_trace=tuple(float(v) for v in elig.trace),
            eligibility=tuple(float(v) for v in D),
            cpu_time=run.cpu_time,
            wall_time=wall,
        )
        history.append(rec)
        if on_trial is not None:
            on_trial(rec)
        if run.success:
            solved = True
            break
        W = chapter_gain_update(W, D, reward, chapter)
        theta_c = theta_c_rule(trial_outcome(run, reward, theta_c), theta_c, chapter.theta_c_rule)
    return NeuralLearning(
        trials=tuple(history),
        W=tuple(float(w) for w in W),
        theta_c=float(theta_c),
        W0=tuple(float(w) for w in controller.gains),
        theta_c0=float(controller.theta_c),
        solved=solved,
        seed=seed,
        neurons=neurons,
        config=lc,
    )
