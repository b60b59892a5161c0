"""The HTML report: what a vehicle engineer needs on one offline page, at a size that travels."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest

from sideslip.drive import Drive
from sideslip.evaluate import evaluate_all
from sideslip.report.html import render_report
from tests.report.conftest import small_run, synthetic_drive


def figures(page: str) -> list[dict]:
    m = re.search(r"<script type='application/json' id='figure-data'>(.*?)</script>", page, flags=re.S)
    assert m, "no figure data in the page"
    return [f["fig"] for f in json.loads(m.group(1).replace("<\\/", "</"))]


def values(arr) -> np.ndarray:
    """A plotted array: plain list or plotly's base64 typed array."""
    if isinstance(arr, dict):
        return np.frombuffer(base64.b64decode(arr["bdata"]), dtype=np.dtype(arr["dtype"]).newbyteorder("<"))
    return np.asarray(arr, dtype=float)


def title(fig: dict) -> str:
    return fig["layout"]["title"]["text"]


def by_title(page: str, start: str) -> dict:
    return next(f for f in figures(page) if title(f).startswith(start))


@pytest.fixture(scope="module")
def hour_page() -> str:
    drive, est = synthetic_drive(1.0)
    return render_report(drive, est, command="sideslip report x y --out r.html")


@pytest.mark.slow  # an hour at 100 Hz: about 25 s on a loaded machine
def test_an_hour_long_drive_stays_under_15_mb_with_time_from_the_start(hour_page):
    assert len(hour_page.encode()) < 15e6  # measured 7.7 MB (4.8 MB of it plotly.js)
    assert hour_page.count("Plotly=") <= 2 and hour_page.count("<script>") == 2  # plotly.js once
    for fig in figures(hour_page):
        if fig["layout"]["xaxis"]["title"]["text"] != "time from start (s)":
            continue
        for trace in fig["data"]:
            x = values(trace["x"])
            x = x[np.isfinite(x)]
            assert x.min() >= 0 and x.max() <= 3600.01  # the recorder's clock started at 46410 s
            assert x.size <= 2000 + 2 * 1000  # decimated (a band holds both edges)
        assert fig["layout"]["xaxis"]["exponentformat"] == "none"  # no "46.41k s"


@pytest.mark.slow  # an hour at 100 Hz: about 25 s on a loaded machine
def test_gnss_outages_are_shaded_on_every_time_plot(hour_page):
    time_figs = [f for f in figures(hour_page) if f["layout"]["xaxis"]["title"]["text"] == "time from start (s)"]
    assert len(time_figs) >= 4
    for fig in time_figs:
        shades = [s for s in fig["layout"].get("shapes", []) if s.get("name") == "GNSS outage"]
        assert len(shades) == 1, title(fig)
        assert abs(shades[0]["x0"] - 60) < 0.2 and abs(shades[0]["x1"] - 90) < 0.2


@pytest.mark.slow  # an hour at 100 Hz: about 25 s on a loaded machine
def test_metrics_use_every_row_while_plots_are_decimated(hour_page):
    drive, est = synthetic_drive(1.0)
    full = evaluate_all(drive, {m: s for m, s in est.items() if m})
    rmse = full["method_00"]["beta_rmse_deg"]
    assert f"<th>method_00</th><td class=best>{rmse:.3f}</td>" in hour_page


def test_beta_plot_shows_reference_and_best_three_each_with_its_own_band():
    drive, est = small_run()
    page = render_report(drive, est.series(), est.params)
    fig = by_title(page, "Sideslip angle")
    results = evaluate_all(drive, {m: dict(e.series) for m, e in zip(est.names, est, strict=True)})
    best = sorted((m for m in results if "beta_rmse_deg" in results[m]), key=lambda m: results[m]["beta_rmse_deg"])[:3]
    shown = {t["name"] for t in fig["data"] if t.get("visible", True) is True}
    assert shown == {"reference", *best, *(f"{m} ±1σ" for m in best if "beta_std" in est[m].series)}
    hidden = {t["name"] for t in fig["data"] if t.get("visible") == "legendonly"}
    others = set(est.names) - set(best)
    with_std = {m for m in others if "beta_std" in est[m].series}
    assert hidden == others | {f"{m} ±1σ" for m in with_std}  # every other method one click away
    assert "kinematic_integration" in hidden
    hist = by_title(page, "β error distribution")
    assert {t["name"] for t in hist["data"] if "name" in t} >= set(best)


def test_sparse_reference_is_drawn_as_markers():
    drive, est = small_run()
    ref = drive["ref_beta"].copy()
    ref[np.arange(ref.size) % 5 != 0] = np.nan  # a 20 Hz truth on the 100 Hz table
    sparse = Drive(drive.t, {**drive.data, "ref_beta": ref}, drive.meta, drive.path)
    fig = by_title(render_report(sparse, est.series()), "Sideslip angle")
    trace = next(t for t in fig["data"] if t["name"] == "reference")
    assert trace["mode"] == "markers"
    assert values(trace["y"]).size == np.isfinite(ref).sum()


def test_without_a_reference_the_page_says_so_and_ranks_nothing():
    drive, est = small_run()
    bare = Drive(drive.t, {k: v for k, v in drive.data.items() if not k.startswith("ref_")}, drive.meta, "d")
    page = render_report(bare, est.series(), est.params)
    assert "no sideslip reference" in page and "not ranked" in page
    assert "most accurate" not in page
    fig = by_title(page, "Sideslip angle")
    shown = [t["name"] for t in fig["data"] if t.get("visible", True) is True]
    assert shown == ["fused ±1σ", "fused"]
    assert [t["name"] for t in fig["data"] if "±" not in t["name"]] == sorted(est.names)  # alphabetical


def test_calibration_table_skipped_methods_parameters_and_foot():
    drive, est = small_run()
    params = {**est.params, "_skipped": {"ekf_wss_sas": "drive lacks 'v_rl'"}}
    page = render_report(drive, est.series(), params, command="sideslip report d.parquet e.parquet --out r.html")
    assert "<meta name='viewport' content='width=device-width, initial-scale=1'>" in page
    assert "Uncertainty calibration" in page and re.search(r"<td class=(good|warn)>(calibrated|over|conservative)", page)
    assert "<th>ekf_wss_sas</th><td class=left>drive lacks &#x27;v_rl&#x27;</td>" in page
    assert "<th>slip_gain_k_s2_m</th>" in page  # fused's identified slip gain, one row of its table
    assert "sideslip 0.1.0 · generated 20" in page and "sideslip report d.parquet e.parquet --out r.html" in page


def test_identified_values_carry_their_sigma_in_the_parameter_table():
    from sideslip.report.tables import params_html

    page = params_html({"fused": {"slip_gain_k_s2pm": 0.0052, "slip_gain_k_sigma": 0.0002, "K": 0.004,
                                  "K_std": 0.0003, "K_prior": 0.005}}, ["fused"])  # fmt: skip
    assert "<th>slip_gain_k_s2pm</th><td class=left>0.0052 <span class=pm>± 0.0002</span>" in page
    assert "<th>K</th><td class=left>0.004 <span class=pm>± 0.0003</span>" in page
    assert "<th>K_prior</th><td class=left>0.005</td>" in page
    assert "slip_gain_k_sigma" not in page and "K_std" not in page
