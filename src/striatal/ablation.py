"""Ablation of the learner variants from random initial gains (docs/ablation.md).

Every run starts from W(0) uniform in [-1, 1]^6 (W1 floored) and theta_c(0) = 0.6,
drawn exactly as ``striatal train --init random --seed S`` draws them, with the
policy noise seeded by S, so any row of the table can be rerun on its own with
``striatal train --init random --seed S --learner ... --success-on mean``.
Success is the chapter's success test on the mean policy; "trials" counts the
learner's 60-s trials (the mean-policy check of each trial is not counted, as in
``train --success-on mean``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from striatal import baselines, experiments
from striatal.errors import ParameterError
from striatal.learners import LearnerConfig, default_config, random_initial_gains
from striatal.params import CHAPTER_INITIAL_THETA_C, Controller, Plant, Simulation
from striatal.rollout import Protocol, simulate


@dataclass(frozen=True)
class Variant:
    """One row of the ablation: a learner's defaults with some options changed."""

    name: str
    learner: str
    changes: tuple[tuple[str, Any], ...]
    what: str
    kind: str = "learner"

    def config(self, max_trials: int) -> LearnerConfig:
        return default_config(
            self.learner, max_trials=max_trials, success_on="mean", **dict(self.changes)
        )

    @property
    def options(self) -> str:
        """The train/sweep options that select this variant."""
        if self.kind != "learner":
            return f"(striatal.baselines.{self.kind.replace('-', '_')}, success on mean)"
        parts = [f"--learner {self.learner}"]
        for k, v in self.changes:
            flag = "--" + k.replace("_", "-")
            if isinstance(v, bool):
                parts.append(flag if v else "--no-" + k.replace("_", "-"))
            else:
                parts.append(f"{flag} {v}")
        return " ".join([*parts, "--success-on mean"])


VARIANTS: tuple[Variant, ...] = (
    Variant("chapter", "chapter", (), "the chapter's rule (alpha 5, sparse reward, b = 0)"),
    Variant("chapter-control", "chapter", (("alpha", 0.0),), "its alpha = 0 control"),
    Variant("rpe", "rpe", (), "chapter rule, delta = r - b with tracked b, normalised"),
    Variant("rpe-raw", "rpe", (("normalise", False),), "rpe, delta not normalised"),
    Variant("rpe-shaped", "rpe", (("reward", "shaped"),), "rpe with the shaped reward"),
    Variant(
        "rpe-shaped-decay",
        "rpe",
        (("reward", "shaped"), ("decay", 6.0)),
        "rpe, shaped reward, decay 6 (W shrinks 3 % per trial)",
    ),
    Variant("pgpe-sparse", "pgpe", (("reward", "sparse"),), "pgpe with the sparse reward"),
    Variant(
        "pgpe-first",
        "pgpe",
        (("explore", 0.3), ("decay", 0.0)),
        "first pgpe: exploration 0.3, no decay",
    ),
    Variant("pgpe-no-decay", "pgpe", (("decay", 0.0),), "pgpe without decay"),
    Variant("pgpe-explore-0.3", "pgpe", (("explore", 0.3),), "pgpe, exploration 0.3"),
    Variant("pgpe", "pgpe", (), "pgpe defaults: exploration 1.0, decay 0.1 (3 % per trial)"),
    Variant("pgpe-raw-rpe", "pgpe", (("normalise", False),), "pgpe, delta not normalised"),
    Variant(
        "pgpe-theta-c-eq21",
        "pgpe",
        (("theta_c_rule", "swingup"),),
        "pgpe, theta_c by eq 21 instead of learned",
    ),
    Variant(
        "pgpe-theta-c-fixed", "pgpe", (("theta_c_rule", "fixed"),), "pgpe, theta_c kept at 0.6"
    ),
    Variant("pgpe-adaptive-sigma", "pgpe", (("sigma_rate", 0.1),), "pgpe, adaptive exploration"),
    Variant("pgpe-rpe-rate-0.3", "pgpe", (("rpe_rate", 0.3),), "pgpe, baseline rate 0.3"),
    Variant("pgpe-control", "pgpe", (("alpha", 0.0),), "its alpha = 0 control"),
    Variant(
        "pgpe-robust",
        "pgpe",
        (("plant_jitter", 0.2),),
        "pgpe on plants with pole mass and length x U[0.8, 1.2]; success also on the 4 corners",
    ),
    Variant(
        "random-search",
        "pgpe",
        (),
        "uniform draws of W1 in [0, 3], W2..W6 in [-3, 3], theta_c in [0.2, 1.4]",
        kind="random-search",
    ),
    Variant(
        "cma-es",
        "pgpe",
        (),
        "CMA-ES over (W, theta_c) from (W(0), 0.6), sigma0 1, on the shaped reward",
        kind="cmaes",
    ),
)
VARIANT_NAMES = tuple(v.name for v in VARIANTS)


