"""A fuzzer over every command, every option, every file kind and the Python API.

The property (docs/reliability.md, "The fuzzer"): whatever the input, a command ends
with exit 0 and a usable result, or exit 2 with exactly one line on stderr; within
:data:`TIME_LIMIT`; never a traceback; nothing written when it refuses; no input file
changed. The commands and their options are found from the CLI's own table
(:data:`striatal.cli.COMMANDS` and each command's parser), so a new option is fuzzed
the day it is added.

Budget: :data:`EXAMPLES` examples per test, derandomized (the same cases on every run
of ``make test``). ``STRIATAL_FUZZ_EXAMPLES=500 pytest tests/test_fuzz.py`` runs a
long, random budget (``make fuzz``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import Ran, cli_in_process
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import striatal
from striatal.cli import COMMANDS, build_parser
from striatal.errors import StriatalError

#: Examples per test: a short budget by default, a long one from the environment.
LONG = "STRIATAL_FUZZ_EXAMPLES" in os.environ
EXAMPLES = int(os.environ.get("STRIATAL_FUZZ_EXAMPLES", "4"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=not LONG,
    suppress_health_check=list(HealthCheck),
    database=None,
)
#: The most seconds one command may take on a fuzzed input (a refusal takes well under
#: one; the cheapest valid runs below take a few).
TIME_LIMIT = 60.0
#: The work limit while fuzzing (``STRIATAL_MAX_STEPS``): every command refuses, in one
#: line, work past what the time limit can wait for, as it refuses past its stated limit.
FUZZ_MAX_STEPS = 2 * 10**7


@pytest.fixture(autouse=True, scope="module")
def _work_the_time_limit_can_wait_for() -> Iterator[None]:
    old = os.environ.get("STRIATAL_MAX_STEPS")
    os.environ["STRIATAL_MAX_STEPS"] = str(FUZZ_MAX_STEPS)
    yield
    if old is None:
        del os.environ["STRIATAL_MAX_STEPS"]
    else:
        os.environ["STRIATAL_MAX_STEPS"] = old


#: Words that have broken commands before, and numbers at every edge.
HOSTILE_WORDS = (
    "",
    " ",
    "-1",
    "0",
    "-0",
    "1e308",
    "-1e308",
    "inf",
    "-inf",
    "nan",
    "1e-320",
    "2147483648",
    "9" * 400,
    "true",
    "none",
    "1,2",
    ",",
    "abc",
    "\u03b8",
    "../x",
    "2.0",
)
WORDS = st.one_of(
    st.sampled_from(HOSTILE_WORDS),
    st.integers(-(2**40), 2**40).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


def snapshot(folder: Path) -> dict[str, str]:
    """{relative path: sha256} of every file under ``folder``."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def check_property(
    ran: Ran,
    seconds: float,
    before: dict[str, str],
    after: dict[str, str],
    limit: float = TIME_LIMIT,
) -> None:
    """Exit 0, or exit 2 with one line; no traceback; within ``limit`` s; on exit 2
    nothing written and nothing changed; on exit 0 no input changed (new files only)."""
    assert "Traceback" not in ran.err, ran.err[-3000:]
    assert ran.rc in (0, 2), f"exit {ran.rc}: {ran.err[-2000:]}"
    assert seconds < limit, f"took {seconds:.1f} s, more than {limit:.0f} s"
    if ran.rc == 2:
        assert len(ran.err.strip().splitlines()) == 1, ran.err
        assert after == before, "a refused command wrote or changed files"
    else:
        changed = [k for k, v in before.items() if after.get(k) != v]
        assert not changed, f"an input changed: {changed}"


