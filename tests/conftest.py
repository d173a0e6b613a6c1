"""Shared fixtures."""

from __future__ import annotations

import pytest

from striatal.params import Plant, Simulation


@pytest.fixture
def plant() -> Plant:
    return Plant()


@pytest.fixture
def sim60() -> Simulation:
    return Simulation()
