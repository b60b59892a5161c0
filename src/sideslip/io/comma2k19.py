"""comma2k19 segments (processed_log + global_pose) to a drive.

Dataset: Schafer et al., "A Commute in Data: The comma2k19 Dataset", arXiv:1812.05752 (MIT).
A segment folder holds ``processed_log/`` and ``global_pose/`` with numpy arrays (no file
extension); every ``t`` and ``frame_times`` is the device's boot time (s).

Time base
    The rows are the IMU samples (accelerometer time stamps, about 104 Hz).  CAN (speed and
    wheel speeds share one clock, steering its own, about 89 Hz and irregular), u-blox fixes
    (10 Hz) and global-pose frames (20 Hz) land on their nearest IMU row with
    :func:`sideslip.io.mapping.place_samples`: on a collision with a row already taken by the
    same sensor the sample moves to the next free row if that row is within one IMU interval of
    the sample's time, otherwise it is dropped.  The counts are in ``meta["alignment"]``.
    Nothing is interpolated; a row never repeats a sample.

Axes and units (ISO 8855, contract section 1)
    * IMU device axes [forward, right, down] -> ISO [forward, left, up]: (x, -y, -z) for the
      accelerometer (specific force, m/s^2; at rest az = +9.8) and the gyro (rad/s).  The gyro
      is ``gyro_uncalibrated`` (the raw sensor, bias included) unless
      ``gyro_calibrated=True``; the Android bias estimate goes to ``meta["android_gyro_bias"]``
      (ISO axes, rad/s) so bias estimators can be checked against it.  The IMU is *not*
      rotated by the phone-mount misalignment: a user's car would not know it either.
    * CAN: ``v_can`` (m/s), ``v_fl``/``v_fr``/``v_rl``/``v_rr`` (m/s), ``steer`` = steering-wheel
      angle (deg, left positive) in rad divided by ``vehicle.steering_ratio``.
    * u-blox fixes: lat/lon/alt to ENU about ``meta["origin"]`` (the first fix); speed and
      bearing (deg true, clockwise from North) to ve = speed sin(bearing),
      vn = speed cos(bearing).  A fix is placed at its own epoch, not at its log time: the fix's
      UTC time (ms) becomes GPS time (+ leap seconds, 18 s since 2017) and then boot time through
      the pose's [week, time-of-week] stamps; on this segment the log lags the epoch by ~0.2 s.
      Against the pose the fixes fit best ~0.07 s (position) to ~0.13 s (speed) after their
      epoch, i.e. a residual ~0.1 s clock mismatch remains (2 m along-track at 17 m/s, whose
      side we cannot tell); ``gnss_time="log"`` keeps the log times instead.

Reference (``ref_*``) from global_pose (comma's INS/GNSS/vision fusion of the *device* pose)
    ``R_ecef_dev`` = quat2rot(q) (Hamilton [w, x, y, z]).  The phone mount is misaligned from
    the car body; the mount rotation ``R_dev_body`` is estimated on straight driving:

    1. straight rows: pose yaw rate |r| < 0.5 deg/s and speed > 5 m/s (at least 20 frames,
       else every moving frame);
    2. mount yaw and pitch: on straight driving the body velocity points along the body x-axis
       (sideslip ~ 0, no velocity normal to the road), so the mean unit velocity in device axes
       is the body x-axis in device axes;
    3. mount roll: the velocity carries no roll information, and gravity cannot separate mount
       roll from road crossfall, so the mean body roll over the straight rows is taken as zero
       (mean crossfall of the straight rows is absorbed into the mount roll).  ``ref_roll`` is
       therefore roll relative to the straight-driving mean.

    Body (ISO) orientation R_enu_body = R_enu_ecef R_ecef_dev R_dev_body F with F = diag(1,-1,-1)
    (FLU <-> FRD); yaw/pitch/roll are its Z-Y-X angles (yaw from East CCW, pitch nose down,
    roll right side down).  Velocity and position are moved from the device to the CG with the
    lever arm ``vehicle.imu_xyz`` (the IMU and camera share the device): v_cg = v_dev - w x l,
    p_cg = p_dev - R l.  ``ref_beta`` = atan2(ref_vy, ref_vx) at the CG; ``ref_r`` is the body
    z-rate from central differences of the pose orientation.  The mount angles and the rows used
    are in ``meta["mount"]``.  Caveat (DATA_NOTES): the pose used this same IMU, so it is not an
    independent reference for IMU biases.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from sideslip.drive import Drive, drive_from_columns
from sideslip.errors import InputError
from sideslip.frames import ecef_to_enu_matrix, geodetic_to_ecef, geodetic_to_enu
from sideslip.io.mapping import Placement, place_samples
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

RAV4_DONGLE = "b0c9d2329ad1606b"
CIVIC_DONGLE = "99c94dc769b5d96e"
GPS_UNIX_EPOCH = 315964800.0  # 1980-01-06 in Unix seconds
GPS_UTC_LEAP_S = 18.0  # GPS - UTC since 2017-01-01 (the dataset is from 2018)
STRAIGHT_RATE = np.radians(0.5)  # rad/s: yaw rate below which driving counts as straight
STRAIGHT_SPEED = 5.0  # m/s
FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])


def _load(seg: Path, rel: str) -> np.ndarray:
    path = seg / rel
    if not path.is_file():
        raise InputError(str(seg), f"expected the comma2k19 array '{rel}' in the segment folder")
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise InputError(str(path), f"cannot read as a numpy array ({exc})") from None


def default_vehicle_name(segment_dir: str | Path) -> str | None:
    """The preset for a segment's dongle (RAV4 -> 'rav4'), None when unknown (e.g. the Civic)."""
    text = str(Path(segment_dir).resolve())
    return "rav4" if RAV4_DONGLE in text else None


