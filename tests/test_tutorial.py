"""docs/tutorial.ipynb runs on this checkout without error, and its stored outputs are current.

The notebook is executed (nbclient, the venv's ``python3`` kernel, this checkout's
``src`` first on PYTHONPATH) in a temporary copy; ``make tutorial`` re-executes the
stored one in place. Needs nbclient, nbformat, ipykernel (the [dev] extra); the full run
also needs stable-baselines3 (the [rl] extra), skipped with the reason when one is
missing. A second run makes torch and stable-baselines3 unimportable, as on a base
install: every cell must still run, and the cells tagged ``rl`` print a skip line.
"""

from __future__ import annotations

import base64
import os
import shutil
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "docs" / "tutorial.ipynb"
#: Cells tagged so do not give the same text on every machine (torch, wall times).
VARIES = "varies"
#: Cells tagged so need the [rl] extra and print a line starting so without it.
RL = "rl"
SKIPPED = "skipped: "
#: Seconds one cell may take (the PPO cell takes under a minute on a shared 2-core machine).
CELL_TIMEOUT = 600
#: The first cell of an executed copy: which Python and which striatal the kernel runs.
PROBE = "import sys, striatal; print(sys.executable); print(striatal.__file__)"
#: A base install: importing torch or stable_baselines3 raises ModuleNotFoundError. A
#: finder rather than ``sys.modules[name] = None``: scipy reads ``sys.modules["torch"]``
#: when the key is there, which a base install never has.
NO_RL = """
import sys
from importlib.abc import MetaPathFinder

assert not {"torch", "stable_baselines3"} & set(sys.modules), "imported before the cell"


class NoRL(MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in ("torch", "stable_baselines3"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


sys.meta_path.insert(0, NoRL())
"""

pytestmark = pytest.mark.slow


def _nbformat() -> Any:
    return pytest.importorskip("nbformat", reason="needs nbformat (the [dev] extra)")


def _text(cell: Any) -> str:
    """The text a code cell printed (stdout and text/plain results)."""
    parts = []
    for out in cell.get("outputs", []):
        if out["output_type"] == "stream":
            parts.append(out["text"])
        elif "data" in out and "image/png" not in out["data"]:
            parts.append(out["data"].get("text/plain", ""))
    return "".join(parts)


def _tags(cell: Any) -> list[str]:
    return list(cell.metadata.get("tags", []))


def _code_cells(nb: Any) -> list[Any]:
    return [c for c in nb.cells if c.cell_type == "code"]


def _execute(tmp_path: Path, first: str) -> tuple[list[Any], list[Any]]:
    """(stored code cells, executed code cells) of a copy run after the cell ``first``,
    which prints the kernel's Python and striatal; checks both are this checkout's."""
    nbformat = _nbformat()
    nbclient = pytest.importorskip("nbclient", reason="needs nbclient (the [dev] extra)")
    pytest.importorskip("ipykernel", reason="needs ipykernel (the [dev] extra)")
    copy = tmp_path / "tutorial.ipynb"
    shutil.copy(NOTEBOOK, copy)
    stored = _code_cells(nbformat.read(copy, as_version=4))
    nb = nbformat.read(copy, as_version=4)
    nb.cells.insert(0, nbformat.v4.new_code_cell(first))
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(
            [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])]
        ),
    }
    client = nbclient.NotebookClient(
        nb,
        timeout=CELL_TIMEOUT,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute(env=env)  # raises CellExecutionError on any cell's error

    python, module = _text(nb.cells[0]).split()
    assert Path(python).resolve() == Path(sys.executable).resolve()
    assert Path(module).resolve() == (ROOT / "src" / "striatal" / "__init__.py").resolve()
    ran = _code_cells(nb)[1:]
    assert len(ran) == len(stored)
    for cell in ran:
        assert all(o["output_type"] != "error" for o in cell.outputs), cell.source[:80]
    return stored, ran


def test_stored_notebook_is_executed_and_small() -> None:
    nb = _nbformat().read(NOTEBOOK, as_version=4)
    code = _code_cells(nb)
    assert code, "the tutorial has no code cell"
    counts = [c.execution_count for c in code]
    assert counts == list(range(1, len(code) + 1)), f"not executed top to bottom: {counts}"
    for cell in code:
        for out in cell.outputs:
            assert out["output_type"] != "error", cell.source[:80]
            png = out.get("data", {}).get("image/png")
            if png is not None:
                assert len(base64.b64decode(png)) < 200_000, "save figures at dpi ~80"
    assert NOTEBOOK.stat().st_size < 600_000
    text = "".join(_text(c) for c in code)
    assert "success test (eqs 24-25): passed" in text
    assert "| arm |" in text and "| learner | random | 5 |" in text
    assert "float32" in text and "track 1.8" in text
    # Stored with the [rl] extra: the PPO cell ran, and its dense episodes met the rails.
    assert SKIPPED not in text, "re-execute the notebook with the [rl] extra installed"
    rl_text = "".join(_text(c) for c in code if RL in _tags(c))
    assert "PPO, 3000 steps" in rl_text and "rails" in rl_text


def test_rl_cells_are_tagged_and_the_first_cell_needs_no_extra() -> None:
    code = _code_cells(_nbformat().read(NOTEBOOK, as_version=4))
    tagged = [c for c in code if RL in _tags(c)]
    assert tagged, "no cell is tagged 'rl'"
    for cell in code:
        uses_rl = "torch" in cell.source or "stable_baselines3" in cell.source
        assert uses_rl == (RL in _tags(cell)), cell.source[:80]
    assert RL not in _tags(code[0])
    for cell in tagged:
        assert "except ImportError" in cell.source and SKIPPED in cell.source


@pytest.mark.rl
def test_notebook_executes_on_this_checkout(tmp_path: Path) -> None:
    pytest.importorskip(
        "stable_baselines3", reason="stable-baselines3 not installed: pip install 'striatal[rl]'"
    )
    stored, ran = _execute(tmp_path, PROBE)
    # The deterministic cells print what the stored notebook shows (else: make tutorial).
    for cell, want in zip(ran, [_text(c) for c in stored], strict=True):
        if VARIES not in _tags(cell):
            assert _text(cell) == want, f"stale output; run `make tutorial`:\n{cell.source}"
    assert not any(_text(c).startswith(SKIPPED) for c in ran)


def test_notebook_runs_without_torch_and_stable_baselines3(tmp_path: Path) -> None:
    stored, ran = _execute(tmp_path, f"{NO_RL}\n{PROBE}")
    rl_cells = [c for c in ran if RL in _tags(c)]
    assert rl_cells, "no cell is tagged 'rl'"
    for cell in rl_cells:
        lines = _text(cell).splitlines()
        assert len(lines) == 1 and lines[0].startswith(SKIPPED), _text(cell)
        assert "pip install 'striatal[rl]'" in lines[0]
    # Every other cell prints what the stored notebook (run with the extra) shows.
    for cell, want in zip(ran, [_text(c) for c in stored], strict=True):
        if RL not in _tags(cell):
            assert SKIPPED not in _text(cell)
            if VARIES not in _tags(cell):
                assert _text(cell) == want, f"differs without the [rl] extra:\n{cell.source}"
