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


class Cli:
    """``striatal ARGS...`` run in this process: exit code, stdout and stderr."""

    def __init__(self, capsys: pytest.CaptureFixture[str]) -> None:
        self._capsys = capsys

    def __call__(self, *argv: object) -> tuple[int, str, str]:
        from striatal.cli import main

        self._capsys.readouterr()  # what earlier calls printed is not this call's
        code = main([str(a) for a in argv])
        out, err = self._capsys.readouterr()
        return code, out, err


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str]) -> Cli:
    """The shared way to run a command in a test: ``code, out, err = cli("train", ...)``."""
    return Cli(capsys)
