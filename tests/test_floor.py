"""The lowest supported dependency versions (tests/floor.txt) install and pass the tests.

Builds a venv under ``.venv-floor/<key>`` (or ``$STRIATAL_FLOOR_DIR/<key>``) with
``pip install -c tests/floor.txt .`` plus pytest, once per set of requirements
(the key hashes floor.txt and pyproject's dependencies), then runs the physics,
policy, environment, rendering, figure and simulate tests there against this
source tree. The first run downloads the wheels (about 2 minutes here).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import tomllib
import venv
from pathlib import Path

import pytest
from packaging.requirements import Requirement

pytestmark = pytest.mark.floor

ROOT = Path(__file__).resolve().parents[1]
FLOOR = ROOT / "tests" / "floor.txt"
SUBSET = [
    "tests/test_dynamics.py",
    "tests/test_control.py",
    "tests/test_policy.py",
    "tests/test_envs.py",
    "tests/test_envs_api.py",
    "tests/test_envs_render.py",
    "tests/test_plots.py",
    "tests/test_cli_simulate.py",
]


def floor_pins() -> dict[str, str]:
    """{name: version} from tests/floor.txt."""
    pins = {}
    for line in FLOOR.read_text().splitlines():
        line = line.split("#")[0].strip()
        if line:
            name, version = line.split("==")
            pins[name.strip().lower()] = version.strip()
    return pins


def core_requirements() -> list[Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return [Requirement(r) for r in project["dependencies"]]


def test_floor_is_pyprojects_lower_bounds() -> None:
    """Every core dependency has a floor, and it is the pyproject lower bound (>=)."""
    pins = floor_pins()
    for req in core_requirements():
        lower = [s.version for s in req.specifier if s.operator == ">="]
        assert len(lower) == 1, f"{req} needs one lower bound"
        # numba's floor 0.59 is pinned as 0.59.0, and so on.
        assert pins[req.name.lower()].startswith(lower[0]), (req, pins.get(req.name.lower()))
        assert pins[req.name.lower()] in req.specifier
    assert set(pins) == {r.name.lower() for r in core_requirements()}


def _floor_venv() -> Path:
    key_src = FLOOR.read_text() + json.dumps([str(r) for r in core_requirements()])
    key = hashlib.sha256(key_src.encode()).hexdigest()[:12]
    base = Path(os.environ.get("STRIATAL_FLOOR_DIR", ROOT / ".venv-floor"))
    env_dir = base / key
    python = env_dir / "bin" / "python"
    stamp = env_dir / "installed"
    if not stamp.exists():
        venv.create(env_dir, with_pip=True, clear=True)
        subprocess.run(
            [str(python), "-m", "pip", "install", "-q", "-c", str(FLOOR), str(ROOT),
             "pytest>=8", "hypothesis>=6.100"],
            check=True,
            timeout=1200,
        )  # fmt: skip
        stamp.write_text("ok\n")
    return env_dir


def test_lowest_versions_install_and_pass_the_tests() -> None:
    env_dir = _floor_venv()
    python = env_dir / "bin" / "python"
    versions = subprocess.run(
        [str(python), "-c", "import json, importlib.metadata as m, sys; "
         "print(json.dumps({n: m.version(n) for n in sys.argv[1:]}))", *floor_pins()],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    assert json.loads(versions.stdout) == floor_pins()
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT / "src"),
        "NUMBA_CACHE_DIR": str(env_dir / "numba-cache"),
        "NUMBA_NUM_THREADS": "1",
    }
    proc = subprocess.run(
        [str(python), "-m", "pytest", "-q", "-p", "no:cacheprovider", "--hypothesis-profile=floor",
         *SUBSET],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )  # fmt: skip
    tail = proc.stdout[-3000:] + proc.stderr[-2000:]
    assert proc.returncode == 0, tail
    # The tests ran against this source tree and these versions, and none was skipped
    # but the one that needs the [render] extra.
    assert " passed" in proc.stdout and " failed" not in proc.stdout, tail
    assert proc.stdout.count("skipped") <= 1, tail
    where = subprocess.run(
        [str(python), "-c", "import striatal; print(striatal.__file__)"],
        env=env, check=True, capture_output=True, text=True,
    )  # fmt: skip
    assert Path(where.stdout.strip()).is_relative_to(ROOT / "src")
