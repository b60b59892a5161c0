"""The report in a real browser (headless Chromium): every plot drawn, no console errors, and a
screenshot that shows it.  Skips with the reason when no browser is installed
(``make test-browser`` installs Debian's chromium)."""

from __future__ import annotations

import re

import pytest

from sideslip.report.html import write_report
from tests.report.browser import find_browser, render, screenshot
from tests.report.conftest import small_run

BROWSER = find_browser()
pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(BROWSER is None, reason="no chromium/chrome on PATH: run `make test-browser`"),
]


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    drive, est = small_run()
    out = tmp_path_factory.mktemp("report") / "report.html"
    params = {**est.params, "_skipped": {"ekf_wss_sas": "drive lacks 'v_rl'"}}
    write_report(drive, est.series(), out, params, command="sideslip report test", inputs=[])
    return out


def test_every_plot_renders_and_the_console_has_no_errors(page, tmp_path):
    assert BROWSER is not None
    shown = render(BROWSER, page, tmp_path)
    expected = shown.attribute("data-plots-expected")
    divs = shown.plot_divs()
    # step steer with reference: beta, its histogram and error, roll, bank, yaw error, map, speed
    assert expected is not None and int(expected) == len(divs) >= 7
    assert shown.attribute("data-plots-rendered") == expected
    for div in divs:
        assert 'class="main-svg"' in div, div[:200]
    assert shown.page_errors() == ""
    assert shown.console_errors() == []


def test_a_narrow_screen_needs_no_sideways_scrolling(page, tmp_path):
    # 500 px is the narrowest window headless Chromium lays out (a phone in landscape); tables
    # scroll inside their own box, plots take the screen's width
    assert BROWSER is not None
    shown = render(BROWSER, page, tmp_path, size=(500, 1200))
    assert shown.attribute("data-plots-rendered") == shown.attribute("data-plots-expected")
    assert shown.attribute("data-overflow-x") == "0"
    widths = [float(w) for w in re.findall(r'<svg class="main-svg"[^>]*width="([0-9.]+)"', shown.dom)]
    assert widths and max(widths) <= 500


def test_a_broken_page_is_caught(page, tmp_path):
    # the checks above can fail: a script error shows in the page's error box and the console
    broken = tmp_path / "broken.html"
    broken.write_text(page.read_text().replace("</body>", "<script>no_such_function_x()</script></body>"))
    assert BROWSER is not None
    shown = render(BROWSER, broken, tmp_path)
    assert "no_such_function_x" in shown.page_errors()
    assert any("no_such_function_x" in line for line in shown.console_errors())


def test_screenshot_shows_a_drawn_page(page, tmp_path):
    from PIL import Image

    size = (1280, 2400)
    assert BROWSER is not None
    shot = screenshot(BROWSER, page, tmp_path, tmp_path / f"report_{size[0]}.png", size)
    with Image.open(shot) as im:
        assert im.size == size
        grey = im.convert("L")
        lo, hi = grey.getextrema()
        # text and plot lines on white: dark pixels exist, and far from all of the page is dark
        assert lo < 80 and hi > 240
        dark = sum(grey.histogram()[:128]) / (size[0] * size[1])
        assert 0.002 < dark < 0.5
