"""Shared signal helpers: hold without inventing samples, speed sources, course gate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.drive import drive_from_columns, load_drive
from sideslip.frames import angle_diff, enu_to_geodetic, geodetic_to_enu, unwrap_angle, wrap_angle
from sideslip.signals import gnss_course, hold, interpolate, reversing, standstill, vehicle_speed
from tests.helpers import CIRCLE


def test_hold_reports_age_and_never_uses_future_samples():
    t = np.arange(6) * 0.1
    x = np.array([np.nan, 1.0, np.nan, np.nan, 4.0, np.nan])
    held, age = hold(x, t, fill=-1.0)
    np.testing.assert_array_equal(held, [-1, 1, 1, 1, 4, 4])
    np.testing.assert_allclose(age[1:], [0, 0.1, 0.2, 0, 0.1])
    assert math.isinf(age[0])


def test_interpolate_leaves_long_gaps_empty():
    t = np.arange(10.0)
    x = np.full(10, np.nan)
    x[[0, 1, 8, 9]] = [0, 1, 8, 9]
    out = interpolate(x, t, max_gap_s=2.0)
    assert np.isnan(out[4])
    assert out[1] == 1.0


def test_speed_from_rear_wheels_and_course_gate():
    drive = load_drive(CIRCLE)
    v = vehicle_speed(drive)
    # rear-axle centre speed of the analytic circle: V cos(beta)
    assert v[0] == pytest.approx(15 * math.cos(0.02), rel=1e-9)
    assert np.isfinite(v).all()
    rows, course, speed = gnss_course(drive, min_speed=3.0)
    np.testing.assert_allclose(speed, 15.0, rtol=1e-9)
    assert rows.size == 200
    np.testing.assert_allclose(angle_diff(course, drive["ref_yaw"][rows] + 0.02), 0, atol=1e-9)
    rows_hi, _, _ = gnss_course(drive, min_speed=20.0)
    assert rows_hi.size == 0


def test_standstill_and_reversing():
    t = np.arange(5) * 0.1
    drive = drive_from_columns({"t": t, "wz": 0 * t, "v_can": [0.0, 0.05, 2.0, -1.0, -0.05]})
    np.testing.assert_array_equal(standstill(drive), [True, True, False, False, True])
    np.testing.assert_array_equal(reversing(drive), [False, False, False, True, False])


def test_angles_and_geodetic_roundtrip():
    assert wrap_angle(3 * math.pi) == pytest.approx(-math.pi)
    np.testing.assert_allclose(
        unwrap_angle([3.0, -3.0, np.nan, -2.9]), [3.0, 2 * math.pi - 3, np.nan, 2 * math.pi - 2.9]
    )
    origin = (37.721, -122.472, 20.0)
    enu = geodetic_to_enu([37.722], [-122.471], [25.0], origin)
    lat, lon, h = enu_to_geodetic(enu, origin)
    assert lat[0] == pytest.approx(37.722, abs=1e-9)
    assert lon[0] == pytest.approx(-122.471, abs=1e-9)
    assert h[0] == pytest.approx(25.0, abs=1e-4)
