"""comma2k19 converter on the shipped segment: frames, signs, units and clocks.

Facts checked come from ../shared/data/comma2k19_example1/DATA_NOTES.md (written from the data
by us): CAN/pose speed ratio 0.9916, gyro z (device, right-positive) correlates 0.84 with the
pose yaw rate, Android gyro bias [-0.00978, -0.03511, 0.06836] rad/s (device FRD), specific
force z ~ -9.8 in the device's down axis, mount yaw ~0.8 deg, u-blox vs pose ~1.5 m.
The converter runs on a copy of the segment in a temporary folder.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from sideslip.drive import Drive, load_drive, save_drive
from sideslip.errors import InputError
from sideslip.frames import angle_diff
from sideslip.io import FORMATS, convert
from sideslip.io.comma2k19 import convert_comma2k19
from sideslip.vehicle import load_vehicle

pytestmark = pytest.mark.realdata

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "comma2k19_example1"
SEGMENT = DATA / "b0c9d2329ad1606b_2018-08-02--08-34-47_40"


@pytest.fixture(scope="module")
def segment_copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not SEGMENT.is_dir():
        pytest.skip(f"real data absent: {SEGMENT} (../shared/data is not shipped with the repo)")
    dst = tmp_path_factory.mktemp("comma") / SEGMENT.name
    shutil.copytree(SEGMENT, dst)
    return dst


@pytest.fixture(scope="module")
def drive(segment_copy: Path) -> Drive:
    return convert("comma2k19", segment_copy, None, None)  # vehicle: rav4 from the dongle id


def _samples(drive: Drive, name: str) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(drive[name])
    return drive.t[ok], drive[name][ok]


def _at_pose(drive: Drive, name: str, smooth: int = 1) -> np.ndarray:
    """A sensor column averaged over ``smooth`` of its samples, at the pose rows (20 Hz)."""
    t, v = _samples(drive, name)
    t_ref, _ = _samples(drive, "ref_r")
    return np.interp(t_ref, t, uniform_filter1d(v, smooth))


def test_time_base_is_the_imu_and_slower_sensors_are_sparse(drive: Drive) -> None:
    assert len(drive) == 6256  # every IMU sample is a row
    assert np.all(np.diff(drive.t) > 0)
    assert 100 < 1 / drive.dt_median < 108  # ~104 Hz
    # CAN ~89 Hz: at most one sample per row, never repeated; <1 % dropped on collisions
    n_can = np.count_nonzero(np.isfinite(drive["v_can"]))
    assert 4974 * 0.99 < n_can <= 4974
    assert drive.meta["alignment"]["v_can"]["dropped"] == 4974 - n_can
    assert 570 < np.count_nonzero(np.isfinite(drive["gnss_e"])) <= 579  # 10 Hz u-blox
    assert 1190 < np.count_nonzero(np.isfinite(drive["ref_yaw"])) <= 1200  # 20 Hz pose


def test_accelerometer_is_iso_up_positive(drive: Drive) -> None:
    # device down-axis reads ~-9.8 -> ISO z up reads +g (mean 9.66 over the minute: the phone
    # is pitched ~3-4 deg and the car accelerates; 0.3 m/s^2 covers g(1-cos 4deg)+vibration)
    assert drive["az"].mean() == pytest.approx(9.8, abs=0.3)


def test_can_speed_over_pose_speed_is_0_99(drive: Drive) -> None:
    _, vx = _samples(drive, "ref_vx")
    _, vy = _samples(drive, "ref_vy")
    ratio = np.mean(_at_pose(drive, "v_can")) / np.mean(np.hypot(vx, vy))
    # DATA_NOTES: 0.9916 (tyre radius in the ECU); +-0.003 covers the CG lever arm choice
    assert ratio == pytest.approx(0.9916, abs=0.003)
    wheels = np.nanmean([_at_pose(drive, w).mean() for w in ("v_fl", "v_fr", "v_rl", "v_rr")])
    assert wheels == pytest.approx(np.mean(_at_pose(drive, "v_can")), rel=2e-3)


def test_yaw_rate_is_left_positive_and_matches_the_pose(drive: Drive) -> None:
    bias_z = drive.meta["android_gyro_bias"][2]
    wz = _at_pose(drive, "wz", smooth=10) - bias_z  # ~0.1 s average, like the 20 Hz pose
    _, r_ref = _samples(drive, "ref_r")
    # same sign convention: strongly positive correlation (DATA_NOTES 0.84 unsmoothed; we
    # measured 0.91 with the 0.1 s average)
    assert np.corrcoef(wz, r_ref)[0, 1] > 0.8
    # after removing Android's bias the residual is the bias difference of DATA_NOTES
    # (3.917 - 3.886 deg/s = 0.03 deg/s); 0.1 deg/s bounds it with margin
    assert abs(np.degrees(np.mean(wz - r_ref))) < 0.1


def test_steering_is_road_wheel_rad_left_positive(drive: Drive) -> None:
    steer = _at_pose(drive, "steer", smooth=9)
    _, r_ref = _samples(drive, "ref_r")
    assert np.corrcoef(steer, r_ref)[0, 1] > 0.6  # left steer <-> left yaw rate (measured 0.79)
    # steering wheel -4.6 ... 2.5 deg / 16.88 -> |road-wheel angle| below 0.3 deg
    assert np.nanmax(np.abs(drive["steer"])) == pytest.approx(np.radians(4.6) / 16.88, rel=1e-6)


def test_android_gyro_bias_in_iso_axes(drive: Drive) -> None:
    # device FRD [-0.00978, -0.03511, 0.06836] -> ISO (x, -y, -z)
    np.testing.assert_allclose(drive.meta["android_gyro_bias"], [-0.00978, 0.03511, -0.06836],
                               atol=2e-5)
    # raw gyro: its mean z carries the bias (the minute is nearly straight: mean pose yaw rate
    # is ~0.01 deg/s), so the mean is within 0.2 deg/s of the bias
    assert np.degrees(drive["wz"].mean() - (-0.06836)) == pytest.approx(0.0, abs=0.2)


def test_reference_heading_matches_gnss_course(drive: Drive) -> None:
    t_g, ve = _samples(drive, "gnss_ve")
    _, vn = _samples(drive, "gnss_vn")
    t_r, yaw = _samples(drive, "ref_yaw")
    course = np.arctan2(vn, ve)
    diff = angle_diff(course, np.interp(t_g, t_r, yaw))
    # course = yaw + beta with |beta| < 0.5 deg here; u-blox course noise ~0.3 deg at 17 m/s
    assert abs(np.degrees(np.mean(diff))) < 0.3
    assert np.degrees(np.std(diff)) < 0.6
    # heading near North: yaw from East CCW is ~90 - 2.5 deg
    assert np.degrees(np.mean(yaw)) == pytest.approx(87.5, abs=1.5)


def test_mount_misalignment_removed_and_reference_sideslip_small(drive: Drive) -> None:
    mount = drive.meta["mount"]
    assert mount["yaw_deg"] == pytest.approx(0.82, abs=0.1)  # DATA_NOTES mean beta_frd 0.82
    assert 2.0 < mount["pitch_deg"] < 5.0  # DATA_NOTES device pitch mean -3.2 deg
    _, beta = _samples(drive, "ref_beta")
    # DATA_NOTES: beta_frd - mean in -0.35 ... +0.45 deg; ours is at the CG (lever arm 0)
    assert abs(np.degrees(beta.mean())) < 0.05
    assert np.degrees(np.abs(beta).max()) < 0.6
    _, roll = _samples(drive, "ref_roll")
    assert np.degrees(np.abs(roll).max()) < 1.5  # device roll 0.36 ... 1.80, mean 1.25 removed


def test_gnss_enu_positions_and_velocity_match_the_pose(drive: Drive) -> None:
    t_g, e = _samples(drive, "gnss_e")
    _, n = _samples(drive, "gnss_n")
    t_r, e_r = _samples(drive, "ref_e")
    _, n_r = _samples(drive, "ref_n")
    err = np.hypot(e - np.interp(t_g, t_r, e_r), n - np.interp(t_g, t_r, n_r))
    # u-blox ~1 m plus a ~0.1 s residual clock mismatch between the fix epoch and the pose
    # (2 m along-track at 17 m/s; see convert_comma2k19): measured RMS 2.1 m
    assert np.sqrt(np.mean(err**2)) < 3.0
    assert drive.meta["origin"][:2] == pytest.approx([37.721, -122.472], abs=1e-3)
    assert np.hypot(e[-1] - e[0], n[-1] - n[0]) == pytest.approx(1006, abs=15)  # ~1 km north
    _, ve = _samples(drive, "gnss_ve")
    _, vn = _samples(drive, "gnss_vn")
    _, vx = _samples(drive, "ref_vx")
    speed_err = np.hypot(ve, vn) - np.interp(t_g, t_r, vx)
    assert np.mean(np.abs(speed_err)) < 0.15  # DATA_NOTES: u-blox speed error 0.09 m/s
    assert np.mean(vn) > 15 * np.mean(np.abs(ve))  # northbound: bearing ~2.5 deg true


def test_gnss_epoch_alignment_moves_fixes_earlier_than_log_time(segment_copy: Path) -> None:
    rav4 = load_vehicle("rav4")
    by_log = convert_comma2k19(segment_copy, rav4, gnss_time="log")
    by_epoch = convert_comma2k19(segment_copy, rav4)
    # the same fix (same east value) sits ~0.2 s earlier (DATA_NOTES: log lags epoch 0.18-0.24)
    when_logged = {v: t for t, v in zip(*_samples(by_log, "gnss_e"), strict=True)}
    lags = [when_logged[v] - t for t, v in zip(*_samples(by_epoch, "gnss_e"), strict=True)
            if v in when_logged]
    assert len(lags) > 570
    assert np.median(lags) == pytest.approx(0.204, abs=0.01)  # 0.01 s = one IMU row
    assert by_epoch.meta["gnss_epoch_lag_s"] == pytest.approx(0.204, abs=0.005)


def test_parquet_round_trip_keeps_columns_and_meta(drive: Drive, tmp_path: Path) -> None:
    out = tmp_path / "drive.parquet"
    save_drive(drive, out)
    back = load_drive(out)
    np.testing.assert_array_equal(back.t, drive.t)
    np.testing.assert_array_equal(back["ref_beta"], drive["ref_beta"])
    assert back.meta["origin"] == drive.meta["origin"]


def test_convert_lists_comma2k19_and_needs_a_vehicle_for_unknown_cars(
    segment_copy: Path, tmp_path: Path
) -> None:
    assert "comma2k19" in FORMATS
    civic = tmp_path / "99c94dc769b5d96e_2018-07-25--12-00-00_3"
    civic.mkdir()
    with pytest.raises(InputError, match="expected --vehicle NAME_OR_TOML"):
        convert("comma2k19", civic, None, None)


def test_missing_array_is_one_line_error_naming_it(segment_copy: Path, tmp_path: Path) -> None:
    broken = tmp_path / segment_copy.name
    shutil.copytree(segment_copy, broken)
    (broken / "processed_log" / "CAN" / "steering_angle" / "value").unlink()
    with pytest.raises(InputError) as err:
        convert_comma2k19(broken, load_vehicle("rav4"))
    assert str(err.value) == (f"{broken}: expected the comma2k19 array "
                              "'processed_log/CAN/steering_angle/value' in the segment folder")
    with pytest.raises(InputError, match="expected a comma2k19 segment folder"):
        convert_comma2k19(tmp_path / "nope", load_vehicle("rav4"))


def test_raw_can_decoded_with_toyota_dbc_matches_processed_log(segment_copy: Path) -> None:
    """The DBC path on real frames: opendbc's Toyota WHEEL_SPEEDS (0xAA) and
    STEER_ANGLE_SENSOR (0x25) layouts reproduce comma's processed CAN arrays."""
    pytest.importorskip("cantools")
    from sideslip.io.dbc import decode_signal, load_dbc
    from tests.io.test_mapping import DBC_TEXT

    dbc = segment_copy.parent / "toyota.dbc"
    dbc.write_text(DBC_TEXT)
    db = load_dbc(dbc)
    can = segment_copy / "processed_log" / "CAN"
    t = np.load(can / "raw_can" / "t")
    bus0 = np.load(can / "raw_can" / "src") == 0
    ids = np.load(can / "raw_can" / "address")[bus0]
    data = np.load(can / "raw_can" / "data")[bus0]  # S8: trailing zero bytes stripped
    t_w, fl = decode_signal(db, "WHEEL_SPEEDS", "WHEEL_SPEED_FL", t[bus0], ids, data,
                            source="dbc", column="v_fl")
    np.testing.assert_allclose(t_w, np.load(can / "wheel_speed" / "t"))
    np.testing.assert_allclose(fl / 3.6, np.load(can / "wheel_speed" / "value")[:, 0],
                               atol=1e-9)
    _, steer = decode_signal(db, "STEER_ANGLE_SENSOR", "STEER_ANGLE", t[bus0], ids, data,
                             source="dbc", column="steer")
    # STEER_ANGLE has 1.5 deg steps; comma adds STEER_FRACTION (+-0.7 deg) on top
    assert np.max(np.abs(steer - np.load(can / "steering_angle" / "value"))) <= 0.75


