"""A systematic hostile pass over every file kind (docs/reliability.md, "A fresh hostile
pass"): every field, each bad value, the command that reads it.

    PYTHONPATH=src python benchmarks/hostile_files.py /tmp/hostile summary runs result history

Makes the inputs in the folder once (a forward run, a generic-model run, a chapter
run, a sweep with and without baselines, an ablation), then, for each kind asked, sets
every field of the JSON file (every path, down to the first two items of a list) to each
of :data:`BAD_JSON` or removes it, or every cell of the CSV file's first row to each of
:data:`BAD_CELLS`, and runs the command that reads it through the CLI's ``main`` on a
fresh copy. The property is tests/test_fuzz.py's: exit 0, or exit 2 with one line; no
traceback; nothing written or changed on a refusal; on success no input changed (a
resume's own folder aside); within 60 s. Prints each failure and the counts.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import os
import shutil
import tempfile
import time
import traceback
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

from striatal.cli import main

BAD_JSON: list[Any] = [None, True, "x", "1", -1, 7.5, 1e308, -1e308, [], {}, 2**64]
BAD_CELLS = ["", "x", "-1", "1e308", "nan", "2.5", "True"]
Argv = Callable[[Path, Path], list[str]]


def cli(*argv: str) -> tuple[int, str]:
    """(exit code, stderr) of ``striatal ARGV`` in this process (a traceback: exit 1)."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            rc = main(list(argv))
        except SystemExit as exc:
            rc = int(exc.code or 0)
        except Exception:
            rc = 1
            err.write(traceback.format_exc())
    return rc, err.getvalue()


def snapshot(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def paths(obj: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    found = [prefix] if prefix else []
    if isinstance(obj, dict):
        for k, v in obj.items():
            found += paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:2]):
            found += paths(v, (*prefix, i))
    return found


class Pass:
    def __init__(self) -> None:
        self.cases = self.failed = 0

    def check(self, label: str, folder: Path, argv: list[str], resumable: bool) -> None:
        self.cases += 1
        before = snapshot(folder)
        t0 = time.monotonic()
        rc, err = cli(*argv)
        seconds = time.monotonic() - t0
        after = snapshot(folder)
        bad = []
        if "Traceback" in err:
            bad.append("traceback")
        if rc not in (0, 2):
            bad.append(f"exit {rc}")
        if rc == 2 and len(err.strip().splitlines()) != 1:
            bad.append("not one line")
        if rc == 2 and after != before:
            bad.append("wrote on refusal")
        if rc == 0 and not resumable and any(after.get(k) != v for k, v in before.items()):
            bad.append("input changed")
        if seconds > 60:
            bad.append(f"{seconds:.0f} s")
        if bad:
            self.failed += 1
            print("FAIL", label, bad, err.strip()[-300:], flush=True)

    def json_kind(self, name: str, src: Path, rel: str, argv: Argv, resumable: bool) -> None:
        base = json.loads((src / rel).read_text())
        for path in paths(base):
            for how in ["missing", *range(len(BAD_JSON))]:
                obj = json.loads(json.dumps(base))
                parent = obj
                for p in path[:-1]:
                    parent = parent[p]
                if how == "missing":
                    if not isinstance(parent, dict):
                        continue
                    del parent[path[-1]]
                else:
                    parent[path[-1]] = BAD_JSON[int(how)]
                with tempfile.TemporaryDirectory() as tmp:
                    folder = Path(tmp) / src.name
                    shutil.copytree(src, folder)
                    (folder / rel).write_text(json.dumps(obj))
                    label = f"{name} {'.'.join(map(str, path))} {how}"
                    self.check(label, Path(tmp), argv(folder, Path(tmp)), resumable)

    def csv_kind(self, name: str, src: Path, rel: str, argv: Argv, resumable: bool) -> None:
        rows = list(csv.reader(io.StringIO((src / rel).read_text())))
        for col in range(len(rows[0])):
            for cell in BAD_CELLS:
                new = [r[:] for r in rows]
                new[1][col] = cell
                buf = io.StringIO()
                csv.writer(buf, lineterminator="\n").writerows(new)
                with tempfile.TemporaryDirectory() as tmp:
                    folder = Path(tmp) / src.name
                    shutil.copytree(src, folder)
                    (folder / rel).write_text(buf.getvalue())
                    label = f"{name} {rows[0][col]}={cell!r}"
                    self.check(label, Path(tmp), argv(folder, Path(tmp)), resumable)


