"""Sweeps over seeds and settings: run specs, a pure worker, backends, resume, statistics.

A sweep is a list of :class:`RunSpec` (frozen, picklable); :func:`run_one` turns one
spec into one row of ``runs.csv`` and depends on nothing else, so the local process
pool and a Ray cluster give the same rows for the same specs.

Seeds: run i of a sweep with root seed R has the integer seed
``SeedSequence(R).spawn(N)[i].generate_state(1)[0]`` (:func:`spawn_seeds`). Every arm
uses the same seeds, and a learner row with seed S is exactly
``striatal train --seed S --init <init> <the same learner options>`` (random W(0) is
drawn as train draws it, from ``default_rng([S, 1])``).

The control arm is the learner with alpha = 0: the gains W never change, while
theta_c still follows eq 21 (the rule does not involve alpha).

Resume: rows are appended and flushed to runs.csv as runs finish; a rerun with the
same output folder reads the rows back (dropping a last line a kill cut short) and
runs only the missing (arm, init, seed). The summary is computed from the rows
sorted by (arm, init, seed), so it does not depend on completion order.
"""

from __future__ import annotations

import csv
import io
import logging
import math
import time
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, TextIO

import numpy as np

from striatal import baselines
from striatal.errors import DataFileError, ParameterError
from striatal.files import atomic_write_text, csv_text
from striatal.learners import LearnerConfig, learn, random_initial_gains
from striatal.params import CHAPTER_INITIAL_W, N_GAINS, Controller, Plant, Simulation
from striatal.rollout import Protocol, simulate

Init = Literal["chapter", "random"]
Backend = Literal["local", "ray"]
METHODS: tuple[str, ...] = ("learn", *baselines.BASELINES)
CONTROL_ARM = "control"

RUN_COLUMNS: tuple[str, ...] = (
    "arm",
    "method",
    "init",
    "seed",
    "alpha",
    "gamma",
    "success",
    "trials",
    *(f"W{i}" for i in range(1, N_GAINS + 1)),
    "theta_c",
    *(f"W0_{i}" for i in range(1, N_GAINS + 1)),
    "theta_c0",
    "mean_policy_success",
    "wall_seconds",
)
_INT_COLUMNS = ("seed", "trials")
_BOOL_COLUMNS = ("success", "mean_policy_success")
_STR_COLUMNS = ("arm", "method", "init")

NOTE_CONTROL = (
    "control arm: alpha = 0, so the gains W never change; theta_c still follows eq 21 "
    "(the threshold rule does not involve alpha), as in the learner arm"
)


@dataclass(frozen=True)
class RunSpec:
    """One run: an arm (learner settings or a baseline), a start and a seed.

    ``template`` carries theta_c(0) and the readings (balance sign, switch,
    inhibition); its gains are replaced by W(0) of ``init``.
    """

    arm: str
    method: str
    init: Init
    seed: int
    config: LearnerConfig
    template: Controller
    plant: Plant
    sim: Simulation

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.arm, self.init, self.seed)


def spawn_seeds(root: int, n: int) -> tuple[int, ...]:
    """The n integer run seeds of root seed ``root``: SeedSequence(root).spawn(n)[i]."""
    if n < 1:
        raise ParameterError(f"the number of seeds must be >= 1, got {n}")
    if root < 0:
        raise ParameterError(f"the root seed must be >= 0, got {root}")
    return tuple(int(child.generate_state(1)[0]) for child in np.random.SeedSequence(root).spawn(n))


def initial_gains(init: Init, seed: int) -> tuple[float, ...]:
    """W(0): the chapter's, or uniform in [-1, 1]^6 drawn as ``striatal train --init random``."""
    if init == "chapter":
        return CHAPTER_INITIAL_W
    if init == "random":
        return random_initial_gains(np.random.default_rng([seed, 1]))
    raise ParameterError(f"init must be 'chapter' or 'random', got {init!r}")


def learning_run(
    plant: Plant, template: Controller, config: LearnerConfig, seed: int, sim: Simulation
) -> dict[str, Any]:
    """success, trials, W and theta_c of one finished :func:`striatal.learners.learn` run.

    train turns Ctrl-C into a partial result; a cut run must never be recorded as
    finished, so it is raised again here as KeyboardInterrupt.
    """
    result = learn(plant, template, config, seed, sim=sim)
    if result.interrupted:
        raise KeyboardInterrupt
    return {
        "success": result.success,
        "trials": result.trials,
        "W": result.W,
        "theta_c": result.theta_c,
    }


