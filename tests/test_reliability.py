"""Reliability scenarios: bad input, numerical faults, interrupted runs, files as data.

Each scenario tries one thing a user (or a crash) can do to striatal and records
what happened. The parametrized test checks each one; ``test_doc_matches`` checks
that the table in docs/reliability.md is the one these scenarios produce now.
Regenerate it with

    STRIATAL_WRITE_RELIABILITY=1 .venv/bin/pytest tests/test_reliability.py

A scenario with ``gap`` set shows a known weakness in a file this suite does not
own: it is an xfail(strict=True), so it fails loudly once the fix lands and the
gap note can go.
"""

from __future__ import annotations

import ast
import contextlib
import csv
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import cli_in_process, cli_process, cli_process_env, default_sigint

from striatal.errors import DataFileError, ParameterError, StriatalError
from striatal.experiments.pool import WATCHDOG_SECONDS
from striatal.io.files import read_json
from striatal.learners import LearnerConfig, initial_state, learning_step
from striatal.learners.chapter import gain_update
from striatal.params import CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.sim.rollout import Protocol, SensorNoise, TrialRequest, run_trial

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "reliability.md"
WRITE_ENV = "STRIATAL_WRITE_RELIABILITY"

# Train runs long enough (1-2 s of trials) to be interrupted in the middle, after
# KILL_AFTER trials: the chapter's learner runs all 1500 trials without success; the
# "rpe" learner (a tracked reward baseline in its checkpoint) succeeds after 890.
TRAIN_LONG = ("--seed", "4", "--max-trials", "1500", "--checkpoint-every", "25", "--no-progress")
TRAIN_RPE = ("--learner", "rpe", "--seed", "5", *TRAIN_LONG[2:])
# long enough that no fast machine finishes it before the last SIGINT of int-start lands
TRAIN_ENDLESS = ("--seed", "4", "--max-trials", "1000000", "--no-progress")
KILL_AFTER = 200
# A sweep of 16 runs (8 seeds, learner and control arm), ~3 s of runs, interrupted after
# SWEEP_KILL_AFTER rows of runs.csv; rerunning the same command resumes it.
SWEEP = (
    "sweep", "--seeds", "8", "--max-trials", "300", "--duration", "20", "--no-progress",
)  # fmt: skip
SWEEP_KILL_AFTER = 5


# --------------------------------------------------------------------------- runners


def snapshot(folder: Path) -> dict[str, bytes]:
    if not folder.exists():
        return {}
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    return lines[-1] if lines else ""


# --------------------------------------------------------------------------- scenarios


@dataclass(frozen=True)
class Scenario:
    """One thing tried. ``run(tmp)`` returns (as expected?, what happened)."""

    key: str
    kind: str
    tried: str
    expected: str
    run: Callable[[Path], tuple[bool, str]]
    gap: str = ""


def usage_error(
    argv: tuple[str, ...],
    *,
    process: bool = False,
    prepare: Callable[[Path], None] | None = None,
    says: str = "",
    untouched_too: bool = True,
) -> Callable[[Path], tuple[bool, str]]:
    """Expect exit 2, nothing on stdout, one line on stderr, no traceback, no file touched.

    ``OUT`` in argv stands for a fresh folder under the test's tmp dir; ``says``, when
    given, must appear in the line (the error names the real problem).
    ``untouched_too=False``: only the message is checked, not the files.
    """

    def run(tmp: Path) -> tuple[bool, str]:
        out = tmp / "OUT"
        if prepare is not None:
            prepare(out)
        before = snapshot(out)
        args = tuple(a.replace("OUT", str(out)) if a.startswith("OUT") else a for a in argv)
        r = cli_process(*args) if process else cli_in_process(*args)
        lines = r.err.strip().splitlines()
        same = snapshot(out) == before and (prepare is not None or not out.exists())
        untouched = same or not untouched_too
        ok = (
            r.rc == 2 and r.out == "" and len(lines) == 1 and "Traceback" not in r.err and untouched
        )
        line = one_line(r.err).replace(str(out), "OUT")
        ok = ok and says in line
        # where and why the JSON parser stopped depends on the file's layout, not on striatal
        line = re.sub(r"\(truncated or corrupted\?\): .*", "(truncated or corrupted?): ...", line)
        if "Traceback" in r.err:
            return ok, f"exit {r.rc}, a Python traceback ending `{line}`"
        written = (
            "nothing written" if same else "files not checked" if untouched else "FILES CHANGED"
        )
        return ok, f"exit {r.rc}, {len(lines)} line: `{line}`; {written}"

    return run


def runs(argv: tuple[str, ...], says: str) -> Callable[[Path], tuple[bool, str]]:
    """Expect exit 0 and ``says`` in what is printed."""

    def run(tmp: Path) -> tuple[bool, str]:
        r = cli_in_process(*argv)
        line = next((s for s in r.out.splitlines() if says in s), one_line(r.err or r.out))
        return r.rc == 0 and says in r.out, f"exit {r.rc}: `{line}`"

    return run


def non_utf8_stdout(encoding: str) -> Callable[[Path], tuple[bool, str]]:
    """``striatal interpret`` prints theta as a Greek letter; a stdout that cannot hold it."""

    def run(tmp: Path) -> tuple[bool, str]:
        r = cli_process_env({"PYTHONIOENCODING": encoding}, "interpret", "--chapter-final")
        line = next((s for s in r.out.splitlines() if s.startswith("mu_1")), "")
        ok = r.rc == 0 and r.err == "" and "\\u03b8" in line
        err = "empty" if not r.err else repr(one_line(r.err))
        return ok, f"exit {r.rc}, stderr {err}; `{line}`"

    return run


