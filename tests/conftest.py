"""Shared fixtures, and the ways a test runs the ``striatal`` command.

- the ``cli`` fixture: in this process through ``main``, output captured by capsys;
- :func:`cli_in_process`: the same without a fixture (for hypothesis tests and module
  fixtures), an escaping exception returned as exit 1 with its traceback;
- :func:`cli_process` / :func:`cli_process_env`: ``python -m striatal`` in a fresh
  process, as a user runs it.
"""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import traceback
from collections.abc import Iterator
from contextlib import redirect_stderr, redirect_stdout
from typing import Any, NamedTuple

import pytest
from hypothesis import settings

from striatal.cli import main
from striatal.params import Plant, Simulation

# `pytest --hypothesis-profile=floor` (tests/test_floor.py): no per-example deadline,
# since the lowest-versions run shares the machine with the rest of the suite.
settings.register_profile("floor", deadline=None)

# No window on screen: pygame (the [render] extra) draws render_mode="human" off-screen,
# also when gymnasium's check_env makes the env in every render mode it lists.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


@pytest.fixture
def plant() -> Plant:
    return Plant()


class KernelCounter:
    """Counts the kernel's trial calls and their simulated steps."""

    def __init__(self) -> None:
        self.calls = 0
        self.steps = 0

    def seconds(self, dt: float = 0.01) -> float:
        return self.steps * dt


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> Iterator[KernelCounter]:
    """Every call of the scalar kernel's ``run_trial`` counted, with its simulated steps."""
    from striatal.sim import kernel, rollout  # the tests that count import the kernel

    counter = KernelCounter()
    real = kernel.run_trial

    def counting(*args: Any) -> Any:
        result = real(*args)
        counter.calls += 1
        counter.steps += int(args[-1][0][kernel.OUT_END_STEP])
        return result

    monkeypatch.setattr(rollout.kernel, "run_trial", counting)
    yield counter


@pytest.fixture
def sim60() -> Simulation:
    return Simulation()


class Cli:
    """``striatal ARGS...`` run in this process: exit code, stdout and stderr."""

    def __init__(self, capsys: pytest.CaptureFixture[str]) -> None:
        self._capsys = capsys

    def __call__(self, *argv: object) -> tuple[int, str, str]:
        self._capsys.readouterr()  # what earlier calls printed is not this call's
        code = main([str(a) for a in argv])
        out, err = self._capsys.readouterr()
        return code, out, err


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str]) -> Cli:
    """The shared way to run a command in a test: ``code, out, err = cli("train", ...)``."""
    return Cli(capsys)


def benchmark_module(name: str) -> Any:
    """benchmarks/``name``.py loaded as a module (benchmarks are scripts, not a package)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"{name}_bench", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def neural_learn_bench() -> Any:
    """benchmarks/neural_learn.py as a module (the spiking learner's runs and tables)."""
    return benchmark_module("neural_learn")


class Ran(NamedTuple):
    rc: int
    out: str
    err: str


def cli_in_process(*argv: str) -> Ran:
    """``striatal ARGV`` through the CLI's own ``main``; an escaping exception is a traceback."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            rc = main(list(argv))
        except SystemExit as exc:
            rc = int(exc.code or 0)
        except Exception:
            rc = 1
            err.write(traceback.format_exc())
    return Ran(rc, out.getvalue(), err.getvalue())


def default_sigint() -> None:
    # a child started from a shell that ignores SIGINT would inherit that
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def cli_process(*argv: str) -> Ran:
    """``python -m striatal ARGV`` in a fresh process, as a user runs it."""
    return cli_process_env({}, *argv)


def cli_process_env(env: dict[str, str], *argv: str) -> Ran:
    """:func:`cli_process` with ``env`` added to the environment; output read as bytes
    and decoded as ``PYTHONIOENCODING`` says (UTF-8 by default)."""
    r = subprocess.run(
        [sys.executable, "-m", "striatal", *argv],
        capture_output=True,
        timeout=300,
        env={**os.environ, **env},
        preexec_fn=default_sigint,
    )
    decode = env.get("PYTHONIOENCODING", "utf-8")
    return Ran(r.returncode, r.stdout.decode(decode), r.stderr.decode(decode))