def run_one(spec: RunSpec) -> dict[str, Any]:
    """One run -> one row (RUN_COLUMNS). Pure: the same spec gives the same row
    (except wall_seconds)."""
    t0 = time.perf_counter()
    W0 = initial_gains(spec.init, spec.seed)
    theta_c0 = spec.template.theta_c
    template = spec.template.with_gains(W0, theta_c0)
    cfg = spec.config
    out: dict[str, Any]
    if spec.method == "learn":
        out = learning_run(spec.plant, template, cfg, spec.seed, spec.sim)
    elif spec.method in ("lqr", "hand"):
        if spec.method == "lqr":
            W, theta_c = baselines.lqr_controller(spec.plant)
        else:
            W, theta_c = baselines.CHAPTER_FINAL_W, baselines.CHAPTER_FINAL_THETA_C
        out = baselines.fixed_controller(
            spec.plant, template, spec.sim, W, theta_c, spec.seed, cfg.max_trials, cfg.success_on
        )
    elif spec.method == "random":
        out = baselines.random_search(
            spec.plant, template, spec.sim, spec.seed, cfg.max_trials, cfg.success_on
        )
    elif spec.method == "cmaes":
        out = baselines.cmaes(
            spec.plant,
            template,
            spec.sim,
            W0,
            theta_c0,
            spec.seed,
            cfg.max_trials,
            cfg.success_on,
        )
    else:
        raise ParameterError(f"unknown method {spec.method!r}; choose from {', '.join(METHODS)}")
    final = template.with_gains(out["W"], out["theta_c"]) if out["W"][0] > 0 else None
    mean_ok = (
        final is not None
        and simulate(spec.plant, final, spec.sim, protocol=Protocol()).outcome.success
    )
    row: dict[str, Any] = {
        "arm": spec.arm,
        "method": spec.method,
        "init": spec.init,
        "seed": spec.seed,
        "alpha": cfg.alpha,
        "gamma": cfg.gamma,
        "success": bool(out["success"]),
        "trials": int(out["trials"]),
    }
    row.update({f"W{i + 1}": float(w) for i, w in enumerate(out["W"])})
    row["theta_c"] = float(out["theta_c"])
    row.update({f"W0_{i + 1}": float(w) for i, w in enumerate(W0)})
    row["theta_c0"] = float(theta_c0)
    row["mean_policy_success"] = bool(mean_ok)
    row["wall_seconds"] = time.perf_counter() - t0
    return row


def _ray_worker(spec: RunSpec) -> dict[str, Any]:
    return run_one(spec)


def execute(
    specs: Sequence[RunSpec],
    *,
    backend: Backend = "local",
    workers: int = 1,
    address: str | None = None,
) -> Iterator[dict[str, Any]]:
    """Rows of ``specs`` in completion order.

    local: in this process (workers 1) or a ProcessPoolExecutor of ``workers``
    processes (module-level worker, safe under spawn and forkserver). ray: tasks on the
    existing Ray cluster at ``address`` (extra [cluster]).
    """
    if workers < 1:
        raise ParameterError(f"--workers must be >= 1, got {workers}")
    if backend == "ray":
        yield from _execute_ray(specs, address)
        return
    if backend != "local":
        raise ParameterError(f"backend must be 'local' or 'ray', got {backend!r}")
    if workers == 1 or len(specs) <= 1:
        for spec in specs:
            yield run_one(spec)
        return
    with ProcessPoolExecutor(max_workers=workers) as pool:
        pending = {pool.submit(run_one, s) for s in specs}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    yield fut.result()
        finally:
            for fut in pending:
                fut.cancel()


def _execute_ray(specs: Sequence[RunSpec], address: str | None) -> Iterator[dict[str, Any]]:
    if not address:
        raise ParameterError("--backend ray needs --address HOST:PORT of a running Ray cluster")
    try:
        import ray
    except ImportError:
        raise ParameterError(
            "--backend ray needs the [cluster] extra: pip install 'striatal[cluster]'"
        ) from None
    ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(_ray_worker)
        pending = [remote.remote(s) for s in specs]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield ray.get(ref)
    finally:
        ray.shutdown()


def row_text(row: dict[str, Any]) -> str:
    """One CSV line (no header) of ``row`` in RUN_COLUMNS order."""
    cells = [int(row[c]) if c in _BOOL_COLUMNS else row[c] for c in RUN_COLUMNS]
    return csv_text(RUN_COLUMNS, [cells]).split("\n", 1)[1]