def _peak_rss_mb(*argv: str) -> tuple[int, float]:
    """(exit code, peak resident memory [MB]) of ``python -m striatal ARGV`` alone."""
    probe = (
        "import resource, subprocess, sys; "
        "r = subprocess.run([sys.executable, '-m', 'striatal', *sys.argv[1:]], "
        "stdout=subprocess.DEVNULL); "
        "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    )
    r = subprocess.run(
        [sys.executable, "-c", probe, *argv], capture_output=True, text=True, timeout=600
    )
    rc, kib = r.stdout.split()
    return int(rc), int(kib) / 1024


STREAM_STEPS = 200_000


def streamed_trajectory(tmp: Path) -> tuple[bool, str]:
    """Writing trajectory.csv adds little memory: rows are formatted a chunk at a time.

    Before, the whole trajectory became Python lists and one string first (about
    600 bytes a step: 6 GB at the 10,000,000-step limit).
    """
    run = ("simulate", "--duration", str(STREAM_STEPS // 10), "--dt", "0.1")
    rc0, without = _peak_rss_mb(*run)
    rc1, with_out = _peak_rss_mb(*run, "--out", str(tmp / "OUT"))
    extra = with_out - without
    ok = rc0 == rc1 == 0 and extra < 40
    # the megabytes vary from machine to machine; the table states the bound
    return ok, f"exit {rc1}; writing {STREAM_STEPS:,} rows adds < 40 MB: {'yes' if ok else 'no'}"


def library_error(
    make: Callable[[Path], object], error: type[StriatalError]
) -> Callable[[Path], tuple[bool, str]]:
    def run(tmp: Path) -> tuple[bool, str]:
        try:
            make(tmp)
        except StriatalError as exc:
            message = str(exc).replace(str(tmp), "DIR")
            return isinstance(exc, error), f"`{type(exc).__name__}: {message}`"
        except Exception as exc:
            return False, f"untyped `{type(exc).__name__}: {exc}`"
        return False, "accepted"

    return run


def _read_text_as_json(tmp: Path, text: str) -> Any:
    path = tmp / "bad.json"
    path.write_text(text)
    return read_json(path)


def _a_file(out: Path) -> None:
    out.mkdir(parents=True)
    (out / "file").write_text("not a folder\n")


def _result_file(out: Path) -> None:
    assert cli_in_process("train", "--max-trials", "2", "--out", str(out)).rc == 0
    for name in ("checkpoint.json", "history.csv"):
        (out / name).unlink()


def _random_result(out: Path) -> None:
    out.mkdir(parents=True)
    _random_bytes(out / "result.json")


def _fifo(out: Path) -> None:
    out.mkdir(parents=True)
    os.mkfifo(out / "result.json")


def _folder_result(out: Path) -> None:
    (out / "result.json").mkdir(parents=True)


def _huge_result(out: Path) -> None:
    """A sparse file one byte over the limit: refused by its size, never read."""
    from striatal.io.files import MAX_INPUT_BYTES

    out.mkdir(parents=True)
    with (out / "result.json").open("wb") as fh:
        fh.truncate(MAX_INPUT_BYTES + 1)


def _dangling(out: Path) -> None:
    out.mkdir(parents=True)
    (out / "link").symlink_to(out / "nowhere" / "x")


def _folder_at(name: str) -> Callable[[Path], None]:
    def prepare(out: Path) -> None:
        (out / name).mkdir(parents=True)

    return prepare


def _random_history(out: Path) -> None:
    out.mkdir(parents=True)
    _random_bytes(out / "history.csv")


def _text_in_history(out: Path) -> None:
    _checkpointed_run(out)
    lines = (out / "history.csv").read_text().splitlines(keepends=True)
    lines[3] = lines[3].replace(lines[3].split(",")[2], "x", 1)
    (out / "history.csv").write_text("".join(lines))


def _null_settings(out: Path) -> None:
    _result_file(out)
    _edit_json(lambda d: d.__setitem__("settings", None))(out / "result.json")


def _checkpointed_run(out: Path) -> None:
    assert cli_in_process("train", "--max-trials", "5", "--out", str(out)).rc == 0


def _with_checkpoint(edit: Callable[[Path], None]) -> Callable[[Path], None]:
    def prepare(out: Path) -> None:
        _checkpointed_run(out)
        edit(out / "checkpoint.json")

    return prepare


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])


def _random_bytes(path: Path) -> None:
    path.write_bytes(np.random.default_rng(8).bytes(600))


def _edit_json(change: Callable[[dict[str, Any]], None]) -> Callable[[Path], None]:
    def edit(path: Path) -> None:
        data = json.loads(path.read_text())
        change(data)
        path.write_text(json.dumps(data))

    return edit


def _nan_gain(d: dict[str, Any]) -> None:
    d["state"]["W"][1] = "NaN-placeholder"


def _nan_token(path: Path) -> None:
    path.write_text(path.read_text().replace('"NaN-placeholder"', "NaN"))


def _nan_gain_checkpoint(path: Path) -> None:
    _edit_json(_nan_gain)(path)
    _nan_token(path)


def _rng_garbage(d: dict[str, Any]) -> None:
    d["state"]["rng_state"] = {"bit_generator": "MT19937"}
    d["settings"]["config"]["max_trials"] = 8


def _drop_seed(d: dict[str, Any]) -> None:
    del d["settings"]["seed"]


def _text_settings(d: dict[str, Any]) -> None:
    d["settings"] = "x"


def _text_max_trials(d: dict[str, Any]) -> None:
    d["settings"]["config"]["max_trials"] = "many"


def _history_gone(out: Path) -> None:
    _checkpointed_run(out)
    (out / "history.csv").unlink()


def _checkpoint_dir(out: Path) -> None:
    _checkpointed_run(out)
    (out / "checkpoint.json").unlink()
    (out / "checkpoint.json").mkdir()


def _history_cells_finite(path: Path) -> bool:
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        for key, cell in row.items():
            if key == "min_abs_theta_swingup" and cell == "":
                continue  # never in swing-up: the CSV null
            if not math.isfinite(float(cell)):
                return False
    return bool(rows)


def absurd_alpha(
    *extra: str, failure: float = -5.0, success_on_trial: bool = True
) -> Callable[[Path], tuple[bool, str]]:
    """``failure``: the reward of a failed trial (-5 sparse, 0 for the shaped reward).

    ``success_on_trial`` False: success is judged on a mean-policy rerun (pgpe), so a
    faulted exploratory trial can still end the run with success.
    """

    def run(tmp: Path) -> tuple[bool, str]:
        out = tmp / "OUT"
        argv = ["train", "--alpha", "1000", "--max-trials", "300", "--out", str(out), *extra]
        r = cli_in_process(*argv)
        result = read_json(out / "result.json")
        with (out / "history.csv").open(newline="") as fh:
            rows = list(csv.DictReader(fh))
        faults = [row for row in rows if row["fault"] == "1"]
        finite = all(math.isfinite(w) for w in result["W"]) and 0 < result["theta_c"] < math.pi
        counted = all(
            float(row["reward"]) == failure and (row["success"] == "0" or not success_on_trial)
            for row in faults
        )
        cells = _history_cells_finite(out / "history.csv")
        ok = r.rc == 0 and finite and counted and cells and bool(faults)
        return ok, (
            f"exit {r.rc}; some trials end in a numerical fault: "
            f"{'yes' if faults else 'no'}, each one a failure with reward {failure:g}: "
            f"{'yes' if counted else 'no'}; W and theta_c finite: {'yes' if finite else 'no'}; "
            f"every history cell finite: {'yes' if cells else 'no'}"
        )

    return run


def printed_sign_fault(tmp: Path) -> tuple[bool, str]:
    out = tmp / "OUT"
    r = cli_in_process(
        "simulate", "--chapter-final", "--balance-sign", "chapter", "--out", str(out)
    )
    summary = read_json(out / "summary.json")  # strict: NaN/Infinity tokens are rejected
    text = (out / "trajectory.csv").read_text().lower()
    clean = "nan" not in text and "inf" not in text
    ok = r.rc == 0 and summary["fault"] is True and summary["success"] is False and clean
    return ok, (
        f"exit {r.rc}; summary.json fault = {str(summary['fault']).lower()}, success = "
        f"{str(summary['success']).lower()}, strict JSON; trajectory.csv has no nan/inf: "
        f"{'yes' if clean else 'no'}; printed: `{_fault_line(r.out)}`"
    )


def _fault_line(text: str) -> str:
    return next((s for s in text.splitlines() if "fault" in s), "")


def kernel_blow_up(tmp: Path) -> tuple[bool, str]:
    W = np.full(6, 1e300)
    trace = np.zeros(6)
    o = run_trial(
        TrialRequest(
            Plant(),
            Controller(CHAPTER_INITIAL_W, 0.6),
            Simulation(),
            protocol=Protocol(),
            trace=trace,
            gamma=0.999,
            rng=np.random.default_rng(0),
            gains=W,
        )
    )
    ok = o.fault and o.reward == -5.0 and not o.success
    return ok, (
        f"fault = {o.fault}, reward = {o.reward:g}, success = {o.success}, "
        f"ended at t = {o.ended_at:g} s"
    )


def learner_fault(tmp: Path) -> tuple[bool, str]:
    cfg = LearnerConfig(alpha=5.0, max_step=math.inf)
    W0 = (1.0, 0.0, 0.0, 1e12, 1e12, 0.0)
    state = initial_state(W0, 0.6, seed=0)
    new, rec = learning_step(state, Plant(), Controller(W0, 0.6), Simulation(), Protocol(), cfg)
    finite = all(math.isfinite(w) for w in new.W) and math.isfinite(new.theta_c)
    row_finite = all(math.isfinite(float(v)) for v in rec.row())
    ok = rec.fault and rec.reward == -5.0 and not rec.success and finite and row_finite
    return ok, (
        f"trial fault = {rec.fault}, reward = {rec.reward:g}, success = {rec.success}; "
        f"next W and theta_c finite: {finite}; history row finite: {row_finite}"
    )


def nan_trace(tmp: Path) -> tuple[bool, str]:
    W = np.array(CHAPTER_INITIAL_W)
    same = all(
        np.array_equal(
            gain_update(
                W,
                np.array([1, bad, 0, 0, 0, 0.0]),
                -5.0,
                alpha=5.0,
                gamma=0.999,
                baseline=0.0,
                max_step=1.0,
                w1_floor=1e-3,
            ),
            W,
        )
        for bad in (math.nan, math.inf, -math.inf)
    )
    return same, f"W unchanged for NaN, +inf, -inf: {same}"


# --------------------------------------------------------------------------- runs (issue 16)


def fresh_over_old_run(tmp: Path) -> tuple[bool, str]:
    """A fresh train into an old run's folder, crashing before its first checkpoint."""
    from unittest import mock

    import striatal.learners.loop as loop

    out = tmp / "OUT"
    assert cli_in_process("train", "--seed", "1", "--max-trials", "8", "--out", str(out)).rc == 0
    real = loop.learning_steps
    calls = {"n": 0}

    def crash(*args: Any, **kwargs: Any) -> Any:
        calls["n"] += 1
        if calls["n"] == 3:
            raise MemoryError("simulated crash")
        return (yield from real(*args, **kwargs))

    with mock.patch.object(loop, "learning_steps", crash):
        crashed = cli_in_process("train", "--seed", "2", "--max-trials", "40", "--out", str(out))
    left = sorted(p.name for p in out.iterdir())
    resumed = cli_in_process("train", "--resume", "--out", str(out))
    line = one_line(resumed.err).replace(str(out), "OUT")
    ok = crashed.rc != 0 and left == ["history.csv"] and resumed.rc == 2
    return ok, (
        f"the new run crashed (exit {crashed.rc}) after 2 trials; left in OUT: "
        f"{', '.join(left)} (the old checkpoint.json and result.json were removed at the "
        f"start); `--resume`: exit {resumed.rc}, `{line}`"
    )


def _two_runs(tmp: Path) -> tuple[Path, Path]:
    a, b = tmp / "A", tmp / "B"
    for out, seed in ((a, "1"), (b, "2")):
        r = cli_in_process(
            "train", "--seed", seed, "--max-trials", "12", "--checkpoint-every", "5",
            "--out", str(out),
        )  # fmt: skip
        assert r.rc == 0, r.err
    return a, b


def resume_mixed(name: str) -> Callable[[Path], tuple[bool, str]]:
    """--resume on run A's folder holding run B's ``name``: refused, nothing changed."""

    def run(tmp: Path) -> tuple[bool, str]:
        a, b = _two_runs(tmp)
        (a / name).write_bytes((b / name).read_bytes())
        before = snapshot(a)
        r = cli_in_process("train", "--resume", "--out", str(a))
        line = one_line(r.err).replace(str(a), "OUT")
        line = re.sub(r"\([0-9a-f]{16}\)", "(ID)", line)
        ok = r.rc == 2 and len(r.err.strip().splitlines()) == 1 and snapshot(a) == before
        written = "nothing written" if snapshot(a) == before else "FILES CHANGED"
        return ok, f"exit {r.rc}: `{line}`; {written}"

    return run


def two_trains(tmp: Path) -> tuple[bool, str]:
    """A second train on a folder another process holds (the lock taken here)."""
    from striatal.io.rundir import RunDir

    out = tmp / "OUT"
    with RunDir(out).lock():
        r = cli_process("train", "--max-trials", "3", "--out", str(out))
    line = one_line(r.err).replace(str(out), "OUT")
    ok = r.rc == 2 and len(r.err.strip().splitlines()) == 1 and not any(out.iterdir())
    return (
        ok,
        f"exit {r.rc}: `{line}`; nothing written: {'yes' if not any(out.iterdir()) else 'no'}",
    )


def locked_out(argv: tuple[str, ...]) -> Callable[[Path], tuple[bool, str]]:
    """``striatal ARGV --out DIR`` while this process holds DIR's lock: refused, no file."""

    def run(tmp: Path) -> tuple[bool, str]:
        from striatal.io.rundir import RunDir

        out = tmp / "OUT"
        with RunDir(out).lock():
            r = cli_process(*argv, "--out", str(out))
        line = one_line(r.err).replace(str(out), "OUT")
        empty = not any(out.iterdir())
        ok = r.rc == 2 and len(r.err.strip().splitlines()) == 1 and empty
        return ok, f"exit {r.rc}: `{line}`; nothing written: {'yes' if empty else 'no'}"

    return run


def resume_extends(tmp: Path) -> tuple[bool, str]:
    """`--resume --max-trials 40` on a finished 30-trial run = the uninterrupted 40-trial run."""
    ref, out = tmp / "ref", tmp / "OUT"
    assert cli_in_process("train", "--seed", "1", "--max-trials", "40", "--out", str(ref)).rc == 0
    assert cli_in_process("train", "--seed", "1", "--max-trials", "30", "--out", str(out)).rc == 0
    r = cli_in_process("train", "--resume", "--max-trials", "40", "--seed", "1", "--out", str(out))
    want, got = read_json(ref / "result.json"), read_json(out / "result.json")
    same = all(got[k] == want[k] for k in ("success", "trials", "W", "theta_c"))
    same_history = (out / "history.csv").read_bytes() == (ref / "history.csv").read_bytes()
    ok = r.rc == 0 and same and same_history
    return ok, (
        f"exit {r.rc}; success after {got['trials']} trials as the uninterrupted run: "
        f"{'yes' if same else 'no'}; history.csv identical: {'yes' if same_history else 'no'}"
    )


def absurd_pgpe_resumes(tmp: Path) -> tuple[bool, str]:
    """pgpe at the largest exploration and an absurd rate: finite files, resumable."""
    out = tmp / "OUT"
    args = ("train", "--learner", "pgpe", "--explore", "100", "--alpha", "1e300", "--decay", "0",
            "--duration", "2", "--checkpoint-every", "2", "--out", str(out))  # fmt: skip
    first = cli_in_process(*args, "--max-trials", "3")
    again = cli_in_process("train", "--resume", "--max-trials", "5", "--out", str(out))
    texts = [(out / n).read_text() for n in ("checkpoint.json", "result.json")]
    clean = all("null" not in t and "NaN" not in t for t in texts)
    rows = (out / "history.csv").read_text().splitlines()[1:]
    finite = all(math.isfinite(float(c)) for row in rows for c in row.split(",") if c)
    ok = first.rc == 0 and again.rc == 0 and clean and finite and len(rows) == 5
    return ok, (
        f"exit {first.rc}, then `--resume --max-trials 5`: exit {again.rc}; checkpoint.json and "
        f"result.json hold no null/NaN: {'yes' if clean else 'no'}; history rows {len(rows)}, "
        f"finite: {'yes' if finite else 'no'}"
    )


def files_follow_umask(tmp: Path) -> tuple[bool, str]:
    modes = {}
    for mask in (0o022, 0o077):
        out = tmp / f"OUT{mask:o}"
        old = os.umask(mask)
        try:
            assert cli_in_process("simulate", "--duration", "1", "--out", str(out)).rc == 0
        finally:
            os.umask(old)
        modes[mask] = {
            oct((out / n).stat().st_mode & 0o777) for n in ("summary.json", "trajectory.csv")
        }
    ok = modes[0o022] == {"0o644"} and modes[0o077] == {"0o600"}
    return ok, (
        f"umask 022: {', '.join(sorted(modes[0o022]))}; umask 077: "
        f"{', '.join(sorted(modes[0o077]))}"
    )


CODE_MODULES = {"pickle", "cPickle", "marshal", "shelve", "dill", "cloudpickle", "joblib"}
CODE_CALLS = {"eval", "exec"}


def _code_loaders(tree: ast.AST) -> list[int]:
    """Lines that import a code-loading module, call eval/exec, pass allow_pickle or yaml.load."""
    hits = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            bad = any(a.name.split(".")[0] in CODE_MODULES for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            bad = (node.module or "").split(".")[0] in CODE_MODULES
        elif isinstance(node, ast.Call):
            f = node.func
            bad = (isinstance(f, ast.Name) and f.id in CODE_CALLS) or (
                isinstance(f, ast.Attribute)
                and isinstance(f.value, ast.Name)
                and f.value.id == "yaml"
                and f.attr in ("load", "unsafe_load", "full_load")
            )
            bad = bad or any(k.arg == "allow_pickle" for k in node.keywords)
        else:
            bad = False
        if bad:
            hits.append(getattr(node, "lineno", 0))
    return hits


def no_code_in_files(tmp: Path) -> tuple[bool, str]:
    files = sorted((ROOT / "src" / "striatal").rglob("*.py"))
    hits = [
        f"{p.relative_to(ROOT)}:{line}"
        for p in files
        for line in _code_loaders(ast.parse(p.read_text(), str(p)))
    ]
    return not hits, ("no match" if not hits else "found in " + ", ".join(hits))


# ---- interruptions


def _complete_rows(path: Path) -> int:
    try:
        return max(path.read_text().count("\n") - 1, 0)
    except (OSError, UnicodeDecodeError):
        return 0


WALL = ("wall_seconds", "wall_seconds_total", "wall_seconds_median")


def _without_wall(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _without_wall(v) for k, v in obj.items() if k not in WALL}
    if isinstance(obj, list):
        return [_without_wall(v) for v in obj]
    return obj


def _runs_without_wall(path: Path) -> list[tuple[str, ...]]:
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    return sorted(tuple(v for k, v in row.items() if k not in WALL) for row in rows)


def sweep_reference(tmp: Path) -> dict[str, Any]:
    """summary.json and runs.csv rows (without wall times) of the uninterrupted SWEEP."""
    if "sweep" not in _REFERENCE:
        ref = tmp / "reference"
        r = cli_process(*SWEEP, "--out", str(ref))
        assert r.rc == 0, r.err
        _REFERENCE["sweep"] = {
            "summary": _without_wall(read_json(ref / "summary.json")),
            "runs": _runs_without_wall(ref / "runs.csv"),
        }
    return _REFERENCE["sweep"]


def _interpreter_start() -> float:
    """Seconds until striatal's own code runs: ``python -c "import striatal.cli"``, the
    slowest of three (about 0.05 s on an idle machine, more on a loaded one). Before
    that the interpreter itself is starting, and Ctrl-C is its to report."""
    times = []
    for _ in range(3):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import striatal.cli"], check=True)
        times.append(time.perf_counter() - t)
    return max(times)


def interrupt_at_start(delays: tuple[float, ...]) -> Callable[[Path], tuple[bool, str]]:
    """SIGINT ``delay`` seconds after striatal's code starts running in ``python -m
    striatal train ...``: while NumPy, Numba and the kernels load (about 1.5 s), or later."""

    def run(tmp: Path) -> tuple[bool, str]:
        seen = []
        for delay in delays:
            start = _interpreter_start()
            proc = subprocess.Popen(
                [sys.executable, "-m", "striatal", "train", *TRAIN_ENDLESS],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
                preexec_fn=default_sigint,
            )
            time.sleep(start + delay)
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=120)
            seen.append((delay, proc.returncode, "Traceback" in err))
        ok = all(rc == 130 and not tb for _, rc, tb in seen)
        return ok, "; ".join(
            f"after {d:g} s: exit {rc}{', a traceback' if tb else ''}" for d, rc, tb in seen
        )

    return run


def interrupted_sweep(sig: signal.Signals) -> Callable[[Path], tuple[bool, str]]:
    def run(tmp: Path) -> tuple[bool, str]:
        want = sweep_reference(tmp)
        out = tmp / "OUT"
        proc = subprocess.Popen(
            [sys.executable, "-m", "striatal", *SWEEP, "--out", str(out)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=default_sigint,
        )
        deadline = time.monotonic() + 120
        while _complete_rows(out / "runs.csv") < SWEEP_KILL_AFTER:
            assert proc.poll() is None, "the sweep ended before it could be interrupted"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        done = _complete_rows(out / "runs.csv")
        mid_run = SWEEP_KILL_AFTER <= done < len(want["runs"])
        stopped = proc.returncode == -sig
        no_summary = not (out / "summary.json").exists()
        again = cli_process(*SWEEP, "--out", str(out))
        m = re.search(r"ran (\d+) runs, (\d+) already in --out", again.out)
        skipped = bool(m) and int(m.group(2)) >= done - 1 and int(m.group(1)) > 0
        same = _without_wall(read_json(out / "summary.json")) == want["summary"]
        same_runs = _runs_without_wall(out / "runs.csv") == want["runs"]
        ok = mid_run and stopped and no_summary and again.rc == 0 and skipped and same
        ok = ok and same_runs and "Traceback" not in err
        code = (
            f"{proc.returncode} (killed by {sig.name})" if proc.returncode < 0 else proc.returncode
        )
        return ok, (
            f"stopped mid-sweep: {'yes' if mid_run else 'no'}, exit {code}, no summary.json "
            f"yet: {'yes' if no_summary else 'no'}; the same command again: exit {again.rc}, "
            f"skipped the finished runs: {'yes' if skipped else 'no'}; summary.json identical "
            f"(but wall_seconds_*): {'yes' if same else 'no'}; runs.csv rows identical (but "
            f"wall_seconds): {'yes' if same_runs else 'no'}"
        )

    return run


def interrupt_inside_sweep_run(tmp: Path) -> tuple[bool, str]:
    """KeyboardInterrupt (what SIGINT raises) from inside one run's learning loop."""
    from unittest import mock

    import striatal.learners.loop as learn_module

    want = sweep_reference(tmp)
    real = learn_module.learning_steps
    calls = {"n": 0}

    def learning_steps(*args: Any, **kwargs: Any) -> Any:
        calls["n"] += 1
        if calls["n"] == 30:
            raise KeyboardInterrupt
        return (yield from real(*args, **kwargs))

    out = tmp / "OUT"
    with mock.patch.object(learn_module, "learning_steps", learning_steps):
        first = cli_in_process(*SWEEP, "--out", str(out))
    rows = _runs_without_wall(out / "runs.csv")
    cut_recorded = any(row not in want["runs"] for row in rows)
    again = cli_process(*SWEEP, "--out", str(out))
    same = _without_wall(read_json(out / "summary.json")) == want["summary"]
    ok = first.rc == 130 and not cut_recorded and again.rc == 0 and same
    return ok, (
        f"exit {first.rc}; the cut run recorded in runs.csv as finished: "
        f"{'yes' if cut_recorded else 'no'}; after the rerun summary.json identical (but "
        f"wall_seconds_*): {'yes' if same else 'no'}"
    )


def same_seed_same_run(tmp: Path) -> tuple[bool, str]:
    runs = {}
    for name, seed in (("a", "3"), ("b", "3"), ("c", "6")):
        out = tmp / name
        r = cli_process("train", "--seed", seed, "--max-trials", "200", "--out", str(out))
        assert r.rc == 0, r.err
        result = read_json(out / "result.json")
        del result["wall_seconds"]
        runs[name] = (result, (out / "history.csv").read_bytes())
    same = runs["a"] == runs["b"]
    differs = runs["a"][1] != runs["c"][1]
    return same and differs, (
        f"seed 3 twice: result.json (but wall_seconds) and history.csv identical: "
        f"{'yes' if same else 'no'}; seed 6: history differs: {'yes' if differs else 'no'}"
    )


def interrupt_before_history_row(tmp: Path) -> tuple[bool, str]:
    """A signal that lands after a trial's state update but before its history row.

    SIGINT/SIGTERM raise KeyboardInterrupt wherever the interpreter is; here it is
    raised, deterministically, from the call that formats trial 10's history row.
    """
    from unittest import mock

    import striatal.io.rundir as train_cli

    real = train_cli.csv_text
    calls = {"rows": 0}

    def csv_text(header: Any, rows: Any) -> str:
        rows = list(rows)
        if rows:
            calls["rows"] += 1
            if calls["rows"] == 10:
                raise KeyboardInterrupt
        return real(header, rows)

    out = tmp / "OUT"
    with mock.patch.object(train_cli, "csv_text", csv_text):
        first = cli_in_process("train", "--max-trials", "20", "--out", str(out))
    resumed = cli_in_process("train", "--resume", "--out", str(out))
    line = one_line(resumed.err).replace(str(out), "OUT")
    ok = first.rc == 130 and resumed.rc == 0
    return ok, f"first run exit {first.rc}; `--resume` exit {resumed.rc}" + (
        f": `{line}`" if resumed.rc else ""
    )


def broken_pipe(tmp: Path) -> tuple[bool, str]:
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        r = subprocess.run(
            [sys.executable, "-m", "striatal", "simulate", "--chapter-final"],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            timeout=300,
        )
    finally:
        os.close(write_end)
    clean = "Traceback" not in r.stderr and r.stderr == ""
    return clean, f"exit {r.returncode}, stderr {'empty' if clean else repr(r.stderr[-200:])}"


_REFERENCE: dict[Any, dict[str, Any]] = {}


def reference_run(tmp: Path, train: tuple[str, ...]) -> dict[str, Any]:
    """The uninterrupted run of ``train`` (computed once per argument list)."""
    if train not in _REFERENCE:
        out = tmp / "reference"
        r = cli_process("train", *train, "--out", str(out))
        assert r.rc == 0, r.err
        _REFERENCE[train] = {
            "result": read_json(out / "result.json"),
            "history": (out / "history.csv").read_bytes(),
        }
    return _REFERENCE[train]


def _checkpoint_trials(path: Path) -> int:
    try:
        return int(json.loads(path.read_text())["state"]["trials_done"])
    except (OSError, ValueError, KeyError):
        return 0


SAME_KEYS = ("success", "trials", "W", "theta_c", "seed", "mean_policy_success", "settings")


def interrupted_train(
    sig: signal.Signals, train: tuple[str, ...] = TRAIN_LONG
) -> Callable[[Path], tuple[bool, str]]:
    def run(tmp: Path) -> tuple[bool, str]:
        ref = reference_run(tmp, train)
        out = tmp / "OUT"
        proc = subprocess.Popen(
            [sys.executable, "-m", "striatal", "train", *train, "--out", str(out)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=default_sigint,
        )
        deadline = time.monotonic() + 120
        while _checkpoint_trials(out / "checkpoint.json") < KILL_AFTER:
            assert proc.poll() is None, "the run ended before it could be interrupted"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        ckpt = read_json(out / "checkpoint.json")
        done = int(ckpt["state"]["trials_done"])
        history_rows = len((out / "history.csv").read_text().splitlines()) - 1
        mid_run = KILL_AFTER <= done < ref["result"]["trials"]
        if sig == signal.SIGKILL:
            stop_ok = proc.returncode == -signal.SIGKILL and not (out / "result.json").exists()
            files = "checkpoint.json valid, no result.json"
        else:
            partial = read_json(out / "result.json")
            stop_ok = (
                proc.returncode == 130
                and partial["interrupted"] is True
                and partial["trials"] == done
                and history_rows == done
                and "Traceback" not in err
                # the first signal says that the run stops after the trial in progress
                and "stopping after the trial in progress" in err
            )
            files = "checkpoint.json, result.json (interrupted: true) and history.csv agree"
        resumed = cli_process("train", "--resume", "--out", str(out), "--no-progress")
        final = read_json(out / "result.json")
        same = all(final[k] == ref["result"][k] for k in SAME_KEYS)
        same_history = (out / "history.csv").read_bytes() == ref["history"]
        ok = mid_run and stop_ok and resumed.rc == 0 and same and same_history
        code = "-9 (killed)" if sig == signal.SIGKILL else str(proc.returncode)
        return (
            ok,
            f"stopped mid-run: {'yes' if mid_run else 'no'}, exit {code}; {files}; "
            f"`--resume` exit {resumed.rc}; result.json {', '.join(SAME_KEYS[:5])} "
            f"identical: {'yes' if same else 'no'}; history.csv byte-identical: "
            f"{'yes' if same_history else 'no'}",
        )

    return run


# ---- issue 16, round 2: duplicates, wrong-typed files, the Gymnasium reset, hangs

SMALL_SWEEP = (
    "sweep", "--seeds", "2", "--max-trials", "5", "--duration", "2", "--eval-draws", "0",
    "--no-progress",
)  # fmt: skip
SMALL_ABLATION = ("ablation", "--variants", "chapter", "--seeds", "1", "--max-trials", "2",
                  "--eval-draws", "0")  # fmt: skip
_MADE: dict[str, Path] = {}


def _made(name: str, argv: tuple[str, ...], tmp_root: Path) -> Path:
    """A folder written once by ``striatal ARGV --out FOLDER`` (in this process)."""
    if name not in _MADE:
        out = Path(tempfile.mkdtemp(prefix=f"striatal-{name}-", dir=tmp_root.parent))
        r = cli_in_process(*argv, "--out", str(out / "run"))
        assert r.rc == 0, r.err
        _MADE[name] = out / "run"
    return _MADE[name]


def duplicate_rows_counted_once(tmp: Path) -> tuple[bool, str]:
    """runs.csv holding one (arm, init, seed) twice: the rerun's summary counts it once."""
    ref = _made("sweep", SMALL_SWEEP, tmp)
    out = tmp / "OUT"
    shutil.copytree(ref, out)
    lines = (out / "runs.csv").read_text().splitlines(keepends=True)
    (out / "runs.csv").write_text("".join([*lines, lines[1], lines[2]]))
    (out / "summary.json").unlink()
    r = cli_in_process(*SMALL_SWEEP, "--out", str(out))
    got, want = read_json(out / "summary.json"), read_json(ref / "summary.json")
    runs = sorted({a["runs"] for a in got["arms"]})
    same = _without_wall(got) == _without_wall(want)
    kept = len((out / "runs.csv").read_text().splitlines()) == len(lines)
    ok = r.rc == 0 and runs == [2] and same and kept
    return ok, (
        f"exit {r.rc}; runs per arm in summary.json: {', '.join(map(str, runs))}; summary.json "
        f"identical (but wall_seconds_*) to the sweep without the duplicates: "
        f"{'yes' if same else 'no'}; the duplicate lines dropped from runs.csv: "
        f"{'yes' if kept else 'no'}"
    )


def _summary_with(field: str, value: Any) -> Callable[[Path], None]:
    """A sweep's summary.json in OUT whose first arm's ``field`` is ``value``."""

    def prepare(out: Path) -> None:
        summary = read_json(_made("sweep", SMALL_SWEEP, out.parent) / "summary.json")
        summary["arms"][0][field] = value
        out.mkdir(parents=True)
        (out / "summary.json").write_text(json.dumps(summary))

    return prepare


def _ablation_runs(value: Any) -> Callable[[Path], None]:
    """An ablation.json in OUT whose variant's ``runs`` is ``value``."""

    def prepare(out: Path) -> None:
        ablation = read_json(_made("ablation", SMALL_ABLATION, out.parent) / "ablation.json")
        ablation["chapter"]["runs"] = value
        out.mkdir(parents=True)
        (out / "ablation.json").write_text(json.dumps(ablation))

    return prepare


def _env_reset(options: Any) -> Any:
    import gymnasium as gym

    import striatal.envs  # noqa: F401 - registers the ids

    env = gym.make("striatal/CartPoleSwingUp-v0")
    try:
        return env.reset(seed=0, options=options)
    finally:
        env.close()


def _env_make(**kwargs: Any) -> Any:
    import gymnasium as gym

    import striatal.envs  # noqa: F401 - registers the ids

    return gym.make("striatal/CartPoleSwingUp-v0", **kwargs)


class _SilentPort:
    """A TCP port that accepts connections (the kernel's backlog) and never answers."""

    def __enter__(self) -> int:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(64)
        return int(self.sock.getsockname()[1])

    def __exit__(self, *exc: object) -> None:
        self.sock.close()


RAY_SWEEP = ("sweep", "--backend", "ray", "--seeds", "1", "--max-trials", "2", "--duration",
             "2", "--eval-draws", "0", "--no-progress")  # fmt: skip


def ray_gives_up(silent: bool, timeout: float = 3.0) -> Callable[[Path], tuple[bool, str]]:
    """``sweep --backend ray`` at an address that refuses, or accepts and stays silent."""

    def run(tmp: Path) -> tuple[bool, str]:
        with _SilentPort() if silent else contextlib.nullcontext(1) as port:
            t0 = time.monotonic()
            r = cli_in_process(*RAY_SWEEP, "--address", f"127.0.0.1:{port}",
                               "--connect-timeout", f"{timeout:g}")  # fmt: skip
            took = time.monotonic() - t0
        line = one_line(r.err).replace(f":{port}", ":PORT")
        lines = r.err.strip().splitlines()
        # the bound: the timeout, plus Ray's import and a probe process's start on a loaded machine
        bounded = took < timeout + 60
        ok = r.rc == 2 and len(lines) == 1 and bounded and f"{timeout:g} s" in line
        return ok, (
            f"exit {r.rc}, {len(lines)} line: `{line}`; gave up within --connect-timeout "
            f"(+ start-up): {'yes' if bounded else 'no'}"
        )

    return run


def _children(pid: int) -> list[int]:
    kids: list[int] = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            kids += [int(k) for k in (task / "children").read_text().split()]
    return kids


def _dead(pid: int) -> bool:
    """Exited: no such process, or a zombie waiting for its new parent to reap it."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state in ("Z", "X")


def _wait_dead(pids: list[int], seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if all(_dead(p) for p in pids):
            return True
        time.sleep(0.02)
    return all(_dead(p) for p in pids)


def _wait_children(proc: subprocess.Popen[str], n: int) -> list[int]:
    deadline = time.monotonic() + 120
    while len(kids := _children(proc.pid)) < n:
        assert proc.poll() is None, "the process ended before it started its children"
        assert time.monotonic() < deadline, "no child process within 120 s"
        time.sleep(0.02)
    return kids


ORPHAN_SWEEP = ("sweep", "--seeds", "40", "--max-trials", "300", "--duration", "30",
                "--workers", "2", "--no-progress")  # fmt: skip


def orphaned_workers(tmp: Path) -> tuple[bool, str]:
    """SIGKILL a 2-worker sweep: its workers must not keep running (issue 16 item 6)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "striatal", *ORPHAN_SWEEP, "--out", str(tmp / "OUT")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        text=True,
        preexec_fn=default_sigint,
    )
    workers = _wait_children(proc, 2)
    time.sleep(1.0)  # both in a learning run
    running = [w for w in workers if not _dead(w)]
    proc.kill()
    proc.wait()
    gone = _wait_dead(running, 5.0)
    ok = len(running) == 2 and gone
    return ok, (
        f"{len(running)} workers running when the sweep was killed; all exited within 5 s: "
        f"{'yes' if gone else 'no'}"
    )


def watchdog_without_pdeathsig(tmp: Path) -> tuple[bool, str]:
    """The portable fallback alone: a worker whose parent exits, with no PR_SET_PDEATHSIG.

    This process forks a parent, which forks the worker (it runs the pool's
    initializer) and then exits at once with no clean-up, as a SIGKILL leaves it.
    """
    from striatal.experiments import pool

    read_end, write_end = os.pipe()
    parent = os.fork()
    if parent == 0:  # the parent: fork the worker, report its pid, die
        try:
            worker = os.fork()
            if worker == 0:
                try:
                    pool._die_with_parent = lambda: False  # the fallback alone
                    pool._worker_init(os.getppid())
                    time.sleep(60)
                finally:
                    os._exit(0)
            os.write(write_end, f"{worker}\n".encode())
            time.sleep(0.3)
        finally:
            os._exit(0)
    os.close(write_end)
    with os.fdopen(read_end) as fh:
        worker = int(fh.readline())
    os.waitpid(parent, 0)
    alive_first = not _dead(worker)
    gone = _wait_dead([worker], 3.0)
    if not gone:
        os.kill(worker, signal.SIGKILL)
    ok = alive_first and gone
    return ok, (
        f"worker alive when its parent exited: {'yes' if alive_first else 'no'}; exited within "
        f"3 s (its watchdog looks every {WATCHDOG_SECONDS:g} s): {'yes' if gone else 'no'}"
    )


def ray_sigterm(tmp: Path) -> tuple[bool, str]:
    """SIGTERM while ``sweep --backend ray`` waits for a silent address (issue 16 item 7)."""
    with _SilentPort() as port:
        proc = subprocess.Popen(
            [sys.executable, "-m", "striatal", *RAY_SWEEP, "--address", f"127.0.0.1:{port}"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=default_sigint,
        )
        probes = _wait_children(proc, 1)  # Ray's handshake has begun, in a child
        time.sleep(1.0)
        t0 = time.monotonic()
        proc.terminate()
        _, err = proc.communicate(timeout=120)
        took = time.monotonic() - t0
        probe_gone = _wait_dead(probes, 5.0)
    prompt = took < 5.0
    ok = proc.returncode == -signal.SIGTERM and prompt and probe_gone and "Traceback" not in err
    return ok, (
        f"exit {proc.returncode} (SIGTERM) within 5 s of the signal: "
        f"{'yes' if prompt else 'no'}; the connecting child exited too: "
        f"{'yes' if probe_gone else 'no'}"
    )


S = Scenario
SCENARIOS: tuple[Scenario, ...] = (
    # ---- bad input at the command line, as a new user types it
    S("sim-pole-mass", "bad input", "`striatal simulate --pole-mass -1`", "exit 2, one line",
      usage_error(("simulate", "--pole-mass", "-1", "--out", "OUT"), process=True)),
    S("sim-gains-nan", "bad input", "`striatal simulate --gains nan 0 0 0 0 0`",
      "exit 2, one line", usage_error(
          ("simulate", "--gains", "nan", "0", "0", "0", "0", "0", "--out", "OUT"), process=True)),
    S("sim-dt-0", "bad input", "`striatal simulate --dt 0`", "exit 2, one line",
      usage_error(("simulate", "--dt", "0", "--out", "OUT"), process=True)),
    S("sim-dt-big", "bad input", "`striatal simulate --dt 0.5`", "exit 2, one line",
      usage_error(("simulate", "--dt", "0.5", "--out", "OUT"))),
    S("sim-duration", "bad input", "`striatal simulate --duration 0`", "exit 2, one line",
      usage_error(("simulate", "--duration", "0", "--out", "OUT"))),
    S("sim-steps", "bad input", "`striatal simulate --duration 1e9 --dt 1e-6`",
      "exit 2, one line (not an out-of-memory crash)",
      usage_error(("simulate", "--duration", "1e9", "--dt", "1e-6", "--out", "OUT"))),
    S("sim-theta-c", "bad input", "`striatal simulate --theta-c 3.2`", "exit 2, one line",
      usage_error(("simulate", "--theta-c", "3.2", "--out", "OUT"))),
    S("sim-w1-zero", "bad input", "`striatal simulate --gains 0 1 1 1 1 1 --theta-c 0.5`",
      "exit 2, one line", usage_error(
          ("simulate", "--gains", "0", "1", "1", "1", "1", "1", "--theta-c", "0.5", "--out",
           "OUT"))),
    S("sim-length-inf", "bad input", "`striatal simulate --length inf`", "exit 2, one line",
      usage_error(("simulate", "--length", "inf", "--out", "OUT"))),
    S("sim-gravity-nan", "bad input", "`striatal simulate --gravity nan`", "exit 2, one line",
      usage_error(("simulate", "--gravity", "nan", "--out", "OUT"))),
    S("sim-inhibition", "bad input", "`striatal simulate --switch soft --inhibition -1`",
      "exit 2, one line",
      usage_error(("simulate", "--switch", "soft", "--inhibition", "-1", "--out", "OUT"))),
    S("sim-theta0", "bad input", "`striatal simulate --theta0 nan`", "exit 2, one line",
      usage_error(("simulate", "--theta0", "nan", "--out", "OUT"))),
    S("sim-two-gains", "bad input", "`striatal simulate --gains 1 2`", "exit 2, one line",
      usage_error(("simulate", "--gains", "1", "2", "--out", "OUT"))),
    S("sim-dt-text", "bad input", "`striatal simulate --dt fast`", "exit 2, one line",
      usage_error(("simulate", "--dt", "fast", "--out", "OUT"))),
    S("train-alpha", "bad input", "`striatal train --alpha nan`", "exit 2, one line",
      usage_error(("train", "--alpha", "nan", "--out", "OUT"))),
    S("train-gamma", "bad input", "`striatal train --gamma 1`", "exit 2, one line",
      usage_error(("train", "--gamma", "1", "--out", "OUT"))),
    S("train-max-trials", "bad input", "`striatal train --max-trials 0`", "exit 2, one line",
      usage_error(("train", "--max-trials", "0", "--out", "OUT"))),
    S("train-max-step", "bad input", "`striatal train --max-step 0`", "exit 2, one line",
      usage_error(("train", "--max-step", "0", "--out", "OUT"))),
    S("train-ckpt-every", "bad input", "`striatal train --checkpoint-every 0`",
      "exit 2, one line", usage_error(("train", "--checkpoint-every", "0", "--out", "OUT"))),
    S("train-init-inf", "bad input", "`striatal train --init-gains 1 0 0 0 inf 0`",
      "exit 2, one line", usage_error(
          ("train", "--init-gains", "1", "0", "0", "0", "inf", "0", "--out", "OUT"))),
    S("train-theta-c0", "bad input", "`striatal train --theta-c0 3.5`", "exit 2, one line",
      usage_error(("train", "--theta-c0", "3.5", "--out", "OUT"))),
    S("train-seed", "bad input", "`striatal train --seed -1`", "exit 2, one line",
      usage_error(("train", "--seed", "-1", "--max-trials", "2", "--out", "OUT"))),
    S("train-resume-no-out", "bad input", "`striatal train --resume` (no --out)",
      "exit 2, one line", usage_error(("train", "--resume"))),
    # ---- files that are missing, truncated, corrupted or not ours
    S("sim-out-file", "bad file", "`striatal simulate --out FILE` where FILE is a file",
      "exit 2, one line, FILE untouched",
      usage_error(("simulate", "--out", "OUT/file"), prepare=_a_file)),
    S("train-out-file", "bad file", "`striatal train --out FILE` where FILE is a file",
      "exit 2, one line, FILE untouched",
      usage_error(("train", "--max-trials", "2", "--out", "OUT/file"), prepare=_a_file)),
    S("resume-missing", "bad file", "`striatal train --resume --out DIR`, DIR has no checkpoint",
      "exit 2, one line", usage_error(("train", "--resume", "--out", "OUT"))),
    S("resume-truncated", "bad file", "`striatal train --resume` on a checkpoint cut in half",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"), process=True,
                  prepare=_with_checkpoint(_truncate))),
    S("resume-random", "bad file", "`striatal train --resume` on 600 random bytes",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"), prepare=_with_checkpoint(_random_bytes))),
    S("resume-not-ours", "bad file", "`striatal train --resume` on a checkpoint holding `[]`",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"),
                  prepare=_with_checkpoint(lambda p: p.write_text("[]")))),
    S("resume-nan", "bad file", "`striatal train --resume`, checkpoint W2 = `NaN` (not JSON)",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"),
                  prepare=_with_checkpoint(_nan_gain_checkpoint))),
    S("resume-dir", "bad file", "`striatal train --resume`, checkpoint.json is a folder",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"), prepare=_checkpoint_dir)),
    S("resume-no-history", "bad file", "`striatal train --resume`, history.csv deleted",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"), prepare=_history_gone)),
    S("resume-no-seed", "bad file", "`striatal train --resume`, checkpoint without settings.seed",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"),
                  prepare=_with_checkpoint(_edit_json(_drop_seed)))),
    S("resume-settings-text", "bad file", "`striatal train --resume`, settings = \"x\"",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"),
                  prepare=_with_checkpoint(_edit_json(_text_settings)))),
    S("resume-text-int", "bad file", "`striatal train --resume`, max_trials = \"many\"",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"),
                  prepare=_with_checkpoint(_edit_json(_text_max_trials)))),
    S("resume-rng", "bad file", "`striatal train --resume`, rng_state not a PCG64 state",
      "exit 2, one line, files untouched",
      usage_error(("train", "--resume", "--out", "OUT"),
                  prepare=_with_checkpoint(_edit_json(_rng_garbage)))),
    S("robustness-missing", "bad file", "`striatal robustness missing.json`", "exit 2, one line",
      usage_error(("robustness", "OUT/missing.json"))),
    S("robustness-random", "bad file", "`striatal robustness FILE`, FILE 600 random bytes",
      "exit 2, one line", usage_error(("robustness", "OUT/result.json"), prepare=_random_result)),
    S("robustness-settings", "bad file", "`striatal robustness result.json` whose settings "
      "is null", "exit 2, one line",
      usage_error(("robustness", "OUT/result.json", "--repeats", "1"), prepare=_null_settings)),
    S("robustness-seed", "bad input", "`striatal robustness result.json --seed -1`",
      "exit 2, one line",
      usage_error(("robustness", "OUT/result.json", "--seed", "-1", "--repeats", "1"),
                  prepare=_result_file)),
    S("curves-random", "bad file", "`striatal curves FILE --out OUT/c.png`, FILE 600 random bytes",
      "exit 2, one line", usage_error(("curves", "OUT/history.csv", "--out", "OUT/c.png"),
                                      prepare=_random_history)),
    S("curves-text", "bad file", "`striatal curves history.csv` with W1 = \"x\" in one row",
      "exit 2, one line", usage_error(("curves", "OUT/history.csv", "--out", "OUT/c.png"),
                                      prepare=_text_in_history)),
    S("figure-random", "bad file", "`striatal figure --result FILE`, FILE 600 random bytes",
      "exit 2, one line", usage_error(("figure", "--result", "OUT/result.json", "--out",
                                       "OUT/f.png"), prepare=_random_result)),
    # ---- negative values (issue 16, item 19): read as values, never as options
    S("neg-exponent", "bad input", "`striatal simulate --gains 1 -2e-1 0 0 0 0 --theta-c 0.5 "
      "--duration 5`", "runs (-2e-1 is W2, not an option)",
      runs(("simulate", "--gains", "1", "-2e-1", "0", "0", "0", "0", "--theta-c", "0.5",
            "--duration", "5"), "success: ")),
    S("neg-inf", "bad input", "`striatal simulate --x0 -inf`",
      "exit 2, one line naming x0 (not \"expected one argument\")",
      usage_error(("simulate", "--x0", "-inf", "--out", "OUT"), says="x0 must be")),
    S("neg-nan", "bad input", "`striatal simulate --theta0 -nan`",
      "exit 2, one line naming theta0",
      usage_error(("simulate", "--theta0", "-nan", "--out", "OUT"), says="theta0 must be")),
    S("neg-list", "bad input", "`striatal sweep --alpha-grid -1,2`",
      "exit 2, one line naming alpha (-1,2 is the grid, not an option)",
      usage_error(("sweep", "--alpha-grid", "-1,2", "--seeds", "1", "--out", "OUT"),
                  says="--alpha-grid must be a list of finite numbers in [0,")),
    # ---- a stdout that is not UTF-8 (issue 16, item 13)
    S("latin-1", "bad input", "`PYTHONIOENCODING=latin-1 striatal interpret --chapter-final`",
      "exit 0; what latin-1 cannot hold printed as an escape", non_utf8_stdout("latin-1")),
    S("ascii", "bad input", "`PYTHONIOENCODING=ascii striatal interpret --chapter-final`",
      "exit 0; what ASCII cannot hold printed as an escape", non_utf8_stdout("ascii")),
    # ---- inputs that are not regular files, or too big (issue 16, item 14)
    S("read-dev-zero", "bad file", "`striatal simulate --result /dev/zero`",
      "exit 2, one line, nothing read",
      usage_error(("simulate", "--result", "/dev/zero"), process=True, says="not a regular")),
    S("curves-dev-zero", "bad file", "`striatal curves /dev/zero`",
      "exit 2, one line, nothing read",
      usage_error(("curves", "/dev/zero", "--out", "OUT/c.png"), says="not a regular")),
    S("read-fifo", "bad file", "`striatal simulate --result FIFO` (no writer: a read would "
      "wait for ever)", "exit 2, one line, no hang",
      usage_error(("simulate", "--result", "OUT/result.json"), process=True, prepare=_fifo,
                  says="not a regular")),
    S("read-folder", "bad file", "`striatal figure --result DIR` where DIR is a folder",
      "exit 2, one line", usage_error(("figure", "--result", "OUT/result.json", "--out",
                                       "OUT/f.png"), prepare=_folder_result, says="folder")),
    S("read-huge", "bad file", "`striatal interpret FILE`, FILE 256 MiB + 1 byte",
      "exit 2, one line, nothing read",
      usage_error(("interpret", "--result", "OUT/result.json"), prepare=_huge_result,
                  says="larger than 256 MiB")),
    # ---- outputs that cannot be written, said before computing (issue 16, item 18)
    S("out-dangling-sim", "bad file", "`striatal simulate --out LINK`, LINK a symbolic link "
      "to a path that does not exist", "exit 2, one line naming the link, before the run",
      usage_error(("simulate", "--out", "OUT/link"), prepare=_dangling, says="symbolic link")),
    S("out-dangling-train", "bad file", "`striatal train --out LINK/run`, LINK as above",
      "exit 2, one line naming the link, before the run",
      usage_error(("train", "--max-trials", "2", "--out", "OUT/link/run"), prepare=_dangling,
                  says="symbolic link")),
    S("out-dangling-figure", "bad file", "`striatal figure --out LINK/f.png`, LINK as above",
      "exit 2, one line naming the link, before the run",
      usage_error(("figure", "--out", "OUT/link/f.png"), prepare=_dangling,
                  says="symbolic link")),
    S("result-is-folder", "bad file", "`striatal train --out DIR`, DIR/result.json a folder",
      "exit 2, one line naming result.json (not a hidden temporary file), before the run; "
      "nothing written",
      usage_error(("train", "--max-trials", "2", "--out", "OUT"),
                  prepare=_folder_at("result.json"),
                  says="cannot write OUT/result.json: it is a folder")),
    S("summary-is-folder", "bad file", "`striatal simulate --out DIR`, DIR/summary.json a "
      "folder", "exit 2, one line naming summary.json, before the run; nothing written",
      usage_error(("simulate", "--duration", "5", "--out", "OUT"),
                  prepare=_folder_at("summary.json"),
                  says="cannot write OUT/summary.json: it is a folder")),
    # ---- sizes checked before they are allocated (issue 16, item 11)
    S("figure-every-tiny", "bad input", "`striatal figure --every 1e-300`",
      "exit 2, one line (no ValueError from NumPy)",
      usage_error(("figure", "--every", "1e-300", "--out", "OUT/f.png"), says="more than")),
    S("figure-every-small", "bad input", "`striatal figure --every 1e-7` (4.5 GiB of indices)",
      "exit 2, one line, before the run",
      usage_error(("figure", "--every", "1e-7", "--out", "OUT/f.png"), says="more than")),
    S("animate-speed", "bad input", "`striatal animate --speed 1e-9` (6.5 TiB of frame times)",
      "exit 2, one line, before the run",
      usage_error(("animate", "--speed", "1e-9", "--out", "OUT/a.gif"), says="more than")),
    S("bench-batch", "bad input", "`striatal bench --batch-size 100000000`",
      "exit 2, one line (no MemoryError)",
      usage_error(("bench", "--batch-size", "100000000"), says="--batch-size")),
    S("bench-seconds", "bad input", "`striatal bench --seconds 1e308`",
      "exit 2, one line (no OverflowError)",
      usage_error(("bench", "--seconds", "1e308"), says="--seconds")),
    # ---- memory (issue 16, item 15)
    S("sim-stream", "bad input", f"`striatal simulate --duration {STREAM_STEPS // 10} --dt 0.1 "
      f"--out DIR` ({STREAM_STEPS:,} steps), peak memory with and without --out",
      "trajectory.csv streamed: writing adds < 40 MB", streamed_trajectory),
    # ---- the library's typed errors
    S("lib-seed", "bad input", "`learn.initial_state(CHAPTER_INITIAL_W, 0.6, seed=-1)`",
      "ParameterError",
      library_error(lambda _: initial_state(CHAPTER_INITIAL_W, 0.6, seed=-1), ParameterError)),
    S("lib-plant", "bad input", "`Plant(pole_mass=-1.0)`", "ParameterError",
      library_error(lambda _: Plant(pole_mass=-1.0), ParameterError)),
    S("lib-plant-text", "bad input", "`Plant(length=\"long\")`", "ParameterError",
      library_error(lambda _: Plant(length="long"), ParameterError)),  # type: ignore[arg-type]
    S("lib-gains", "bad input", "`Controller(gains=(nan, 0, 0, 0, 0, 0))`", "ParameterError",
      library_error(lambda _: Controller(gains=(math.nan, 0, 0, 0, 0, 0)), ParameterError)),
    S("lib-sim", "bad input", "`Simulation(dt=0)`", "ParameterError",
      library_error(lambda _: Simulation(dt=0.0), ParameterError)),
    S("lib-learner", "bad input", "`LearnerConfig(alpha=inf)`", "ParameterError",
      library_error(lambda _: LearnerConfig(alpha=math.inf), ParameterError)),
    S("lib-protocol", "bad input", "`Protocol(goal_x=0)`", "ParameterError",
      library_error(lambda _: Protocol(goal_x=0.0), ParameterError)),
    S("lib-sensor", "bad input", "`SensorNoise(x_std=-0.1)`", "ParameterError",
      library_error(lambda _: SensorNoise(x_std=-0.1), ParameterError)),
    S("lib-read-json", "bad file", "`read_json` of a file holding `{\"W\": 1e999}`",
      "DataFileError",
      library_error(lambda tmp: _read_text_as_json(tmp, '{"W": 1e999}'), DataFileError)),
    # ---- numerical faults
    S("fault-kernel", "numerical fault", "one trial with every gain = 1e300",
      "the state blows up: fault flag, failure, reward -5", kernel_blow_up),
    S("fault-learner", "numerical fault", "one learning step from W4 = W5 = 1e12",
      "fault counted as a failure; W, theta_c and the history row stay finite", learner_fault),
    S("fault-trace", "numerical fault", "gain update with a NaN / inf eligibility trace",
      "W unchanged", nan_trace),
    S("fault-alpha", "numerical fault", "`striatal train --alpha 1000 --max-trials 300`",
      "finishes; finite W, theta_c, history", absurd_alpha()),
    S("fault-alpha-inf", "numerical fault",
      "`striatal train --alpha 1000 --max-step inf --max-trials 300` (no bound on the update)",
      "finishes; finite W, theta_c, history", absurd_alpha("--max-step", "inf")),
    S("fault-alpha-rpe", "numerical fault",
      "`striatal train --learner rpe --alpha 1000 --max-trials 300`",
      "finishes; finite W, theta_c, history", absurd_alpha("--learner", "rpe")),
    S("fault-alpha-pgpe", "numerical fault",
      "`striatal train --learner pgpe --init random --alpha 1000 --decay 0 --max-trials 300` "
      "(its default decay needs alpha x decay < 1)",
      "finishes; finite W, theta_c, history (a fault scores 0 under its shaped reward)",
      absurd_alpha("--learner", "pgpe", "--init", "random", "--decay", "0", failure=0.0,
                   success_on_trial=False)),
    S("fault-simulate", "numerical fault",
      "`striatal simulate --chapter-final --balance-sign chapter` (the printed, unstable law)",
      "fault reported; no NaN or inf in the files", printed_sign_fault),
    # ---- runs: folders, resume, locks (issue 16)
    S("fresh-over-old", "runs", "`striatal train --seed 2 --out DIR` over a finished run in DIR, "
      "crashing after 2 trials (before its first checkpoint), then `--resume`",
      "the old checkpoint.json and result.json are gone; `--resume` refuses",
      fresh_over_old_run),
    S("resume-other-result", "runs", "`striatal train --resume` where result.json is another "
      "run's", "exit 2, one line, files untouched", resume_mixed("result.json")),
    S("resume-other-history", "runs", "`striatal train --resume` where history.csv is another "
      "run's", "exit 2, one line, files untouched", resume_mixed("history.csv")),
    S("two-trains", "runs", "`striatal train --out DIR` while another process holds DIR",
      "exit 2, one line, nothing written", two_trains),
    S("two-sweeps", "runs", "`striatal sweep --out DIR` while another process holds DIR",
      "exit 2, one line, nothing written", locked_out(SMALL_SWEEP)),
    S("two-ablations", "runs", "`striatal ablation --out DIR` while another process holds DIR "
      "(its lock also covers ablation.json and ablation.md, written after its sweep)",
      "exit 2, one line, nothing written", locked_out(SMALL_ABLATION)),
    S("resume-changed", "runs", "`striatal train --resume --alpha 3 --seed 4` on a run with "
      "alpha 5, seed 0", "exit 2, one line naming --alpha and --seed",
      usage_error(("train", "--resume", "--alpha", "3", "--seed", "4", "--out", "OUT"),
                  prepare=_checkpointed_run)),
    S("resume-extend", "runs", "`striatal train --resume --max-trials 40` on a finished "
      "30-trial run", "the same files as the uninterrupted 40-trial run", resume_extends),
    S("resume-ckpt-every", "bad input", "`striatal train --resume --checkpoint-every 0`",
      "exit 2, one line", usage_error(("train", "--resume", "--checkpoint-every", "0", "--out",
                                       "OUT"), prepare=_checkpointed_run)),
    S("pgpe-explore-huge", "bad input", "`striatal train --learner pgpe --explore 1.7e308`",
      "exit 2, one line", usage_error(("train", "--learner", "pgpe", "--explore", "1.7e308",
                                       "--max-trials", "5", "--duration", "2", "--out", "OUT"))),
    S("pgpe-absurd", "numerical fault", "`striatal train --learner pgpe --explore 100 --alpha "
      "1e300 --decay 0 --duration 2 --max-trials 3`, then `--resume --max-trials 5`",
      "finite files; the resume works", absurd_pgpe_resumes),
    S("out-empty", "bad input", "`striatal train --out \"\"` (every command's --out)",
      "exit 2, one line", usage_error(("train", "--max-trials", "2", "--out", ""))),
    S("out-empty-sim", "bad input", "`striatal simulate --out \"\"`", "exit 2, one line",
      usage_error(("simulate", "--out", ""))),
    S("umask", "runs", "`striatal simulate --out DIR` under umask 022 and 077",
      "files 0644 and 0600, as `open()` makes them", files_follow_umask),
    # ---- issue 16, round 2: duplicates, wrong-typed files, the Gymnasium reset, Ray
    S("sweep-duplicate", "runs", "a finished sweep's runs.csv with two of its rows appended "
      "again, then the same `striatal sweep` command", "each (arm, init, seed) counted once",
      duplicate_rows_counted_once),
    S("compare-rate-text", "bad file", "`striatal compare summary.json` whose arm has "
      "`\"success_rate\": \"x\"`", "exit 2, one line",
      usage_error(("compare", "OUT/summary.json"), prepare=_summary_with("success_rate", "x"),
                  says="success_rate")),
    S("compare-arm-int", "bad file", "`striatal compare summary.json` whose arm has "
      "`\"arm\": 5`", "exit 2, one line",
      usage_error(("compare", "OUT/summary.json"), prepare=_summary_with("arm", 5), says="arm")),
    S("compare-wall-dict", "bad file", "`striatal compare summary.json` whose arm has "
      "`\"wall_seconds_total\": {}`", "exit 2, one line",
      usage_error(("compare", "OUT/summary.json"),
                  prepare=_summary_with("wall_seconds_total", {}), says="wall_seconds_total")),
    S("robustness-runs-text", "bad file", "`striatal robustness ablation.json` whose "
      "`\"runs\"` is `\"x\"`", "exit 2, one line",
      usage_error(("robustness", "OUT/ablation.json", "--repeats", "1"),
                  prepare=_ablation_runs("x"), says="runs")),
    S("robustness-runs-list", "bad file", "`striatal robustness ablation.json` whose "
      "`\"runs\"` is `[5]`", "exit 2, one line",
      usage_error(("robustness", "OUT/ablation.json", "--repeats", "1"),
                  prepare=_ablation_runs([5]), says="runs")),
    S("ablation-variants-empty", "bad input", "`striatal ablation --variants \"\"`",
      "exit 2, one line", usage_error(("ablation", "--variants", "", "--out", "OUT"),
                                      says="--variants")),
    S("env-reset-huge", "bad input", "Gymnasium `env.reset(options={\"perturbation\": 1e308})`",
      "ParameterError, as `gymnasium.make(..., perturbation=1e308)`",
      library_error(lambda _: _env_reset({"perturbation": 1e308}), ParameterError)),
    S("env-reset-text", "bad input", "Gymnasium `env.reset(options=\"x\")`", "ParameterError",
      library_error(lambda _: _env_reset("x"), ParameterError)),
    S("env-reset-unknown", "bad input", "Gymnasium `env.reset(options={\"perturbaton\": 0.1})` "
      "(a misspelt key)", "ParameterError naming the key",
      library_error(lambda _: _env_reset({"perturbaton": 0.1}), ParameterError)),
    S("env-reset-state-huge", "bad input", "Gymnasium `env.reset(options={\"initial_state\": "
      "[1e308, 0, 0, 0]})`", "ParameterError (the start is beyond the kernel's blow-up bound)",
      library_error(lambda _: _env_reset({"initial_state": [1e308, 0, 0, 0]}), ParameterError)),
    S("env-make-state-huge", "bad input", "`gymnasium.make(..., initial_state=[0, 0, 0, 1e9])`",
      "ParameterError, as reset",
      library_error(lambda _: _env_make(initial_state=[0, 0, 0, 1e9]), ParameterError)),
    S("ray-refused", "hang", "`striatal sweep --backend ray --address 127.0.0.1:PORT "
      "--connect-timeout 3`, PORT refusing connections", "exit 2, one line, after about 3 s",
      ray_gives_up(silent=False)),
    S("ray-silent", "hang", "the same, PORT accepting connections and never answering (no Ray "
      "head; Ray alone retries for minutes)", "exit 2, one line, after about 3 s",
      ray_gives_up(silent=True)),
    S("worker-watchdog", "hang", "a sweep worker (its initializer run, PR_SET_PDEATHSIG "
      "switched off) whose parent exits without clean-up", "the worker exits within 3 s",
      watchdog_without_pdeathsig),
    # ---- files are data, never code
    S("no-code", "files are data", "every module of src/striatal parsed: imports of pickle, "
      "marshal, shelve, dill, cloudpickle, joblib; calls of eval, exec, yaml.load; "
      "allow_pickle=", "none", no_code_in_files),
)  # fmt: skip

