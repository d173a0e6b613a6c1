"""A sweep: arms x inits x seeds, run on an engine, resumable, summarised.

:func:`sweep` is the Python API of ``striatal sweep`` (the same defaults and the same
rows and summary for the same arguments); :func:`plan` turns its arguments into run
specs and the settings recorded in sweep.json; :func:`run_sweep` runs specs.

Resume: rows are appended and flushed to runs.csv as runs finish; a rerun with the
same output folder reads the rows back (dropping a last line a kill cut short) and
runs only the missing (arm, init, seed). Each row carries the id of the settings it
was computed with (:func:`settings_id`): a row of other settings is never reused.
The output folder is locked
(:meth:`striatal.io.rundir.RunDir.lock`) while a sweep runs in it.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, TextIO

from striatal import arguments
from striatal.errors import ParameterError
from striatal.experiments import baselines as baseline_methods
from striatal.experiments.pool import (
    CONNECT_TIMEOUT,
    Backend,
    check_backend,
    check_cluster,
    execute,
)
from striatal.experiments.report import summarise
from striatal.experiments.results import Sweep
from striatal.experiments.runner import (
    CONTROL_ARM,
    EVAL_DRAWS,
    NOTE_BUDGET,
    NOTE_ROBUST,
    NOTE_SIMD,
    ROLES,
    control_note,
)
from striatal.experiments.runs_csv import read_runs, row_text, sort_rows
from striatal.experiments.spec import SEED_RULE, Init, RunSpec, initial_gains, spawn_seeds
from striatal.io.files import atomic_write_text, check_out_dir
from striatal.io.rundir import RunDir
from striatal.learners import LearnerConfig, default_config, rule_of
from striatal.learners.config import (
    Eligibility,
    ForwardModel,
    RewardKind,
    SuccessOn,
    ThetaCRule,
    require_count,
)
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    BalanceSign,
    Controller,
    Plant,
    Simulation,
    SwitchKind,
    check_seed,
)
from striatal.sim.rollout import Protocol

Engine = Literal["processes", "batch", "simd"]


#: How a sweep runs its specs: one learning loop per run, or the runs of an arm in lockstep
#: on the exact batch kernel ("batch") or on the SIMD lockstep kernel ("simd").
ENGINES: tuple[str, ...] = ("processes", "batch", "simd")


def arm_label(alpha: float, gamma: float, grid: bool) -> str:
    return f"learner a={alpha:g} g={gamma:g}" if grid else "learner"


def build_specs(
    *,
    config: LearnerConfig,
    template: Controller,
    plant: Plant,
    sim: Simulation,
    seeds: Sequence[int],
    inits: Sequence[Init],
    alphas: Sequence[float] = (),
    gammas: Sequence[float] = (),
    control: bool = True,
    methods: Sequence[str] = (),
    eval_draws: int = 0,
) -> tuple[list[RunSpec], dict[str, dict[str, Any]]]:
    """(specs, config of each arm): the grid of alpha x gamma (default: config's own),
    the learner's declared no-learning control arm, and the baselines, each for every
    init and seed."""
    alphas = tuple(alphas) or (config.alpha,)
    gammas = tuple(gammas) or (config.gamma,)
    grid = len(alphas) * len(gammas) > 1
    arms: list[Arm] = [
        Arm(arm_label(a, g, grid), "learn", replace(config, alpha=a, gamma=g))
        for a in alphas
        for g in gammas
    ]
    if control:
        arms.append(Arm(CONTROL_ARM, "learn", rule_of(config).control_config(config), "control"))
    for m in methods:
        if m not in baseline_methods.BASELINES:
            raise ParameterError(
                f"unknown baseline {m!r}; choose from {', '.join(baseline_methods.BASELINES)}"
            )
        arms.append(Arm(m, m, config, "baseline"))
    return specs_of(
        arms,
        template=template,
        plant=plant,
        sim=sim,
        seeds=seeds,
        inits=inits,
        eval_draws=eval_draws,
    )


@dataclass(frozen=True)
class Arm:
    """One arm of a sweep: a name, a method ("learn" or a baseline), its config, its role."""

    name: str
    method: str
    config: LearnerConfig
    role: str = "learner"

    def settings(self) -> dict[str, Any]:
        return {"method": self.method, "role": self.role, "config": self.config.to_dict()}


def specs_of(
    arms: Sequence[Arm],
    *,
    template: Controller,
    plant: Plant,
    sim: Simulation,
    seeds: Sequence[int],
    inits: Sequence[Init],
    eval_draws: int = 0,
) -> tuple[list[RunSpec], dict[str, dict[str, Any]]]:
    """(specs, settings of each arm): every arm for every init and seed."""
    names = [a.name for a in arms]
    if len(set(names)) != len(names):
        raise ParameterError("two arms of the sweep have the same name; check the grid")
    if not arms:
        raise ParameterError("the sweep has no arm to run")
    for a in arms:
        if a.role not in ROLES:
            raise ParameterError(f"arm role must be one of {', '.join(ROLES)}, got {a.role!r}")
    if eval_draws < 0:
        raise ParameterError(f"--eval-draws must be >= 0, got {eval_draws}")
    for init in inits:
        initial_gains(init, 0)
    specs = [
        RunSpec(
            a.name, a.method, init, int(seed), a.config, template, plant, sim, a.role, eval_draws
        )
        for a in arms
        for init in inits
        for seed in seeds
    ]
    return specs, {a.name: a.settings() for a in arms}


def run_sweep(
    specs: Sequence[RunSpec],
    settings: dict[str, Any],
    *,
    out: Path | None,
    max_trials: int,
    backend: Backend = "local",
    workers: int = 1,
    address: str | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
    progress: bool = False,
    engine: Engine = "processes",
    locked: bool = False,
    on_run: Callable[[dict[str, Any]], None] | None = None,
) -> Sweep:
    """Run the specs not already in ``out``/runs.csv, appending each row as it finishes,
    then write ``out``/summary.json (atomically) from all rows.

    ``engine`` "processes": :func:`execute` (one learning loop per run, on ``backend``);
    "batch": :func:`striatal.experiments.lockstep_sweep.execute_batch` (every run in this
    process, side by side, their trials batched; the same rows but wall_seconds); "simd":
    the same on the SIMD kernel (:func:`striatal.sim.kernel.run_trials_lockstep`), rows
    equal only within round-off (docs/performance.md), so ``settings`` gets
    ``trial_kernel`` (:data:`NOTE_SIMD`) and a folder is never resumed across the two kinds.

    ``settings`` is stored in ``out``/sweep.json; a rerun in the same folder must use
    the same settings (ParameterError otherwise), ``settings["options"]`` aside: the
    options as they were given, recorded for ``--print-config --from-summary``.
    ``out`` is locked for the whole sweep: a second sweep on it gets DataFileError.
    ``locked``: the caller already holds ``RunDir(out).lock()`` (to write more files
    under the same lock). ``on_run`` is called with each row as it is written (a
    :class:`striatal.io.tracking.Tracker`'s ``on_run``, e.g. TensorBoard).
    """
    if engine not in ENGINES:
        raise ParameterError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if engine != "processes" and (backend != "local" or workers != 1):
        raise ParameterError(
            f"--engine {engine} runs in this process on Numba's threads "
            "(NUMBA_NUM_THREADS); --workers and --backend ray are for --engine processes"
        )
    check_backend(backend, workers, address, connect_timeout)
    if backend == "ray" and address:
        # nothing is written into out before the cluster answers a whole connection
        check_cluster(address, connect_timeout)
    if engine != "processes":
        from striatal.experiments.lockstep_sweep import check_specs

        check_specs(specs)
    if engine == "simd":
        # its rows are not the exact kernel's: recorded, so a folder never mixes the two
        settings = {**settings, "trial_kernel": NOTE_SIMD}
    # a folder not yet locked is locked for the whole sweep
    guard = contextlib.nullcontext() if out is None or locked else RunDir(out).lock()
    with guard:
        return _run_sweep(
            specs,
            settings,
            out,
            max_trials,
            backend,
            workers,
            address,
            connect_timeout,
            progress,
            engine,
            on_run,
        )


def _run_sweep(
    specs: Sequence[RunSpec],
    settings: dict[str, Any],
    out: Path | None,
    max_trials: int,
    backend: Backend,
    workers: int,
    address: str | None,
    connect_timeout: float,
    progress: bool,
    engine: Engine = "processes",
    on_run: Callable[[dict[str, Any]], None] | None = None,
) -> Sweep:
    from tqdm import tqdm

    from striatal.io.files import write_json
    from striatal.io.schema import read_sweep_settings

    rows: list[dict[str, Any]] = []
    stream: TextIO | None = None
    wanted = {s.key for s in specs}
    ids = {s.arm: settings_id(s, settings.get("trial_kernel")) for s in specs}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        spath = out / "sweep.json"
        checked = spath.exists()
        if checked:
            old = read_sweep_settings(spath)
            # settings.options records how the sweep was asked for (an option left to its
            # default or given at that value), the rest what it computes: only that counts
            new = json_roundtrip(settings)
            new.pop("options", None)
            if isinstance(old, dict):
                old.pop("options", None)
            if old != new:
                differ = settings_differences(old, new)
                raise ParameterError(
                    f"{out} holds a sweep with other settings ({', '.join(differ)}); use "
                    "another --out or the same options to resume it"
                )
        rpath = out / "runs.csv"
        old_rows, clean = read_runs(rpath, max_trials=max_trials)
        check_row_settings(old_rows, ids, checked=checked, where=rpath)
        if not checked:
            write_json(spath, settings)
        rows = [r for r in old_rows if (r["arm"], r["init"], r["seed"]) in wanted]
        atomic_write_text(rpath, clean)
        stream = rpath.open("a", encoding="utf-8", newline="")
    done = {(r["arm"], r["init"], r["seed"]) for r in rows}
    todo = [s for s in specs if s.key not in done]
    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), unit="run", disable=not progress)
    try:
        if engine != "processes":
            from striatal.experiments.lockstep_sweep import execute_batch

            rows_in = execute_batch(todo, engine=engine)
        else:
            rows_in = execute(
                todo,
                backend=backend,
                workers=workers,
                address=address,
                connect_timeout=connect_timeout,
            )
        for row in rows_in:
            row = {**row, "settings_id": ids[row["arm"]]}
            rows.append(row)
            if stream is not None:
                stream.write(row_text(row))
                stream.flush()
            if on_run is not None:
                on_run(row)
            bar.update(1)
    finally:
        bar.close()
        if stream is not None:
            stream.close()
    summary = summarise(rows, max_trials, settings)
    if out is not None:
        write_json(out / "summary.json", summary)
    return Sweep(
        rows=sort_rows(rows),
        summary=summary,
        folder=out,
        ran=len(todo),
        skipped=len(specs) - len(todo),
    )


def settings_id(spec: RunSpec, trial_kernel: str | None = None) -> str:
    """The id of the settings a run of ``spec`` computes with (runs.csv's ``settings_id``):
    a short hash of its arm (method, role, config) and of what every arm shares (the
    controller template, plant, trial, evaluation draws; ``trial_kernel``, the SIMD
    kernel's note, when set). The arm's name, init and seed are the row's key, not part
    of the id: every run of an arm has the same id."""
    import hashlib
    import json
    from dataclasses import asdict

    text = json.dumps(
        json_roundtrip(
            {
                "method": spec.method,
                "role": spec.role,
                "config": spec.config.to_dict(),
                "template": spec.template.to_dict(),
                "plant": spec.plant.to_dict(),
                "sim": asdict(spec.sim),
                "eval_draws": spec.eval_draws,
                "trial_kernel": trial_kernel,
                # only when set, so the ids of the kernel's runs stay as they were
                **({} if spec.network is None else {"network": spec.network.to_dict()}),
            }
        ),
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def check_row_settings(
    rows: Sequence[dict[str, Any]], ids: dict[str, str], *, checked: bool, where: Path
) -> None:
    """ParameterError unless every row of runs.csv ``where`` was computed with the settings
    of its arm here (``ids``: arm -> :func:`settings_id`). A row without an id (a file of
    an older striatal) is taken only when ``checked``: sweep.json is there and matches."""
    other = [r for r in rows if r["settings_id"] and ids.get(r["arm"]) != r["settings_id"]]
    if other:
        arms = ", ".join(dict.fromkeys(r["arm"] for r in other))
        raise ParameterError(
            f"{where.parent} holds rows of other settings ({len(other)} of {len(rows)} "
            f"rows in {where.name}, arm {arms}); use another --out"
        )
    if not checked and any(not r["settings_id"] for r in rows):
        raise ParameterError(
            f"{where.parent} holds rows without a settings id and no sweep.json to check "
            "them against; use another --out"
        )


def settings_differences(old: Any, new: dict[str, Any]) -> list[str]:
    """The settings keys in which sweep.json ``old`` differs from ``new``: top-level keys,
    and for ``arms`` the arm (``arms.NAME``) or its fields (``arms.NAME.config.FIELD``)."""
    if not isinstance(old, dict):
        return ["sweep.json is not an object"]
    keys: list[str] = []
    for k in dict.fromkeys([*new, *old]):
        a, b = old.get(k), new.get(k)
        if a == b:
            continue
        if k == "arms" and isinstance(a, dict) and isinstance(b, dict):
            keys.extend(_arm_differences(a, b))
        else:
            keys.append(k)
    return keys


def _arm_differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    keys: list[str] = []
    for name in dict.fromkeys([*new, *old]):
        a, b = old.get(name), new.get(name)
        if a == b:
            continue
        if not (isinstance(a, dict) and isinstance(b, dict)):
            keys.append(f"arms.{name}")
            continue
        for field in dict.fromkeys([*b, *a]):
            fa, fb = a.get(field), b.get(field)
            if fa == fb:
                continue
            if field == "config" and isinstance(fa, dict) and isinstance(fb, dict):
                keys.extend(
                    f"arms.{name}.config.{f}"
                    for f in dict.fromkeys([*fb, *fa])
                    if fa.get(f) != fb.get(f)
                )
            else:
                keys.append(f"arms.{name}.{field}")
    return keys


def json_roundtrip(obj: Any) -> Any:
    """``obj`` as it reads back from JSON (tuples become lists, non-finite floats None)."""
    import json

    from striatal.io.files import dumps_json

    return json.loads(dumps_json(obj))


#: Seeds per arm and init of a sweep: the number every documented result uses (a
#: success rate's 95 % interval is then about +-10 points).
SEEDS = 100
#: The most seeds a sweep takes (its run specs are built before any run starts).
MAX_SEEDS = 100_000
#: The most runs (arms x inits x seeds) a sweep holds.
MAX_RUNS = 1_000_000


@dataclass(frozen=True)
class Plan:
    """What a sweep runs (``specs``) and records (``settings``, stored in sweep.json)."""

    specs: list[RunSpec]
    settings: dict[str, Any]
    max_trials: int


def _numbers(name: str, values: object) -> tuple[float, ...]:
    """``values`` as a tuple of real numbers (a grid), else ParameterError naming ``name``."""
    items = tuple(values) if isinstance(values, Sequence) and not isinstance(values, str) else None
    if items is None or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in items
    ):
        raise ParameterError(f"{name} must be a list of numbers, got {values!r}")
    return tuple(float(v) for v in items)


def plan(
    learner: str | None = None,
    *,
    seeds: int = SEEDS,
    seed: int = 0,
    init: str | Sequence[str] = "chapter",
    theta_c0: float = CHAPTER_INITIAL_THETA_C,
    alpha_grid: Sequence[float] = (),
    gamma_grid: Sequence[float] = (),
    control: bool = True,
    eval_draws: int = EVAL_DRAWS,
    baselines: Sequence[str] = (),
    plant: Plant | None = None,
    sim: Simulation | None = None,
    balance_sign: str | None = None,
    switch: str | None = None,
    inhibition: float | None = None,
    **options: Any,
) -> Plan:
    """The run specs and settings of a sweep (arguments as :func:`sweep`), validated."""
    require_count("seeds", seeds)
    if seeds > MAX_SEEDS:
        raise ParameterError(f"--seeds must be <= {MAX_SEEDS}, got {seeds}")
    root = check_seed(seed)
    require_count("eval_draws", eval_draws, 0)
    alphas, gammas = _numbers("alpha_grid", alpha_grid), _numbers("gamma_grid", gamma_grid)
    methods = (baselines,) if isinstance(baselines, str) else baselines
    if not isinstance(methods, Sequence) or not all(isinstance(m, str) for m in methods):
        raise ParameterError(f"baselines must be names of baselines, got {baselines!r}")
    inits = (init,) if isinstance(init, str) else tuple(init) if isinstance(init, Sequence) else ()
    if not inits or not all(isinstance(i, str) for i in inits):
        raise ParameterError(f"init must be 'chapter', 'random' or a list of them, got {init!r}")
    inits = tuple(dict.fromkeys(inits))
    runs = seeds * len(inits) * max(1, len(alphas)) * max(1, len(gammas))
    runs += seeds * len(inits) * (int(bool(control)) + len(methods))
    if runs > MAX_RUNS:
        raise ParameterError(
            f"the sweep would hold {runs} runs (arms x inits x seeds), at most {MAX_RUNS}"
        )
    config = default_config(learner or "chapter", **options)
    check_libraries(config)
    plant = Plant() if plant is None else plant
    sim = Simulation() if sim is None else sim
    if not isinstance(plant, Plant) or not isinstance(sim, Simulation):
        raise ParameterError("plant must be a striatal.Plant and sim a striatal.Simulation")
    arguments.check_learning_work(
        runs,
        config.max_trials,
        config.imagine_trials if config.learner == "forward" else 0,
        math.ceil(sim.duration / sim.dt),
        eval_draws,
        "the sweep",
    )
    readings: dict[str, Any] = {
        "balance_sign": balance_sign,
        "switch": switch,
        "inhibition": inhibition,
    }
    template = Controller(
        gains=CHAPTER_INITIAL_W,
        theta_c=theta_c0,
        **{k: v for k, v in readings.items() if v is not None},
    )
    run_seeds = spawn_seeds(root, seeds)
    specs, arm_settings = build_specs(
        config=config,
        template=template,
        plant=plant,
        sim=sim,
        seeds=run_seeds,
        inits=inits,  # type: ignore[arg-type]
        alphas=alphas,
        gammas=gammas,
        control=control,
        methods=list(methods),
        eval_draws=eval_draws,
    )
    settings: dict[str, Any] = {
        "command": "striatal sweep",
        "root_seed": root,
        "seeds": seeds,
        "run_seeds": list(run_seeds),
        "seed_rule": SEED_RULE,
        "inits": list(inits),
        "theta_c0": template.theta_c,
        "max_trials": config.max_trials,
        "success_on": config.success_on,
        "arms": arm_settings,
        "control": control,
        "control_reading": control_note(config.learner),
        "budget": NOTE_BUDGET,
        "eval_draws": eval_draws,
        "controller": {
            "balance_sign": template.balance_sign,
            "switch": template.switch,
            "inhibition": template.inhibition,
        },
        "plant": plant.to_dict(),
        "trial": {"dt": sim.dt, "duration": sim.duration, "theta0": sim.theta0, "x0": sim.x0},
        "protocol": json_roundtrip(Protocol().__dict__),
        "baselines": {
            "lqr": lqr_settings(plant),
            "random_box": [
                baseline_methods.RANDOM_BOX[0].tolist(),
                baseline_methods.RANDOM_BOX[1].tolist(),
            ],
            "cmaes": "IPOP-CMA-ES: sigma0 1 from (W(0), theta_c(0)), cma's default "
            "population (9), restarted with twice the population when cma stops, "
            "minimising minus the shaped reward",
        },
        "reproduce": "striatal train --seed S --init INIT with the same learner options "
        "(control arm: the options of settings.arms.control.config)",
    }
    if config.robust:
        # only when set, so the settings of sweeps without it stay as they were
        settings["robust"] = NOTE_ROBUST
    tuning_root = rule_of(config).tuning_root_of(config)
    if tuning_root is not None:
        settings["tuning_root"] = tuning_root
    return Plan(specs, settings, config.max_trials)


def lqr_settings(plant: Plant) -> dict[str, Any]:
    """The LQR baseline's fit to ``plant`` as sweep.json records it; ParameterError (one
    line, before any run) when the Riccati equation has no solution for that plant."""
    from numpy.linalg import LinAlgError

    try:
        return baseline_methods.lqr_fit(plant).to_dict()
    except (LinAlgError, ArithmeticError) as exc:
        raise ParameterError(
            f"the LQR baseline cannot be fitted to this plant (--cart-mass, --pole-mass, "
            f"--length, --gravity): {str(exc).splitlines()[0][:120]}"
        ) from None


def check_libraries(config: LearnerConfig) -> None:
    """ParameterError, before any run or file, if a library the runs need does not load
    (not merely missing: a broken install fails only on import)."""
    if config.learner == "forward" and config.forward_model != "structured":
        try:
            import sklearn.linear_model
            import sklearn.pipeline
            import sklearn.preprocessing  # noqa: F401
        except Exception as exc:
            first = (str(exc).splitlines() or [type(exc).__name__])[0][:200]
            raise ParameterError(
                f"--forward-model {config.forward_model} needs scikit-learn, which does not load "
                f"({first}): "
                "pip install 'striatal[model]'"
            ) from None


def in_sample_note(settings: dict[str, Any]) -> str | None:
    """The warning for a sweep run on the root its preset was tuned on, else None."""
    root = settings.get("tuning_root")
    if root is None or root != settings["root_seed"]:
        return None
    return (
        f"note: the preset was tuned on root seed {root}: these are its tuning seeds, "
        "not a held-out evaluation (use another --seed)"
    )


#: The learner options of :func:`sweep` (the fields of LearnerConfig but ``learner``):
#: None keeps the learner's preset (:func:`striatal.learners.default_config`), except
#: ``max_force`` and ``track``, where None is "no limit", as in LearnerConfig.
LEARNER_OPTIONS = (
    "alpha",
    "gamma",
    "baseline",
    "action_every",
    "reset_trace",
    "eligibility",
    "success_on",
    "theta_c_rule",
    "max_trials",
    "max_step",
    "w1_floor",
    "reward",
    "rpe_rate",
    "normalise",
    "explore",
    "sigma_rate",
    "decay",
    "plant_jitter",
    "symmetric",
    "robust",
    "stop_margin",
    "margin_after_success",
    "critic_rate",
    "td_discount",
    "critic_decay",
    "imagine_trials",
    "imagine_round",
    "imagine_duration",
    "forward_model",
    "imagine_margin",
    "max_force",
    "track",
)


def sweep(
    learner: str | None = None,
    *,
    out: str | os.PathLike[str] | None = None,
    seeds: int = SEEDS,
    seed: int = 0,
    init: str | Sequence[str] = "chapter",
    theta_c0: float = CHAPTER_INITIAL_THETA_C,
    alpha_grid: Sequence[float] | None = None,
    gamma_grid: Sequence[float] | None = None,
    control: bool = True,
    eval_draws: int = EVAL_DRAWS,
    baselines: Sequence[str] = (),
    plant: Plant | None = None,
    sim: Simulation | None = None,
    balance_sign: BalanceSign | None = None,
    switch: SwitchKind | None = None,
    inhibition: float | None = None,
    alpha: float | None = None,
    gamma: float | None = None,
    baseline: float | None = None,
    action_every: int | None = None,
    reset_trace: bool | None = None,
    eligibility: Eligibility | None = None,
    success_on: SuccessOn | None = None,
    theta_c_rule: ThetaCRule | None = None,
    max_trials: int | None = None,
    max_step: float | None = None,
    w1_floor: float | None = None,
    reward: RewardKind | None = None,
    rpe_rate: float | None = None,
    normalise: bool | None = None,
    explore: float | None = None,
    sigma_rate: float | None = None,
    decay: float | None = None,
    plant_jitter: float | None = None,
    symmetric: bool | None = None,
    robust: bool | None = None,
    stop_margin: float | None = None,
    margin_after_success: bool | None = None,
    critic_rate: float | None = None,
    td_discount: float | None = None,
    critic_decay: float | None = None,
    imagine_trials: int | None = None,
    imagine_round: int | None = None,
    imagine_duration: float | None = None,
    forward_model: ForwardModel | None = None,
    imagine_margin: float | None = None,
    max_force: float | None = None,
    track: float | None = None,
    engine: Engine = "processes",
    workers: int = 1,
    backend: Backend = "local",
    address: str | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
    progress: bool = False,
    on_run: Callable[[dict[str, Any]], None] | None = None,
) -> Sweep:
    """Many learning runs over seeds, as ``striatal sweep`` runs them (same defaults).

    ``learner``: a key of :data:`striatal.learners.RULES` (default "chapter").
    ``seeds`` per arm and init (100), from the root ``seed`` (0); ``init`` "chapter" or
    "random" or both; ``theta_c0`` [rad]; ``alpha_grid``, ``gamma_grid``: a grid of
    learner arms; ``control``: the learner's no-learning control arm; ``eval_draws``
    (200) noisy draws judging W(0) and the final W; ``baselines`` from
    :data:`striatal.experiments.baseline_methods.BASELINES`; ``plant``, ``sim`` and the
    controller readings. ``alpha`` ... ``track``: the
    :class:`striatal.learners.LearnerConfig` fields, None keeping the learner's preset.
    Every argument is checked, before anything runs or is written, against the one
    table the command line uses (:mod:`striatal.arguments`, LearnerConfig's fields).
    Every arm runs on the same seeds: the learner, its no-learning control and the
    baselines. With ``out``, runs.csv, sweep.json and summary.json are written there and
    a rerun resumes (:func:`run_sweep`). ``on_run(row)`` is called with each run's row
    (a dict of runs.csv's columns) as it finishes, in this process, whatever the engine
    or backend; rows already in ``out`` from an earlier call are not replayed. Returns a
    :class:`~striatal.experiments.results.Sweep`: its ``.runs`` (rows sorted by (arm, init,
    seed)), ``.arms`` (each rate with its interval), ``.summary`` and ``.plot()`` (the
    performance profiles).

    >>> result = sweep(seeds=4, init="random", learner="pgpe", max_trials=50)  # doctest: +SKIP
    >>> [(a.name, a.success_rate, a.interval) for a in result.arms]  # doctest: +SKIP
    >>> result.plot().savefig("profiles.png")  # doctest: +SKIP
    """
    given = dict(locals())
    if on_run is not None and not callable(on_run):
        raise ParameterError(f"on_run must be a function of one row, got {on_run!r}")
    if out is not None and (
        not isinstance(out, str | os.PathLike) or not str(os.fspath(out)).strip()
    ):
        raise ParameterError(f"out must be a folder's path, got {out!r}")
    checked = arguments.check_all(
        {k: v for k, v in given.items() if k in arguments.ARGS and k not in LEARNER_OPTIONS}
    )
    options = {k: arguments.plain(given[k]) for k in LEARNER_OPTIONS if given[k] is not None}
    folder = None if out is None else check_out_dir(out)
    the_plan = plan(
        learner,
        seeds=checked["seeds"],
        seed=checked["seed"],
        init=checked["init"],
        theta_c0=checked["theta_c0"],
        alpha_grid=checked["alpha_grid"] or (),
        gamma_grid=checked["gamma_grid"] or (),
        control=checked["control"],
        eval_draws=checked["eval_draws"],
        baselines=checked["baselines"],
        plant=plant,
        sim=sim,
        balance_sign=None if balance_sign is None else checked["balance_sign"],
        switch=None if switch is None else checked["switch"],
        inhibition=None if inhibition is None else checked["inhibition"],
        **options,
    )
    return run_sweep(
        the_plan.specs,
        the_plan.settings,
        out=folder,
        max_trials=the_plan.max_trials,
        backend=checked["backend"],
        workers=checked["workers"],
        address=checked["address"],
        connect_timeout=checked["connect_timeout"],
        progress=checked["progress"],
        engine=checked["engine"],
        on_run=on_run,
    )
