"""Headless Chromium for the report's browser tests (not a test module).

The page records its own state in the DOM (``data-plots-expected``/``data-plots-rendered`` on
``<body>``, failures in ``#js-errors``); ``--dump-dom`` after plotly has drawn returns it, and
``--enable-logging=stderr`` returns the console, scanned for uncaught errors.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars",
    "--disable-extensions", "--mute-audio",
)  # fmt: skip
BUDGET_MS = 20000  # virtual time for plotly to draw (virtual: an idle page skips ahead)


def find_browser() -> str | None:
    return next((p for p in map(shutil.which, NAMES) if p), None)


@dataclass(frozen=True)
class Rendered:
    dom: str
    console: str

    def attribute(self, name: str) -> str | None:
        m = re.search(rf'<body[^>]*\s{name}="([^"]*)"', self.dom)
        return m.group(1) if m else None

    def plot_divs(self) -> list[str]:
        """The inner HTML of each plot div (split at the next plot)."""
        starts = [m.start() for m in re.finditer(r'<div class="plot[^"]*" id="plot-\d+"', self.dom)]
        return [self.dom[a:b] for a, b in zip(starts, [*starts[1:], len(self.dom)], strict=True)]

    def console_errors(self) -> list[str]:
        lines = self.console.splitlines()
        return [ln for ln in lines if "Uncaught" in ln or ":ERROR:CONSOLE" in ln or ("CONSOLE(" in ln and "rror" in ln)]

    def page_errors(self) -> str:
        m = re.search(r"<pre id=\"js-errors\">(.*?)</pre>", self.dom, flags=re.S)
        return m.group(1).strip() if m else "<no #js-errors element>"


def _run(browser: str, page: Path, profile: Path, extra: list[str]) -> subprocess.CompletedProcess[str]:
    cmd = [browser, *FLAGS, f"--user-data-dir={profile}", f"--virtual-time-budget={BUDGET_MS}", *extra,
           page.resolve().as_uri()]  # fmt: skip
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180)


def render(browser: str, page: Path, tmp: Path, size: tuple[int, int] = (1280, 2400)) -> Rendered:
    """Open ``page`` headless, let plotly draw, return the DOM and the console log."""
    flags = ["--enable-logging=stderr", "--v=0", f"--window-size={size[0]},{size[1]}", "--dump-dom"]
    res = _run(browser, page, tmp / f"profile-dom-{size[0]}", flags)
    return Rendered(res.stdout, res.stderr)


def screenshot(browser: str, page: Path, tmp: Path, out: Path, size: tuple[int, int]) -> Path:
    _run(browser, page, tmp / "profile-shot", [f"--window-size={size[0]},{size[1]}", f"--screenshot={out}"])
    return out
