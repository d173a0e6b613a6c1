"""Fault-injection soak: interrupt train and sweep runs at random, resume, compare.

    PYTHONPATH=src python benchmarks/soak.py --runs 50 --seed 0 --out /tmp/soak

Each of ``--runs`` runs is a small ``striatal train`` (learner chapter, rpe or
pgpe, 60-150 trials of 20 s) or ``striatal sweep`` (2 seeds, learner and
control, 60-100 trials, 1 or 2 workers), chosen and parametrised by a
``random.Random`` seeded from ``--seed`` and the run's index. The run is started
in its own process and sent SIGINT, SIGTERM, SIGKILL or two SIGINTs at a random
moment: during start-up (one time in five) or within 1.2 times the run's own
duration after it wrote its first file. One time in three the resumed run is
interrupted again. Then it is resumed to the end (``train --resume``, or the same
``sweep`` command; a train killed before its first checkpoint is started
afresh, as a user would) and its files are compared with its uninterrupted
twin, computed in this process under the same options: train's result.json
(but wall_seconds and run_id) and history.csv byte for byte, sweep's
summary.json and runs.csv rows (but wall times).

A run fails if a final result differs from its twin, an interrupted process
printed a traceback, or exited with a code other than 0 (it finished first),
130 (SIGINT/SIGTERM), -9 (SIGKILL) or -15 (a sweep's SIGTERM). Prints one JSON
line per run and a summary; writes them to ``--out``/soak.json. Exit 1 when a
run failed.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

from striatal.cli import main as striatal_main
from striatal.io.files import read_json

WALL = ("wall_seconds", "wall_seconds_total", "wall_seconds_median")
SIGNALS = ("SIGINT", "SIGTERM", "SIGKILL", "SIGINT x2")
#: Exit codes an interrupted process may end with.
STOP_CODES = {0, 130, -signal.SIGKILL, -signal.SIGTERM}


def _without(obj: Any, keys: tuple[str, ...]) -> Any:
    if isinstance(obj, dict):
        return {k: _without(v, keys) for k, v in obj.items() if k not in keys}
    if isinstance(obj, list):
        return [_without(v, keys) for v in obj]
    return obj


def _runs_rows(path: Path) -> list[tuple[str, ...]]:
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    return sorted(tuple(v for k, v in row.items() if k not in WALL) for row in rows)


def fingerprint(kind: str, out: Path) -> Any:
    """What must equal the twin's: the final files, wall times and run ids aside."""
    if kind == "train":
        result = _without(read_json(out / "result.json"), ("wall_seconds", "run_id"))
        return result, (out / "history.csv").read_bytes()
    return _without(read_json(out / "summary.json"), WALL), _runs_rows(out / "runs.csv")


def options_of(rng: random.Random) -> tuple[str, list[str]]:
    """(kind, striatal argv without --out) of one soak run."""
    if rng.random() < 0.5:
        learner = rng.choice(("chapter", "rpe", "pgpe"))
        return "train", [
            "train", "--learner", learner, "--seed", str(rng.randrange(1000)),
            "--max-trials", str(rng.randint(60, 150)), "--duration", "20",
            "--checkpoint-every", str(rng.choice((1, 5, 10, 25))), "--no-progress",
        ]  # fmt: skip
    return "sweep", [
        "sweep", "--seeds", "2", "--seed", str(rng.randrange(1000)),
        "--max-trials", str(rng.randint(60, 100)), "--duration", "20", "--eval-draws", "20",
        "--workers", str(rng.choice((1, 2))), "--no-progress",
    ]  # fmt: skip


def in_process(argv: list[str]) -> int:
    """``striatal ARGV`` through the CLI's main in this process (output discarded)."""
    sink = io.StringIO()
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
        try:
            return int(striatal_main(argv))
        except SystemExit as exc:
            return int(exc.code or 0)


def _started(kind: str, out: Path, since: float) -> bool:
    """Whether the run started at ``since`` (time.time()) has written its first rows: a
    file left by an earlier, interrupted run does not count."""
    path = out / ("history.csv" if kind == "train" else "runs.csv")
    try:
        return path.stat().st_mtime >= since
    except FileNotFoundError:
        return False


def interpreter_start() -> float:
    """Seconds until striatal's own code runs (``python -c "import striatal.cli"``, the
    slowest of three): a signal before that lands while the interpreter itself starts,
    and Python, not striatal, reports it (a KeyboardInterrupt traceback, exit -2)."""
    times = []
    for _ in range(3):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import striatal.cli"], check=True)
        times.append(time.perf_counter() - t)
    return max(times)


