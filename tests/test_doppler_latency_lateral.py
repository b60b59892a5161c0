"""The Doppler's latency from its course rate against the lateral accelerometer
(sideslip.doppler_latency_lateral), graded on the simulator's receiver: every epoch reports the
truth the stated latency before its stamp, and the simulator's roll, bank, tyres and sensor
errors are not the fit's model.  Tolerances: 2.5 of the fit's own sigma (its honesty), and a
sigma bound from the measured values (docstrings) with margin, so that a fit that stops
deciding these drives fails."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from sideslip.doppler_latency_lateral import lateral_doppler_latency
from sideslip.drive import Drive
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup


@functools.lru_cache(maxsize=8)
def late_drive(name: str, latency_s: float, lever_offset_x: float = 0.0) -> Drive:
    """``name`` with its own receiver, ``latency_s`` late, its antenna ``lever_offset_x`` m
    ahead of where the vehicle file (here: the IMU) says."""
    receiver = {"gnss_latency_s": latency_s, "gnss_lever_offset_x": lever_offset_x}
    config = SensorConfig().with_overrides(_lookup(name).sensor_overrides).with_overrides(receiver)
    return simulate(name, seed=0, config=config)


def without(drive: Drive, *names: str) -> Drive:
    return Drive(drive.t, {k: v for k, v in drive.data.items() if k not in names}, drive.meta, drive.path)


@pytest.mark.parametrize(("name", "latency_s", "max_sigma"), [
    ("slalom_low_mu", 0.0, 0.02), ("slalom_low_mu", 0.1, 0.02), ("cr_slalom", 0.05, 0.015),
])  # fmt: skip
def test_the_course_rate_lags_the_lateral_accelerometer_by_the_latency(name, latency_s, max_sigma) -> None:
    """Slaloms at one speed (the speed fit's sigma: hours): measured slalom_low_mu +0.002 /
    +0.103 +- 0.014 / 0.016 s, cr_slalom (CommonRoad's multi-body truth) +0.052 +- 0.011 s."""
    found = lateral_doppler_latency(late_drive(name, latency_s))
    assert found is not None
    tau, sigma, gain = found
    assert sigma < max_sigma
    assert abs(tau - latency_s) < 2.5 * sigma
    assert 0.8 < gain < 1.1  # the reading's gain to the path's acceleration: roll tilt only


def test_the_antenna_ahead_of_the_imu_is_moved_with_the_yaw_acceleration() -> None:
    """cr_limit_slalom 50 ms late with the antenna 1.5 m ahead: the antenna's lateral
    acceleration leads the IMU's by 1.5 r', which without the lever arm reads as an early
    receiver (measured -0.040 +- 0.016 s); with it, +0.056 +- 0.014 s."""
    drive = late_drive("cr_limit_slalom", 0.05, 1.5)
    with_lever = lateral_doppler_latency(drive, lever_x_m=1.5)
    no_lever = lateral_doppler_latency(drive, lever_x_m=0.0)
    assert with_lever is not None and no_lever is not None
    assert abs(with_lever[0] - 0.05) < 2.5 * with_lever[1]
    assert no_lever[0] < 0.05 - 3.0 * no_lever[1]


def test_the_antenna_above_the_imu_is_moved_with_the_roll_acceleration() -> None:
    """cr_limit_slalom on time, the antenna 1 m above the IMU (the vehicle file's): the body's
    roll swings the antenna sideways by -1 m x the roll rate, and its acceleration by -1 m x
    the roll acceleration, in step with every steering reversal.  With that term the fit's
    sigma halves (measured 0.015 -> 0.007 s) and it stays within 2.5 sigma of 0."""
    drive = late_drive("cr_limit_slalom", 0.0)
    with_z = lateral_doppler_latency(drive, lever_z_m=1.0)
    without_z = lateral_doppler_latency(drive)
    assert with_z is not None and without_z is not None
    assert with_z[1] < 0.7 * without_z[1]
    assert abs(with_z[0]) < 2.5 * with_z[1]


def test_bank_changes_are_told_from_lag_by_the_roll_gyro() -> None:
    """dlc_bank (a double lane change across changing bank): the bank's gravity term moves
    with the lateral acceleration.  With the roll gyro the fit finds +0.104 +- 0.023 s for the
    true 0.1 s; without it the fit's gain leaves the plausible range and there is no estimate
    (or at least not a decisive one)."""
    drive = late_drive("dlc_bank", 0.1)
    found = lateral_doppler_latency(drive)
    assert found is not None
    assert found[1] < 0.035
    assert abs(found[0] - 0.1) < 2.5 * found[1]
    blind = lateral_doppler_latency(without(drive, "wx"))
    assert blind is None or blind[1] > 0.05


def test_a_few_rows_missing_from_the_roll_gyro_keep_its_term() -> None:
    """dlc_bank 0.1 s late with the roll gyro's first five rows empty (an IMU whose first
    samples the logger missed, or one moved back by sideslip.imu_timing): the gyro is
    integrated across them.  Before, any gap took the roll term away and the fit gave nothing."""
    drive = late_drive("dlc_bank", 0.1)
    wx = drive["wx"].copy()
    wx[:5] = np.nan
    found = lateral_doppler_latency(Drive(drive.t, {**drive.data, "wx": wx}, drive.meta, drive.path))
    assert found is not None and found[1] < 0.035
    assert abs(found[0] - 0.1) < 2.5 * found[1]


def test_an_imu_slower_than_the_table_is_read_at_its_own_rate() -> None:
    """slalom_low_mu 0.1 s late with the IMU on every second row only (a 50 Hz IMU in the
    100 Hz table, NaN between its samples): interpolated between its samples, the fit still
    decides the latency (before, every span held a NaN row and the fit gave nothing)."""
    drive = late_drive("slalom_low_mu", 0.1)
    data = dict(drive.data)
    for name in ("ax", "ay", "az", "wx", "wy", "wz"):
        col = drive[name].copy()
        col[1::2] = np.nan
        data[name] = col
    found = lateral_doppler_latency(Drive(drive.t, data, drive.meta, drive.path))
    assert found is not None and found[1] < 0.02
    assert abs(found[0] - 0.1) < 2.5 * found[1]


def test_a_sensor_gap_leaves_its_epochs_out() -> None:
    """Ten seconds of accelerometer gap (NaN) in the slalom: the epochs that would read it are
    left out, the rest still decide, and nothing non-finite comes out."""
    drive = late_drive("slalom_low_mu", 0.1)
    ay = drive["ay"].copy()
    ay[(drive.t > 5.0) & (drive.t < 15.0)] = np.nan
    found = lateral_doppler_latency(Drive(drive.t, {**drive.data, "ay": ay}, drive.meta, drive.path))
    assert found is not None and all(np.isfinite(found))
    assert abs(found[0] - 0.1) < 2.5 * found[1]


def test_no_estimate_without_doppler_or_turns_enough() -> None:
    drive = late_drive("slalom_low_mu", 0.0)
    assert lateral_doppler_latency(without(drive, "gnss_ve", "gnss_vn")) is None
    assert lateral_doppler_latency(without(drive, "ay")) is None
    assert lateral_doppler_latency(drive.slice(0, 400)) is None  # 4 s: under 50 epochs
    # reversing (negative wheel and CAN speeds) throughout: the path's left is the body's right
    backwards = {k: -v if k.startswith("v_") else v for k, v in drive.data.items()}
    assert lateral_doppler_latency(Drive(drive.t, backwards, drive.meta, drive.path)) is None
    # a 1 Hz receiver (suburban_outages' own): its 2 s spans are left to the speed fit
    assert lateral_doppler_latency(late_drive("suburban_outages", 0.0)) is None


def test_segment_offsets_are_taken_out_as_a_dense_design_would() -> None:
    """The roll fit's per-segment constant and drift are removed by Frisch-Waugh-Lovell
    (O(n) memory on an hour's drive): the residualised columns equal those of a weighted least
    squares on the dense dummy design, to rounding."""
    from sideslip.doppler_latency_lateral import _within

    rng = np.random.default_rng(3)
    n = 600
    seg = np.repeat(np.arange(3), n // 3).astype(np.intp)
    ramp = np.tile(np.linspace(0.0, 1.0, n // 3), 3)
    values = rng.standard_normal((n, 2))
    weights = rng.uniform(0.2, 1.0, n)
    dense = np.zeros((n, 6))
    dense[np.arange(n), 2 * seg] = 1.0
    dense[np.arange(n), 2 * seg + 1] = ramp
    root = np.sqrt(weights)[:, None]
    coef = np.linalg.lstsq(dense * root, values * root, rcond=None)[0]
    np.testing.assert_allclose(_within(values, weights, seg, ramp), values - dense @ coef, atol=1e-10)
    means = (
        values
        - np.array([np.average(values[seg == s], axis=0, weights=weights[seg == s]) for s in range(3)])[seg]
    )
    np.testing.assert_allclose(_within(values, weights, seg, None), means, atol=1e-12)
