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
from striatal.params import N_GAINS, Controller, Plant, check_seed
from striatal.sim.robust import Perturbation, run_case
from striatal.sim.rollout import Protocol, TrialRequest

__all__ = [
    "CONDITIONS",
    "MARGIN_CONDITIONS",
    "MARGIN_DRAWS",
    "controller_groups",
    "evaluate",
    "margin_passes",
    "margin_table",
    "robustness_table",
    "sweep_controllers",
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


#: Seed and number of the margin set's random (pole mass, length) draws in [0.6, 1.4].
MARGIN_SEED = 20261205
MARGIN_DRAWS = 20


def _margin_conditions() -> tuple[Perturbation, ...]:
    scan = tuple(
        Perturbation(f"pole mass x{m}, length x{l}", pole_mass=m, length=l)
        for m in (0.8, 1.2)
        for l in (0.6, 0.65, 0.7, 0.75, 1.3, 1.4, 1.5)
    )
    draws = np.random.default_rng(MARGIN_SEED).uniform(0.6, 1.4, (MARGIN_DRAWS, 2))
    drawn = tuple(
        Perturbation(f"draw {i}: pole mass x{m:.3f}, length x{l:.3f}", pole_mass=m, length=l)
        for i, (m, l) in enumerate(draws.round(3).tolist())
    )
    carts = tuple(Perturbation(f"cart mass x{c}", cart_mass=c) for c in (0.7, 1.3))
    starts = (
        Perturbation("theta0 = pi - 0.6", theta0=float(np.pi - 0.6)),
        Perturbation("theta0 = pi + 0.6", theta0=float(np.pi + 0.6)),
        Perturbation("x0 = -1.0 m", x0=-1.0),
        Perturbation("x0 = +1.0 m", x0=1.0),
    )
    return scan + drawn + carts + starts


#: The margin set: conditions outside the robustness set (none of its nine cases),
#: judged as the robustness set judges (the mean policy, 60 s, the force held, the
#: success test at T_f; :func:`striatal.sim.robust.run_case`): a pole-length scan
#: beyond +-20 % at pole mass x0.8 and x1.2, :data:`MARGIN_DRAWS` random (pole mass,
#: length) factors in [0.6, 1.4], the cart mass x0.7 and x1.3, and starts farther out.
MARGIN_CONDITIONS: tuple[Perturbation, ...] = _margin_conditions()


def margin_passes(
    controllers: Sequence[Controller],
    conditions: Sequence[Perturbation] = MARGIN_CONDITIONS,
    *,
    nominal: Plant | None = None,
) -> np.ndarray:
    """(n_controllers, n_conditions) bool: each controller's run of each condition
    passes the success test at T_f (:func:`striatal.sim.robust.run_case`, one
    simulation each, ``len(controllers) * len(conditions)`` in all)."""
    return np.array(
        [[run_case(c, cond, plant=nominal).success for cond in conditions] for c in controllers],
        dtype=bool,
    ).reshape(len(controllers), len(conditions))


def sweep_controllers(rows: Sequence[dict[str, Any]]) -> dict[str, dict[int, Controller]]:
    """The controllers of a sweep's runs.csv rows that succeeded (with ``--robust``:
    passed the robustness set), by arm and seed."""
    out: dict[str, dict[int, Controller]] = {}
    for r in rows:
        if str(r.get("success")) not in ("1", "True"):
            continue
        try:
            gains = tuple(float(r[f"W{i}"]) for i in range(1, N_GAINS + 1))
            out.setdefault(r["arm"], {})[int(r["seed"])] = Controller(
                gains=gains, theta_c=float(r["theta_c"])
            )
        except (KeyError, ValueError, ParameterError) as exc:
            raise ParameterError(f"runs.csv row without valid W and theta_c: {exc}") from None
    return out


def margin_table(
    arms: dict[str, dict[int, Controller]],
    reference: str = "random",
    conditions: Sequence[Perturbation] = MARGIN_CONDITIONS,
) -> tuple[str, list[dict[str, Any]]]:
    """Markdown table of the margin set for each arm's solved seeds: the fraction of
    conditions passed per controller (median and mean), beside ``reference``'s on the
    seeds both solved (Wilcoxon signed-rank p, and seeds better / worse), and the
    simulations run; and the rows, one per arm and condition."""
    from scipy.stats import wilcoxon

    passes = {
        arm: dict(zip(ctrls, margin_passes(list(ctrls.values()), conditions), strict=True))
        for arm, ctrls in arms.items()
    }
    rows: list[dict[str, Any]] = []
    lines = [
        f"| arm | controllers | conditions passed per controller: mean, median | "
        f"paired with {reference} (seeds both solved): mean of both, better / worse, "
        "Wilcoxon p | simulations |",
        "|---|---|---|---|---|",
    ]
    ref = passes.get(reference, {})
    for arm, by_seed in passes.items():
        frac = np.array([v.mean() for v in by_seed.values()])
        cell = "-"
        if arm != reference and ref:
            shared = sorted(set(by_seed) & set(ref))
            a = np.array([by_seed[s].mean() for s in shared])
            b = np.array([ref[s].mean() for s in shared])
            diff = a - b
            p = float(wilcoxon(a, b).pvalue) if np.any(diff != 0) else 1.0
            cell = (
                f"n = {len(shared)}: {100 * a.mean():.1f} % vs {100 * b.mean():.1f} %, "
                f"{int((diff > 0).sum())} / {int((diff < 0).sum())}, p = {p:.2g}"
            )
        lines.append(
            f"| {arm} | {len(frac)} | {100 * frac.mean():.1f} %, {100 * np.median(frac):.1f} % "
            f"| {cell} | {len(frac) * len(conditions)} |"
        )
        stacked = np.array(list(by_seed.values())).reshape(len(by_seed), len(conditions))
        for j, cond in enumerate(conditions):
            rows.append(
                {
                    "arm": arm,
                    "condition": cond.name,
                    "runs": len(by_seed),
                    "success": float(stacked[:, j].mean()) if len(by_seed) else float("nan"),
                }
            )
    return "\n".join(lines) + "\n", rows


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