def make_inputs(root: Path) -> None:
    """The folders the kinds read, made once."""
    quick = ("--max-trials", "3", "--duration", "2")
    sweep = ("sweep", "--seeds", "2", *quick, "--eval-draws", "0", "--no-progress")
    made = {
        "F": ("train", "--learner", "forward", "--imagine-trials", "200", *quick),
        "G": ("train", "--learner", "forward", "--forward-model", "generic", *quick),
        "R": ("train", *quick),
        "S": sweep,
        "SB": (*sweep, "--baselines", "hand,random"),
        "AB": ("ablation", "--seeds", "2", "--max-trials", "1", "--variants", "chapter,pgpe"),
    }
    for name, argv in made.items():
        if not (root / name).exists():
            out = ("--out", str(root / name))
            rc, err = cli(*argv, *out, *(("--no-progress",) if name == "AB" else ()))
            if rc != 0:
                raise SystemExit(f"making {name}: {err.strip()[-300:]}")


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path, help="where the inputs are made (kept)")
    parser.add_argument("kinds", nargs="+")
    args = parser.parse_args()
    os.environ["STRIATAL_MAX_STEPS"] = str(2 * 10**7)  # as the fuzzer: work it can wait for
    root: Path = args.folder
    root.mkdir(parents=True, exist_ok=True)
    make_inputs(root)
    rerun = [
        *("sweep", "--seeds", "2", "--max-trials", "3", "--duration", "2"),
        *("--eval-draws", "0", "--no-progress", "--out"),
    ]
    kinds: dict[str, tuple[str, str, str, Argv, bool]] = {
        "summary": ("json", "SB", "summary.json", lambda f, t: ["compare", str(f)], False),
        "summary-profile": (
            "json", "SB", "summary.json",
            lambda f, t: ["profile", str(f), "--out", str(t / "p.png")], False,
        ),
        "runs": (
            "csv", "S", "runs.csv",
            lambda f, t: ["profile", str(f), "--out", str(t / "p.png")], False,
        ),
        "runs-rerun": ("csv", "S", "runs.csv", lambda f, t: [*rerun, str(f)], True),
        "result": (
            "json", "F", "result.json",
            lambda f, t: ["simulate", "--result", str(f / "result.json"), "--duration", "2"],
            False,
        ),
        "result-interpret": (
            "json", "F", "result.json",
            lambda f, t: ["interpret", "--result", str(f / "result.json")], False,
        ),
        "history": (
            "csv", "G", "history.csv",
            lambda f, t: ["curves", str(f / "history.csv"), "--out", str(t / "c.png")], False,
        ),
        "history-interpret": (
            "csv", "G", "history.csv",
            lambda f, t: ["interpret", "--history", str(f / "history.csv")], False,
        ),
        "checkpoint": (
            "json", "R", "checkpoint.json",
            lambda f, t: ["train", "--max-trials", "4", "--duration", "2", "--resume",
                          "--out", str(f)],
            True,
        ),
        "sweepjson": ("json", "S", "sweep.json", lambda f, t: [*rerun, str(f)], True),
        "ablation": (
            "json", "AB", "ablation.json",
            lambda f, t: ["robustness", str(f / "ablation.json"), "--repeats", "1"], False,
        ),
    }  # fmt: skip
    run = Pass()
    for kind in args.kinds:
        form, src, rel, argv, resumable = kinds[kind]
        start = run.cases
        how = run.json_kind if form == "json" else run.csv_kind
        how(kind, root / src, rel, argv, resumable)
        print(f"{kind}: {run.cases - start} cases", flush=True)
    print(f"{run.cases} cases, {run.failed} failed")


if __name__ == "__main__":
    main_()
