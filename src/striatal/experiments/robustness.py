"""Robustness of learned controllers to a plant that differs from the one they learned on.

The controller keeps believing in the nominal plant (its partial feedback
linearisation, eq 12, uses the nominal M, m, l), while the true plant has the pole
mass and length scaled by +-20 %, and/or the x and theta the controller sees carry
Gaussian sensor noise. Every run acts with the mean policy (no policy noise) from
the chapter's start (theta = 3.12 at rest) for 60 s under the protocol of eqs 24-25.
Two measures per run: the chapter's success test (at rest within 0.05 m / 0.05 rad
/ 0.005 per s at T_f) and "balanced": the +10 reward of eq 25 (|x| < 0.1 m and
|theta| < pi/9 at T_f, and the t = 30 s check passed).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from striatal.errors import DataFileError, ParameterError
from striatal.io.rundir import result_of
from striatal.params import Controller, Plant, check_seed
from striatal.sim.robust import Perturbation
from striatal.sim.rollout import Protocol, TrialRequest

__all__ = [
    "CONDITIONS",
    "controller_groups",
    "evaluate",
    "robustness_table",
]


#: The conditions of ``striatal robustness``: the true plant changed, or sensor noise.
CONDITIONS: tuple[Perturbation, ...] = (
    Perturbation("nominal"),
    Perturbation("pole mass -20%", pole_mass=0.8),
    Perturbation("pole mass +20%", pole_mass=1.2),
    Perturbation("length -20%", length=0.8),
    Perturbation("length +20%", length=1.2),
    Perturbation("mass and length -20%", pole_mass=0.8, length=0.8),
    Perturbation("mass and length +20%", pole_mass=1.2, length=1.2),
    Perturbation("sensor noise 0.001", x_std=0.001, theta_std=0.001),
    Perturbation("sensor noise 0.01", x_std=0.01, theta_std=0.01),
    Perturbation("sensor noise 0.05", x_std=0.05, theta_std=0.05),
)


def evaluate(
    controllers: Sequence[Controller],
    condition: Perturbation,
    *,
    nominal: Plant | None = None,
    repeats: int = 10,
    seed: int = 0,
) -> dict[str, Any]:
    """Fractions of runs passing the success test and balanced at T_f, over controllers.

    Each controller runs once without sensor noise, or ``repeats`` times with
    independent sensor noise (streams spawned from ``seed``). Every run is one
    :func:`striatal.sim.rollout.run_trial` with ``mean_policy=True`` on the true plant,
    the controller believing ``nominal`` (the generator draws only the sensor noise).
    """
    if not controllers:
        raise ParameterError("no controllers to evaluate")
    seed = check_seed(seed)
    nominal = nominal or Plant()
    plant = condition.plant(nominal)
    sim, protocol = condition.sim(), Protocol()
    n = repeats if condition.sensor.active else 1
    streams = np.random.SeedSequence(seed).spawn(len(controllers))
    success = balanced = 0
    for controller, ss in zip(controllers, streams, strict=True):
        rng = np.random.default_rng(ss)
        for _ in range(n):
            o = TrialRequest(
                plant,
                controller,
                sim,
                protocol,
                rng=rng,
                model=nominal,
                sensor=condition.sensor,
                mean_policy=True,
            ).run()
            success += o.success
            balanced += o.reward == protocol.reward_success
    total = n * len(controllers)
    return {
        "condition": condition.name,
        "runs": total,
        "success": success / total,
        "balanced": balanced / total,
    }


def robustness_table(
    groups: Sequence[tuple[str, Sequence[Controller]]],
    conditions: Sequence[Perturbation] = CONDITIONS,
    *,
    repeats: int = 10,
    seed: int = 0,
) -> tuple[str, list[dict[str, Any]]]:
    """Markdown table (conditions x groups: success % / balanced %) and its rows."""
    rows: list[dict[str, Any]] = []
    header = "| condition | " + " | ".join(f"{name} (n={len(c)})" for name, c in groups) + " |"
    lines = [header, "|---|" + "---|" * len(groups)]
    for cond in conditions:
        cells = []
        for name, ctrls in groups:
            r = evaluate(ctrls, cond, repeats=repeats, seed=seed)
            r["group"] = name
            rows.append(r)
            cells.append(f"{100 * r['success']:.0f}% / {100 * r['balanced']:.0f}%")
        lines.append(f"| {cond.name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n", rows


def controller_groups(
    data: Any, *, variants: Sequence[str] = ()
) -> list[tuple[str, list[Controller]]]:
    """Named groups of controllers from a ``train`` result.json ("learned") or an ablation.json.

    For an ablation.json: one group per variant (those of ``variants`` the file
    holds, or every variant) holding the gains of its successful runs; empty groups
    are left out.
    """
    if isinstance(data, dict) and "W" in data and "theta_c" in data:
        try:
            return [("learned", [result_of(data, "").controller])]
        except DataFileError as exc:
            raise ParameterError(str(exc)) from None
    if isinstance(data, dict) and all(isinstance(v, dict) and "runs" in v for v in data.values()):
        groups = []
        for name in [v for v in variants if v in data] if variants else list(data):
            runs = data[name]["runs"]
            if not isinstance(runs, list) or not all(isinstance(r, dict) for r in runs):
                raise ParameterError(f'variant {name!r}: "runs" must be a list of objects')
            ctrls = []
            for i, r in enumerate(runs):
                if not r.get("success"):
                    continue
                try:
                    ctrls.append(Controller(gains=tuple(r["W"]), theta_c=r["theta_c"]))
                except (KeyError, TypeError, ValueError, ParameterError) as exc:
                    raise ParameterError(
                        f"variant {name!r} run {i}: no valid W and theta_c ({exc})"
                    ) from None
            if ctrls:
                groups.append((name, ctrls))
        return groups
    raise ParameterError("expected a train result.json or an ablation.json")