def variant(name: str) -> Variant:
    for v in VARIANTS:
        if v.name == name:
            return v
    raise ParameterError(f"no variant {name!r}; choose from {', '.join(VARIANT_NAMES)}")


def run_seed(config: LearnerConfig, seed: int, kind: str = "learner") -> dict[str, Any]:
    """One learning run from the random W(0) of ``seed``; the learned gains re-simulated.

    ``kind`` "random-search" or "cmaes" runs that baseline of the sweep instead
    (:func:`striatal.baselines.random_search`, :func:`striatal.baselines.cmaes`,
    success judged on the mean policy) with ``config.max_trials`` trials.
    """
    W0 = random_initial_gains(np.random.default_rng([seed, 1]))
    template = Controller(W0, CHAPTER_INITIAL_THETA_C)
    plant, sim = Plant(), Simulation()
    if kind == "random-search":
        found = baselines.random_search(plant, template, sim, seed, config.max_trials, "mean")
    elif kind == "cmaes":
        found = baselines.cmaes(
            plant, template, sim, W0, CHAPTER_INITIAL_THETA_C, seed, config.max_trials, "mean"
        )
    else:
        found = experiments.learning_run(plant, template, config, seed, sim)
    resimulated = False
    if found["success"]:
        learned = template.with_gains(tuple(found["W"]), found["theta_c"])
        resimulated = simulate(plant, learned, sim, protocol=Protocol()).outcome.success
    return {
        "seed": seed,
        "success": bool(found["success"]),
        "trials": int(found["trials"]),
        "W0": list(W0),
        "W": [float(v) for v in found["W"]],
        "theta_c": float(found["theta_c"]),
        "resimulated": resimulated,
    }


def _run_one(job: tuple[LearnerConfig, int, str]) -> dict[str, Any]:
    return run_seed(*job)


def run_variant(
    config: LearnerConfig, seeds: Sequence[int], workers: int = 1, kind: str = "learner"
) -> list[dict[str, Any]]:
    """run_seed for every seed, in ``workers`` processes (results in seed order)."""
    jobs = [(config, s, kind) for s in seeds]
    if workers <= 1:
        return [_run_one(j) for j in jobs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(_run_one, jobs, chunksize=4))


def summary(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Success rate, trials to success (median, 90th percentile) and re-simulation check."""
    ok = [r["trials"] for r in runs if r["success"]]
    return {
        "runs": len(runs),
        "successes": len(ok),
        "median_trials": float(np.median(ok)) if ok else math.nan,
        "p90_trials": float(np.percentile(ok, 90)) if ok else math.nan,
        "resimulated": sum(bool(r["resimulated"]) for r in runs),
    }


def markdown_table(rows: Sequence[tuple[Variant, dict[str, Any]]]) -> str:
    """The ablation table, one row per variant."""

    def num(v: float) -> str:
        return "-" if not math.isfinite(v) else f"{v:g}"

    lines = [
        "| variant | options | what | success | median trials | 90th pct | re-simulated |",
        "|---|---|---|---|---|---|---|",
    ]
    for v, s in rows:
        lines.append(
            f"| {v.name} | `{v.options}` | {v.what} | {s['successes']}/{s['runs']} | "
            f"{num(s['median_trials'])} | {num(s['p90_trials'])} | "
            f"{s['resimulated']}/{s['successes']} |"
        )
    return "\n".join(lines) + "\n"
