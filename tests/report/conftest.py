"""Shared pieces of the report tests: a short simulated drive with a few estimates."""

from __future__ import annotations

import functools

import pytest

import sideslip as ss
from tests.conftest import sim_drive

METHODS = ("fused", "fg_batch", "kkf", "mkf", "kinematic_integration", "obs_bicycle")


@functools.lru_cache(maxsize=2)
def small_run(scenario: str = "step_steer") -> tuple[ss.Drive, ss.Estimates]:
    """A 12 s step steer with six methods (four with a sideslip sigma), run once per session."""
    drive = sim_drive(scenario, 0)
    return drive, ss.estimate(drive, drive.meta["vehicle"], methods=list(METHODS))


@pytest.fixture
def small() -> tuple[ss.Drive, ss.Estimates]:
    return small_run()
