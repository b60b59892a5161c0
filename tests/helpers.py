"""Small helpers shared by the tests (not a test module)."""

from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

from sideslip.drive import Drive

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
CIRCLE = DATA / "circle_drive.csv"
SHARED_DATA = ROOT.parent / "shared" / "data"
PHONE_BIAS = math.radians(3.0)  # rad/s: a raw phone-class gyro bias (comma2k19's: -3.9 deg/s)


def raw_gyro(drive: Drive, bias: float = PHONE_BIAS) -> Drive:
    """``drive`` with ``bias`` (rad/s) added to its gyro, as a raw phone gyro would read."""
    return replace(drive, data={**drive.data, "wz": drive["wz"] + bias})


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the `sideslip` command in a subprocess, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "sideslip.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=600,
    )
