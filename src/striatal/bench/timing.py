"""The building blocks of ``striatal bench``: its configuration, timings and comparisons.

Timing: ``time.perf_counter``; warm-up calls excluded; the two sides of a ratio are
timed alternately, repeat by repeat (:func:`compare`), and the ratio uses the best
repeat of each (the median ratio is reported too).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.params import Simulation
from striatal.sim.bench import calibrate, timed

__all__ = ["QUICK", "BenchConfig", "Comparison", "Timing", "compare", "linear_fit"]


@dataclass(frozen=True)
class BenchConfig:
    """How long and how big the measurements are.

    ``seconds``: rough wall budget of one timed repeat of one side [s];
    ``repeats``: timed repeats per side (best and median reported);
    ``batch_size``: B of the batched comparison; ``duration``: trial length [s];
    ``train``: also time ``striatal train --init chapter`` (``train_max_trials`` caps it,
    None for the command's own default); ``scaling_durations``: trial lengths [s] of the
    cost-growth fit; ``cold_compile``: also time a fresh process compiling the kernels
    into an empty Numba cache folder; ``sweep_seeds``: seeds of the timed
    ``striatal sweep`` on 1 and on all workers (0: skip; ``sweep_max_trials`` caps each
    run); ``memory_runs``: runs of the sweep whose peak memory is measured (0: skip),
    capped at ``memory_max_trials``.
    """

    seconds: float = 0.5
    repeats: int = 5
    batch_size: int = 256
    duration: float = 60.0
    dt: float = 0.01
    train: bool = True
    train_max_trials: int | None = None
    scaling_durations: tuple[float, ...] = (7.5, 15.0, 30.0, 60.0, 120.0, 240.0)
    cold_compile: bool = True
    sweep_seeds: int = 0
    sweep_max_trials: int | None = None
    memory_runs: int = 0
    memory_max_trials: int = 20
    anchors: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ParameterError(f"seconds must be a finite number > 0, got {self.seconds}")
        if self.repeats < 1:
            raise ParameterError(f"repeats must be >= 1, got {self.repeats}")
        if self.batch_size < 1:
            raise ParameterError(f"batch size must be >= 1, got {self.batch_size}")
        Simulation(duration=self.duration, dt=self.dt)  # validates duration and dt
        if len(self.scaling_durations) < 2:
            raise ParameterError("the scaling fit needs at least two durations")
        for d in self.scaling_durations:
            Simulation(duration=d, dt=self.dt)
        if self.sweep_seeds < 0 or self.memory_runs < 0:
            raise ParameterError("sweep seeds and memory runs must be >= 0")
        if self.train_max_trials is not None and self.train_max_trials < 1:
            raise ParameterError(f"train max trials must be >= 1, got {self.train_max_trials}")

    @property
    def timed_seconds(self) -> float:
        """The wall budget of the timed repeats [s], at most: each timed side (three
        comparisons of two sides, one per scaling duration) calibrates for ``seconds``
        and then times ``repeats`` repeats of about ``seconds``; ``anchors`` add theirs."""
        sides = 3 * 2 + len(self.scaling_durations)
        return sides * (self.repeats + 1) * self.seconds

    def check_work(self) -> None:
        """ParameterError (one line, with the estimate) if the commands the bench times
        (``train``, the sweeps of ``sweep_seeds`` and ``memory_runs``, each of the
        learner and its control arm, at their trial budgets of default-length trials)
        would exceed the work limit (:func:`striatal.arguments.check_work`). The timed
        kernel repeats are bounded by ``seconds`` x ``repeats`` instead."""
        from striatal.arguments import check_work
        from striatal.learners import LearnerConfig

        steps = Simulation().n_steps
        budget = LearnerConfig().max_trials
        train = (self.train_max_trials or budget) if self.train else 0
        sweep = 2 * self.sweep_seeds * 2 * (self.sweep_max_trials or budget)
        memory = (5 + self.memory_runs // 2) * 2 * self.memory_max_trials if self.memory_runs else 0
        check_work(
            float(train + sweep + memory) * steps,
            "the bench",
            f"train {train:,} + sweeps {sweep:,} + memory sweeps {memory:,} trials x "
            f"{steps:,} steps",
        )


QUICK = BenchConfig(
    seconds=0.05,
    repeats=2,
    batch_size=32,
    duration=10.0,
    train_max_trials=20,
    scaling_durations=(2.5, 5.0, 10.0),
    cold_compile=False,
)


@dataclass(frozen=True)
class Timing:
    """Repeated timings of one side: env-steps and seconds of each repeat."""

    name: str
    steps: tuple[int, ...]
    seconds: tuple[float, ...]

    @property
    def rates(self) -> list[float]:
        """Env-steps per second of each repeat."""
        return [n / t for n, t in zip(self.steps, self.seconds, strict=True)]

    @property
    def best_steps_per_second(self) -> float:
        return max(self.rates)

    @property
    def median_steps_per_second(self) -> float:
        return statistics.median(self.rates)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "repeat_steps": list(self.steps),
            "repeat_seconds": list(self.seconds),
            "best_steps_per_second": self.best_steps_per_second,
            "median_steps_per_second": self.median_steps_per_second,
        }


@dataclass(frozen=True)
class Comparison:
    """One kernel figure and its reference; ``ratio`` = best kernel / best reference."""

    kernel: Timing
    reference: Timing
    target_ratio: float
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ratio(self) -> float:
        return self.kernel.best_steps_per_second / self.reference.best_steps_per_second

    @property
    def median_ratio(self) -> float:
        return self.kernel.median_steps_per_second / self.reference.median_steps_per_second

    def to_dict(self) -> dict[str, Any]:
        return {
            "kernel": self.kernel.to_dict(),
            "reference": self.reference.to_dict(),
            "ratio": self.ratio,
            "median_ratio": self.median_ratio,
            "target_ratio": self.target_ratio,
            "meets_target": self.ratio >= self.target_ratio,
            "notes": self.notes,
            **self.extra,
        }


def compare(
    kernel_name: str,
    kernel_run: Callable[[], int],
    reference_name: str,
    reference_run: Callable[[], int],
    config: BenchConfig,
) -> tuple[Timing, Timing]:
    """Time both sides alternately (warm-up excluded), ``config.repeats`` repeats each.

    Each ``run`` returns the env-steps it actually performed (a trial that ends early
    counts only its steps).
    """
    kc = calibrate(kernel_run, config.seconds)
    rc = calibrate(reference_run, config.seconds)
    kn: list[int] = []
    ks: list[float] = []
    rn: list[int] = []
    rs: list[float] = []
    for _ in range(config.repeats):
        n, t = timed(kernel_run, kc)
        kn.append(n)
        ks.append(t)
        n, t = timed(reference_run, rc)
        rn.append(n)
        rs.append(t)
    return (
        Timing(kernel_name, tuple(kn), tuple(ks)),
        Timing(reference_name, tuple(rn), tuple(rs)),
    )


def linear_fit(x: np.ndarray, y: np.ndarray) -> dict[str, float]:
    """Least-squares y = intercept + slope x and its coefficient of determination R^2."""
    slope, intercept = np.polyfit(x, y, 1)
    pred = intercept + slope * x
    ss_res = float(np.sum((y - pred) ** 2))
    ss_tot = float(np.sum((y - np.mean(y)) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    return {"slope": float(slope), "intercept": float(intercept), "r2": r2}