# -- the inputs the commands read: one tiny train run and one tiny sweep, made once ----


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with ``run`` (train: result.json, checkpoint.json, history.csv),
    ``sweep`` (runs.csv, summary.json, sweep.json) and ``ablation`` (ablation.json)."""
    root = tmp_path_factory.mktemp("fuzz-inputs")
    for argv in (
        ("train", "--max-trials", "2", "--duration", "2", "--out", str(root / "run")),
        (
            *("sweep", "--seeds", "2", "--max-trials", "2", "--duration", "2"),
            *("--eval-draws", "0", "--no-progress", "--out", str(root / "sweep")),
        ),
        (
            *("ablation", "--seeds", "2", "--max-trials", "1", "--variants", "chapter,pgpe"),
            *("--no-progress", "--out", str(root / "ablation")),
        ),
    ):
        ran = cli_in_process(*argv)
        assert ran.rc == 0, ran.err
    return root


def base_argv(command: str, inputs: Path, out: Path) -> list[str]:
    """A cheap valid invocation of ``command`` (a few seconds at most), writing under ``out``."""
    run, swept = inputs / "run", inputs / "sweep"
    return {
        "simulate": ["simulate", "--duration", "2", "--out", str(out / "sim")],
        "evaluate": ["evaluate", "--draws", "2", "--duration", "2"],
        "train": ["train", "--max-trials", "1", "--duration", "2", "--out", str(out / "t")],
        "figure": ["figure", "--duration", "2", "--out", str(out / "f.png")],
        "sweep": [
            *("sweep", "--seeds", "1", "--max-trials", "1", "--duration", "2"),
            *("--eval-draws", "0", "--no-progress", "--out", str(out / "s")),
        ],
        "compare": ["compare", str(swept)],
        "report": ["report", str(swept), "--out", str(out / "r.html")],
        "curves": ["curves", str(run / "history.csv"), "--out", str(out / "c.png")],
        "profile": ["profile", str(swept), "--out", str(out / "p.png")],
        "switch-figure": ["switch-figure", "--out", str(out / "sw.png")],
        "ablation": [
            *("ablation", "--seeds", "1", "--max-trials", "1", "--variants", "chapter"),
            *("--no-progress", "--out", str(out / "a")),
        ],
        "interpret": ["interpret", "--chapter-final"],
        "robustness": ["robustness", str(run / "result.json"), "--repeats", "1"],
        # the cheapest bench: one repeat of 0.05 s a side, no train, no sweeps (~15 s)
        "bench": [
            *("bench", "--quick", "--no-train", "--repeats", "1", "--seconds", "0.05"),
            *("--batch-size", "2"),
        ],
        # the smallest network for half a second (~2 s); more is refused by the work
        # limit the fuzzer sets (neurons x steps)
        "neural": [
            *("neural", "--neurons", "160", "--duration", "0.5", "--no-progress"),
            *("--out", str(out / "n")),
        ],
        "animate": [
            *("animate", "--duration", "1", "--width", "16", "--height", "16", "--fps", "2"),
            *("--out", str(out / "a.gif")),
        ],
    }[command]


def options_of(command: str) -> list[argparse.Action]:
    """Every option of ``command``, from its own parser (the CLI's table)."""
    parser = build_parser(only=command)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [
        a
        for a in sub.choices[command]._actions
        if a.option_strings and not isinstance(a, argparse._HelpAction) and a.help != "==SUPPRESS=="
    ]


FUZZED = list(COMMANDS)


@contextmanager
def workspace(inputs: Path) -> Iterator[tuple[Path, Path]]:
    """(a copy of the inputs, an empty folder for outputs), under a fresh folder that is
    also the working folder (a relative path such as ``../x`` stays inside it)."""
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / "in"
        shutil.copytree(inputs, copy)
        out = Path(tmp) / "out"
        out.mkdir()
        (Path(tmp) / "cwd").mkdir()
        os.chdir(Path(tmp) / "cwd")
        try:
            yield copy, out
        finally:
            os.chdir(here)


def time_limit(argv: list[str]) -> float:
    """:data:`TIME_LIMIT`, plus the wall budget the bench's options ask it to spend timing
    (``BenchConfig.timed_seconds``: the bench measures for as long as it is told)."""
    if argv[0] != "bench":
        return TIME_LIMIT
    from striatal.cli.bench import config_from

    try:
        args = build_parser(only="bench").parse_args(argv)
        return TIME_LIMIT + config_from(args).timed_seconds
    except (SystemExit, StriatalError):
        return TIME_LIMIT  # refused: at once


def run_timed(argv: list[str]) -> tuple[Ran, float]:
    t0 = time.monotonic()
    ran = cli_in_process(*argv)
    return ran, time.monotonic() - t0


@pytest.mark.parametrize("command", FUZZED)
@FUZZ
@given(data=st.data())
def test_every_option_of_every_command(command: str, made: Path, data: st.DataObject) -> None:
    """A hostile value for one option (or two) of ``command``."""
    actions = options_of(command)
    with workspace(made) as (inputs, out):
        argv = base_argv(command, inputs, out)
        for _ in range(data.draw(st.integers(1, 2), label="options")):
            action = data.draw(st.sampled_from(actions), label="option")
            flag = action.option_strings[-1]
            if action.nargs == 0:
                argv.append(flag)
            elif isinstance(action.nargs, int):
                argv += [flag, *(data.draw(WORDS, label=flag) for _ in range(action.nargs))]
            else:
                argv.append(f"{flag}={data.draw(WORDS, label=flag)}")
        before = snapshot(inputs.parent)
        ran, seconds = run_timed(argv)
        after = snapshot(inputs.parent)
        if ran.rc == 0:  # what it wrote is new; its inputs stay as they were
            after = {k: v for k, v in after.items() if k in before}
        check_property(ran, seconds, before, after, time_limit(argv))


# -- every field of every file kind ---------------------------------------------------

#: Each file kind: where it lies in the inputs, and the commands that read it.
FILES: dict[str, tuple[str, Callable[[Path, Path], list[str]]]] = {
    "result.json": (
        "run/result.json",
        lambda i, o: ["simulate", "--result", str(i / "run/result.json"), "--duration", "2"],
    ),
    "checkpoint.json": (
        "run/checkpoint.json",
        lambda i, o: ["train", "--resume", "--max-trials", "3", "--out", str(i / "run")],
    ),
    "history.csv": (
        "run/history.csv",
        lambda i, o: ["curves", str(i / "run/history.csv"), "--out", str(o / "c.png")],
    ),
    "runs.csv": (
        "sweep/runs.csv",
        lambda i, o: ["profile", str(i / "sweep"), "--out", str(o / "p.png")],
    ),
    "summary.json": ("sweep/summary.json", lambda i, o: ["compare", str(i / "sweep")]),
    "sweep.json": (
        "sweep/sweep.json",
        lambda i, o: [
            *("sweep", "--seeds", "2", "--max-trials", "2", "--duration", "2"),
            *("--eval-draws", "0", "--no-progress", "--out", str(i / "sweep")),
        ],
    ),
    "ablation.json": (
        "ablation/ablation.json",
        lambda i, o: ["robustness", str(i / "ablation/ablation.json"), "--repeats", "1"],
    ),
}

#: Values of the wrong type, out of range, or huge, for any field.
BAD_VALUES = st.one_of(
    st.sampled_from(
        [None, True, False, "", "x", "1", -1, -4, 0, 2.5, 1e300, -1e300, 10**30, [], {}, [1] * 7]
    ),
    st.integers(-(2**64), 2**64),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=20),
)
CELLS = st.one_of(
    st.sampled_from(["", "-1", "-4", "x", "1e300", "nan", "inf", "2.5", "1e6", "0", "1", "True"]),
    st.integers(-(2**40), 2**40).map(str),
)