def test_reference_pitch_is_nose_down_positive_and_follows_the_road_grade(drive: Drive) -> None:
    # Climbing (u rising along the path) lifts the nose: ISO pitch = -atan(grade).  The mount
    # pitch (3.8 deg) is removed, so what remains is grade plus suspension pitch: measured
    # correlation 0.99, means -0.52 vs -0.53 deg.
    t, u = _samples(drive, "ref_u")
    _, vx = _samples(drive, "ref_vx")
    _, pitch = _samples(drive, "ref_pitch")
    grade_pitch = -np.arctan(np.gradient(u, t) / vx)
    assert np.corrcoef(pitch, grade_pitch)[0, 1] > 0.95
    assert np.degrees(abs(np.mean(pitch) - np.mean(grade_pitch))) < 0.2


def test_reference_roll_sign_matches_the_lateral_accelerometer(drive: Drive) -> None:
    # ISO: a_y,m = a_y + g sin(roll), roll right side down positive.  The IMU is not de-rotated,
    # so its roll is ref_roll + the mount roll.  a_y - v r (centripetal) against g sin(roll):
    # measured correlation +0.56 (the opposite sign would give -0.56); the residual std is
    # 0.1 m/s^2 (accelerometer noise after a 0.2 s average, road vibration).
    ok = np.isfinite(drive["ref_roll"])
    ay = uniform_filter1d(drive["ay"], 21)[ok]
    lateral = ay - drive["ref_vx"][ok] * drive["ref_r"][ok]
    roll = drive["ref_roll"][ok] + np.radians(drive.meta["mount"]["roll_deg"])
    assert np.corrcoef(lateral, 9.81 * np.sin(roll))[0, 1] > 0.4