def _parse_row(cells: list[str]) -> dict[str, Any]:
    if len(cells) != len(RUN_COLUMNS):
        raise ValueError(f"{len(cells)} cells, expected {len(RUN_COLUMNS)}")
    row: dict[str, Any] = {}
    for name, cell in zip(RUN_COLUMNS, cells, strict=True):
        if name in _STR_COLUMNS:
            if not cell:
                raise ValueError(f"empty {name}")
            row[name] = cell
        elif name in _INT_COLUMNS:
            row[name] = int(cell)
        elif name in _BOOL_COLUMNS:
            if cell not in ("0", "1"):
                raise ValueError(f"{name} must be 0 or 1, got {cell!r}")
            row[name] = cell == "1"
        else:
            row[name] = float(cell) if cell else math.nan
    return row


def read_runs(path: Path) -> tuple[list[dict[str, Any]], str]:
    """(rows, clean text) of runs.csv; a last line that does not parse is dropped.

    A last line without its newline or that does not parse is what a kill during
    a write leaves; any other bad line raises DataFileError.
    """
    if not path.exists():
        return [], csv_text(RUN_COLUMNS, [])
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"runs file {path} cannot be read: {exc}") from None
    lines = text.splitlines(keepends=True)
    header = ",".join(RUN_COLUMNS)
    if not lines or not lines[0].endswith("\n"):
        return [], csv_text(RUN_COLUMNS, [])
    if lines[0].strip() != header:
        raise DataFileError(f"runs file {path} does not have the header of a striatal sweep")
    rows: list[dict[str, Any]] = []
    kept = [lines[0]]
    for i, line in enumerate(lines[1:], start=2):
        last = i == len(lines)
        try:
            if not line.endswith("\n"):
                raise ValueError("line cut short")
            cells = next(csv.reader(io.StringIO(line)))
            rows.append(_parse_row(cells))
        except (ValueError, StopIteration, csv.Error) as exc:
            if last:
                break
            raise DataFileError(f"runs file {path} line {i} is malformed: {exc}") from None
        kept.append(line)
    return rows, "".join(kept)


def _quantile(values: Sequence[float], q: float) -> float:
    return float(np.quantile(np.asarray(values, dtype=float), q)) if values else math.nan


def arm_statistics(rows: Sequence[dict[str, Any]], max_trials: int) -> dict[str, Any]:
    """Success rate, trials to success (median, quartiles over solved runs), unsolved share.

    ``trials_median_all`` counts unsolved runs as ``max_trials`` (a lower bound on
    their true trials to success).
    """
    n = len(rows)
    solved = [float(r["trials"]) for r in rows if r["success"]]
    every = [float(r["trials"]) if r["success"] else float(max_trials) for r in rows]
    wall = [float(r["wall_seconds"]) for r in rows]
    return {
        "runs": n,
        "successes": len(solved),
        "success_rate": len(solved) / n if n else math.nan,
        "unsolved_share": (n - len(solved)) / n if n else math.nan,
        "trials_median": _quantile(solved, 0.5),
        "trials_q1": _quantile(solved, 0.25),
        "trials_q3": _quantile(solved, 0.75),
        "trials_median_all": _quantile(every, 0.5),
        "mean_policy_success_rate": (
            sum(bool(r["mean_policy_success"]) for r in rows) / n if n else math.nan
        ),
        "wall_seconds_total": float(sum(wall)),
        "wall_seconds_median": _quantile(wall, 0.5),
    }


