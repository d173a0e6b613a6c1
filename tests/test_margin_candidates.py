"""benchmarks/margin_candidates.py keeps each NAME's own arms apart: a control run under
``--stop-margin`` is not the plain sweep's control, so the two never share a row."""

from __future__ import annotations

from typing import Any

import pytest
from conftest import benchmark_module


@pytest.fixture(scope="module")
def bench() -> Any:
    return benchmark_module("margin_candidates")


def test_each_names_control_and_cmaes_have_their_own_row_and_random_search_one(bench: Any) -> None:
    keys = {
        (name, arm): bench.arm_key(name, arm)
        for name in ("pgpe", "pgpe-m10")
        for arm in ("learner", "control", "cmaes", "random")
    }
    assert keys[("pgpe", "learner")] == "pgpe" and keys[("pgpe-m10", "learner")] == "pgpe-m10"
    assert keys[("pgpe", "random")] == keys[("pgpe-m10", "random")] == "random"
    assert keys[("pgpe", "control")] != keys[("pgpe-m10", "control")]
    assert len(set(keys.values())) == len(keys) - 1  # only random search is shared
