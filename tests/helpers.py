"""Small helpers shared by the tests (not a test module)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
CIRCLE = DATA / "circle_drive.csv"
SHARED_DATA = ROOT.parent / "shared" / "data"


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the `sideslip` command in a subprocess, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "sideslip.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=600,
    )
