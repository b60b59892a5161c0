"""Sensor models and reference columns, graded on analytic truths built here.

The truths (straight line, constant-radius circle with sideslip, circle on a banked road,
standstill) are written independently of the simulator's truth model, so every expected value
below comes from closed-form kinematics.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from sideslip.drive import Drive
from sideslip.frames import rot_x, rot_y, rot_z, wrap_angle
from sideslip.simulate import SensorConfig, drive_from_truth
from sideslip.simulate.sensors import body_to_enu, sample_rows, sensor_columns
from sideslip.simulate.truth import Truth
from sideslip.vehicle import G, load_vehicle

VEHICLE = load_vehicle("seed003_sedan").with_changes(imu_xyz=(0.0, 0.0, 0.0), gnss_xyz=(0.0, 0.0, 0.0))
TRACK = 1.55
WHEELBASE = 2.776


# ------------------------------------------------------------------------------------------
# analytic truths
# ------------------------------------------------------------------------------------------
def circle_truth(
    speed: float = 15.0,
    radius: float = 50.0,
    beta: float = 0.0,
    bank: float = 0.0,
    roll_sus: float = 0.0,
    pitch: float = 0.0,
    duration_s: float = 20.0,
    dt: float = 0.01,
) -> Truth:
    """Left turn at constant CG speed on a circle about the origin, constant sideslip.

    Course nu = yaw + beta; position R [sin nu, -cos nu]; velocity V [cos nu, sin nu];
    acceleration V r [-sin nu, cos nu]; body rates from the Euler rates (yaw rate r only).
    ``radius = inf`` gives a straight line along East.
    """
    t = np.arange(round(duration_s / dt) + 1) * dt
    one = np.ones_like(t)
    r = speed / radius
    yaw = r * t
    nu = yaw + beta
    if math.isinf(radius):
        e, n = speed * math.cos(beta) * t, speed * math.sin(beta) * t
    else:
        e, n = radius * np.sin(nu), -radius * np.cos(nu)
    vx, vy = speed * math.cos(beta) * one, speed * math.sin(beta) * one
    acc = np.column_stack([-speed * r * np.sin(nu), speed * r * np.cos(nu), 0 * t])
    roll = bank + roll_sus
    omega = np.column_stack(
        [
            -r * math.sin(pitch) * one,
            r * math.sin(roll) * math.cos(pitch) * one,
            r * math.cos(roll) * math.cos(pitch) * one,
        ]
    )
    wheels = np.column_stack([vx - r * TRACK / 2, vx + r * TRACK / 2] * 2)
    return Truth(
        t=t, e=e, n=n, u=0 * t, yaw=yaw, pitch=pitch * one, roll=roll * one,
        roll_sus=roll_sus * one, bank=bank * one, grade=0 * t, vx=vx, vy=vy, r=r * one,
        ax=-r * vy, ay=r * vx, acc_enu=acc, omega_body=omega, wheel_speed=wheels,
        steer=WHEELBASE / radius * one, mu=one,
    )  # fmt: skip


def straight_truth(speed: float = 20.0, duration_s: float = 10.0, dt: float = 0.01) -> Truth:
    """Straight line along East at constant speed (negative speed: reversing)."""
    return circle_truth(speed=speed, radius=math.inf, duration_s=duration_s, dt=dt)


def standstill_truth(bank: float = 0.0, duration_s: float = 10.0, dt: float = 0.01) -> Truth:
    """Parked car on a road banked by ``bank`` (no suspension roll)."""
    return replace(
        circle_truth(speed=0.0, radius=math.inf, bank=bank, duration_s=duration_s, dt=dt),
        steer=np.zeros(round(duration_s / dt) + 1),
    )


def make_drive(truth: Truth, config: SensorConfig, seed: int = 0, vehicle=VEHICLE) -> Drive:
    return drive_from_truth(truth, vehicle, seed=seed, config=config, scenario="analytic")


def finite_rows(drive: Drive, name: str) -> np.ndarray:
    return np.flatnonzero(np.isfinite(drive[name]))


# ------------------------------------------------------------------------------------------
# reference columns
# ------------------------------------------------------------------------------------------
def test_reference_columns_equal_truth_states() -> None:
    truth = circle_truth(beta=0.04, bank=0.05, roll_sus=0.02)
    drive = make_drive(truth, SensorConfig())
    pairs = {"ref_beta": truth.beta, "ref_yaw": truth.yaw, "ref_roll": truth.roll,
             "ref_pitch": truth.pitch, "ref_bank": truth.bank, "ref_e": truth.e,
             "ref_n": truth.n, "ref_u": truth.u, "ref_vx": truth.vx, "ref_vy": truth.vy,
             "ref_r": truth.r, "ref_ay": truth.ay}  # fmt: skip
    for name, expected in pairs.items():
        np.testing.assert_array_equal(drive[name], expected, err_msg=name)
    np.testing.assert_allclose(drive["ref_beta"], 0.04, atol=1e-12)


def test_reference_positions_are_the_integral_of_reference_velocities() -> None:
    drive = make_drive(circle_truth(beta=0.05), SensorConfig())
    yaw, vx, vy = drive["ref_yaw"], drive["ref_vx"], drive["ref_vy"]
    ve = np.cos(yaw) * vx - np.sin(yaw) * vy
    vn = np.sin(yaw) * vx + np.cos(yaw) * vy
    e = drive["ref_e"][0] + cumulative_trapezoid(ve, drive.t, initial=0.0)
    n = drive["ref_n"][0] + cumulative_trapezoid(vn, drive.t, initial=0.0)
    # Trapezoid error: dt^2/12 |jerk| T = 1e-4/12 * 15 * 0.09 * 20 s = 2e-4 m.
    np.testing.assert_allclose(e, drive["ref_e"], atol=1e-3)
    np.testing.assert_allclose(n, drive["ref_n"], atol=1e-3)


def test_gnss_course_minus_reference_yaw_is_reference_beta() -> None:
    drive = make_drive(circle_truth(beta=0.05), SensorConfig.noiseless())
    rows = finite_rows(drive, "gnss_ve")
    course = np.arctan2(drive["gnss_vn"][rows], drive["gnss_ve"][rows])
    # Noise off and the antenna at the CG: exact up to round-off.
    np.testing.assert_allclose(
        wrap_angle(course - drive["ref_yaw"][rows]), drive["ref_beta"][rows], atol=1e-9
    )


@pytest.mark.parametrize("pitch", [0.0, 0.03])
def test_lateral_specific_force_minus_reference_ay_is_gravity_plus_bias(pitch: float) -> None:
    bank, roll_sus = 0.08, 0.03
    config = SensorConfig.noiseless(accel_bias_std=0.1)
    drive = make_drive(circle_truth(bank=bank, roll_sus=roll_sus, pitch=pitch), config)
    bias_y = drive.meta["truth_sensor"]["accel_bias"][1]
    assert abs(bias_y) > 1e-4  # a bias was drawn
    roll, theta = bank + roll_sus, pitch
    ay, ax = drive["ref_ay"], -drive["ref_r"] * drive["ref_vy"]
    residual = drive["ay"] - drive["ref_ay"] - (G * math.sin(roll) * math.cos(theta) + bias_y)
    # The identity neglects the rotation of a_y itself into the tilted body y axis:
    # (cos(roll) - 1) a_y + sin(roll) sin(pitch) a_x  (0.0027 m/s^2 here).
    bound = (1 - math.cos(roll)) * np.abs(ay) + abs(math.sin(roll) * math.sin(theta)) * np.abs(ax)
    assert np.all(np.abs(residual) <= bound + 1e-9)
    exact = math.cos(roll) * ay + math.sin(roll) * math.sin(theta) * ax
    np.testing.assert_allclose(drive["ay"] - bias_y, exact + G * math.sin(roll) * math.cos(theta), atol=1e-9)


def test_positive_bank_at_standstill_raises_ay_by_g_sin_bank() -> None:
    drive = make_drive(standstill_truth(bank=0.05), SensorConfig.noiseless())
    np.testing.assert_allclose(drive["ay"], G * math.sin(0.05), atol=1e-12)
    np.testing.assert_allclose(drive["az"], G * math.cos(0.05), atol=1e-12)
    np.testing.assert_allclose(drive["ax"], 0.0, atol=1e-12)


# ------------------------------------------------------------------------------------------
# IMU
# ------------------------------------------------------------------------------------------
def test_body_to_enu_is_rot_z_rot_y_rot_x() -> None:
    yaw, pitch, roll = np.array([0.3, -2.0]), np.array([0.1, -0.05]), np.array([-0.2, 0.07])
    rot = body_to_enu(yaw, pitch, roll)
    for i in range(2):
        np.testing.assert_allclose(rot[i], rot_z(yaw[i]) @ rot_y(pitch[i]) @ rot_x(roll[i]), atol=1e-15)


def test_accelerometer_forward_of_cg_sees_centripetal_lever_arm_term() -> None:
    arm = 1.2
    truth = circle_truth(speed=15.0, radius=40.0)
    at_cg = make_drive(truth, SensorConfig.noiseless())
    ahead = make_drive(truth, SensorConfig.noiseless(), vehicle=VEHICLE.with_changes(imu_xyz=(arm, 0.0, 0.0)))
    r = 15.0 / 40.0
    # omega x (omega x l) = [-r^2 l, 0, 0] for omega = [0, 0, r]; d(omega)/dt = 0.
    np.testing.assert_allclose(ahead["ax"] - at_cg["ax"], -(r**2) * arm, atol=1e-9)
    np.testing.assert_allclose(ahead["ay"], at_cg["ay"], atol=1e-9)


def test_gyro_reads_scaled_rate_plus_drawn_bias() -> None:
    config = SensorConfig.noiseless(gyro_scale_factor=0.02, gyro_bias_std=0.01)
    drive = make_drive(circle_truth(speed=15.0, radius=50.0), config)
    ts = drive.meta["truth_sensor"]
    assert ts["gyro_scale_factor"] == pytest.approx(0.02, abs=1e-15)
    np.testing.assert_allclose(drive["wz"], 1.02 * 0.3 + ts["gyro_bias"][2], atol=1e-12)
    np.testing.assert_allclose(drive["wx"], ts["gyro_bias"][0], atol=1e-12)


def test_gyro_white_noise_and_bias_walk_have_configured_size() -> None:
    walk = 1e-4
    config = SensorConfig.noiseless(gyro_noise_std=0.002, gyro_bias_walk=walk)
    drive = make_drive(standstill_truth(duration_s=600.0), config)
    wz = drive["wz"]
    noise = np.diff(wz)  # = bias increments (tiny) + n_k - n_{k-1}
    # 60000 samples: the sample std is within ~1 % of sqrt(2) sigma; allow 5 %.
    assert np.std(noise) == pytest.approx(math.sqrt(2) * 0.002, rel=0.05)
    drift = wz[10000::10000] - wz[:-10000:10000]  # 100 s apart
    # Random walk over 100 s: sigma sqrt(100) = 1e-3 rad/s vs noise 0.003: the increments'
    # RMS over 5 windows scatters a lot (chi2 with 5 dof), so only the order of magnitude.
    assert 0.2 * walk * 10 < np.sqrt(np.mean(drift**2)) < 5 * walk * 10


def test_misalignment_moves_gravity_into_ay_as_reported() -> None:
    config = SensorConfig.noiseless(imu_misalignment_std=0.01)
    drive = make_drive(standstill_truth(), config)
    ts = drive.meta["truth_sensor"]
    roll_misalignment = ts["imu_misalignment"][0]
    # Sensor axes rolled by +e about x: gravity appears as +g sin(e) on y.
    np.testing.assert_allclose(drive["ay"], ts["ay_bias_level"], atol=1e-12)
    assert ts["ay_bias_level"] == pytest.approx(
        G * math.sin(roll_misalignment) * math.cos(ts["imu_misalignment"][1]), rel=1e-9
    )


# ------------------------------------------------------------------------------------------
# rates, NaN rows, outages, multipath, Gauss-Markov
# ------------------------------------------------------------------------------------------
def test_sensors_sample_at_their_rates_and_leave_nan_between() -> None:
    drive = make_drive(straight_truth(duration_s=10.0), SensorConfig())
    counts = {name: finite_rows(drive, name).size
              for name in ("wz", "ay", "v_fl", "v_can", "steer", "gnss_e", "gnss_ve",
                           "gnss_pos_std")}  # fmt: skip
    # 10 s + the sample at t = 0.
    assert counts == {
        "wz": 1001,
        "ay": 1001,
        "v_fl": 501,
        "v_can": 201,
        "steer": 501,
        "gnss_e": 101,
        "gnss_ve": 101,
        "gnss_pos_std": 101,
    }
    np.testing.assert_array_equal(finite_rows(drive, "gnss_e"), np.arange(0, 1001, 10))
    np.testing.assert_array_equal(finite_rows(drive, "gnss_vn"), finite_rows(drive, "gnss_u"))


def test_sample_rows_handles_rates_that_do_not_divide_the_table_rate() -> None:
    t = np.arange(1001) * 0.01
    rows = sample_rows(t, 3.0)
    assert rows.size == 31  # t = 0, 1/3, ..., 10
    assert np.all(np.abs(t[rows] - np.arange(31) / 3.0) < 0.01 + 1e-12)
    assert sample_rows(t, 0.0).size == 0
    assert sample_rows(t, 500.0).size == 1001


def test_zero_rate_removes_the_sensor_columns() -> None:
    drive = make_drive(straight_truth(), SensorConfig(steer_rate_hz=0.0, gnss_rate_hz=0.0))
    assert "steer" not in drive and "gnss_e" not in drive and "gnss_ve" not in drive
    assert "wz" in drive and "v_fl" in drive


def test_gnss_outages_leave_no_gnss_rows_inside_the_windows() -> None:
    config = SensorConfig(gnss_outages=((2.0, 4.0), (6.05, 7.5)))
    drive = make_drive(straight_truth(duration_s=10.0), config)
    t = drive.t[finite_rows(drive, "gnss_e")]
    assert not np.any((t >= 2.0) & (t < 4.0))
    assert not np.any((t >= 6.05) & (t < 7.5))
    assert t.size == 101 - 20 - 14  # epochs 2.0..3.9 and 6.1..7.4
    assert 4.0 in np.round(t, 6) and 7.5 in np.round(t, 6)
    for name in ("gnss_ve", "gnss_pos_std", "gnss_vel_std"):
        np.testing.assert_array_equal(finite_rows(drive, name), finite_rows(drive, "gnss_e"))


def test_multipath_epochs_are_rare_large_position_jumps() -> None:
    prob = 0.01
    config = SensorConfig.noiseless(gnss_multipath_prob=prob)
    drive = make_drive(straight_truth(duration_s=3600.0, dt=0.1), config)
    rows = finite_rows(drive, "gnss_e")
    err = np.hypot(drive["gnss_e"][rows] - drive["ref_e"][rows], drive["gnss_n"][rows] - drive["ref_n"][rows])
    verr = np.hypot(drive["gnss_ve"][rows] - 20.0, drive["gnss_vn"][rows])
    hits = err > 1e-9
    reported = drive.meta["truth_sensor"]["gnss_multipath_epochs"]
    assert hits.sum() == reported
    # Binomial(36001, 0.01): mean 360, sd 19; 5 sd.
    assert abs(reported - prob * rows.size) < 5 * math.sqrt(rows.size * prob)
    # Jumps of sigma 8 m per axis (median ~9.4 m) and velocity spikes of 0.5 m/s.
    assert 6.0 < np.median(err[hits]) < 13.0
    assert 0.3 < np.median(verr[hits]) < 0.9


def test_multipath_bursts_are_runs_of_correlated_errors_with_configured_size() -> None:
    rate, mean_s = 0.05, 2.0
    config = SensorConfig.noiseless(gnss_burst_rate_hz=rate, gnss_burst_s=mean_s)
    drive = make_drive(straight_truth(duration_s=3600.0, dt=0.1), config)
    rows = finite_rows(drive, "gnss_e")
    de = drive["gnss_e"][rows] - drive["ref_e"][rows]
    dve = drive["gnss_ve"][rows] - 20.0
    hit = np.abs(de) > 1e-9
    ts = drive.meta["truth_sensor"]
    assert hit.sum() == ts["gnss_burst_epochs"]
    assert np.array_equal(np.round(drive.t[rows][hit][:1000], 6), ts["gnss_burst_t"])
    # Poisson(180) bursts of exponential length (mean 20 epochs at 10 Hz): about 3600 epochs
    # inside bursts (overlaps shave a few %); the count's 1-sigma is about 270, allow 4 sigma.
    assert abs(hit.sum() - rate * 3600.0 * mean_s * 10.0) < 1100
    # Inside bursts: 3 m per axis and 0.4 m/s (defaults), each within 15 % over ~180 bursts.
    assert np.std(de[hit]) == pytest.approx(3.0, rel=0.15)
    assert np.std(dve[hit]) == pytest.approx(0.4, rel=0.15)
    # Correlated over gnss_burst_tau_s = 1 s: neighbouring epochs (0.1 s) correlate by
    # exp(-0.1) = 0.90; white multipath would give 0.
    pairs = hit[:-1] & hit[1:]
    rho = np.corrcoef(dve[:-1][pairs], dve[1:][pairs])[0, 1]
    assert rho == pytest.approx(math.exp(-0.1), abs=0.05)
    # Runs, not spikes: the mean run of consecutive burst epochs is many epochs long.
    edges = np.flatnonzero(np.diff(np.r_[0, hit.astype(np.int8), 0]))
    assert np.mean(edges[1::2] - edges[::2]) > 10


def test_drives_without_bursts_draw_nothing_for_them() -> None:
    truth = straight_truth(duration_s=30.0)
    plain = make_drive(truth, SensorConfig())
    zero = make_drive(truth, SensorConfig(gnss_burst_rate_hz=0.0, gnss_burst_s=5.0))
    for name in plain.data:
        np.testing.assert_array_equal(plain[name], zero[name])
    assert "gnss_burst_epochs" not in plain.meta["truth_sensor"]


def test_gnss_position_error_is_gauss_markov_with_configured_sigma_and_tau() -> None:
    config = SensorConfig.noiseless(gnss_pos_gm_std=1.0, gnss_pos_tau_s=1.0)
    drive = make_drive(straight_truth(duration_s=7200.0, dt=0.1), config)
    rows = finite_rows(drive, "gnss_e")
    err = drive["gnss_e"][rows] - drive["ref_e"][rows]
    # 7200 s / (2 tau) = 3600 effective samples: std within ~1.2 % (1 sd); allow 5 %.
    assert np.std(err) == pytest.approx(1.0, rel=0.05)
    lag = 10  # epochs at 10 Hz = tau
    rho = np.corrcoef(err[:-lag], err[lag:])[0, 1]
    assert rho == pytest.approx(math.exp(-1.0), abs=0.05)
    assert np.all(drive["gnss_pos_std"][rows] == pytest.approx(1.0))


def test_gnss_antenna_lever_arm_moves_position_and_velocity() -> None:
    arm = np.array([0.5, 0.3, 1.2])
    truth = circle_truth(speed=15.0, radius=50.0, bank=0.05, roll_sus=0.03, pitch=0.02)
    drive = make_drive(truth, SensorConfig.noiseless(), vehicle=VEHICLE.with_changes(gnss_xyz=tuple(arm)))
    for i in finite_rows(drive, "gnss_e")[::37]:
        rot = rot_z(truth.yaw[i]) @ rot_y(truth.pitch[i]) @ rot_x(truth.roll[i])
        pos = np.array([truth.e[i], truth.n[i], truth.u[i]]) + rot @ arm
        vel = np.array([15.0 * math.cos(truth.yaw[i]), 15.0 * math.sin(truth.yaw[i]), 0.0])
        vel += rot @ np.cross(truth.omega_body[i], arm)
        got_p = [drive[k][i] for k in ("gnss_e", "gnss_n", "gnss_u")]
        got_v = [drive[k][i] for k in ("gnss_ve", "gnss_vn", "gnss_vu")]
        np.testing.assert_allclose(got_p, pos, atol=1e-9)
        np.testing.assert_allclose(got_v, vel, atol=1e-9)


# ------------------------------------------------------------------------------------------
# wheels, CAN speed, steering
# ------------------------------------------------------------------------------------------
def test_wheel_speeds_carry_scale_factors_and_quantisation() -> None:
    config = SensorConfig.noiseless(
        wheel_scale_factor_std=0.01, wheel_resolution=0.01, can_speed_resolution=0.01
    )
    truth = circle_truth(speed=15.0, radius=50.0)
    drive = make_drive(truth, config)
    sf = np.array(drive.meta["truth_sensor"]["wheel_scale_factor"])
    for k, name in enumerate(("v_fl", "v_fr", "v_rl", "v_rr")):
        rows = finite_rows(drive, name)
        vals = drive[name][rows]
        np.testing.assert_allclose(vals / 0.01, np.round(vals / 0.01), atol=1e-6)
        np.testing.assert_allclose(vals, (1 + sf[k]) * truth.wheel_speed[rows, k], atol=0.005)
    rows = finite_rows(drive, "v_can")
    expected = ((1 + sf) * truth.wheel_speed[rows]).mean(axis=1)
    np.testing.assert_allclose(drive["v_can"][rows], expected, atol=0.005 + 1e-9)


def test_wheel_speed_noise_has_configured_std() -> None:
    config = SensorConfig.noiseless(wheel_noise_std=0.02)
    drive = make_drive(straight_truth(duration_s=200.0), config)
    err = drive["v_rl"][finite_rows(drive, "v_rl")] - 20.0
    assert np.std(err) == pytest.approx(0.02, rel=0.05)  # 10001 samples: ~0.7 % (1 sd)


def test_reversing_wheel_speeds_are_signed_or_magnitudes() -> None:
    truth = straight_truth(speed=-3.0)
    signed = make_drive(truth, SensorConfig.noiseless())
    magnitude = make_drive(truth, SensorConfig.noiseless(wheel_speed_signed=False))
    np.testing.assert_allclose(signed["v_rl"][finite_rows(signed, "v_rl")], -3.0)
    np.testing.assert_allclose(magnitude["v_rl"][finite_rows(magnitude, "v_rl")], 3.0)
    np.testing.assert_allclose(magnitude["v_can"][finite_rows(magnitude, "v_can")], 3.0)


def test_steering_reports_road_wheel_angle_with_offset_and_scale() -> None:
    config = SensorConfig.noiseless(steer_offset=0.01, steer_scale_factor=0.05)
    truth = circle_truth(radius=50.0)
    drive = make_drive(truth, config)
    rows = finite_rows(drive, "steer")
    np.testing.assert_allclose(drive["steer"][rows], 1.05 * WHEELBASE / 50.0 + 0.01, atol=1e-12)
    ts = drive.meta["truth_sensor"]
    assert (ts["steer_offset"], ts["steer_scale_factor"]) == pytest.approx((0.01, 0.05))


# ------------------------------------------------------------------------------------------
# standstill, seeds, speed, configuration
# ------------------------------------------------------------------------------------------
def test_standstill_gives_finite_samples_and_zero_wheel_speeds() -> None:
    drive = make_drive(standstill_truth(duration_s=30.0), SensorConfig())
    for name in drive.data:
        col = drive[name]
        assert not np.isinf(col).any(), name
        assert np.isfinite(col).any(), name
    for name in ("v_fl", "v_fr", "v_rl", "v_rr", "v_can"):
        np.testing.assert_array_equal(drive[name][finite_rows(drive, name)], 0.0)


def test_same_seed_gives_the_same_drive_and_another_seed_a_different_one() -> None:
    truth = circle_truth(duration_s=5.0)
    a, b, c = (make_drive(truth, SensorConfig(), seed=s) for s in (3, 3, 4))
    for name in a.data:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert not np.allclose(np.nan_to_num(a["wz"]), np.nan_to_num(c["wz"]))
    assert a.meta["truth_sensor"] == b.meta["truth_sensor"]


def test_one_hour_of_sensor_data_takes_a_few_seconds() -> None:
    truth = straight_truth(duration_s=3600.0)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    cols, _ = sensor_columns(truth, VEHICLE, SensorConfig(), rng)
    elapsed = time.perf_counter() - start
    assert cols["t"].size == 360001
    # Measured ~0.3 s on the shared 2-core machine; 10 s leaves room for load from others.
    assert elapsed < 10.0


def test_defaults_match_the_papers_sensor_grades() -> None:
    c = SensorConfig()
    assert (c.imu_rate_hz, c.gnss_rate_hz, c.wheel_rate_hz) == (100.0, 10.0, 50.0)
    assert 50.0 <= c.steer_rate_hz <= 100.0
    assert c.gnss_vel_std == 0.05  # u-blox M8T velocity accuracy, m/s
    assert c.gnss_outages == () and 0 < c.gnss_multipath_prob < 0.01


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"gyro_noise_std": -1.0}, "SensorConfig.gyro_noise_std = -1.0: expected a value >= 0"),
        ({"gnss_outages": ((5.0, 2.0),)}, "expected (t0, t1) pairs in s with t0 < t1"),
        ({"gnss_multipath_prob": 2.0}, "expected a probability in [0, 1]"),
        ({"gnss_burst_s": 0.0}, "SensorConfig.gnss_burst_s: expected a time > 0 s"),
        ({"gnss_rate_hz": math.nan}, "SensorConfig.gnss_rate_hz = nan: expected a finite number"),
    ],
)
def test_bad_sensor_config_is_refused_with_a_message(changes: dict, message: str) -> None:
    with pytest.raises(ValueError) as err:
        SensorConfig(**changes)
    assert message in str(err.value)


def test_unknown_override_names_the_field() -> None:
    with pytest.raises(ValueError, match=r"unknown SensorConfig field.*gyro_sf"):
        SensorConfig().with_overrides({"gyro_sf": 0.02})
    assert SensorConfig().with_overrides({"gnss_outages": [(1, 2)]}).gnss_outages == ((1.0, 2.0),)
