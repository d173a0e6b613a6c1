"""Ablation of the learner variants from random initial gains (docs/ablation.md).

Every run starts from W(0) uniform in [-1, 1]^6 (W1 floored) and theta_c(0) = 0.6,
drawn exactly as ``striatal train --init random --seed S`` draws them, with the
policy noise seeded by S, so any row of the table can be rerun on its own with
``striatal train --init random --seed S --learner ... --success-on mean``.
Success is the chapter's success test on the mean policy. The variants are arms of
one sweep (:func:`striatal.experiments.sweeps.run_sweep`: resume, progress, the Ray backend,
the output folder's lock), with seeds S..S+N-1 and init "random". "trials" counts
the learner's 60-s trials; "simulations" every simulated trial, the mean-policy
checks of ``--success-on mean`` included (pgpe judges the candidate its trial ran,
so its check is that trial). The ``-control`` variants are their learner's declared
no-learning control (:func:`striatal.learners.control_config`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from striatal.errors import ParameterError
from striatal.experiments import runner, sweeps
from striatal.experiments.results import Sweep
from striatal.experiments.spec import SEED_RULE, RunSpec, spawn_seeds
from striatal.learners import LearnerConfig, control_config, default_config
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)

__all__ = [
    "VARIANTS",
    "VARIANT_NAMES",
    "Variant",
    "build",
    "markdown_table",
    "runs_of",
    "summary",
    "table_rows",
    "variant",
]


@dataclass(frozen=True)
class Variant:
    """One row of the ablation: a learner's defaults with some options changed."""

    name: str
    learner: str
    changes: tuple[tuple[str, Any], ...]
    what: str
    kind: str = "learner"
    control: bool = False

    def config(self, max_trials: int) -> LearnerConfig:
        """The learner's preset with the changes (and, for a control, learning off)."""
        cfg = default_config(
            self.learner, max_trials=max_trials, success_on="mean", **dict(self.changes)
        )
        return control_config(cfg) if self.control else cfg

    @property
    def method(self) -> str:
        """The sweep's method: "learn", or the baseline ("random", "cmaes")."""
        return {"learner": "learn", "random-search": "random"}.get(self.kind, self.kind)

    @property
    def role(self) -> str:
        if self.kind != "learner":
            return "baseline"
        return "control" if self.control else "learner"

    def arm(self, max_trials: int) -> sweeps.Arm:
        return sweeps.Arm(self.name, self.method, self.config(max_trials), self.role)

    @property
    def options(self) -> str:
        """The train/sweep options that select this variant."""
        if self.kind != "learner":
            return (
                f"(striatal.experiments.baselines.{self.kind.replace('-', '_')}, success on mean)"
            )
        parts = [f"--learner {self.learner}"]
        changes = dict(self.changes)
        if self.control:
            changes.update(_control(self))
        for k, v in changes.items():
            flag = "--" + k.replace("_", "-")
            if isinstance(v, bool):
                parts.append(flag if v else "--no-" + k.replace("_", "-"))
            else:
                parts.append(f"{flag} {v}")
        return " ".join([*parts, "--success-on mean"])


VARIANTS: tuple[Variant, ...] = (
    Variant("chapter", "chapter", (), "the chapter's rule (alpha 5, sparse reward, b = 0)"),
    Variant("chapter-control", "chapter", (), "its no-learning control (alpha = 0)", control=True),
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
    Variant(
        "pgpe-control",
        "pgpe",
        (),
        "its no-learning control (alpha = 0, sigma_rate = 0): the same perturbations "
        "around W(0), no update",
        control=True,
    ),
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
        "IPOP-CMA-ES over (W, theta_c) from (W(0), 0.6), sigma0 1, population 9 doubled "
        "at each restart, on the shaped reward",
        kind="cmaes",
    ),
)
VARIANT_NAMES = tuple(v.name for v in VARIANTS)


def variant(name: str) -> Variant:
    for v in VARIANTS:
        if v.name == name:
            return v
    raise ParameterError(f"no variant {name!r}; choose from {', '.join(VARIANT_NAMES)}")


def _control(v: Variant) -> dict[str, Any]:
    from striatal.learners import rule_of

    return dict(rule_of(v.learner).control)