def interrupt_once(
    rng: random.Random,
    kind: str,
    argv: list[str],
    out: Path,
    run_seconds: float,
    signals: tuple[str, ...] = SIGNALS,
) -> dict[str, Any]:
    """Start ``argv`` in a process, signal it at a random moment; what happened.

    "start-up": 0-2 s after striatal's code starts (the interpreter's own start, timed
    as :func:`interpreter_start`, excluded); "running": after this process wrote its
    first rows."""
    start = interpreter_start()
    since = time.time()
    proc = subprocess.Popen(
        [sys.executable, "-m", "striatal", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    how = rng.choice(signals)
    if rng.random() < 0.2:
        moment = "start-up"
        delay = start + rng.uniform(0.0, 2.0)
    else:
        moment = "running"
        delay = rng.uniform(0.0, 1.2 * run_seconds)
        deadline = time.monotonic() + 120
        while (
            not _started(kind, out, since) and proc.poll() is None and time.monotonic() < deadline
        ):
            time.sleep(0.005)
    time.sleep(delay)
    if how == "SIGINT x2":
        proc.send_signal(signal.SIGINT)
        time.sleep(rng.uniform(0.0, 0.2))
        proc.send_signal(signal.SIGINT)
    else:
        proc.send_signal(getattr(signal, how))
    try:
        _, err = proc.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        return {"signal": how, "moment": moment, "rc": "hung", "traceback": False}
    return {
        "signal": how,
        "moment": moment,
        "delay": round(delay, 3),
        "rc": proc.returncode,
        "traceback": "Traceback" in err,
        "err": err.strip().splitlines()[-1:] if proc.returncode not in STOP_CODES else [],
    }


def resume_argv(kind: str, argv: list[str], out: Path) -> list[str]:
    if kind == "train" and (out / "checkpoint.json").exists():
        return ["train", "--resume", "--no-progress", "--out", str(out)]
    return [*argv, "--out", str(out)]  # a sweep resumes by the same command


def soak_run(
    i: int, root_seed: int, work: Path, signals: tuple[str, ...] = SIGNALS
) -> dict[str, Any]:
    rng = random.Random(f"{root_seed}-{i}")
    kind, argv = options_of(rng)
    twin, out = work / f"{i:03d}-twin", work / f"{i:03d}-run"
    t0 = time.perf_counter()
    twin_rc = in_process([*argv, "--out", str(twin)])
    run_seconds = time.perf_counter() - t0
    stops = [interrupt_once(rng, kind, [*argv, "--out", str(out)], out, run_seconds, signals)]
    while stops[-1]["rc"] != 0 and rng.random() < 1 / 3 and len(stops) < 3:
        again = resume_argv(kind, argv, out)
        stops.append(interrupt_once(rng, kind, again, out, run_seconds, signals))
    final_rc = 0
    if stops[-1]["rc"] != 0:
        final_rc = in_process(resume_argv(kind, argv, out))
    equal = twin_rc == 0 and final_rc == 0 and fingerprint(kind, out) == fingerprint(kind, twin)
    bad_stop = any(s["rc"] not in STOP_CODES or s["traceback"] for s in stops)
    row = {
        "run": i,
        "kind": kind,
        "argv": " ".join(argv),
        "stops": stops,
        "final_rc": final_rc,
        "equal_to_twin": equal,
        "ok": equal and not bad_stop,
    }
    shutil.rmtree(twin, ignore_errors=True)
    if row["ok"]:
        shutil.rmtree(out, ignore_errors=True)
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=50, help="number of soak runs")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random choices")
    parser.add_argument("--out", type=Path, default=None, help="work folder (default: a temp)")
    parser.add_argument(
        "--signals",
        default=",".join(SIGNALS),
        help=f"comma-separated signals to choose from: {', '.join(SIGNALS)}",
    )
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs must be >= 1, got {args.runs}")
    signals = tuple(x.strip() for x in args.signals.split(",") if x.strip())
    if not signals or any(x not in SIGNALS for x in signals):
        parser.error(f"--signals must name some of {', '.join(SIGNALS)}, got {args.signals!r}")
    work = args.out if args.out is not None else Path(tempfile.mkdtemp(prefix="striatal-soak-"))
    work.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("PYTHONPATH", str(Path(__file__).resolve().parents[1] / "src"))
    t0 = time.perf_counter()
    rows = []
    for i in range(args.runs):
        row = soak_run(i, args.seed, work, signals)
        rows.append(row)
        print(json.dumps(row), flush=True)
    stops = [s for r in rows for s in r["stops"]]
    summary = {
        "command": " ".join(["benchmarks/soak.py", *(sys.argv[1:] if argv is None else argv)]),
        "runs": len(rows),
        "kinds": dict(Counter(r["kind"] for r in rows)),
        "signals": dict(Counter(s["signal"] for s in stops)),
        "moments": dict(Counter(s["moment"] for s in stops)),
        "exit_codes": {str(k): v for k, v in Counter(s["rc"] for s in stops).items()},
        "stopped_before_the_end": sum(1 for s in stops if s["rc"] != 0),
        "runs_stopped": sum(1 for r in rows if any(s["rc"] != 0 for s in r["stops"])),
        "tracebacks": sum(1 for s in stops if s["traceback"]),
        "equal_to_twin": sum(1 for r in rows if r["equal_to_twin"]),
        "failed": [r["run"] for r in rows if not r["ok"]],
        "wall_seconds": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(summary), flush=True)
    (work / "soak.json").write_text(json.dumps({"summary": summary, "runs": rows}, indent=1))
    return 1 if summary["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