# Interrupted runs: checked by tests/test_reliability_interrupt.py (slower: ~1 min).
INTERRUPTIONS: tuple[Scenario, ...] = (
    S("kill-train", "interruption",
      f"`striatal train {' '.join(TRAIN_LONG)}`, SIGKILL after trial {KILL_AFTER}, "
      "then `--resume`", "same result as the uninterrupted run",
      interrupted_train(signal.SIGKILL)),
    S("term-train", "interruption", f"the same run, SIGTERM after trial {KILL_AFTER}, then "
      "`--resume`", "exit 130, valid files; same result after resume",
      interrupted_train(signal.SIGTERM)),
    S("int-train", "interruption", f"the same run, SIGINT (Ctrl-C) after trial {KILL_AFTER}, "
      "then `--resume`", "exit 130, valid files; same result after resume",
      interrupted_train(signal.SIGINT)),
    S("signal-between", "interruption",
      "SIGINT/SIGTERM landing after trial 10's update but before its history row "
      "(simulated: KeyboardInterrupt raised there)", "exit 130; `--resume` continues",
      interrupt_before_history_row),
    S("kill-train-rpe", "interruption",
      f"`striatal train {' '.join(TRAIN_RPE)}`, SIGKILL after trial {KILL_AFTER}, "
      "then `--resume`", "same result as the uninterrupted run",
      interrupted_train(signal.SIGKILL, TRAIN_RPE)),
    S("kill-sweep", "interruption",
      f"`striatal {' '.join(SWEEP)} --out DIR`, SIGKILL after {SWEEP_KILL_AFTER} of its 16 "
      "runs, then the same command again", "same summary.json as the uninterrupted sweep",
      interrupted_sweep(signal.SIGKILL)),
    S("term-sweep", "interruption",
      f"the same sweep, SIGTERM after {SWEEP_KILL_AFTER} runs, then the same command",
      "valid files; same summary.json after the rerun", interrupted_sweep(signal.SIGTERM)),
    S("signal-in-sweep-run", "interruption",
      "SIGINT landing inside one learning run of the same sweep (simulated: KeyboardInterrupt "
      "raised in its 30th trial), then the same command", "exit 130; the cut run is not "
      "recorded; same summary.json after the rerun", interrupt_inside_sweep_run),
    S("determinism", "interruption",
      "`striatal train --seed 3 --max-trials 200` in two processes, and with `--seed 6`",
      "same seed, same files; another seed, another run", same_seed_same_run),
    S("int-start", "interruption",
      f"`striatal train {' '.join(TRAIN_ENDLESS)}`, SIGINT (Ctrl-C) 0, 0.1, 0.3, 0.6, 1 and 1.5 s "
      "after striatal's code starts (while the libraries load; the interpreter's own start, "
      "timed as `python -c 'import striatal.cli'`, excluded)", "exit 130, no traceback",
      interrupt_at_start((0.0, 0.1, 0.3, 0.6, 1.0, 1.5))),
    S("broken-pipe", "interruption",
      "`striatal simulate --chapter-final` writing into a pipe whose reader has gone "
      "(as `| head` does)", "no traceback", broken_pipe),
    S("orphan-workers", "interruption", f"`striatal {' '.join(ORPHAN_SWEEP)} --out DIR`, "
      "SIGKILL once both workers run", "the workers exit within seconds",
      orphaned_workers),
    S("ray-sigterm", "interruption", "SIGTERM while `striatal sweep --backend ray` waits for an "
      "address that accepts connections and never answers (default --connect-timeout 30)",
      "ends within 5 s, its connecting child too", ray_sigterm),
)  # fmt: skip


