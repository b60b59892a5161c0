"""The drive's own gyro zero (:func:`sideslip.calibrate.sensors.drive_gyro_bias`): a raw MEMS
gyro's bias of degrees per second, as on the comma2k19 phone (-3.9 deg/s), on drives from the
simulator's nonlinear truth.  The methods that subtract it are tested in their own files
(test_observers, test_factor_graph, test_kkf)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from sideslip.calibrate.result import Fitted
from sideslip.calibrate.sensors import drive_gyro_bias, gyro_zero_params, subtracted_zero
from sideslip.drive import Drive
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.helpers import PHONE_BIAS, raw_gyro


def _without_gnss(drive: Drive) -> Drive:
    return replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})


def test_drive_zero_recovers_a_phone_class_bias() -> None:
    """demo (GNSS Doppler, 6 s standstill at the start): the zero is the added 3 deg/s plus the
    simulated gyro's own bias (the mean of w_z - r cos(roll) against the reference) within
    0.05 deg/s, about 3 of the fit's 1-sigma (0.015 deg/s)."""
    drive = sim_drive("demo")
    vehicle = load_vehicle(drive.meta["vehicle"])
    zero = drive_gyro_bias(raw_gyro(drive), vehicle)
    own = float(np.nanmean(drive["wz"] - drive["ref_r"] * np.cos(drive["ref_roll"])))
    assert zero.informed
    assert math.degrees(abs(zero.value - PHONE_BIAS - own)) < 0.05
    assert 0 < math.degrees(zero.sigma) < 0.05


def test_drive_zero_is_not_invented_without_gnss_or_standstill() -> None:
    """cr_circle without its GNSS columns: no course, no standstill and one speed all drive
    long (the rear wheels cannot tell a bias from their radius mismatch), so nothing to tell
    the bias from; the zero is 0 and says why (the methods then use the samples as recorded)."""
    drive = _without_gnss(sim_drive("cr_circle"))
    zero = drive_gyro_bias(drive, load_vehicle(drive.meta["vehicle"]))
    assert not zero.informed
    assert zero.value == 0.0
    assert "standstill" in zero.note and "GNSS course" in zero.note and "rear wheel" in zero.note


def test_drive_zero_from_gnss_positions_alone() -> None:
    """demo with issue 15's receiver (20 Hz positions, no Doppler, 50 ms late, antenna 0.5 m
    off the file): the course from differenced fixes tells the 3 deg/s raw bias, 0.02 deg/s
    off, with the fit's 1-sigma 0.08 deg/s (noisier than Doppler's 0.015).  Bound 3 sigma;
    the source names the positions."""
    from sideslip.simulate import SensorConfig, simulate
    from sideslip.simulate.run import _lookup

    receiver = {"gnss_rate_hz": 20.0, "gnss_doppler": False, "gnss_latency_s": 0.05,
                "gnss_lever_offset_x": 0.5}  # fmt: skip
    config = SensorConfig().with_overrides(_lookup("demo").sensor_overrides).with_overrides(receiver)
    drive = simulate("demo", seed=0, config=config)
    assert "gnss_ve" not in drive
    vehicle = load_vehicle(drive.meta["vehicle"])
    zero = drive_gyro_bias(raw_gyro(drive), vehicle)
    own = float(np.nanmean(drive["wz"] - drive["ref_r"] * np.cos(drive["ref_roll"])))
    assert zero.informed and "positions" in zero.source
    assert abs(zero.value - PHONE_BIAS - own) < 3 * zero.sigma
    assert math.degrees(zero.sigma) < 0.15


def test_a_zero_within_two_sigma_of_nothing_is_not_subtracted() -> None:
    """A calibrated gyro: the methods without a bias state keep its samples rather than take on
    the fit's noise; a raw gyro's zero, many sigma from 0, is subtracted."""
    calibrated = Fitted("gyro_bias_rad_s", 1e-4, 1e-4, 100, "s", True, "rad/s", 0.0)
    raw = Fitted("gyro_bias_rad_s", 0.068, 3e-4, 100, "s", True, "rad/s", 0.0)
    assert subtracted_zero(calibrated) == 0.0
    assert "not subtracted" in str(gyro_zero_params(calibrated)["gyro_zero_note"])
    assert "gyro_zero_note" not in gyro_zero_params(calibrated, subtracted=False)
    assert subtracted_zero(raw) == 0.068


def test_a_short_drive_tells_a_raw_gyros_zero() -> None:
    """dlc_bank (30 s, under the 40 s of course a zero usually needs, no standstill): with 3
    deg/s added the fit over its 15 course windows is far beyond its 1-sigma, so the drive tells
    it (measured 0.014 deg/s off the added bias plus the simulated gyro's own, 1-sigma 0.023;
    bound 3 sigma and under 0.1 deg/s).  As recorded (the simulator's 0.2 deg/s class, here
    -0.03 deg/s) it stays untold: a calibrated gyro keeps its samples, the rule is for degrees
    per second (RAW_BIAS_MIN)."""
    drive = sim_drive("dlc_bank")
    vehicle = load_vehicle(drive.meta["vehicle"])
    assert drive.t[-1] - drive.t[0] < 40.0
    own = float(drive.meta["truth_sensor"]["gyro_bias_mean"][2])
    zero = drive_gyro_bias(raw_gyro(drive), vehicle)
    assert zero.informed, zero.note
    assert abs(zero.value - PHONE_BIAS - own) < min(3 * zero.sigma, math.radians(0.1))
    calibrated = drive_gyro_bias(drive, vehicle)
    assert not calibrated.informed
    assert "10 s for a bias beyond 0.5 deg/s" in calibrated.note