def _paths(obj: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every path to a value in a JSON object (lists: their first three items)."""
    found = [prefix] if prefix else []
    if isinstance(obj, dict):
        for k, v in obj.items():
            found += _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:3]):
            found += _paths(v, (*prefix, i))
    return found


def mutate_json(text: str, data: st.DataObject) -> str:
    """``text`` with one field given a bad value, removed, or its list doubled."""
    obj = json.loads(text)
    paths = _paths(obj)
    path = data.draw(st.sampled_from(paths), label="field")
    parent = obj
    for p in path[:-1]:
        parent = parent[p]
    how = data.draw(st.sampled_from(["value", "missing", "duplicated"]), label="how")
    last = path[-1]
    if how == "missing" and isinstance(parent, dict):
        del parent[last]
    elif how == "duplicated" and isinstance(parent, list):
        parent.append(parent[last])
    elif how == "duplicated" and isinstance(parent[last], list):
        parent[last] = parent[last] * 2
    else:
        parent[last] = data.draw(BAD_VALUES, label="value")
    return json.dumps(obj)


def mutate_csv(text: str, data: st.DataObject) -> str:
    """``text`` with one cell changed, a column removed, or a row duplicated or changed."""
    lines = text.splitlines(keepends=True)
    header = lines[0].rstrip("\n").split(",")
    how = data.draw(st.sampled_from(["cell", "missing", "duplicated", "conflict"]), label="how")
    row = data.draw(st.integers(1, len(lines) - 1), label="row")
    col = data.draw(st.integers(0, len(header) - 1), label="column")
    if how == "missing":
        return "".join(
            ",".join(c for j, c in enumerate(line.rstrip("\n").split(",")) if j != col) + "\n"
            for line in lines
        )
    if how == "duplicated":
        return "".join([*lines, lines[row]])
    cells = lines[row].rstrip("\n").split(",")
    cells[col] = data.draw(CELLS, label=header[col])
    changed = ",".join(cells) + "\n"
    if how == "conflict":
        return "".join([*lines, changed])
    lines[row] = changed
    return "".join(lines)


@pytest.mark.parametrize("kind", list(FILES))
@FUZZ
@given(data=st.data())
def test_every_field_of_every_file(kind: str, made: Path, data: st.DataObject) -> None:
    """One field of ``kind`` mutated; the command that reads it."""
    where, argv_of = FILES[kind]
    with workspace(made) as (inputs, out):
        path = inputs / where
        text = path.read_text(encoding="utf-8")
        path.write_text(
            mutate_csv(text, data) if kind.endswith(".csv") else mutate_json(text, data),
            encoding="utf-8",
        )
        before = snapshot(inputs.parent)
        ran, seconds = run_timed(argv_of(inputs, out))
        after = snapshot(inputs.parent)
        if ran.rc == 0:
            # an accepted resume goes on writing into its own folder, by design; every
            # other reader leaves its inputs as they were
            resumed = {"checkpoint.json": "in/run/", "sweep.json": "in/sweep/"}.get(kind)
            after = {
                k: v
                for k, v in after.items()
                if k in before and not (resumed and k.startswith(resumed))
            }
            before = {k: v for k, v in before.items() if not (resumed and k.startswith(resumed))}
        check_property(ran, seconds, before, after)


# -- the Python API -------------------------------------------------------------------

API_VALUES = st.one_of(
    st.sampled_from(
        [None, True, "2", "", 2.0, -1, 0, 10**30, float("nan"), float("inf"), [], (), {"a": 1}]
    ),
    st.sampled_from([np.int64(2), np.float64(0.5), np.int64(-1), np.bool_(True)]),
    st.integers(-(2**40), 2**40),
)
SWEEP_BASE: dict[str, Any] = {
    "seeds": 1,
    "max_trials": 1,
    "eval_draws": 0,
    "sim": striatal.Simulation(duration=2.0),
}


@FUZZ
@given(data=st.data())
def test_the_sweep_api(data: st.DataObject) -> None:
    """striatal.sweep with one argument hostile: a result, or one StriatalError; nothing
    written when refused."""
    import inspect

    names = [
        n for n in inspect.signature(striatal.sweep).parameters if n not in ("out", "progress")
    ]
    name = data.draw(st.sampled_from(names), label="argument")
    value = data.draw(API_VALUES, label=name)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "s"
        t0 = time.monotonic()
        try:
            result = striatal.sweep(**{**SWEEP_BASE, name: value, "out": out})
        except StriatalError as exc:
            assert "\n" not in str(exc)
            assert not out.exists() or not any(out.iterdir()), "written before refusing"
        else:
            assert result.summary["arms"] and (out / "summary.json").exists()
        assert time.monotonic() - t0 < TIME_LIMIT


@FUZZ
@given(data=st.data())
def test_the_train_api(data: st.DataObject) -> None:
    """striatal.train with one keyword hostile: a run, or one StriatalError."""
    name = data.draw(
        st.sampled_from(["seed", "theta_c0", "inhibition", "max_trials", "alpha", "gamma", "init"]),
        label="argument",
    )
    value = data.draw(API_VALUES, label=name)
    t0 = time.monotonic()
    try:
        run = striatal.train(
            **{"max_trials": 1, "sim": striatal.Simulation(duration=2.0), name: value}
        )
    except StriatalError as exc:
        assert "\n" not in str(exc)
    else:
        assert run.trials >= 1
    assert time.monotonic() - t0 < TIME_LIMIT


@FUZZ
@given(data=st.data())
def test_the_gymnasium_kwargs(data: st.DataObject) -> None:
    """gymnasium.make with one kwarg hostile: an env that steps, or one StriatalError."""
    gym = pytest.importorskip("gymnasium")
    name = data.draw(
        st.sampled_from(["dt", "duration", "u_max", "track", "perturbation", "dtype"]),
        label="kwarg",
    )
    value = data.draw(API_VALUES, label=name)
    try:
        env = gym.make("striatal/CartPoleSwingUp-v0", **{name: value})
    except StriatalError as exc:
        assert "\n" not in str(exc)
        return
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
