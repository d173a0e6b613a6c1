"""Interrupted runs: SIGKILL, SIGTERM and SIGINT in the middle of ``train`` and ``sweep``.

Each scenario stops a real run in a fresh process, resumes it, and compares the
result with an uninterrupted run under the same seed. The scenarios and their
machinery are in tests/test_reliability.py; this module checks them and the
"interruptions" table of docs/reliability.md (regenerate with
``STRIATAL_WRITE_RELIABILITY=1 pytest tests/test_reliability_interrupt.py``).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_reliability import INTERRUPTIONS, Scenario, check_doc_section, outcome, params_of

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def interrupt_tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("interruptions")


@pytest.mark.parametrize("scenario", params_of(INTERRUPTIONS))
def test_interruption(scenario: Scenario, interrupt_tmp: Path) -> None:
    ok, observed = outcome(scenario, interrupt_tmp)
    assert ok, observed


def test_doc_matches_interruptions(interrupt_tmp: Path) -> None:
    check_doc_section(
        "interruptions", INTERRUPTIONS, interrupt_tmp, "test_reliability_interrupt.py"
    )