def sort_rows(rows: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(rows, key=lambda r: (r["arm"], r["init"], int(r["seed"])))


def summarise(
    rows: Sequence[dict[str, Any]], max_trials: int, settings: dict[str, Any]
) -> dict[str, Any]:
    """summary.json: statistics per (arm, init) in sorted order, learner vs control, settings."""
    ordered = sort_rows(rows)
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in ordered:
        groups.setdefault((r["arm"], r["init"]), []).append(r)
    arms = [
        {"arm": arm, "init": init, "method": g[0]["method"], **arm_statistics(g, max_trials)}
        for (arm, init), g in groups.items()
    ]
    side_by_side = []
    for a in arms:
        if a["method"] == "learn" and a["arm"] != CONTROL_ARM:
            ctrl = next(
                (c for c in arms if c["arm"] == CONTROL_ARM and c["init"] == a["init"]), None
            )
            if ctrl is not None:
                side_by_side.append(
                    {
                        "init": a["init"],
                        "arm": a["arm"],
                        "success_rate": a["success_rate"],
                        "control_success_rate": ctrl["success_rate"],
                        "trials_median": a["trials_median"],
                        "control_trials_median": ctrl["trials_median"],
                    }
                )
    return {
        "arms": arms,
        "learner_vs_control": side_by_side,
        "notes": [NOTE_CONTROL],
        "settings": settings,
    }


def markdown_table(summary: dict[str, Any]) -> str:
    """The comparison table of a summary, one line per (arm, init)."""

    def num(v: Any, fmt: str = "g") -> str:
        return "-" if v is None or not math.isfinite(v) else format(v, fmt)

    lines = [
        "| arm | init | runs | success | trials to success: median [q1, q3] | "
        "unsolved at max | mean policy passes | wall s (total) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for a in summary["arms"]:
        lines.append(
            f"| {a['arm']} | {a['init']} | {a['runs']} | {num(a['success_rate'], '.0%')} | "
            f"{num(a['trials_median'])} [{num(a['trials_q1'])}, {num(a['trials_q3'])}] | "
            f"{num(a['unsolved_share'], '.0%')} | {num(a['mean_policy_success_rate'], '.0%')} | "
            f"{num(a['wall_seconds_total'], '.1f')} |"
        )
    return "\n".join(lines) + "\n"


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
) -> tuple[list[RunSpec], dict[str, dict[str, Any]]]:
    """(specs, config of each arm): the grid of alpha x gamma (default: config's own),
    the alpha = 0 control arm, and the baselines, each for every init and seed."""
    alphas = tuple(alphas) or (config.alpha,)
    gammas = tuple(gammas) or (config.gamma,)
    grid = len(alphas) * len(gammas) > 1
    arms: list[tuple[str, str, LearnerConfig]] = [
        (arm_label(a, g, grid), "learn", replace(config, alpha=a, gamma=g))
        for a in alphas
        for g in gammas
    ]
    if control:
        arms.append((CONTROL_ARM, "learn", replace(config, alpha=0.0)))
    for m in methods:
        if m not in baselines.BASELINES:
            raise ParameterError(
                f"unknown baseline {m!r}; choose from {', '.join(baselines.BASELINES)}"
            )
        arms.append((m, m, config))
    names = [a[0] for a in arms]
    if len(set(names)) != len(names):
        raise ParameterError("two arms of the sweep have the same name; check the grid")
    for init in inits:
        initial_gains(init, 0)
    specs = [
        RunSpec(arm, method, init, int(seed), cfg, template, plant, sim)
        for arm, method, cfg in arms
        for init in inits
        for seed in seeds
    ]
    arm_settings = {arm: {"method": method, "config": cfg.to_dict()} for arm, method, cfg in arms}
    return specs, arm_settings


@dataclass(frozen=True)
class SweepResult:
    rows: list[dict[str, Any]]
    ran: int
    skipped: int
    summary: dict[str, Any]


def sweep(
    specs: Sequence[RunSpec],
    settings: dict[str, Any],
    *,
    out: Path | None,
    max_trials: int,
    backend: Backend = "local",
    workers: int = 1,
    address: str | None = None,
    progress: bool = False,
) -> SweepResult:
    """Run the specs not already in ``out``/runs.csv, appending each row as it finishes,
    then write ``out``/summary.json (atomically) from all rows.

    ``settings`` is stored in ``out``/sweep.json; a rerun in the same folder must use
    the same settings (ParameterError otherwise).
    """
    from tqdm import tqdm

    from striatal.files import read_json, write_json

    rows: list[dict[str, Any]] = []
    stream: TextIO | None = None
    wanted = {s.key for s in specs}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        spath = out / "sweep.json"
        if spath.exists():
            old = read_json(spath, what="sweep settings")
            if old != json_roundtrip(settings):
                raise ParameterError(
                    f"{out} holds a sweep with other settings; use another --out "
                    "or the same options to resume it"
                )
        else:
            write_json(spath, settings)
        rpath = out / "runs.csv"
        old_rows, clean = read_runs(rpath)
        rows = [r for r in old_rows if (r["arm"], r["init"], r["seed"]) in wanted]
        atomic_write_text(rpath, clean)
        stream = rpath.open("a", encoding="utf-8", newline="")
    done = {(r["arm"], r["init"], r["seed"]) for r in rows}
    todo = [s for s in specs if s.key not in done]
    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), unit="run", disable=not progress)
    try:
        for row in execute(todo, backend=backend, workers=workers, address=address):
            rows.append(row)
            if stream is not None:
                stream.write(row_text(row))
                stream.flush()
            bar.update(1)
    finally:
        bar.close()
        if stream is not None:
            stream.close()
    summary = summarise(rows, max_trials, settings)
    if out is not None:
        write_json(out / "summary.json", summary)
    return SweepResult(
        rows=sort_rows(rows), ran=len(todo), skipped=len(specs) - len(todo), summary=summary
    )


def json_roundtrip(obj: Any) -> Any:
    """``obj`` as it reads back from JSON (tuples become lists, non-finite floats None)."""
    import json

    from striatal.files import dumps_json

    return json.loads(dumps_json(obj))
