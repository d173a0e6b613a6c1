"""A fast start: help loads only the command's own module, and the first compile of the
kernel is announced in one line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import striatal
from striatal.cli import COMMANDS, jit

HEAVY = ("numba", "scipy", "matplotlib")
SRC = str(Path(striatal.__file__).parents[1])
#: Commands whose options come from the learners, whose modules import the compiled kernel
#: at their top: their help loads Numba until the learners' registry loads without it.
NEEDS_LEARNERS = {"train", "sweep", "ablation"}


def _loaded_after(argv: list[str]) -> list[str]:
    code = textwrap.dedent(
        f"""
        import json, sys
        from striatal.cli import main
        try:
            main({argv!r})
        except SystemExit:
            pass
        print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]), file=sys.stderr)
        """
    )
    env = {**os.environ, "PYTHONPATH": SRC}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    assert "usage:" in done.stdout
    return json.loads(done.stderr.strip().splitlines()[-1])


def test_striatal_help_loads_no_heavy_library() -> None:
    assert _loaded_after(["--help"]) == []


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(
            n,
            marks=pytest.mark.xfail(
                n in NEEDS_LEARNERS,
                reason="striatal.learners imports the kernel at its top",
                strict=True,
            ),
        )
        for n in COMMANDS
    ],
)
def test_command_help_loads_no_heavy_library(name: str) -> None:
    assert _loaded_after([name, "--help"]) == []


def test_train_help_loads_no_scipy_subpackage() -> None:
    """The learners' registry (forward's model included) loads none of SciPy's
    subpackages: forward's fit reaches scipy.optimize only when it runs."""
    code = textwrap.dedent(
        """
        import json, sys
        from striatal.cli import main
        try:
            main(["train", "--help"])
        except SystemExit:
            pass
        import striatal.learners.forward.model
        print(json.dumps(sorted(m for m in sys.modules if m.startswith("scipy."))))
        """
    )
    env = {**os.environ, "PYTHONPATH": SRC}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    loaded = json.loads(done.stdout.strip().splitlines()[-1])
    # Numba imports the bare package (its version check); nothing public below it
    assert [m for m in loaded if not m.split(".")[1].startswith("_")] == ["scipy.version"]


PROBE = """
from numba import njit

@njit(cache=True)
def twice(x):
    return 2 * x

@njit(cache=True)
def thrice(x):
    return 3 * x
"""


FORKED = """
import multiprocessing, sys
sys.path.insert(0, sys.argv[1])
from striatal.cli import jit
jit.announce_compiles(package="probe")
import probe

def work(x):  # each worker compiles a function of its own
    return probe.twice(x) if x == 1 else probe.thrice(x)

with multiprocessing.get_context("fork").Pool(2) as pool:
    pool.map(work, [1, 2], chunksize=1)
"""


def _run_probe(tmp_path: Path, forked: bool = False) -> str:
    code = (
        FORKED
        if forked
        else textwrap.dedent(
            """
        import sys
        sys.path.insert(0, sys.argv[1])
        from striatal.cli import jit
        jit.announce_compiles(package="probe")
        import probe
        probe.twice(3)
        """
        )
    )
    env = {**os.environ, "PYTHONPATH": SRC, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    return done.stderr


def test_the_first_compile_is_announced_once_and_a_warm_cache_is_silent(tmp_path: Path) -> None:
    (tmp_path / "probe.py").write_text(PROBE)
    cold = _run_probe(tmp_path)
    assert cold.count("compiling the simulation kernel") == 1, cold
    assert str(tmp_path / "cache") in cold
    assert _run_probe(tmp_path) == ""


def test_forked_workers_say_it_once_in_all(tmp_path: Path) -> None:
    (tmp_path / "probe.py").write_text(PROBE)
    assert _run_probe(tmp_path, forked=True).count("compiling the simulation kernel") == 1


def test_the_commands_that_run_the_kernel_announce_its_compile() -> None:
    quiet = {name for name, c in COMMANDS.items() if not c.compiles}
    assert quiet == {"compare", "curves", "profile", "report", "switch-figure", "interpret"}
    assert jit.NOTICE.count("\n") == 1 and jit.NOTICE.endswith("\n")


def test_a_warm_simulate_says_nothing_on_stderr() -> None:
    env = {**os.environ, "PYTHONPATH": SRC}
    argv = [sys.executable, "-m", "striatal", "simulate", "--chapter-final", "--json"]
    subprocess.run(argv, capture_output=True, env=env, check=True)  # warms the cache
    done = subprocess.run(argv, capture_output=True, text=True, env=env, check=True)
    assert done.stderr == ""
