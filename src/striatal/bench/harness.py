"""The ``striatal bench`` report: every measurement of :mod:`striatal.bench` in one run.

:func:`run_all` measures, :class:`BenchReport` holds the result (``to_dict`` is the
``--json`` report), :func:`format_report` is the table ``striatal bench`` prints.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from striatal.bench import anchors
from striatal.bench.measure import (
    batch_vs_gymnasium_vector,
    first_calls,
    machine,
    scalar_vs_gymnasium,
    scaling,
    second_process,
    sweep_memory,
    sweep_scaling,
    train_wall,
)
from striatal.bench.timing import BenchConfig, Comparison

__all__ = ["BenchReport", "format_report", "run_all"]


@dataclass(frozen=True)
class BenchReport:
    """Everything ``striatal bench`` measured; ``not_measured`` names what was skipped and why."""

    config: BenchConfig
    machine: dict[str, Any]
    compile: dict[str, Any]
    scalar_vs_gymnasium: Comparison
    batch_vs_gymnasium_vector: Comparison
    scaling: dict[str, Any]
    train: dict[str, Any] | None
    sweep: dict[str, Any] | None
    sweep_memory: dict[str, Any] | None
    not_measured: dict[str, str]
    total_seconds: float
    anchors: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "config": asdict(self.config),
            "machine": self.machine,
            "compile": self.compile,
            "scalar_vs_gymnasium": self.scalar_vs_gymnasium.to_dict(),
            "batch_vs_gymnasium_vector": self.batch_vs_gymnasium_vector.to_dict(),
            "scaling": self.scaling,
            "train": self.train,
            "sweep": self.sweep,
            "sweep_memory": self.sweep_memory,
            "not_measured": self.not_measured,
            "total_seconds": self.total_seconds,
            "anchors": self.anchors,
        }


def run_all(config: BenchConfig, seed: int = 0) -> BenchReport:
    """Every measurement in one process, in the order compile, 1, 2, 4, 3, anchors."""
    config.check_work()  # before anything is timed
    if config.anchors:
        anchors.check_installed()  # before anything is timed
    t_start = time.perf_counter()
    rng = np.random.default_rng(seed)
    here = first_calls(rng)
    compile_info = {"this_process": here, "second_process": second_process()}
    if config.cold_compile:
        import tempfile

        with tempfile.TemporaryDirectory(prefix="striatal-numba-") as empty:
            compile_info["cold_process"] = second_process(cache_dir=empty)
    scalar = scalar_vs_gymnasium(config, rng)
    batch = batch_vs_gymnasium_vector(config, rng)
    grow = scaling(config, rng)
    train = train_wall(config.train_max_trials) if config.train else None
    sweep = (
        sweep_scaling(config.sweep_seeds, config.sweep_max_trials) if config.sweep_seeds else None
    )
    memory = (
        sweep_memory(config.memory_runs, config.memory_max_trials) if config.memory_runs else None
    )
    anchor_rows = anchors.measure(config, rng) if config.anchors else None
    not_measured: dict[str, str] = {}
    if anchor_rows is None:
        not_measured["anchors"] = "skipped (no --anchors)"
    elif (why := anchors.gymnax_missing()) is not None:
        not_measured["anchors_gymnax"] = why
    if train is None:
        not_measured["train"] = "skipped (--no-train)"
    if sweep is None:
        not_measured["sweep"] = "skipped (--sweep-seeds 0)"
    if memory is None:
        not_measured["sweep_memory"] = "skipped (--memory-runs 0)"
    return BenchReport(
        config=config,
        machine=machine(),
        compile=compile_info,
        scalar_vs_gymnasium=scalar,
        batch_vs_gymnasium_vector=batch,
        scaling=grow,
        train=train,
        sweep=sweep,
        sweep_memory=memory,
        not_measured=not_measured,
        total_seconds=time.perf_counter() - t_start,
        anchors=anchor_rows,
    )


def format_report(report: BenchReport) -> str:
    """The human-readable table printed by ``striatal bench``."""
    m = report.machine
    lines = [
        f"machine: {m['cpu_model']}, {m['logical_cores']} logical cores, "
        f"{m['numba_threads']} Numba threads; numpy {m['numpy']}, numba {m['numba']}, "
        f"gymnasium {m['gymnasium']}",
    ]
    here = report.compile["this_process"]
    second = report.compile["second_process"]
    lines.append(
        "compile/warm-up (excluded from all rates): first run_trial "
        f"{here['first_run_trial_seconds']:.3f} s, first run_trials_lockstep "
        f"{here['first_run_trials_batch_seconds']:.3f} s "
        f"({'compile included' if here['compile_included'] else 'loaded from cache'}); "
        f"second process {second['first_run_trial_seconds']:.3f} s + "
        f"{second['first_run_trials_batch_seconds']:.3f} s "
        f"({'compile included' if second['compile_included'] else 'loaded from cache'})"
    )
    cold = report.compile.get("cold_process")
    if cold is not None:
        lines.append(
            "cold start (empty Numba cache, compile included): first run_trial "
            f"{cold['first_run_trial_seconds']:.2f} s, first run_trials_lockstep "
            f"{cold['first_run_trials_batch_seconds']:.2f} s"
        )
    for key, comp in (
        ("scalar_vs_gymnasium", report.scalar_vs_gymnasium),
        ("batch_vs_gymnasium_vector", report.batch_vs_gymnasium_vector),
    ):
        lines.append(
            f"{key}: {comp.kernel.best_steps_per_second:,.0f} steps/s "
            f"vs {comp.reference.best_steps_per_second:,.0f} steps/s = {comp.ratio:.1f}x "
            f"(median {comp.median_ratio:.1f}x; target >= {comp.target_ratio:g}x)"
        )
        lines.append(f"  kernel:    {comp.kernel.name}")
        lines.append(f"  reference: {comp.reference.name}")
    vp = report.batch_vs_gymnasium_vector.extra["lockstep_vs_prange"]
    lines.append(
        f"lockstep_vs_prange: {vp['kernel']['best_steps_per_second']:,.0f} steps/s vs "
        f"{vp['reference']['best_steps_per_second']:,.0f} steps/s = {vp['ratio']:.1f}x "
        f"(median {vp['median_ratio']:.1f}x; target >= {vp['target_ratio']:g}x)"
    )
    fit = report.scaling["fit"]
    lines.append(
        f"scaling: time per trial = {fit['intercept'] * 1e6:.1f} us + "
        f"{fit['ns_per_step']:.1f} ns x n_steps, R^2 = {fit['r2']:.5f}"
    )
    for row in report.scaling["rows"]:
        lines.append(
            f"  {row['duration']:>7g} s  {row['n_steps']:>7d} steps  "
            f"{row['seconds_per_trial'] * 1e3:.3f} ms/trial"
        )
    if report.train is not None:
        t = report.train
        lines.append(
            f"train: `{t['command']}` {t['process_wall_seconds']:.2f} s wall "
            f"({t['learning_loop_seconds']:.2f} s learning loop, {t['trials']} trials, "
            f"success={t['success']})"
        )
    if report.sweep is not None:
        sw = report.sweep
        for key in ("one_worker", "all_workers"):
            r = sw[key]
            lines.append(
                f"sweep: `{r['command']}` {r['runs']} runs, {r['wall_seconds']:.1f} s wall"
            )
        lines.append(f"  speed-up 1 -> all workers: {sw['speedup']:.2f}x")
    if report.sweep_memory is not None:
        for key in ("small", "large"):
            r = report.sweep_memory[key]
            lines.append(
                f"memory: `{r['command']}` {r['runs']} runs, peak RSS {r['peak_rss_mib']:.0f} MiB"
            )
    if report.anchors is not None:
        for key, comp in report.anchors.items():
            if key == "versions":
                continue
            lines.append(
                f"anchor {key}: {comp['kernel']['best_steps_per_second']:,.0f} steps/s vs "
                f"{comp['reference']['best_steps_per_second']:,.0f} steps/s = "
                f"{comp['ratio']:.1f}x (median {comp['median_ratio']:.1f}x)"
            )
            lines.append(f"  kernel:    {comp['kernel']['name']}")
            lines.append(f"  reference: {comp['reference']['name']}")
    for name, why in report.not_measured.items():
        lines.append(f"not measured: {name}: {why}")
    lines.append(f"total {report.total_seconds:.1f} s")
    return "\n".join(lines)