# --------------------------------------------------------------------------- running


_RESULTS: dict[str, tuple[bool, str]] = {}


def outcome(s: Scenario, tmp: Path) -> tuple[bool, str]:
    if s.key not in _RESULTS:
        folder = tmp / s.key
        folder.mkdir(parents=True, exist_ok=True)
        _RESULTS[s.key] = s.run(folder)
    return _RESULTS[s.key]


@pytest.fixture(scope="module")
def scenario_tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("reliability")


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(scenarios: tuple[Scenario, ...], tmp: Path) -> str:
    lines = [
        "| id | kind | what was tried | expected | what happened | verdict |",
        "|---|---|---|---|---|---|",
    ]
    for s in scenarios:
        ok, observed = outcome(s, tmp)
        verdict = "as expected" if ok else f"**gap** ({s.gap})" if s.gap else "**FAILED**"
        lines.append(
            f"| {s.key} | {s.kind} | {_cell(s.tried)} | {_cell(s.expected)} | {_cell(observed)} "
            f"| {_cell(verdict)} |"
        )
    return "\n".join(lines) + "\n"


def check_doc_section(name: str, scenarios: tuple[Scenario, ...], tmp: Path, module: str) -> None:
    """The table between ``<!-- name:begin ... -->`` and ``<!-- name:end -->`` is current."""
    begin = f"<!-- {name}:begin (generated by tests/{module}) -->"
    end = f"<!-- {name}:end -->"
    text = DOC.read_text(encoding="utf-8")
    assert begin in text and end in text, f"{DOC} lacks the markers {begin} {end}"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    fresh = f"{head}{begin}\n{table(scenarios, tmp)}{end}{tail}"
    if os.environ.get(WRITE_ENV) == "1":
        DOC.write_text(fresh, encoding="utf-8")
        return
    assert fresh == text, f"{DOC} is out of date: run `{WRITE_ENV}=1 pytest tests/{module}`"


def params_of(scenarios: tuple[Scenario, ...]) -> list[Any]:
    return [
        pytest.param(s, id=s.key, marks=pytest.mark.xfail(strict=True, reason=s.gap))
        if s.gap
        else pytest.param(s, id=s.key)
        for s in scenarios
    ]


@pytest.mark.parametrize("scenario", params_of(SCENARIOS))
def test_scenario(scenario: Scenario, scenario_tmp: Path) -> None:
    ok, observed = outcome(scenario, scenario_tmp)
    assert ok, observed


def test_doc_matches(scenario_tmp: Path) -> None:
    """docs/reliability.md's table is what the scenarios produce now (never drifts)."""
    check_doc_section("scenarios", SCENARIOS, scenario_tmp, "test_reliability.py")
