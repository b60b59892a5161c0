"""Shared test fixtures: a session-cached simulator.

``sim_drive(name, seed)`` simulates a scenario once per test session (process) and returns the
same :class:`~sideslip.drive.Drive` on every later call; use it (or the ``sim`` fixture) instead
of calling ``simulate`` in tests, so the ~8 test files that grade methods on the same scenario
pay for it once.  Import it as ``from tests.conftest import sim_drive``.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # so that `from tests.conftest import sim_drive` works
    sys.path.insert(0, str(ROOT))

from sideslip.drive import Drive  # noqa: E402
from sideslip.simulate import simulate  # noqa: E402


@functools.lru_cache(maxsize=32)
def sim_drive(name: str, seed: int = 0) -> Drive:
    """The drive of scenario ``name`` with ``seed`` (default sensors), simulated once."""
    return simulate(name, seed=seed)


@pytest.fixture
def sim() -> Callable[..., Drive]:
    """The cached simulator :func:`sim_drive`: ``drive = sim("step_steer", seed=0)``."""
    return sim_drive
