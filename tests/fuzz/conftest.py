"""Print how many cases each fuzz property ran (the fuzz statistics) at the end of the run."""

from __future__ import annotations

from typing import Any

from tests.fuzz.common import CASES


def pytest_terminal_summary(terminalreporter: Any) -> None:
    if CASES:
        terminalreporter.write_sep("-", f"fuzz cases run: {sum(CASES.values())}")
        for name, n in sorted(CASES.items()):
            terminalreporter.write_line(f"  {name}: {n}")
