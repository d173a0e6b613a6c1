"""The project's learning loop with its trials run on the spiking network.

:func:`striatal.learners.loop.learning_steps` is the one trial protocol of every rule: a
rule plans a trial, the loop yields it as a :class:`~striatal.sim.batch.TrialRequest`,
a driver runs it, the rule updates. :func:`network_drive` is a driver that runs each
request on the network (nengo or the Brian2 program) instead of the kernel, so any rule
whose trials the loop yields (the chapter's, pgpe, ...) learns the pathway weights with
its own update; :func:`learn_with_rule` runs a learning run that way, and
:func:`learn_network` is its chapter rule with each trial's network run recorded (the
dopamine stage of :mod:`striatal.neural.learn`).

What the network gives the loop: the action noise drawn from the request's generator
as the kernel draws it (``rollout.noise_arrays``), so the generator's state after a
trial is the kernel's; the eligibility trace D of eq 3 from the pathways' traces
(``D <- gamma^n D + (J^T E, E_6)``, :mod:`striatal.neural.learn`); the outcome with the
reward of eq 25 at T_f. The request's own gains and threshold (``TrialRequest.W``,
``.threshold``) set the pathways and the switch. Requests the network cannot run (a
model, sensor noise, the chapter's printed eligibility, a motor limit, held actions,
online learning, another start) are refused.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TypeVar

import numpy as np

from striatal.errors import ParameterError
from striatal.learners import default_config
from striatal.learners.common import initial_state
from striatal.learners.config import LearnerConfig
from striatal.learners.loop import learning_steps
from striatal.learners.state import LearnerState, TrialRecord
from striatal.neural.interpret import pathway_coefficients
from striatal.neural.learn import Eligibility, gain_eligibility, trial_outcome, trial_reward
from striatal.neural.network import NetworkConfig
from striatal.neural.run import NeuralRun, Simulator, run_network
from striatal.params import CHAPTER_HARDWARE, N_GAINS, Controller, Plant, Simulation, check_seed
from striatal.sim import kernel
from striatal.sim.batch import Steps, TrialRequest
from striatal.sim.rollout import Protocol, TrialOutcome

__all__ = [
    "NETWORK_RULES",
    "NetworkTrial",
    "NeuralLearning",
    "NeuralTrial",
    "check_network_learning",
    "learn_network",
    "learn_with_rule",
    "network_drive",
    "prepare_simulator",
    "run_request",
]

T = TypeVar("T")

#: The rules whose every trial the network runs: the Gaussian policy of eq 5 per step
#: (chapter, rpe) or noise-free candidates (pgpe). ac learns within its trial and forward
#: imagines on a model: their requests are not the network's.
NETWORK_RULES: tuple[str, ...] = ("chapter", "pgpe", "rpe")

#: The network's step [s] (nengo's and the Brian2 program's dt).
NET_DT = 0.001


@dataclass(frozen=True)
class NetworkTrial:
    """What one requested trial did on the network, beyond the loop's outcome: the run,
    the pathways' traces E (7,) and the gains' trace D of the trial alone (6,; zeros for
    a mean-policy trial), and its wall time [s]."""

    run: NeuralRun
    pathway_trace: np.ndarray
    eligibility: np.ndarray
    wall_time: float


#: Called with each trial the network ran.
OnRun = Callable[[NetworkTrial], None]


def run_request(
    r: TrialRequest,
    config: NetworkConfig,
    seed: int,
    simulator: Simulator,
    net_dt: float = NET_DT,
    *,
    on_run: OnRun | None = None,
    on_compile: Callable[[Path], None] | None = None,
) -> TrialOutcome:
    """One requested trial on the network (network seed ``seed``); ``r.trace`` updated.

    The request's gains and threshold (``r.W``, ``r.threshold``) set the pathways and the
    switch; ``on_run`` gets the run and its traces."""
    if (
        r.model is not None
        or r.sensor.active
        or r.chapter_eligibility
        or r.action_every != 1
        or r.hardware != CHAPTER_HARDWARE
        or r.online is not None
        or r.state0 is not None
    ):
        raise ParameterError(
            "the network runs the chapter's trial only: no model mismatch, sensor noise, "
            "printed eligibility, held actions, motor limit, online learning or other start"
        )
    noise, _ = r.noise()
    W = np.array(r.W, dtype=float)
    controller = r.controller.with_gains(W, r.threshold)
    explores = noise.size > 0
    sigma = kernel.sigma_of(W[5]) if explores else 0.0
    every = max(1, int(round(r.sim.dt / net_dt)))
    elig = Eligibility(sigma, noise if explores else np.zeros(r.sim.n_steps), r.gamma, every)
    t0 = time.perf_counter()
    run = run_network(
        controller,
        r.plant,
        r.sim,
        config,
        seed,
        net_dt=net_dt,
        record_rates=False,
        exploration=elig if explores else None,
        simulator=simulator,
        on_compile=on_compile,
    )
    wall = time.perf_counter() - t0
    d = np.zeros(N_GAINS)
    if explores:
        d = gain_eligibility(elig.trace, elig.sigma_trace, W, r.plant, controller.sign)
        r.trace[:] = r.gamma**r.sim.n_steps * r.trace + d
    if on_run is not None:
        on_run(NetworkTrial(run, elig.trace.copy(), d, wall))
    reward = trial_reward(run, r.protocol)
    return trial_outcome(run, reward, controller.theta_c)


def network_drive(
    steps: Steps[T],
    config: NetworkConfig,
    seed: int,
    simulator: Simulator,
    net_dt: float = NET_DT,
    *,
    on_run: OnRun | None = None,
    on_compile: Callable[[Path], None] | None = None,
) -> T:
    """Run ``steps`` to its end, each request on the network; its return value."""
    try:
        requests = next(steps)
        while True:
            requests = steps.send(
                [
                    run_request(
                        r, config, seed, simulator, net_dt, on_run=on_run, on_compile=on_compile
                    )
                    for r in requests
                ]
            )
    except StopIteration as stop:
        return stop.value  # type: ignore[no-any-return]


def prepare_simulator(
    simulator: Simulator,
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    net_dt: float = NET_DT,
    *,
    on_compile: Callable[[Path], None] | None = None,
) -> None:
    """Get the Brian2 program for ``sim``'s trials of ``config``'s network ready in this
    process now: compiled into the cache if it is not there (``on_compile(folder)`` told
    first), generated and held otherwise. Nothing for nengo. A sweep calls it before its
    runs, so that the notice comes once, before the progress bar."""
    if simulator != "brian2":
        return
    from striatal.neural.brian import compiled_network, require_brian2
    from striatal.neural.translate import translate

    require_brian2()
    tr = translate(controller, plant, config, check_seed(seed), net_dt)
    compiled_network(tr, sim.duration, sim.dt, on_compile=on_compile)


def check_network_learning(config: LearnerConfig, sim: Simulation) -> None:
    """ParameterError (one line) unless the network can run ``config``'s learning trials
    of ``sim``: the sparse reward of eq 25, a rule of :data:`NETWORK_RULES`, trials of
    at most 30 s (the check of eq 24 at 30 s is not applied to the network)."""
    if config.learner not in NETWORK_RULES:
        raise ParameterError(
            f"learner {config.learner!r} cannot learn on the network (it learns within the "
            f"trial or on a model); choose from {', '.join(NETWORK_RULES)}"
        )
    if config.reward != "sparse":
        raise ParameterError("the network's trials give the sparse reward of eq 25 only")
    check_time = Protocol().check_time
    if 0.0 <= check_time < sim.duration or not math.isfinite(sim.duration):
        raise ParameterError(
            f"learning trials of the network must be at most {check_time:g} s "
            f"(the eq-24 check is not applied to it), got {sim.duration:g}"
        )


def learn_with_rule(
    learner: str,
    controller: Controller,
    plant: Plant,
    sim: Simulation,
    config: NetworkConfig,
    seed: int,
    *,
    trials: int,
    simulator: Simulator = "brian2",
    on_trial: Callable[[LearnerState, TrialRecord], None] | None = None,
    state: LearnerState | None = None,
    net_dt: float = NET_DT,
    on_run: OnRun | None = None,
    on_compile: Callable[[Path], None] | None = None,
    **options: object,
) -> LearnerState:
    """A learning run of rule ``learner`` (its preset, ``options`` over it, the sparse
    reward of eq 25) on the network from ``controller``'s W and theta_c, up to ``trials``
    trials or the first success; ``seed`` seeds the network and the rule's generator.
    ``state``: continue an earlier run (its state after its last trial). ``on_run``
    gets every trial the network runs (:class:`NetworkTrial`), ``on_trial`` every
    learning trial's state and record."""
    seed = check_seed(seed)
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise ParameterError(f"trials must be a whole number >= 1, got {trials!r}")
    config.check_work(sim.duration, net_dt, trials)
    lc: LearnerConfig = default_config(learner, reward="sparse", max_trials=trials, **options)
    check_network_learning(lc, sim)
    protocol = Protocol()
    if state is None:
        state = initial_state(controller.gains, controller.theta_c, seed)
    template = replace(controller)
    while state.trials_done < trials and not state.success:
        state, record = network_drive(
            learning_steps(state, plant, template, sim, protocol, lc),
            config,
            seed,
            simulator,
            net_dt,
            on_run=on_run,
            on_compile=on_compile,
        )
        if on_trial is not None:
            on_trial(state, record)
    return state


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
    """A learning run of the network: its trials, and the W and theta_c it ended with;
    ``state`` is the learning loop's state after the last trial (what a resume continues)."""

    trials: tuple[NeuralTrial, ...]
    W: tuple[float, ...]
    theta_c: float
    W0: tuple[float, ...]
    theta_c0: float
    solved: bool
    seed: int
    neurons: int
    config: LearnerConfig
    state: LearnerState
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
    on_trial: Callable[[NeuralTrial], None] | None = None,
    net_dt: float = NET_DT,
    simulator: Simulator = "nengo",
    on_compile: Callable[[Path], None] | None = None,
    resume: NeuralLearning | None = None,
) -> NeuralLearning:
    """The chapter's rule on the network (the dopamine stage of :mod:`striatal.neural.learn`):
    ``trials`` learning trials from ``controller``'s W and theta_c, with each trial's
    network run and traces recorded.

    :func:`learn_with_rule` with ``"chapter"`` (the chapter learner's options, alpha 5,
    gamma 0.999 per draw, b = 0, max step 1, eq 21 under the swing-up; ``alpha``
    replaced if given, alpha = 0: no learning). ``seed`` fixes the network (the same
    neurons every trial) and the exploration noise (``numpy.random.default_rng(seed)``,
    one standard normal per control step). A trial that passes the chapter's success
    test (on the noisy trial) keeps W and ends the run. ``resume``: an earlier run of
    the same start, seed and options, continued up to ``trials`` trials in all, equal to
    one run of ``trials`` trials.
    """
    seed = check_seed(seed)
    options = {} if alpha is None else {"alpha": alpha}
    lc = default_config("chapter", reward="sparse", **options)
    history: list[NeuralTrial] = []
    state: LearnerState | None = None
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
        history, state = list(resume.trials), resume.state
    runs: list[NetworkTrial] = []
    neurons = [resume.neurons if resume is not None else 0]

    def record(_state: LearnerState, rec: TrialRecord) -> None:
        net = runs[0]  # the learning trial (a success check's runs come after it)
        runs.clear()
        neurons[0] = net.run.neurons
        run, sw = net.run, net.run.switch_times
        x, xd, th, thd = (float(v) for v in run.data[-1, 1:5])
        trial = NeuralTrial(
            trial=rec.trial,
            W=rec.W,
            theta_c=rec.theta_c,
            transforms=tuple(float(c) for c in pathway_coefficients(rec.W, plant, controller.sign)),
            reward=rec.reward,
            success=rec.success,
            upright_last_10s=run.upright_last_10s,
            fault=run.fault,
            final_state=(x, xd, float(kernel.wrap_angle(th)), thd),
            first_switch=sw[0] if sw else math.nan,
            pathway_trace=tuple(float(v) for v in net.pathway_trace),
            eligibility=tuple(float(v) for v in net.eligibility),
            cpu_time=run.cpu_time,
            wall_time=net.wall_time,
        )
        history.append(trial)
        if on_trial is not None:
            on_trial(trial)

    state = learn_with_rule(
        "chapter",
        controller,
        plant,
        sim,
        config,
        seed,
        trials=trials,
        simulator=simulator,
        on_trial=record,
        state=state,
        net_dt=net_dt,
        on_run=runs.append,
        on_compile=on_compile,
        **options,
    )
    return NeuralLearning(
        trials=tuple(history),
        W=state.W,
        theta_c=state.theta_c,
        W0=tuple(float(w) for w in controller.gains),
        theta_c0=float(controller.theta_c),
        solved=state.success,
        seed=seed,
        neurons=neurons[0],
        config=lc,
        state=state,
    )
