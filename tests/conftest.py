"""Shared fixtures."""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

from striatal.params import Plant, Simulation

# `pytest --hypothesis-profile=floor` (tests/test_floor.py): no per-example deadline,
# since the lowest-versions run shares the machine with the rest of the suite.
settings.register_profile("floor", deadline=None)

# No window on screen: pygame (the [render] extra) draws render_mode="human" off-screen,
# also when gymnasium's check_env makes the env in every render mode it lists.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


@pytest.fixture
def plant() -> Plant:
    return Plant()


@pytest.fixture
def sim60() -> Simulation:
    return Simulation()
