"""The API reference builds from the docstrings (mkdocs --strict), and reads them right."""

from __future__ import annotations

import importlib.util
import os
import re
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


# --------------------------------------------------------------------------- the pages

README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: "issue 14", "Issues 9 and 14", "(issue-15)": a tracker's number, not the code's story
ISSUE_NUMBER = re.compile(r"\bissues?[ -]#?\d+", re.IGNORECASE)
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _words(text: str) -> int:
    """Words as ``wc -w`` counts them: runs of non-whitespace."""
    return len(text.split())


def _slug(heading: str) -> str:
    """The anchor mkdocs' toc (and GitHub) give a heading: lower case, punctuation out."""
    text = re.sub(r"[^\w\s-]", "", heading.strip().lower())
    return re.sub(r"[\s]+", "-", text)


def _anchors(page: Path) -> set[str]:
    return {
        _slug(m.group(1))
        for m in re.finditer(r"^#{1,6}\s+(.*?)\s*$", page.read_text(encoding="utf-8"), re.M)
    }


def _nav_files(node: object) -> list[str]:
    """Every page of an mkdocs ``nav`` (lists of strings and one-key mappings)."""
    if isinstance(node, str):
        return [node]
    if isinstance(node, list):
        return [f for item in node for f in _nav_files(item)]
    if isinstance(node, dict):
        return [f for value in node.values() for f in _nav_files(value)]
    raise TypeError(f"unexpected nav entry {node!r}")


def _mkdocs_config() -> dict[str, object]:
    yaml = pytest.importorskip("yaml", reason="needs PyYAML (mkdocs, the [dev] extra)")
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    assert isinstance(config, dict)
    return config


def _doc_pages(config: dict[str, object]) -> set[str]:
    """docs/ pages mkdocs builds: every .md and .ipynb outside ``exclude_docs``."""
    excluded = str(config.get("exclude_docs", "")).split()
    pages = set()
    for path in DOCS.rglob("*"):
        rel = path.relative_to(DOCS).as_posix()
        if path.suffix not in (".md", ".ipynb") or ".ipynb_checkpoints" in rel:
            continue
        if any(rel == ex or (ex.endswith("/") and rel.startswith(ex)) for ex in excluded):
            continue
        pages.add(rel)
    return pages


def test_helpers_read_what_they_should() -> None:
    assert _words("make run  # set-up\n\n`pip install .`") == 7
    assert _slug("A three-factor actor-critic learner") == "a-three-factor-actor-critic-learner"
    assert _slug("`make run`: the chapter's experiment") == "make-run-the-chapters-experiment"
    for text in ("Issue 9.", "predates issue 14", "(issue-15)", "issues 9 and", "Issue #18"):
        assert ISSUE_NUMBER.search(text), text
    for text in ("the issue's box", "no issues here", "tissue 5", "issue the command"):
        assert not ISSUE_NUMBER.search(text), text
    nav = [{"Home": "index.md"}, {"Guide": [{"A": "a.md"}, "api/index.md"]}]
    assert _nav_files(nav) == ["index.md", "a.md", "api/index.md"]


def test_readme_is_short_and_starts_with_the_two_commands() -> None:
    text = README.read_text(encoding="utf-8")
    assert _words(text) <= 1000, f"README.md has {_words(text)} words; move detail to docs/"
    first_block = text.split("```", 2)[1]
    assert first_block.splitlines()[1].startswith("make run")
    assert first_block.splitlines()[2].startswith("make test")
    assert re.search(r"^## Installation$", text, re.M)
    for name in ("rl", "render", "cluster", "neural", "model", "bench", "dev", "all"):
        assert f"- `{name}`:" in text, f"README's Installation does not name the {name} extra"
    assert "pip install '.[all]'" in text


def test_readme_has_no_p_values() -> None:
    """Rates with intervals, not test statistics: those are in docs/results.md."""
    text = README.read_text(encoding="utf-8")
    assert not re.search(r"\bp\s*=\s*[0-9.e-]+", text)


def test_readme_links_point_at_files_and_headings() -> None:
    text = README.read_text(encoding="utf-8")
    targets = [t for t in LINK.findall(text) if not re.match(r"https?://", t)]
    assert targets, "README.md links to no docs page"
    for target in targets:
        path, _, anchor = target.partition("#")
        assert (ROOT / path).is_file(), target
        if anchor:
            assert anchor in _anchors(ROOT / path), target


def test_nav_lists_every_page_and_only_pages_that_exist() -> None:
    config = _mkdocs_config()
    nav = _nav_files(config["nav"])
    assert nav[0] == "index.md", "the home page leads the nav"
    missing = _doc_pages(config) - set(nav)
    assert not missing, f"docs pages missing from mkdocs.yml's nav: {sorted(missing)}"
    absent = [page for page in nav if not (DOCS / page).is_file()]
    assert not absent, f"nav entries with no file: {absent}"
    assert len(nav) == len(set(nav)), "a page is in the nav twice"


def test_no_issue_numbers_in_readme_or_docs() -> None:
    """History (which tracker issue asked for what) belongs in CHANGELOG.md."""
    pages = [README, *DOCS.rglob("*.md"), *DOCS.glob("*.ipynb")]
    found = [
        f"{page.relative_to(ROOT)}:{n}: {line.strip()}"
        for page in pages
        for n, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1)
        if ISSUE_NUMBER.search(line)
    ]
    assert not found, "\n".join(found)
