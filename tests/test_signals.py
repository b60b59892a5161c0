"""Shared signal helpers: hold without inventing samples, speed sources, course gate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.drive import drive_from_columns, load_drive
from sideslip.frames import angle_diff, enu_to_geodetic, geodetic_to_enu, unwrap_angle, wrap_angle
from sideslip.signals import (
    gnss_course,
    hold,
    interpolate,
    kernel_input,
    reversing,
    standstill,
    vehicle_speed,
)
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


def test_white_noise_sigma_is_identified_under_a_manoeuvre():
    from sideslip.signals import white_noise_sigma_100hz

    rng = np.random.default_rng(4)
    t = np.arange(0.0, 120.0, 0.02)  # 50 Hz
    smooth = 0.3 * np.sin(2 * np.pi * 0.5 * t)  # a slalom's yaw rate, rad/s
    x = smooth + rng.normal(0.0, 0.002, t.size)
    got = white_noise_sigma_100hz(t, x)
    # fixed density: 0.002 per sample at 50 Hz is 0.002 * sqrt(2) per sample at 100 Hz;
    # 6000 samples with a robust (MAD) scale: ~2 % 1-sigma, 8 % is 4 sigma
    assert got == pytest.approx(0.002 * math.sqrt(2.0), rel=0.08)
    assert white_noise_sigma_100hz(t[:100], x[:100]) is None  # too few samples


def test_sample_variance_scales_with_rate():
    from sideslip.signals import sample_variance

    t = np.r_[np.arange(0.0, 1.0, 0.01), 1.0 + np.arange(1, 11) * 0.05]
    var = sample_variance(t, 0.1)
    assert var[50] == pytest.approx(0.01)
    assert var[-1] == pytest.approx(0.01 * 0.01 / 0.05)


def test_gravity_cue_reads_the_bank_of_a_straight_banked_road():
    from sideslip.signals import GRAVITY_M_S2, gravity_lateral_sin

    n = 1000
    t = np.arange(n) * 0.01
    bank = 0.05  # sin of the bank
    cols = {"t": t, "ay": np.full(n, GRAVITY_M_S2 * bank), "wz": np.zeros(n),
            "v_rl": np.full(n, 20.0), "v_rr": np.full(n, 20.0)}
    drive = drive_from_columns(cols, {})
    cue = gravity_lateral_sin(drive, vehicle_speed(drive), np.zeros(n))
    np.testing.assert_allclose(cue, bank, atol=1e-12)
    # a level turn: the lateral force is all kinematic (V r), no gravity component
    turn = drive_from_columns({**cols, "ay": np.full(n, 20.0 * 0.1)}, {})
    np.testing.assert_allclose(gravity_lateral_sin(turn, vehicle_speed(turn), np.full(n, 0.1)),
                               0.0, atol=1e-12)
    no_acc = drive_from_columns({k: v for k, v in cols.items() if k != "ay"}, {})
    assert gravity_lateral_sin(no_acc, vehicle_speed(no_acc), np.zeros(n)) is None


def test_kernel_input_is_a_read_only_float64_view_that_leaves_the_source_writable():
    source = np.arange(5.0)
    view = kernel_input(source)
    assert view.dtype == np.float64 and view.flags.c_contiguous and not view.flags.writeable
    assert np.shares_memory(view, source) and source.flags.writeable
    strided = kernel_input(np.arange(10, dtype=np.float32)[::2])
    np.testing.assert_array_equal(strided, [0.0, 2.0, 4.0, 6.0, 8.0])
    assert strided.dtype == np.float64 and strided.flags.c_contiguous