def seeds_of(root: int, n: int) -> tuple[int, ...]:
    """The ablation's ``n`` run seeds from root seed ``root``: the seeds of
    ``striatal sweep --seed root --seeds n`` (:func:`striatal.experiments.spec.spawn_seeds`)."""
    return spawn_seeds(root, n)


def build(
    variants: Sequence[Variant],
    seeds: Sequence[int],
    max_trials: int,
    eval_draws: int = 0,
    *,
    root: int | None = None,
) -> tuple[list[RunSpec], dict[str, Any]]:
    """(specs, settings) of the ablation sweep: every variant an arm, init "random", on
    the run ``seeds``; ``root``: the root seed they were spawned from
    (:func:`seeds_of`), recorded in the settings."""
    if not variants:
        raise ParameterError("no variant to run: name at least one")
    arms = [v.arm(max_trials) for v in variants]
    specs, arm_settings = sweeps.specs_of(
        arms,
        template=Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        plant=Plant(),
        sim=Simulation(),
        seeds=seeds,
        inits=("random",),
        eval_draws=eval_draws,
    )
    settings = {
        "command": "striatal ablation",
        "root_seed": root,
        "seeds": len(seeds),
        "run_seeds": list(seeds),
        "seed_rule": SEED_RULE if root is not None else "the run seeds given",
        "init": "random",
        "theta_c0": CHAPTER_INITIAL_THETA_C,
        "max_trials": max_trials,
        "success_on": "mean",
        "eval_draws": eval_draws,
        "arms": arm_settings,
        "variants": {v.name: {"options": v.options, "what": v.what} for v in variants},
        "budget": runner.NOTE_BUDGET,
    }
    return specs, settings


def runs_of(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows of one variant as ablation.json's "runs" (seed order)."""
    return [
        {
            "seed": int(r["seed"]),
            "success": bool(r["success"]),
            "trials": int(r["trials"]),
            "simulations": int(r["simulations"]),
            "simulated_seconds": float(r["simulated_seconds"]),
            "W0": [float(r[f"W0_{i}"]) for i in range(1, 7)],
            "W": [float(r[f"W{i}"]) for i in range(1, 7)],
            "theta_c": float(r["theta_c"]),
            "resimulated": bool(r["success"] and r["mean_policy_success"]),
        }
        for r in sorted(rows, key=lambda r: int(r["seed"]))
    ]


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


def table_rows(
    variants: Sequence[Variant], result: Sweep
) -> tuple[list[tuple[Variant, dict[str, Any]]], dict[str, Any]]:
    """(table rows, ablation.json) of a finished ablation sweep, in the variants' order.

    Each row's statistics: :func:`summary` of its runs plus the sweep summary's arm
    block (success_rate_ci, simulations_median and its interval...).
    """
    arms = {a["arm"]: a for a in result.summary["arms"]}
    rows, data = [], {}
    for v in variants:
        runs = runs_of([r for r in result.rows if r["arm"] == v.name])
        cfg = result.summary["settings"]["arms"][v.name]["config"]
        data[v.name] = {"options": v.options, "config": cfg, "runs": runs}
        rows.append((v, {**arms.get(v.name, {}), **summary(runs)}))
    return rows, data


def markdown_table(rows: Sequence[tuple[Variant, dict[str, Any]]]) -> str:
    """The ablation table, one row per variant (95 % intervals: Wilson for the success
    rate, bootstrap for the median simulations to success)."""

    def num(v: Any) -> str:
        return "-" if not isinstance(v, int | float) or not math.isfinite(v) else f"{v:g}"

    def ci(v: Any, fmt: str = "g") -> str:
        if not isinstance(v, list | tuple) or len(v) != 2:
            return ""
        return f" [{format(v[0], fmt)}, {format(v[1], fmt)}]"

    lines = [
        "| variant | options | what | success | 95% CI | median trials | 90th pct | "
        "median simulations [95% CI] | re-simulated |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for v, s in rows:
        lines.append(
            f"| {v.name} | `{v.options}` | {v.what} | {s['successes']}/{s['runs']} | "
            f"{ci(s.get('success_rate_ci'), '.2f').strip() or '-'} | "
            f"{num(s['median_trials'])} | {num(s['p90_trials'])} | "
            f"{num(s.get('simulations_median'))}{ci(s.get('simulations_median_ci'))} | "
            f"{s['resimulated']}/{s['successes']} |"
        )
    return "\n".join(lines) + "\n"
