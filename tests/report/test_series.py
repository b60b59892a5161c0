"""What the report plots: decimation keeps the envelope, outages, ranking, calibration."""

from __future__ import annotations

import numpy as np

from sideslip.drive import Drive
from sideslip.report.series import (
    BUCKETS,
    Calibration,
    decimate,
    gnss_outages,
    is_sparse,
    minmax_indices,
    rank,
)


def test_minmax_decimation_keeps_every_spike_and_bounds_the_points():
    y = np.sin(np.linspace(0, 60, 360_000))
    y[123_457] = 9.0  # a one-sample spike must survive a 180x reduction
    y[300_001] = -7.0
    idx = minmax_indices(y)
    assert idx.size <= 2 * BUCKETS
    assert 123_457 in idx and 300_001 in idx
    assert np.all(np.diff(idx) > 0)


def test_decimation_breaks_the_line_across_missing_rows():
    t = np.arange(10_000.0)
    y = np.ones_like(t)
    y[4000:6000] = np.nan  # e.g. a reference missing during a stop
    td, yd = decimate(t, y)
    gap = np.flatnonzero(np.isnan(yd))
    assert gap.size == 1
    assert td[gap[0] - 1] < 4000 and td[gap[0] + 1] >= 6000


def test_sparse_reference_is_detected():
    y = np.full(1000, np.nan)
    y[::5] = 0.1  # a 20 Hz reference on a 100 Hz table
    assert is_sparse(y) and not is_sparse(np.zeros(1000))


def test_outages_are_found_in_time_from_the_start():
    t = 5000.0 + np.arange(0, 100, 0.01)
    gnss = np.where(np.arange(t.size) % 10 == 0, 1.0, np.nan)
    gnss[(t >= 5030) & (t < 5040)] = np.nan
    gnss[t > 5095] = np.nan  # lost before the end
    drive = Drive(t, {"gnss_e": gnss}, {}, "x")
    out = gnss_outages(drive)
    assert len(out) == 2
    assert abs(out[0][0] - 29.9) < 0.11 and abs(out[0][1] - 40.0) < 0.11
    assert abs(out[1][0] - 95.0) < 0.11 and abs(out[1][1] - 99.99) < 0.11


def test_ranking_without_a_reference_ranks_nothing_and_shows_fused():
    methods = ["obs_bicycle", "fused", "doppler_slip", "fg_batch"]
    r = rank(methods, {m: {} for m in methods}, "beta_rmse_deg")
    assert r.by is None
    assert r.order == tuple(sorted(methods)) and r.shown == {"fused"}


def test_ranking_with_a_reference_shows_the_best_three():
    res = {"a": {"beta_rmse_deg": 0.3}, "b": {"beta_rmse_deg": 0.1}, "c": {"beta_rmse_deg": 0.2},
           "d": {"beta_rmse_deg": 0.4}, "e": {}}  # fmt: skip
    r = rank(list(res), res, "beta_rmse_deg")
    assert r.order == ("b", "c", "a", "d", "e") and r.shown == {"a", "b", "c"}
    assert r.visible("d") == "legendonly"


def test_calibration_verdicts():
    assert Calibration("m", 0.68, 0.95, 100).verdict == "calibrated"
    assert Calibration("m", 0.40, 0.70, 100).verdict.startswith("over-confident")
    assert Calibration("m", 0.99, 1.00, 100).verdict.startswith("conservative")
