"""Metrics on hand-made cases with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.drive import drive_from_columns
from sideslip.evaluate import SPEED_GATE, Window, metrics, window_errors, xtrack_100m


def _straight(n: int = 2001, speed: float = 10.0, dt: float = 0.1) -> dict:
    t = np.arange(n) * dt
    return {
        "t": t, "wz": 0 * t, "ref_e": speed * t, "ref_n": 0 * t, "ref_yaw": 0 * t,
        "ref_beta": 0 * t, "ref_vx": speed + 0 * t, "ref_roll": 0 * t,
    }  # fmt: skip


def test_beta_stats_of_a_constant_offset_and_speed_gate():
    cols = _straight()
    cols["ref_vx"][:100] = 1.0  # below the gate: excluded
    drive = drive_from_columns(cols)
    beta = np.full(len(drive), math.radians(0.5))
    beta[:100] = 1.0  # huge error where the gate excludes it
    m = metrics(drive, {"beta": beta})
    assert SPEED_GATE > 1.0
    assert m["beta_rmse_deg"] == pytest.approx(0.5)
    assert m["beta_mean_err_deg"] == pytest.approx(0.5)
    assert m["beta_std_err_deg"] == pytest.approx(0.0, abs=1e-12)
    assert m["beta_max_err_deg"] == pytest.approx(0.5)


def test_beta_sigma_shares_count_errors_inside_the_methods_own_sigma():
    """Errors of 0.5 deg against a beta_std of 0.4 deg on the first 1000 gated rows (inside 2
    sigma, not 1) and 0.6 deg on the rest (inside both); rows below the gate and rows without
    a sigma are left out; a method without beta_std gets no share."""
    cols = _straight()
    cols["ref_vx"][:100] = 1.0  # below the gate: excluded even with a huge error
    drive = drive_from_columns(cols)
    n = len(drive)
    beta = np.full(n, math.radians(0.5))
    beta[:100] = 1.0
    std = np.full(n, math.radians(0.6))
    std[100:1100] = math.radians(0.4)
    std[-1] = np.nan  # no sigma on this row: not counted
    m = metrics(drive, {"beta": beta, "beta_std": std})
    gated = n - 100 - 1
    assert m["beta_within_1sigma"] == pytest.approx((gated - 1000) / gated)
    assert m["beta_within_2sigma"] == pytest.approx(1.0)
    assert "beta_within_2sigma" not in metrics(drive, {"beta": beta})


def test_yaw_error_is_wrapped():
    drive = drive_from_columns(_straight())
    yaw = np.full(len(drive), 2 * math.pi + math.radians(1.0))
    assert metrics(drive, {"yaw": yaw})["yaw_rmse_deg"] == pytest.approx(1.0)


def test_xtrack_of_a_heading_error_is_100m_times_its_sine():
    # Estimated path: straight at 1 deg to the reference from the origin.  Aligned by position
    # only (no yaw), each 100 m segment ends 100 sin(1 deg) = 1.745 m to the left.
    drive = drive_from_columns(_straight())
    s = drive["ref_e"]
    a = math.radians(1.0)
    e, n = s * math.cos(a), s * math.sin(a)
    xt = xtrack_100m(drive, e, n)
    assert xt.size == pytest.approx((2000 - 100) / 10, abs=2)
    np.testing.assert_allclose(xt, 100 * math.sin(a), rtol=2e-3)
    # Aligned by heading as well (the estimate's yaw says 1 deg): the error vanishes.
    xt_aligned = xtrack_100m(drive, e, n, yaw=np.full(len(drive), a))
    np.testing.assert_allclose(xt_aligned, 0.0, atol=1e-9)
    m = metrics(drive, {"e": e, "n": n})
    assert m["xtrack_100m_max_m"] == pytest.approx(100 * math.sin(a), rel=2e-3)
    assert m["xtrack_100m_p95_m"] == pytest.approx(100 * math.sin(a), rel=2e-3)


def test_xtrack_ignores_along_track_error():
    drive = drive_from_columns(_straight())
    e = drive["ref_e"] * 1.05  # 5 % scale error: 5 m along-track per 100 m, no cross-track
    xt = xtrack_100m(drive, e, drive["ref_n"])
    np.testing.assert_allclose(xt, 0.0, atol=1e-9)


def test_xtrack_on_a_circle_measures_normal_to_the_path():
    # Reference: circle of radius 100 m.  Estimate: the same circle scaled to radius 101 m
    # about the centre.  Aligned at each start, the end point lies about
    # 101*(1-cos(1 rad)) - 100*(1-cos(1 rad))... computed exactly below.
    n_pts = 6284
    th = np.linspace(0, 2 * math.pi, n_pts)
    t = np.arange(n_pts) * 0.1
    cols = {"t": t, "wz": 0 * t, "ref_e": 100 * np.cos(th), "ref_n": 100 * np.sin(th)}
    drive = drive_from_columns(cols)
    e, n = 101 * np.cos(th), 101 * np.sin(th)
    xt = xtrack_100m(drive, e, n)
    phi = 100.0 / 100.0  # 100 m of arc at R = 100 m
    # start aligned: estimate's chord from angle 0 to phi has length 2*101*sin(phi/2), direction
    # phi/2 + pi/2; end point minus reference end projected on the reference normal.
    start = np.array([100.0, 0.0])
    end_est = start + 101 * np.array([math.cos(phi) - 1, math.sin(phi)])
    end_ref = 100 * np.array([math.cos(phi), math.sin(phi)])
    tangent = np.array([-math.sin(phi), math.cos(phi)])
    expected = tangent[0] * (end_est - end_ref)[1] - tangent[1] * (end_est - end_ref)[0]
    np.testing.assert_allclose(np.median(xt), expected, rtol=0.01)


def test_window_errors_mean_and_max():
    drive = drive_from_columns(_straight())
    e = drive["ref_e"].copy()
    rows = (drive.t >= 10) & (drive.t <= 20)
    e[rows] += (drive.t[rows] - 10) * 0.5  # error ramps 0 -> 5 m across the window
    w = window_errors(drive, e, drive["ref_n"], [Window(10.0, 20.0)])
    assert w[0]["max_m"] == pytest.approx(5.0)
    assert w[0]["mean_m"] == pytest.approx(2.5, abs=0.03)
    m = metrics(drive, {"e": e, "n": drive["ref_n"]}, windows=[Window(10.0, 20.0)])
    assert m["window_10-20_pos_max_m"] == pytest.approx(5.0)
