"""How often a noisy trial passes the chapter's success test with fixed gains.

The learner of the chapter judges success on the noisy trial (docs/paper-notes.md,
table row 8): the Gaussian policy of eq 5 draws an action every step, and the
trial counts as solved when its final state passes the test at T_f (end of
section 2.4). With fixed gains that is a Bernoulli draw; :func:`pass_probability`
estimates its probability over many independent noise draws, with a Wilson 95 %
interval, beside the deterministic verdict of the mean policy. Every trial is a
call of :func:`striatal.sim.rollout.run_trial`, the one the learner makes, so the
test is the same.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.experiments.stats import wilson_interval
from striatal.params import (
    CHAPTER_HARDWARE,
    Controller,
    Hardware,
    Plant,
    Simulation,
    check_seed,
)
from striatal.sim.batch import Steps, TrialRequest, driven
from striatal.sim.rollout import Protocol, SensorNoise

__all__ = [
    "MAX_DRAWS",
    "PassProbability",
    "check_draws",
    "pass_probability",
    "pass_probability_steps",
]

#: Noisy trials requested at once (their noise is drawn when a driver runs them). The
#: runs of a sweep that reach their budget together evaluate their final gains in the
#: same rounds of the lockstep engines: in chunks this size, a round's noise stays tens
#: of MB rather than hundreds, and its calls short enough for both workers to share
#: them (docs/performance.md, round 9). The draws and their order do not depend on it.
DRAWS_AT_ONCE = 32
#: Most noise draws one estimate may take: at ~2 ms a 60-s trial, about half an hour.
MAX_DRAWS = 1_000_000


@dataclass(frozen=True)
class PassProbability:
    """The estimate of :func:`pass_probability`.

    ``passes`` of ``draws`` noisy trials passed the success test; ``rate_ci`` is
    the Wilson 95 % interval of ``passes / draws``. ``reward_positive``: how many
    earned the +10 of eq 25 (a looser test than the success test).
    ``mean_policy_pass``: the verdict of one noise-free trial with the mean policy.
    ``simulations``: every trial run (``draws`` noisy + 1 mean-policy);
    ``simulated_seconds``: their total simulated time [s].
    """

    gains: tuple[float, ...]
    theta_c: float
    seed: int
    draws: int
    passes: int
    rate: float
    rate_ci: tuple[float, float]
    reward_positive: int
    mean_policy_pass: bool
    simulations: int
    simulated_seconds: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready; ``rate_ci`` as a list ``[low, high]``."""
        return {
            "gains": list(self.gains),
            "theta_c": self.theta_c,
            "seed": self.seed,
            "draws": self.draws,
            "passes": self.passes,
            "pass_rate": self.rate,
            "pass_rate_ci": list(self.rate_ci),
            "interval": "Wilson 95 %",
            "reward_positive": self.reward_positive,
            "reward_positive_rate": self.reward_positive / self.draws,
            "mean_policy_pass": self.mean_policy_pass,
            "simulations": self.simulations,
            "simulated_seconds": self.simulated_seconds,
        }


def check_draws(draws: object) -> int:
    """A number of noise draws: a whole number in [1, MAX_DRAWS], else ParameterError."""
    whole = isinstance(draws, int | np.integer) and not isinstance(draws, bool)
    if whole and 1 <= draws <= MAX_DRAWS:  # type: ignore[operator]
        return int(draws)  # type: ignore[call-overload]
    raise ParameterError(f"draws must be a whole number in [1, {MAX_DRAWS:,}], got {draws!r}")


def pass_probability_steps(
    plant: Plant,
    controller: Controller,
    sim: Simulation,
    protocol: Protocol,
    draws: int,
    seed: int,
    *,
    action_every: int = 1,
    model: Plant | None = None,
    sensor: SensorNoise | None = None,
    hardware: Hardware = CHAPTER_HARDWARE,
    on_draw: Callable[[int], None] | None = None,
    chunk: int = DRAWS_AT_ONCE,
) -> Steps[PassProbability]:
    """Chance that one noisy trial with ``controller``'s gains passes the success test.

    Runs ``draws`` trials of the protocol under the Gaussian policy of eq 5
    (sigma from W6, eqs 22-23), all from one ``np.random.default_rng(seed)`` in
    sequence, and one with the mean policy. Each noisy trial's success is
    :attr:`striatal.sim.rollout.TrialOutcome.success`, the one the learner uses when
    success is judged on the noisy trial (docs/paper-notes.md, table row 8 and
    section 8). ``sensor``: noise on what the controller sees (default none);
    ``hardware``: the motor's hold and limit and the track (default: the chapter's
    idealisation; docs/paper-notes.md section 9). Same seed, same result. For the
    robustness set see :func:`striatal.sim.robust.check_robust`. ``on_draw(k)`` is called
    after the k-th noisy trial (a progress bar); it does not touch the draws.

    As :data:`striatal.sim.batch.Steps`: the mean-policy trial, then the noisy trials
    ``chunk`` at a time (the same draws in the same order, whichever driver runs them;
    :func:`pass_probability` runs them on the scalar kernel).
    """
    n = check_draws(draws)
    sensor = sensor or SensorNoise()
    rng = np.random.default_rng(check_seed(seed))

    def trial(mean_policy: bool) -> TrialRequest:
        return TrialRequest(
            plant,
            controller,
            sim,
            protocol,
            # the mean policy needs the generator only for sensor noise
            rng=None if mean_policy and not sensor.active else rng,
            action_every=action_every,
            model=model,
            sensor=sensor,
            mean_policy=mean_policy,
            hardware=hardware,
        )

    (mean,) = yield [trial(mean_policy=True)]
    passes = positive = 0
    seconds = mean.ended_at
    done = 0
    while done < n:
        outcomes = yield [trial(mean_policy=False) for _ in range(min(chunk, n - done))]
        for o in outcomes:
            passes += o.success
            positive += o.reward > 0
            seconds += o.ended_at
            done += 1
            if on_draw is not None:
                on_draw(done)
    low, high = wilson_interval(passes, n).bounds or (0.0, 1.0)  # n >= 1: never None
    return PassProbability(
        gains=controller.gains,
        theta_c=controller.theta_c,
        seed=int(seed),
        draws=n,
        passes=passes,
        rate=passes / n,
        rate_ci=(low, high),
        reward_positive=positive,
        mean_policy_pass=mean.success,
        simulations=n + 1,
        simulated_seconds=seconds,
    )


#: :func:`pass_probability_steps` run to its end on the scalar kernel.
pass_probability = driven(pass_probability_steps)
