"""`sideslip report --static`: PNG and SVG figures for papers."""

from __future__ import annotations

from sideslip.report.static import write_static
from tests.helpers import run_cli
from tests.report.conftest import small_run


def test_static_figures_are_written_as_png_and_svg(tmp_path):
    from PIL import Image

    drive, est = small_run()
    written = write_static(drive, est.series(), tmp_path / "fig")
    names = {p.name for p in written}
    for fig in ("beta", "beta_error_histogram", "beta_calibration", "roll", "trajectory"):
        assert {f"{fig}.png", f"{fig}.svg"} <= names
    with Image.open(tmp_path / "fig" / "beta.png") as im:
        assert im.size[0] >= 1000  # 7 in at 200 dpi
        lo, hi = im.convert("L").getextrema()
        assert lo < 80 and hi > 240  # drawn, not blank
    svg = (tmp_path / "fig" / "beta.svg").read_text()
    assert "<svg" in svg and "sideslip" in svg  # the axis label is text in the SVG
    assert not list((tmp_path / "fig").glob("*.part"))


def test_report_command_needs_an_output(tmp_path):
    res = run_cli("report", "d.parquet", "e.parquet")
    assert res.returncode == 2
    assert res.stderr.strip() == "error: --out: expected --out report.html and/or --static DIR"
