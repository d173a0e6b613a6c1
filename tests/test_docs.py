"""The API reference builds from the docstrings (mkdocs --strict), and reads them right."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _extension() -> object:
    spec = importlib.util.spec_from_file_location(
        "griffe_descriptions", ROOT / "docs" / "griffe_descriptions.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_section_items_become_numpydoc_descriptions() -> None:
    pytest.importorskip("griffe", reason="needs mkdocstrings-python (the [dev] extra)")
    ext = _extension()
    text = (
        "Summary, see :func:`~striatal.sim.kernel.rk4_step`.\n\n"
        "Parameters\n----------\n"
        "state : (4,) [x, x_dot, theta, theta_dot]\n    continued.\n"
        "width, height : image size [px].\n\n"
        "Prose after : the section is not an item.\n"
    )
    out = ext.plain_roles(ext.split_items(text))  # type: ignore[attr-defined]
    assert out.splitlines() == [
        "Summary, see `striatal.sim.kernel.rk4_step`.",
        "",
        "Parameters",
        "----------",
        "state",
        "    (4,) [x, x_dot, theta, theta_dot]",
        "    continued.",
        "width, height",
        "    image size [px].",
        "",
        "Prose after : the section is not an item.",
    ]


def test_api_reference_builds_in_strict_mode(tmp_path: Path) -> None:
    for module in ("mkdocs", "mkdocstrings", "mkdocstrings_handlers.python", "material"):
        pytest.importorskip(module, reason="needs the docs tools of the [dev] extra")
    site = tmp_path / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    page = (site / "api" / "envs" / "index.html").read_text(encoding="utf-8")
    # A parameter's text is its description, not its type.
    assert "switching threshold [rad] (eq 21)." in page
    assert "<code>switching threshold" not in page
    for name in ("training", "model", "learning", "envs", "analysis", "files"):
        assert (site / "api" / name / "index.html").is_file()
    # The Python API leads the reference, and every layer's public module is on a page.
    index = (site / "api" / "index.html").read_text(encoding="utf-8")
    assert index.index('<td><a href="training/">') < index.index('<td><a href="model/">')
    learning = (site / "api" / "learning" / "index.html").read_text(encoding="utf-8")
    for module in ("config", "state", "rule", "loop", "chapter", "rpe", "pgpe"):
        assert f'id="striatal.learners.{module}"' in learning, module
    for module in ("stats", "evaluate", "profiles"):
        assert f'id="striatal.experiments.{module}"' in learning, module
    training = (site / "api" / "training" / "index.html").read_text(encoding="utf-8")
    assert (
        'id="striatal.experiments.training.train"' in training
        and 'id="striatal.io.rundir"' in training
    )
    # Re-exports are documented once, where they are defined.
    assert 'id="striatal.learners.LearnerConfig"' not in learning
    # The tutorial is a page with its stored outputs; the architecture page is built.
    tutorial = (site / "tutorial" / "index.html").read_text(encoding="utf-8")
    assert "success test (eqs 24-25): passed" in tutorial and "<img" in tutorial
    assert (site / "architecture" / "index.html").is_file()
    assert not list(site.rglob("cli*")), "the CLI is not part of the API reference"
