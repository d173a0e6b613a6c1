"""The package's metadata: what a package index shows, built as pip builds it."""

from __future__ import annotations

import email.parser
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def metadata(tmp_path_factory: pytest.TempPathFactory) -> email.message.Message:
    """METADATA of a wheel built from this tree (python -m build, no isolation: offline)."""
    pytest.importorskip("build", reason="needs the build package of the [dev] extra")
    pytest.importorskip("setuptools", reason="needs setuptools to build without isolation")
    src = tmp_path_factory.mktemp("src")
    # Build from a copy: the build must not write egg-info or build/ into the tree.
    for name in ("pyproject.toml", "LICENSE", "README.md"):
        shutil.copy(ROOT / name, src / name)
    (src / "docs").mkdir()
    shutil.copy(ROOT / "docs" / "pypi-description.md", src / "docs" / "pypi-description.md")
    shutil.copytree(ROOT / "src", src / "src", ignore=shutil.ignore_patterns("__pycache__"))
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out)],
        cwd=src,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (wheel,) = out.glob("striatal-*.whl")
    with zipfile.ZipFile(wheel) as zf:
        (name,) = [n for n in zf.namelist() if n.endswith(".dist-info/METADATA")]
        text = zf.read(name).decode()
        assert any(n.endswith(".dist-info/licenses/LICENSE") for n in zf.namelist())
    return email.parser.Parser().parsestr(text)


def test_description_reads_on_its_own(metadata: email.message.Message) -> None:
    """No relative links or images (they break on an index page), no make targets first."""
    assert metadata["Description-Content-Type"] == "text/markdown"
    body = metadata.get_payload()
    assert isinstance(body, str) and "pip install striatal" in body
    targets = re.findall(r"\]\(([^)]*)\)", body) + re.findall(r"<img[^>]*src=\"([^\"]*)\"", body)
    relative = [t for t in targets if not re.match(r"https?://", t)]
    assert relative == [], relative
    assert "make run" not in body.split("\n## ")[0]


def test_core_metadata(metadata: email.message.Message) -> None:
    assert metadata["Name"] == "striatal"
    assert metadata["License-Expression"] == "MIT"
    assert metadata["Author"] or metadata["Author-email"]
    classifiers = metadata.get_all("Classifier") or []
    assert "Programming Language :: Python :: 3.11" in classifiers
    extras = set(metadata.get_all("Provides-Extra") or [])
    assert {"dev", "rl", "cluster", "render"} <= extras
    requires = metadata.get_all("Requires-Dist") or []
    gym = [Requirement(r) for r in requires if r.startswith("gymnasium")]
    # 1.0 lacks gymnasium.vector.AutoresetMode, which striatal.envs imports
    assert gym and "1.0.0" not in gym[0].specifier and "1.1.0" in gym[0].specifier
    # torch is a range in [rl], never an exact pin
    torch = [r for r in requires if r.startswith("torch")]
    assert torch and all(s.operator != "==" for r in torch for s in Requirement(r).specifier), torch
    assert any(r.startswith("pygame") and 'extra == "render"' in r for r in requires)
    # No project URL that points nowhere.
    for url in metadata.get_all("Project-URL") or []:
        assert "example" not in url and "TODO" not in url


def test_citation_cites_chapter_and_software() -> None:
    text = (ROOT / "CITATION.cff").read_text()
    assert text.startswith("cff-version: 1.2.0")
    assert "type: software" in text and "version: 0.1.0" in text
    assert "Basal ganglionic learning applied to control of an underactuated system" in text
    assert "Chapter 7" in text
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert "## [Unreleased]" in (ROOT / "CHANGELOG.md").read_text()
