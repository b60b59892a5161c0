"""Signals the calibration relations share, on two grids, with the rows each relation may use.

* The *row grid*: every drive row, sensors interpolated between their real samples (gaps longer
  than ``MAX_GAP_S`` stay NaN) and smoothed by a centred moving mean of ``SMOOTH_S`` seconds, the
  same filter on every signal so that linear relations between them hold after filtering.
* The *GNSS grid*: the rows with a fresh Doppler velocity faster than ``V_GNSS_MIN``: course
  over ground at the CG (antenna lever arm removed with the measured yaw and roll rates),
  3-D speed, course rate and the kinematic accelerations ``a_x = d|v|/dt``,
  ``a_y = |v| d(course)/dt`` (centred differences over ``RATE_S`` seconds, or two epochs of a
  slow receiver).

Nothing here identifies anything; the gates (speed, lateral acceleration below ~0.4 g for
linear tyres, quasi-steady yaw, standstill) are set here once and named in the report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.frames import unwrap_angle
from sideslip.gnss import velocity_samples
from sideslip.signals import interpolate, speed_raw, speed_source
from sideslip.vehicle import G

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.intp]

SMOOTH_S = 0.5  # s: moving-mean window applied to every signal
MAX_GAP_S = 0.5  # s: a sensor gap longer than this leaves the rows NaN
RATE_S = 0.6  # s: span of the centred differences of the GNSS course and speed
V_GNSS_MIN = 5.0  # m/s: GNSS course used above this speed (course noise sigma_v / v)
V_STEER_MIN = 3.0  # m/s: the steering relation needs a defined curvature r / v
AY_LINEAR_MAX = 0.4 * G  # m/s^2: linear tyre range (seed 001 test turn, 0.4 g)
RDOT_MAX = 0.5  # rad/s^2: quasi-steady yaw (the r' term is modelled; this cuts fast transients)
JERK_MAX = 3.0  # m/s^3: quasi-steady lateral acceleration (roll follows a_y without lag)
STANDSTILL_MPS = 0.05  # m/s: wheels and GNSS both below this -> the vehicle stands still
STEER_GRID_S = 0.1  # s: the steering relation uses one row per this interval


def moving_mean(t: FloatArray, x: FloatArray, window_s: float) -> FloatArray:
    """Centred moving mean over ``window_s`` seconds (NaN where any sample inside is NaN)."""
    if x.size == 0:
        return x.copy()
    ok = np.isfinite(x)
    c = np.concatenate([[0.0], np.cumsum(np.where(ok, x, 0.0))])
    n = np.concatenate([[0], np.cumsum(~ok)])
    lo = np.searchsorted(t, t - 0.5 * window_s, side="left")
    hi = np.searchsorted(t, t + 0.5 * window_s, side="right")
    count = hi - lo
    bad = (n[hi] - n[lo]) > 0
    out = (c[hi] - c[lo]) / np.maximum(count, 1)
    return np.where(bad | (count == 0), np.nan, out)


def _smoothed(drive: Drive, name: str) -> FloatArray | None:
    col = drive.get(name)
    if col is None:
        return None
    return moving_mean(drive.t, interpolate(col, drive.t, MAX_GAP_S), SMOOTH_S)


def _cumulative(t: FloatArray, x: FloatArray) -> FloatArray:
    """Trapezoid integral of x over t from t[0] (NaN samples count as 0)."""
    x0 = np.nan_to_num(x)
    inc = 0.5 * (x0[1:] + x0[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(inc)])


@dataclass(frozen=True)
class Signals:
    """Prepared signals.  Row grid (length n): smoothed sensor columns (NaN = unavailable).

        ``speed`` wheel/CAN speed (m/s) and ``speed_source``; ``wz, wx, wy`` gyro (rad/s);
        ``ax, ay, az`` accelerometer (m/s^2); ``steer`` road-wheel angle (rad); ``yaw_int`` the
        integral of the raw (interpolated) ``wz`` (rad); ``standstill`` rows.
        GNSS grid (length m): ``g_rows`` their drive rows; ``g_course`` (rad, unwrapped per run,
        at the CG), ``g_speed`` (3-D, m/s), ``g_course_rate`` (rad/s), ``g_ax``/``g_ay``
        (kinematic, m/s^2), ``g_dt`` the receiver interval (s); ``g_valid`` rows where the rates
        are defined; ``g_run`` the run of consecutive epochs each belongs to; ``g_grade`` the road grade (rad,
    from the vertical Doppler; 0 without ``gnss_vu``).
    """

    t: FloatArray
    speed: FloatArray
    speed_source: str
    wz: FloatArray
    wx: FloatArray | None
    wy: FloatArray | None
    ax: FloatArray | None
    ay: FloatArray | None
    az: FloatArray | None
    steer: FloatArray | None
    yaw_int: FloatArray
    standstill: BoolArray
    g_rows: IntArray
    g_course: FloatArray
    g_speed: FloatArray
    g_course_rate: FloatArray
    g_ax: FloatArray
    g_ay: FloatArray
    g_dt: float
    g_valid: BoolArray
    g_run: IntArray
    g_grade: FloatArray

    @property
    def has_gnss(self) -> bool:
        return bool(self.g_valid.sum() >= 10)


def _gnss(
    drive: Drive,
    wz: FloatArray,
    wx: FloatArray | None,
    lever: tuple[float, float, float],
    velocity: tuple[FloatArray, FloatArray] | None = None,
) -> tuple:
    """The GNSS grid of :class:`Signals` from the Doppler velocity, or from ``velocity`` (east,
    north per row, NaN where none) when given."""
    t = drive.t
    empty = np.zeros(0)
    none = (
        np.zeros(0, dtype=np.intp),
        empty,
        empty,
        empty,
        empty,
        empty,
        math.nan,
        np.zeros(0, bool),
        np.zeros(0, dtype=np.intp),
        empty,
    )
    if velocity is not None:
        ve, vn = velocity
    elif "gnss_ve" in drive and "gnss_vn" in drive:
        ve, vn = drive["gnss_ve"], drive["gnss_vn"]
    else:
        return none
    vu = drive["gnss_vu"] if "gnss_vu" in drive and velocity is None else np.zeros_like(ve)
    vu = np.where(np.isfinite(vu), vu, 0.0)
    vh = np.hypot(ve, vn)
    fresh = np.flatnonzero(np.isfinite(vh))
    if fresh.size < 10:
        return none
    dt_g = float(np.median(np.diff(t[fresh])))
    rows = fresh[vh[fresh] > V_GNSS_MIN]
    if rows.size < 10:
        return none
    tg = t[rows]
    course = np.arctan2(vn[rows], ve[rows])
    speed = np.hypot(vh[rows], vu[rows])
    # antenna lever arm (x forward, z up): v_y,ant = v_y + r x - p z  ->  course at the CG
    rx, _ry, rz = lever
    r_row = np.nan_to_num(interpolate(wz, t, MAX_GAP_S)[rows])
    p_row = np.nan_to_num(interpolate(wx, t, MAX_GAP_S)[rows]) if wx is not None else 0.0 * r_row
    course = course - (rx * r_row - rz * p_row) / vh[rows]
    # runs of consecutive epochs; rates and windows never cross a run (so a global unwrap,
    # whose multiple of 2 pi across a gap is arbitrary, is safe)
    run_break = np.concatenate([[True], np.diff(tg) > 2.5 * dt_g])
    run = np.cumsum(run_break) - 1
    out = unwrap_angle(course)
    span = max(RATE_S, 2.0 * dt_g)
    lo = np.searchsorted(tg, tg - 0.5 * span - 1e-9, side="left")
    hi = np.searchsorted(tg, tg + 0.5 * span + 1e-9, side="right") - 1
    dtt = tg[hi] - tg[lo]
    valid = (run[lo] == run) & (run[hi] == run) & (dtt > 0.5 * span)
    rate = np.where(valid, (out[hi] - out[lo]) / np.where(dtt > 0, dtt, 1.0), np.nan)
    acc = np.where(valid, (speed[hi] - speed[lo]) / np.where(dtt > 0, dtt, 1.0), np.nan)
    # smooth course-derived series with the row grid's filter (epochs inside SMOOTH_S)
    if dt_g < SMOOTH_S:
        rate = moving_mean(tg, rate, SMOOTH_S)
        acc = moving_mean(tg, acc, SMOOTH_S)
    ay = speed * rate
    # road grade from the vertical Doppler: sin(grade) = v_u / |v|
    grade = np.arcsin(np.clip(vu[rows] / speed, -0.5, 0.5))
    if dt_g < SMOOTH_S:
        grade = moving_mean(tg, grade, SMOOTH_S)
    valid = np.isfinite(rate) & np.isfinite(acc)
    return rows, out, speed, rate, acc, ay, dt_g, valid, run, np.nan_to_num(grade)


@dataclass(frozen=True)
class GyroSignals:
    """What the gyro-bias relation needs (:func:`sideslip.calibrate.sensors.gyro_bias_scale`),
    prepared alone: ``yaw_int`` the integral of the raw (interpolated) ``wz`` (rad, no tilt
    correction: that is a scale, not a bias), ``standstill`` rows, and the GNSS course grid of
    :class:`Signals` (``g_rows``, ``g_course``, ``g_run``, ``g_dt``, ``g_valid``), whose course
    comes from ``course_source``: "Doppler", or "positions" (differenced fixes,
    :func:`sideslip.gnss.velocity_samples`) on a drive without Doppler velocity."""

    t: FloatArray
    yaw_int: FloatArray
    standstill: BoolArray
    g_rows: IntArray
    g_course: FloatArray
    g_run: IntArray
    g_dt: float
    g_valid: BoolArray
    course_source: str = "Doppler"

    @property
    def has_gnss(self) -> bool:
        return bool(self.g_valid.sum() >= 10)


def _smoothed_speed(drive: Drive) -> FloatArray:
    """The methods' speed (:func:`sideslip.signals.speed_raw`) on the row grid, smoothed; NaN
    without a speed column."""
    raw = speed_raw(drive)
    if raw is None:
        return np.full(drive.t.size, np.nan)
    return moving_mean(drive.t, interpolate(raw, drive.t, MAX_GAP_S), SMOOTH_S)


def _standstill(drive: Drive, speed: FloatArray) -> BoolArray:
    """Wheels (smoothed ``speed``) and, where the drive has it, the GNSS Doppler at rest."""
    still = np.abs(np.nan_to_num(speed, nan=1.0)) < STANDSTILL_MPS
    if "gnss_ve" in drive and "gnss_vn" in drive:
        vh = interpolate(np.hypot(drive["gnss_ve"], drive["gnss_vn"]), drive.t, 2.0)
        still &= ~(np.nan_to_num(vh, nan=0.0) > 0.2)
    return still


def gyro_signals(drive: Drive, gnss_lever: tuple[float, float, float]) -> GyroSignals:
    """The gyro-bias relation's signals of ``drive`` (a few row-grid passes, not all of
    :func:`prepare`); ``gnss_lever`` the antenna lever arm (m, from the CG)."""
    t = drive.t
    speed = _smoothed_speed(drive)
    wz_raw = drive["wz"]
    wz = interpolate(wz_raw, t, MAX_GAP_S)
    velocity, source = None, "Doppler"
    if not ("gnss_ve" in drive and "gnss_vn" in drive):
        vel = velocity_samples(drive, use_positions=True)
        if vel.rows.size:
            ve, vn = np.full(t.size, np.nan), np.full(t.size, np.nan)
            ve[vel.rows], vn[vel.rows] = vel.ve, vel.vn
            velocity, source = (ve, vn), "positions"
    g = _gnss(drive, wz_raw, drive.get("wx"), gnss_lever, velocity)
    return GyroSignals(
        t=t,
        yaw_int=_cumulative(t, wz),
        standstill=_standstill(drive, speed) & np.isfinite(wz),
        g_rows=g[0],
        g_course=g[1],
        g_run=g[8],
        g_dt=g[6],
        g_valid=g[7],
        course_source=source,
    )


def _tilt_cosine(drive: Drive, t: FloatArray, speed: FloatArray, wz: FloatArray) -> FloatArray:
    """cos(roll) cos(pitch) of the body from the accelerometer: the horizontal heading rate is
    ``w_z / (cos(phi) cos(theta))`` (Euler kinematics, ``w_z = psi' cos(phi) cos(theta) -
    theta' sin(phi)``), which matters in banked curves (5 deg: 0.4 %).  ``sin(phi) ~ (a_y,m -
    v r) / g``, ``sin(theta) ~ -(a_x,m - v') / g``; 1 where the accelerometer is missing."""
    out = np.ones_like(t)
    ay, ax = _smoothed(drive, "ay"), _smoothed(drive, "ax")
    v = np.nan_to_num(speed)
    if ay is not None:
        s_phi = np.clip(np.nan_to_num((ay - v * np.nan_to_num(wz)) / G), -0.5, 0.5)
        out *= np.sqrt(1.0 - s_phi**2)
    if ax is not None:
        s_theta = np.clip(np.nan_to_num((ax - derivative(t, v)) / G), -0.5, 0.5)
        out *= np.sqrt(1.0 - s_theta**2)
    return out


def prepare(drive: Drive, gnss_lever: tuple[float, float, float]) -> Signals:
    """Prepare the signals of ``drive``; ``gnss_lever`` the antenna lever arm (m, from the CG)."""
    t = drive.t
    speed = _smoothed_speed(drive)
    wz_raw = drive["wz"]
    wz = moving_mean(t, interpolate(wz_raw, t, MAX_GAP_S), SMOOTH_S)
    wx = _smoothed(drive, "wx")
    wz_interp = interpolate(wz_raw, t, MAX_GAP_S)
    yaw_int = _cumulative(t, wz_interp / _tilt_cosine(drive, t, speed, wz))
    g = _gnss(drive, wz_raw, drive.get("wx"), gnss_lever)
    still = _standstill(drive, speed)
    return Signals(
        t=t,
        speed=speed,
        speed_source=speed_source(drive),
        wz=wz,
        wx=wx,
        wy=_smoothed(drive, "wy"),
        ax=_smoothed(drive, "ax"),
        ay=_smoothed(drive, "ay"),
        az=_smoothed(drive, "az"),
        steer=_smoothed(drive, "steer"),
        yaw_int=yaw_int,
        standstill=still & np.isfinite(wz),
        g_rows=g[0],
        g_course=g[1],
        g_speed=g[2],
        g_course_rate=g[3],
        g_ax=g[4],
        g_ay=g[5],
        g_dt=g[6],
        g_valid=g[7],
        g_run=g[8],
        g_grade=g[9],
    )


def derivative(t: FloatArray, x: FloatArray) -> FloatArray:
    """Centred time derivative (NaN propagates)."""
    if x.size < 3:
        return np.zeros_like(x)
    return np.gradient(x, t)