def _frd_to_iso(values: FloatArray) -> FloatArray:
    return np.asarray(values, dtype=float) * np.array([1.0, -1.0, -1.0])


def _ypr_enu(r_enu_body: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Z-Y-X angles (yaw from East CCW, pitch nose down, roll right side down) of (n,3,3)."""
    yaw = np.arctan2(r_enu_body[:, 1, 0], r_enu_body[:, 0, 0])
    pitch = -np.arcsin(np.clip(r_enu_body[:, 2, 0], -1.0, 1.0))
    roll = np.arctan2(r_enu_body[:, 2, 1], r_enu_body[:, 2, 2])
    return yaw, pitch, roll


def _body_rates(rot: Rotation, t: FloatArray) -> FloatArray:
    """Body-frame angular velocity (rad/s, frame of ``rot``'s body) by central differences."""
    n = len(rot)
    w = np.zeros((n, 3))
    if n < 2:
        return w
    i0 = np.r_[0, np.arange(n - 2), n - 2]
    i1 = np.r_[1, np.arange(2, n), n - 1]
    rel = rot[i0].inv() * rot[i1]
    dt = t[i1] - t[i0]
    return rel.as_rotvec() / dt[:, None]


def estimate_mount(
    r_ecef_dev: Rotation, v_ecef: FloatArray, t: FloatArray, r_enu_ecef: FloatArray
) -> tuple[FloatArray, dict[str, Any]]:
    """Phone-mount rotation R_dev_body (FRD body axes in device axes) from straight driving.

    See the module docstring for the method.  Returns the matrix and a report (angles in deg,
    number of straight frames).
    """
    v_dev = r_ecef_dev.inv().apply(v_ecef)
    speed = np.linalg.norm(v_dev, axis=1)
    rate_dev = _body_rates(r_ecef_dev, t)
    straight = (np.abs(rate_dev[:, 2]) < STRAIGHT_RATE) & (speed > STRAIGHT_SPEED)
    if straight.sum() < 20:
        straight = speed > STRAIGHT_SPEED
    if straight.sum() < 2:
        return np.eye(3), {"estimated": False, "reason": "no driving above 5 m/s"}
    x_b = (v_dev[straight] / speed[straight, None]).mean(axis=0)
    x_b /= np.linalg.norm(x_b)
    e3 = np.array([0.0, 0.0, 1.0])
    z_b = e3 - (e3 @ x_b) * x_b
    z_b /= np.linalg.norm(z_b)
    y_b = np.cross(z_b, x_b)
    mount0 = np.column_stack([x_b, y_b, z_b])
    r_enu_body0 = r_enu_ecef @ r_ecef_dev.as_matrix()[straight] @ mount0 @ FRD_TO_FLU
    _, _, roll0 = _ypr_enu(r_enu_body0)
    roll_m = float(np.mean(roll0))
    c, s = np.cos(-roll_m), np.sin(-roll_m)
    mount = mount0 @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    report = {
        "estimated": True,
        "straight_frames": int(straight.sum()),
        "yaw_deg": float(np.degrees(np.arctan2(x_b[1], x_b[0]))),
        "pitch_deg": float(np.degrees(-np.arcsin(x_b[2]))),
        "roll_deg": float(np.degrees(roll_m)),
        "meaning": "body x-axis lies yaw_deg to the right of and pitch_deg above the device "
        "x-axis (device FRD); roll_deg is the straight-driving mean roll removed",
    }
    return mount, report


def _reference(seg: Path, origin: tuple[float, float, float],
               vehicle: Vehicle) -> tuple[FloatArray, dict[str, FloatArray], dict[str, Any]]:
    t = _load(seg, "global_pose/frame_times").astype(float)
    pos = _load(seg, "global_pose/frame_positions").astype(float)
    vel = _load(seg, "global_pose/frame_velocities").astype(float)
    quat = _load(seg, "global_pose/frame_orientations").astype(float)
    rot = Rotation.from_quat(quat[:, [1, 2, 3, 0]])  # scipy wants [x, y, z, w]
    r_enu_ecef = ecef_to_enu_matrix(origin[0], origin[1])
    mount, report = estimate_mount(rot, vel, t, r_enu_ecef)
    r_enu_body = r_enu_ecef @ rot.as_matrix() @ mount @ FRD_TO_FLU
    body = Rotation.from_matrix(r_enu_body)
    yaw, pitch, roll = _ypr_enu(r_enu_body)
    w_body = _body_rates(body, t)  # ISO body axes, rad/s
    lever = np.asarray(vehicle.imu_xyz, dtype=float)
    v_body_dev = body.inv().apply(vel @ r_enu_ecef.T)
    v_cg = v_body_dev - np.cross(w_body, lever)
    p_enu = (pos - geodetic_to_ecef(*origin)) @ r_enu_ecef.T
    p_cg = p_enu - body.apply(lever)
    ref = {
        "ref_e": p_cg[:, 0], "ref_n": p_cg[:, 1], "ref_u": p_cg[:, 2],
        "ref_yaw": yaw, "ref_pitch": pitch, "ref_roll": roll,
        "ref_vx": v_cg[:, 0], "ref_vy": v_cg[:, 1],
        "ref_beta": np.arctan2(v_cg[:, 1], v_cg[:, 0]),
        "ref_r": w_body[:, 2],
    }  # fmt: skip
    return t, ref, report


def _gnss_epochs(seg: Path, t_log: FloatArray, utc_ms: FloatArray) -> tuple[FloatArray, float]:
    """Boot time of each fix epoch from its UTC stamp; (times, median log lag in s)."""
    ft = _load(seg, "global_pose/frame_times").astype(float)
    gps = _load(seg, "global_pose/frame_gps_times").astype(float)
    offset = float(np.median(gps[:, 1] - ft))  # tow - boot
    week = float(np.median(gps[:, 0]))
    tow = utc_ms / 1000.0 - GPS_UNIX_EPOCH - week * 604800.0 + GPS_UTC_LEAP_S
    boot = tow - offset
    lag = t_log - boot
    # A stamp off by more than 2 s from its log time is not trusted: keep the log time.
    boot = np.where(np.abs(lag) < 2.0, boot, t_log)
    return boot, float(np.median(lag))


def _spread(t_rows: FloatArray, t_s: FloatArray, values: FloatArray,
            report: dict[str, Any], name: str) -> tuple[FloatArray, Placement]:
    order = np.argsort(t_s, kind="stable")
    pl = place_samples(t_rows, t_s[order])
    report[name] = {"samples": int(t_s.size), "moved": pl.moved, "dropped": pl.dropped}
    return pl.spread(np.asarray(values, dtype=float)[order], t_rows.size), pl


def convert_comma2k19(
    segment_dir: str | Path,
    vehicle: Vehicle,
    *,
    gyro_calibrated: bool = False,
    gnss_time: str = "epoch",
) -> Drive:
    """A comma2k19 segment folder to a validated drive with reference columns.

    ``vehicle`` supplies ``steering_ratio`` (steering wheel -> road wheel) and the IMU lever arm
    ``imu_xyz`` (device -> CG for the reference).  ``gyro_calibrated`` picks Android's
    bias-corrected gyro instead of the raw one.  ``gnss_time`` = "epoch" places each u-blox fix
    at its own UTC epoch (default), "log" at its log arrival time.  On the example segment the
    pose agrees best with the fixes ~0.07 s (position) to ~0.13 s (speed) after the epoch, i.e.
    between the two: a residual clock mismatch of ~0.1 s that we cannot attribute.  See the
    module docstring for frames, units, clocks and the mount-misalignment method.
    """
    if gnss_time not in ("epoch", "log"):
        raise ValueError(f"gnss_time must be 'epoch' or 'log', not {gnss_time!r}")
    seg = Path(segment_dir)
    if not seg.is_dir():
        raise InputError(str(seg), "expected a comma2k19 segment folder (processed_log/, "
                         "global_pose/)")
    vehicle.need("steering_ratio")
    src = str(seg)
    t_acc = _load(seg, "processed_log/IMU/accelerometer/t").astype(float)
    acc = _load(seg, "processed_log/IMU/accelerometer/value").astype(float)
    gyro_name = "gyro" if gyro_calibrated else "gyro_uncalibrated"
    t_g = _load(seg, f"processed_log/IMU/{gyro_name}/t").astype(float)
    gyro = _load(seg, f"processed_log/IMU/{gyro_name}/value").astype(float)
    bias = _load(seg, "processed_log/IMU/gyro_bias/value").astype(float)
    order = np.argsort(t_acc, kind="stable")
    keep = np.r_[True, np.diff(t_acc[order]) > 0]  # a repeated time stamp keeps its first row
    rows = order[keep]
    t = t_acc[rows]
    report: dict[str, Any] = {"base": "IMU accelerometer", "imu_rows_dropped": int((~keep).sum())}
    cols: dict[str, FloatArray] = {"t": t}
    acc_iso = _frd_to_iso(acc[rows])
    for k, name in enumerate(("ax", "ay", "az")):
        cols[name] = acc_iso[:, k]
    gyro_iso = _frd_to_iso(gyro)
    for k, name in enumerate(("wx", "wy", "wz")):
        if np.array_equal(t_g, t_acc):  # one clock for both (the usual case)
            cols[name] = gyro_iso[rows, k]
        else:
            cols[name], _ = _spread(t, t_g, gyro_iso[:, k], report, name)

    t_can = _load(seg, "processed_log/CAN/speed/t").astype(float)
    v_can = _load(seg, "processed_log/CAN/speed/value").astype(float).reshape(-1)
    cols["v_can"], _ = _spread(t, t_can, v_can, report, "v_can")
    t_ws = _load(seg, "processed_log/CAN/wheel_speed/t").astype(float)
    ws = _load(seg, "processed_log/CAN/wheel_speed/value").astype(float)
    for k, name in enumerate(("v_fl", "v_fr", "v_rl", "v_rr")):
        cols[name], _ = _spread(t, t_ws, ws[:, k], report, name)
    t_st = _load(seg, "processed_log/CAN/steering_angle/t").astype(float)
    st = _load(seg, "processed_log/CAN/steering_angle/value").astype(float).reshape(-1)
    cols["steer"], _ = _spread(t, t_st, np.radians(st) / vehicle.steering_ratio, report, "steer")

    t_fix = _load(seg, "processed_log/GNSS/live_gnss_ublox/t").astype(float)
    fix = _load(seg, "processed_log/GNSS/live_gnss_ublox/value").astype(float)
    good = np.isfinite(fix[:, [0, 1, 4]]).all(axis=1) & (np.abs(fix[:, 0]) > 1e-6)
    if not good.any():
        raise InputError(src, "expected at least one u-blox fix (live_gnss_ublox)")
    t_fix, fix = t_fix[good], fix[good]
    t_epoch, lag = _gnss_epochs(seg, t_fix, fix[:, 3])
    if gnss_time == "log":
        t_epoch = t_fix
    origin = (float(fix[0, 0]), float(fix[0, 1]), float(fix[0, 4]))
    enu = geodetic_to_enu(fix[:, 0], fix[:, 1], fix[:, 4], origin)
    bearing = np.radians(fix[:, 5])
    gnss = {
        "gnss_e": enu[:, 0], "gnss_n": enu[:, 1], "gnss_u": enu[:, 2],
        "gnss_ve": fix[:, 2] * np.sin(bearing), "gnss_vn": fix[:, 2] * np.cos(bearing),
    }  # fmt: skip
    for name, values in gnss.items():
        cols[name], _ = _spread(t, t_epoch, values, report, name)

    t_ref, ref, mount = _reference(seg, origin, vehicle)
    for name, values in ref.items():
        cols[name], _ = _spread(t, t_ref, values, report, name)

    meta = {
        "source": "comma2k19",
        "segment": seg.resolve().name,
        "vehicle": vehicle.name,
        "origin": list(origin),
        "origin_note": "ENU origin = first u-blox fix (lat deg, lon deg, WGS-84 height m)",
        "gyro": gyro_name,
        "android_gyro_bias": _frd_to_iso(np.median(bias, axis=0)).tolist(),
        "android_gyro_bias_note": "Android's gyro bias estimate in ISO axes (rad/s); "
        "gyro_uncalibrated - gyro_bias = gyro",
        "gnss_time": gnss_time,
        "gnss_epoch_lag_s": lag,
        "mount": mount,
        "alignment": report,
        "reference": "global_pose of the device (comma INS/GNSS/vision fusion), mount "
        "misalignment removed, moved to the CG with vehicle.imu_xyz; not independent of the IMU",
        "citation": "Schafer et al., A Commute in Data: The comma2k19 Dataset, arXiv:1812.05752",
    }
    return drive_from_columns(cols, meta, path=src)
