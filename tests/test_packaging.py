"""The package's metadata: what a package index shows, built as pip builds it."""

from __future__ import annotations

import email.parser
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from striatal.errors import StriatalError

ROOT = Path(__file__).resolve().parents[1]
#: extras that `all` leaves out: the tools of development and of benchmarking (gymnax
#: holds gymnasium below 1.4)
NOT_IN_ALL = {"dev", "bench", "all"}


def _project() -> dict[str, object]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert isinstance(project, dict)
    return project


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
        # the report's template is package data: striatal report works from the wheel
        assert "striatal/reports/templates/report.html.j2" in zf.namelist()
    return email.parser.Parser().parsestr(text)


def test_description_reads_on_its_own(metadata: email.message.Message) -> None:
    """No relative links or images (they break on an index page), no make targets first."""
    assert metadata["Description-Content-Type"] == "text/markdown"
    body = metadata.get_payload()
    assert isinstance(body, str)
    # what works: a clone or a wheel built from it; the package is on no index
    assert "pip install -e ." in body and "python -m build --wheel" in body
    assert "not published" in body
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
    assert "Typing :: Typed" in classifiers
    assert "Operating System :: POSIX" in classifiers
    assert "Operating System :: OS Independent" not in classifiers
    extras = set(metadata.get_all("Provides-Extra") or [])
    assert {"dev", "rl", "cluster", "render", "neural", "model", "all"} <= extras
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


def test_all_extra_is_the_union_of_the_user_facing_extras() -> None:
    extras = _project()["optional-dependencies"]
    assert isinstance(extras, dict)
    user_facing = set(extras) - NOT_IN_ALL
    assert {"rl", "render", "cluster", "neural", "model"} <= user_facing
    union = {str(Requirement(r)) for name in user_facing for r in extras[name]}
    everything = [str(Requirement(r)) for r in extras["all"]]
    assert len(everything) == len(set(everything)), "a requirement twice in [all]"
    lacks, more = sorted(union - set(everything)), sorted(set(everything) - union)
    assert not lacks and not more, f"[all] lacks {lacks}, has {more} of no other extra"


def test_classifiers_state_what_is_tested() -> None:
    """Python 3.11 (what the tests and the floor test run) and 3.13 (a subset run under
    it), POSIX, typed."""
    project = _project()
    classifiers = project["classifiers"]
    assert isinstance(classifiers, list)
    versions = {
        c.rsplit(" :: ", 1)[1]
        for c in classifiers
        if re.fullmatch(r"Programming Language :: Python :: 3\.\d+", c)
    }
    assert versions == {"3.11", "3.13"}, versions
    assert project["requires-python"] == ">=3.11"
    assert (ROOT / "src" / "striatal" / "py.typed").is_file()
    assert "Typing :: Typed" in classifiers
    assert "Operating System :: POSIX" in classifiers
    assert not [c for c in classifiers if "OS Independent" in c or "Windows" in c]


def _citation_urls(text: str) -> dict[str, str]:
    """``repository-code`` and ``url`` of a CITATION.cff's top level, when it has them."""
    found = {}
    for line in text.splitlines():
        m = re.match(r"(repository-code|url):\s*[\"']?([^\"'\s]+)", line)
        if m:
            found[m.group(1)] = m.group(2)
    return found


def test_project_urls_come_from_the_citation() -> None:
    """No invented address: the project's URLs are CITATION.cff's repository, or none."""
    urls = _project().get("urls", {})
    assert isinstance(urls, dict)
    cited = _citation_urls((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    repository = cited.get("repository-code")
    if repository is None:
        assert urls == {}, f"project URLs {urls} but CITATION.cff names no repository-code"
        return
    assert set(urls) >= {"Homepage", "Documentation", "Source", "Changelog"}, urls
    assert urls["Source"] == repository
    for name, url in urls.items():
        assert re.match(r"https://", url), (name, url)
        assert url.startswith((repository, cited.get("url", repository))), (name, url)


def test_citation_url_reader() -> None:
    text = "title: x\nrepository-code: 'https://host/o/r'\nurl: https://o.host/r\n  url: nested\n"
    assert _citation_urls(text) == {
        "repository-code": "https://host/o/r",
        "url": "https://o.host/r",
    }
    assert _citation_urls("title: x\n") == {}


def test_folder_lock_works_without_fcntl(tmp_path: Path) -> None:
    """The folder lock is filelock's: without fcntl (not POSIX) it is filelock's soft lock,
    which still refuses a second writer, and leaves nothing in the folder."""
    code = (
        "import sys, warnings; sys.modules['fcntl'] = None\n"
        "warnings.simplefilter('ignore')\n"
        "import striatal.io.rundir as rd\n"
        "from striatal.errors import StriatalError\n"
        "first, second = rd.RunDir(sys.argv[1]), rd.RunDir(sys.argv[1])\n"
        "with first.lock():\n"
        "    try:\n"
        "        with second.lock():\n"
        "            raise SystemExit('the lock was taken twice')\n"
        "    except StriatalError as exc:\n"
        "        print(exc)\n"
    )
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-c", code, str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "in use by another striatal process" in proc.stdout and str(out) in proc.stdout
    assert list(out.iterdir()) == [], "the lock file is not in the folder"


def test_no_hand_written_fcntl_locks() -> None:
    """Locks are filelock's (portable): no module of the package uses fcntl."""
    sources = (ROOT / "src" / "striatal").rglob("*.py")
    assert [p for p in sources if "fcntl" in p.read_text(encoding="utf-8")] == []


def test_lock_still_locks_with_fcntl(tmp_path: Path) -> None:
    from striatal.io.rundir import RunDir

    folder = RunDir(tmp_path / "run")
    second = RunDir(tmp_path / "run")
    with (
        folder.lock(),
        pytest.raises(StriatalError, match="in use by another striatal process"),
        second.lock(),
    ):
        pass
