"""The gyro zero from the rear wheels' speed difference (:mod:`sideslip.calibrate.wheel_yaw`):
an analytic drive whose wheels carry a radius mismatch and whose file states a track 10 % off,
and the simulator's nonlinear truth (wheel radii 0.5 % apart per wheel, quantised CAN speeds)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from sideslip.calibrate.sensors import drive_gyro_bias
from sideslip.calibrate.wheel_yaw import wheel_gyro_zero
from sideslip.drive import Drive
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.helpers import PHONE_BIAS, raw_gyro

TRACK = 1.55  # m: the analytic car's rear track


def _analytic(bias: float, speed_swing: float, seed: int = 0) -> Drive:
    """100 s at 100 Hz: speed 16 +- ``speed_swing`` m/s, yaw rate 0.1 rad/s swinging at 0.05 Hz
    (|a_y| <= 2.6 m/s^2), gyro = r + ``bias`` + 0.1 deg/s noise; rear wheels at v -+ r T / 2
    with rolling radii 0.4 % apart, 0.02 m/s noise and 0.01 m/s steps."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 100.0, 0.01)
    v = 16.0 + speed_swing * np.sin(2.0 * np.pi * t / 37.0)
    r = 0.1 * np.sin(2.0 * np.pi * 0.05 * t)
    wz = r + bias + rng.normal(0.0, math.radians(0.1), t.size)

    def wheel(side: float, radius_error: float) -> np.ndarray:
        true = (v + side * r * TRACK / 2.0) * (1.0 + radius_error)
        return np.round((true + rng.normal(0.0, 0.02, t.size)) / 0.01) * 0.01

    data = {
        "wz": wz,
        "ax": np.gradient(v, t),
        "ay": v * r,
        "v_rl": wheel(-1.0, -0.002),
        "v_rr": wheel(1.0, 0.002),
    }
    return Drive(t, data)


def test_analytic_bias_is_told_apart_from_radius_mismatch_and_track() -> None:
    """A 2 deg/s bias with the rear radii 0.4 % apart (at 16 m/s that reads as 2.4 deg/s of
    yaw rate, more than the bias) and the file's track 10 % long: recovered within 0.05 deg/s
    (measured 0.020 off, the fit's 1-sigma 0.041 deg/s: the speed swings 8 m/s, so bias and
    mismatch separate), and within 3 of its own 1-sigma."""
    bias = math.radians(2.0)
    zero = wheel_gyro_zero(_analytic(bias, 8.0), 1.1 * TRACK)
    assert zero.informed, zero.note
    assert abs(math.degrees(zero.value - bias)) < 0.05
    assert abs(zero.value - bias) < 3.0 * zero.sigma + math.radians(0.01)
    assert "wheel" in zero.source


def test_one_speed_all_drive_long_leaves_the_zero_untold() -> None:
    """At one speed a bias and a radius mismatch read alike: the zero stays 0 and says why."""
    zero = wheel_gyro_zero(_analytic(math.radians(2.0), 0.0), TRACK)
    assert not zero.informed
    assert zero.value == 0.0
    assert "radius mismatch" in zero.note


def test_without_rear_wheel_speeds_nothing_is_invented() -> None:
    drive = _analytic(0.0, 8.0)
    drive = replace(drive, data={k: v for k, v in drive.data.items() if k != "v_rr"})
    zero = wheel_gyro_zero(drive, TRACK)
    assert not zero.informed
    assert "v_rl, v_rr" in zero.note


def test_simulated_urban_drive_raw_gyro() -> None:
    """urban_course (stop-and-go, 0.5 % per-wheel radius errors) with a phone-class 3 deg/s
    added: the wheels alone give the zero within 0.1 deg/s of the truth (the added bias plus the
    simulated gyro's own, the mean of w_z - r against the reference); measured 0.03 deg/s off
    with a 1-sigma of 0.03 (seed 0, benchmarks/results/gyro_zero_wheels.md (b))."""
    drive = raw_gyro(sim_drive("urban_course"))
    vehicle = load_vehicle(drive.meta["vehicle"])
    truth = float(np.nanmean(drive["wz"] - drive["ref_r"]))
    zero = wheel_gyro_zero(drive, vehicle.track_rear)
    assert zero.informed, zero.note
    assert abs(math.degrees(zero.value - truth)) < 0.1
    assert abs(math.degrees(truth)) > math.degrees(PHONE_BIAS) - 0.5


def test_drive_zero_falls_back_to_the_wheels_without_gnss() -> None:
    """urban_highway without its GNSS columns (no course, no standstill): the drive's zero
    comes from the rear wheels, within 2 of its 1-sigma of the simulated gyro's own bias."""
    drive = sim_drive("urban_highway")
    drive = replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})
    vehicle = load_vehicle(drive.meta["vehicle"])
    zero = drive_gyro_bias(drive, vehicle)
    truth = float(np.nanmean(drive["wz"] - drive["ref_r"]))
    assert zero.informed, zero.note
    assert "rear wheel speed" in zero.source
    assert abs(zero.value - truth) < 2.0 * zero.sigma


def test_calibrate_reports_the_wheels_zero_without_gnss() -> None:
    """``sideslip calibrate`` on urban_highway without GNSS and with a 3 deg/s gyro: its gyro
    bias comes from the rear wheels, within 2 of its 1-sigma of the truth (it was 'not
    identified' before)."""
    from sideslip.calibrate import calibrate

    drive = raw_gyro(sim_drive("urban_highway"))
    drive = replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})
    vehicle = load_vehicle(drive.meta["vehicle"])
    bias = next(f for f in calibrate(drive, vehicle).fitted if f.name == "gyro_bias_rad_s")
    truth = float(np.nanmean(drive["wz"] - drive["ref_r"]))
    assert bias.informed, bias.note
    assert "rear wheel speed" in bias.source
    assert abs(bias.value - truth) < 2.0 * bias.sigma
