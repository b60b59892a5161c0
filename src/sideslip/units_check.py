"""The IMU against the speed and the steering: units and axes a range check cannot see.

The range limits of :data:`sideslip.drive.LIMITS` catch a unit that makes values impossible
(yaw rates beyond 5 rad/s, speeds beyond 150 m/s), not one that keeps them plausible: a
lateral acceleration logged in g (at most about 1.2), a gentle drive's yaw rate in deg/s
(a highway's 2-3 deg/s) or in ft/s^2 (at most about 40).  Every method then runs
and reads garbage: the Revs lap with ``ay`` and ``ax`` in g gave ``fused`` a beta RMSE of 21
deg, 0.25 with m/s^2.

The drive shows it.  In a turn the lateral specific force is the centripetal acceleration
``v_x w_z`` plus the slip's rate (zero on average over a drive) and gravity through the body's
roll (a few per cent more) and the road's bank (less: on a banked curve driven near its
design speed the bank carries part of the turn).  So over the turning rows of a drive, the
least-squares slope of ``a_y`` on ``v w_z`` (with an intercept for the accelerometer's and
the gyro's offsets) is about 1 in SI units: 0.99 on the Revs lap, 0.58-1.21 on the simulated
scenarios, the lowest where the superelevation grows with the curvature (urban_highway, to 5
deg: 0.62), other than a 25-degree banked bowl (slope and correlation negative, the bank
carrying more than the turn).  ``a_y`` in g reads 0.10, ``w_z`` in deg/s 0.017, ``a_y`` in
ft/s^2 3.3.  A speed in km/h (0.28) or mph (0.45) stays inside the range a superelevated road
may give, so the check leaves it alone.  Where the two are tightly related
(correlation at least :data:`MIN_CORRELATION`: a raw gyro's bias or a drive without turns
leaves them unrelated and the check silent) and the slope lies outside
:data:`SLOPE_RANGE`, the drive is bad input.
"""

from __future__ import annotations

import math

import numpy as np

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.signals import hold, sample_step, speed_raw, vehicle_speed

MIN_SPEED = 5.0  # m/s: slower, the slip angles' share of the lateral motion grows
MIN_CENTRIPETAL = 2.0  # m/s^2: |v w_z| of the rows taken as turning (a road bank is less)
MIN_TURNING_S = 10.0  # s of turning rows the check needs
MIN_CORRELATION = 0.8
SLOPE_RANGE = (0.2, 1.8)  # SI 0.62-1.19 measured; ay in g 0.10, wz in deg/s 0.017, ft/s^2 3.3


MIN_SPREAD = 1.0  # m/s^2: 5-95 % spread one side of a slope needs


def _narrow(x: np.ndarray) -> bool:
    """Whether ``x`` spans less than :data:`MIN_SPREAD` between its 5th and 95th percentiles.
    Where both sides of a slope are that narrow (one steady circle, or a synthetic drive's
    constant turn) only noise or rounding would decide it; where one side spans (a wrong unit
    shrinks the other) it is judged."""
    lo, hi = np.percentile(x, [5.0, 95.0])
    return bool(hi - lo < MIN_SPREAD)


def _slope(
    x: np.ndarray, y: np.ndarray, rows: np.ndarray, min_rows: float
) -> tuple[float, float, int] | None:
    """``(slope, correlation, first row)`` of ``y`` on ``x`` (with an intercept) over
    ``rows``, or None with fewer than ``max(50, min_rows)`` rows or both sides narrow."""
    if rows.sum() < max(50.0, min_rows) or (_narrow(x[rows]) and _narrow(y[rows])):
        return None
    xa, ya = x[rows] - x[rows].mean(), y[rows] - y[rows].mean()
    sxx, syy = float(np.sum(xa * xa)), float(np.sum(ya * ya))
    if sxx <= 0.0 or syy <= 0.0:
        return None
    sxy = float(np.sum(xa * ya))
    return sxy / sxx, sxy / float(np.sqrt(sxx * syy)), int(np.flatnonzero(rows)[0])


def lateral_slope(drive: Drive) -> tuple[float, float, int] | None:
    """``(slope, correlation, first row)`` of ``a_y`` on ``v w_z`` over the drive's turning
    rows (faster than :data:`MIN_SPEED`, ``|v w_z|`` beyond :data:`MIN_CENTRIPETAL`), or
    None where the drive lacks a column or :data:`MIN_TURNING_S` of such rows."""
    if "ay" not in drive or "wz" not in drive or speed_raw(drive) is None:
        return None
    ay = np.asarray(drive["ay"], dtype=float)
    wz = np.asarray(drive["wz"], dtype=float)
    v = vehicle_speed(drive)
    x = v * wz
    with np.errstate(invalid="ignore"):
        rows = np.isfinite(ay) & np.isfinite(x) & (v > MIN_SPEED) & (np.abs(x) > MIN_CENTRIPETAL)
    # seconds of turning at the IMU's own sample spacing (an IMU slower than the table)
    return _slope(x, ay, rows, MIN_TURNING_S / sample_step(drive.t, ay))


def check_lateral_units(drive: Drive) -> float | None:
    """Raise :class:`InputError` naming column ``ay`` when the lateral specific force and the
    yaw rate times speed are tightly related with a slope outside :data:`SLOPE_RANGE` (see
    the module docstring); returns the slope, or None where the drive cannot tell."""
    return _in_range(
        drive, lateral_slope(drive), SLOPE_RANGE, "ay", "in turns (the first from this row) ay follows",
        "speed x wz", "ay in m/s^2, wz in rad/s and the speed in m/s (ay in g reads 0.10, wz in "
        "deg/s 0.017, ay in ft/s^2 3.3)",
    )  # fmt: skip


def _in_range(
    drive: Drive, found: tuple[float, float, int] | None, bounds: tuple[float, float], column: str,
    lead: str, regressor: str, units: str,
) -> float | None:  # fmt: skip
    """The slope of ``found``; :class:`InputError` naming ``column`` where it is tight
    (correlation at least :data:`MIN_CORRELATION`) and outside ``bounds``."""
    if found is None:
        return None
    slope, corr, first = found
    if corr >= MIN_CORRELATION and not bounds[0] <= slope <= bounds[1]:
        raise InputError(
            drive.path,
            f"{lead} {slope:.3g} x {regressor} (correlation {corr:.2f}): expected about 1 with {units}",
            column=column,
            row=first + 1,
        )
    return slope


LINEAR_BAND = (1.5, 4.0)  # m/s^2: |v w_z| of the rows where the tyres are linear (no countersteer)
MIN_LINEAR_S = 10.0  # s of such rows the axes check needs
AXIS_CORRELATION = -0.5  # a channel correlated below this with the others turns the other way


def lateral_axes(drive: Drive) -> tuple[float, float, int] | None:
    """``(corr(a_y, v w_z), corr(steer, w_z), first row)`` over the rows faster than
    :data:`MIN_SPEED` with ``|v w_z|`` inside :data:`LINEAR_BAND`, or None where the drive
    lacks a column or :data:`MIN_LINEAR_S` of such rows."""
    if any(c not in drive for c in ("ay", "wz", "steer")) or speed_raw(drive) is None:
        return None
    ay = np.asarray(drive["ay"], dtype=float)
    wz = np.asarray(drive["wz"], dtype=float)
    steer = np.asarray(drive["steer"], dtype=float)
    v = vehicle_speed(drive)
    x = v * wz
    with np.errstate(invalid="ignore"):
        rows = (
            np.isfinite(ay) & np.isfinite(x) & np.isfinite(steer) & (v > MIN_SPEED)
            & (np.abs(x) > LINEAR_BAND[0]) & (np.abs(x) < LINEAR_BAND[1])
        )  # fmt: skip
    if rows.sum() < 50 or rows.sum() * sample_step(drive.t, ay) < MIN_LINEAR_S or _narrow(x[rows]):
        return None
    c_ay = np.corrcoef(ay[rows], x[rows])[0, 1]
    c_steer = np.corrcoef(steer[rows], wz[rows])[0, 1]
    if not (np.isfinite(c_ay) and np.isfinite(c_steer)):
        return None
    return float(c_ay), float(c_steer), int(np.flatnonzero(rows)[0])


def check_lateral_axes(drive: Drive, uses_steer: bool) -> None:
    """Raise :class:`InputError` where one of ``wz``, ``ay`` and ``steer`` turns against the
    other two in the drive's gentle turns (``|v w_z|`` 1.5-4 m/s^2, where the tyres are
    linear: the steering points into the turn, no countersteer; ISO 8855 axes, y left and z
    up, all three positive turning left).

    * ``wz`` against both ``steer`` and ``a_y``: a yaw gyro mounted upside down (the GNSS
      course catches it where the drive has GNSS, :func:`sideslip.methods.registry.check_gyro_sign`;
      this is the check without).  Every method.
    * ``steer`` against both ``w_z`` and ``a_y`` (only where the method reads the steering):
      a steering angle positive to the right, or an IMU in SAE axes (y right, z down: both
      its channels flipped).
    * ``a_y`` alone against the other two is not judged: a steeply banked curve turns the
      lateral specific force against the turn (the simulated 25-degree bowl: correlation
      -0.88, the steering and the gyro agreeing at 0.98).

    Measured on the valid drives (correlations of a_y with v w_z / of steer with w_z): the Revs
    lap 0.87 / 0.93, the simulated and CommonRoad scenarios with 10 s of such rows 0.89-1.00 /
    0.97-1.00 (the rest not judged)."""
    found = lateral_axes(drive)
    if found is None:
        return
    c_ay, c_steer, first = found
    if c_steer >= AXIS_CORRELATION:
        return
    if c_ay < AXIS_CORRELATION:
        raise InputError(
            drive.path,
            f"in gentle turns (the first from this row) the yaw rate turns against the steering "
            f"(correlation {c_steer:.2f}) and against ay / speed (correlation {c_ay:.2f}): expected "
            "wz > 0 turning left (ISO 8855, z up); is the gyro axis flipped?",
            column="wz",
            row=first + 1,
        )
    if uses_steer and c_ay > -AXIS_CORRELATION:
        raise InputError(
            drive.path,
            f"in gentle turns (the first from this row) the steering turns against the yaw rate "
            f"(correlation {c_steer:.2f}) while ay agrees with it ({c_ay:.2f}): expected steer > 0 "
            "turning left (ISO 8855); is the steering positive right, or the IMU in SAE axes (y "
            "right, z down)?",
            column="steer",
            row=first + 1,
        )


# road-wheel angle over the kinematic one L w_z / v in gentle turns: 1 + K_us v^2 / L for an
# understeering car (the bicycle model's steady state, Gillespie 1992 eq 6-15).  Measured
# 0.82-2.40 (16 scenarios x seeds 0-1 where judged: cr_circle 0.82, two_turns_gyro_sf 2.40;
# the Revs lap 1.39); a steering-wheel angle reads about the steering ratio (12-20 x), degrees
# 57 x
STEER_SLOPE_RANGE = (0.3, 6.0)
MAX_HOLD_S = 0.5  # s: a held sample older than this is a gap, not a reading


def steer_slope(drive: Drive, wheelbase_m: float) -> tuple[float, float, int] | None:
    """``(slope, correlation, first row)`` of ``steer`` on the kinematic road-wheel angle
    ``L w_z / v`` over the gentle turns (``|v w_z|`` in :data:`LINEAR_BAND`, faster than
    :data:`MIN_SPEED`; both columns held across their gaps), or None where the drive lacks a
    column or :data:`MIN_LINEAR_S` of such rows, or the wheelbase is not finite."""
    if not np.isfinite(wheelbase_m) or wheelbase_m <= 0.0:
        return None
    if any(c not in drive for c in ("steer", "wz")) or speed_raw(drive) is None or len(drive) < 3:
        return None
    t = drive.t
    steer, steer_age = hold(np.asarray(drive["steer"], dtype=float), t)
    wz, wz_age = hold(np.asarray(drive["wz"], dtype=float), t)
    v = vehicle_speed(drive)
    with np.errstate(invalid="ignore", divide="ignore"):
        kinematic = wheelbase_m * wz / np.where(np.abs(v) > MIN_SPEED, v, np.inf)
        centripetal = np.abs(v * wz)
        rows = (
            (steer_age < MAX_HOLD_S) & (wz_age < MAX_HOLD_S) & (v > MIN_SPEED)
            & (centripetal >= LINEAR_BAND[0]) & (centripetal <= LINEAR_BAND[1])
        )  # fmt: skip
    if rows.sum() < max(50.0, MIN_LINEAR_S / drive.dt_median):
        return None
    xa = kinematic[rows] - kinematic[rows].mean()
    ya = steer[rows] - steer[rows].mean()
    sxx, syy = float(xa @ xa), float(ya @ ya)
    spread = math.sqrt(sxx) * math.sqrt(syy)
    if not spread > 0.0:  # a constant steering or yaw rate decides no slope
        return None
    sxy = float(xa @ ya)
    return sxy / sxx, sxy / spread, int(np.flatnonzero(rows)[0])


def check_steer_units(drive: Drive, wheelbase_m: float) -> float | None:
    """Raise :class:`InputError` naming column ``steer`` where the steering follows the
    kinematic road-wheel angle ``L w_z / v`` tightly (correlation at least
    :data:`MIN_CORRELATION`) with a slope outside :data:`STEER_SLOPE_RANGE`: a steering-wheel
    angle (the steering ratio times the road wheels') or degrees that stay inside the range
    limit of 1.2 (a highway's road-wheel angles are a degree or two).  Only for methods that
    read the steering; returns the slope, or None where the drive cannot tell."""
    return _in_range(
        drive, steer_slope(drive, wheelbase_m), STEER_SLOPE_RANGE, "steer",
        "in gentle turns (the first from this row) steer follows", "wheelbase x wz / speed",
        "steer the road-wheel angle in rad (up to 2.5 with understeer; a steering-wheel angle "
        "reads about the steering ratio, 12-20, degrees 57): divide a steering-wheel angle by "
        "the steering ratio",
    )  # fmt: skip


LON_SMOOTH_S = 0.5  # s: moving mean of ax and the speed before the rate (wheel-speed steps)
MIN_LON_ACCEL = 1.0  # m/s^2: |dv/dt| or |a_x| of the rows taken as speeding up or braking
MIN_LON_S = 5.0  # s of such rows the check needs
LON_SLOPE_RANGE = (0.4, 2.5)  # SI 0.74-1.05 measured; ax in g 0.10, t in ms 1000, km/h 0.28


def longitudinal_slope(drive: Drive) -> tuple[float, float, int] | None:
    """``(slope, correlation, first row)`` of ``a_x`` on the speed's rate ``dv/dt`` (both a
    :data:`LON_SMOOTH_S` moving mean) over the rows faster than :data:`MIN_SPEED` where
    either is beyond :data:`MIN_LON_ACCEL` (either: a wrong unit of one shrinks it below the
    gate), or None where the drive lacks a column or :data:`MIN_LON_S` of such rows."""
    if "ax" not in drive or speed_raw(drive) is None or len(drive) < 3:
        return None
    from scipy.ndimage import uniform_filter1d

    ax = np.asarray(drive["ax"], dtype=float)
    finite = np.isfinite(ax)
    n = max(1, round(LON_SMOOTH_S / drive.dt_median))
    # the mean of the samples in each window (an IMU slower than the table has NaN between
    # its samples: zeros there read a 50 Hz IMU in a 100 Hz table as ax at half scale)
    count = uniform_filter1d(finite.astype(float), n, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        ax_m = uniform_filter1d(np.where(finite, ax, 0.0), n, mode="nearest") / count
    ax_m[count < 0.5 / n] = np.nan
    v_m = uniform_filter1d(vehicle_speed(drive), n, mode="nearest")
    dv = np.gradient(v_m, drive.t)
    with np.errstate(invalid="ignore"):
        rows = (
            np.isfinite(ax_m) & (v_m > MIN_SPEED)
            & ((np.abs(dv) > MIN_LON_ACCEL) | (np.abs(ax_m) > MIN_LON_ACCEL))
        )  # fmt: skip
    return _slope(dv, ax_m, rows, MIN_LON_S * (1.0 / drive.dt_median))


def check_longitudinal(drive: Drive) -> float | None:
    """Raise :class:`InputError` naming column ``ax`` where the longitudinal specific force
    turns against the speed's rate (an IMU mounted backwards: its ``a_y`` is then flipped
    too) or follows it with a slope outside :data:`LON_SLOPE_RANGE` (a unit: ``a_x`` in g,
    the time stamps in ms, the speed in km/h).  ``a_x = dv/dt + g sin(pitch)``: the road's
    grade adds scatter, not a slope, except where a drive only coasts on hills.  Measured
    (slope, correlation): the Revs lap 1.05 / 1.00, the comma2k19 minute 0.74 / 0.97, the
    simulated drives that speed up or brake for 5 s 0.96-1.05 / 0.98-1.00.  Returns the
    slope, or None where the drive cannot tell."""
    found = longitudinal_slope(drive)
    if found is None:
        return None
    _, corr, first = found
    if corr <= -MIN_CORRELATION:
        raise InputError(
            drive.path,
            f"speeding up and braking (the first from this row), ax turns against the speed's "
            f"rate (correlation {corr:.2f}): expected ax > 0 speeding up (ISO 8855, x forward); "
            "is the IMU mounted backwards?",
            column="ax",
            row=first + 1,
        )
    return _in_range(
        drive, found, LON_SLOPE_RANGE, "ax", "speeding up and braking (the first from this row), ax "
        "follows", "the speed's rate", "ax in m/s^2, the speed in m/s and t in s (ax in g reads "
        "0.10, t in ms 1000, a speed in km/h 0.28)",
    )  # fmt: skip


TILT_WINDOW_S = 10.0  # s over which the roll / pitch angle a rate turns is judged
# rad (115 deg): no road vehicle turns its roll or pitch this far in 10 s (a car's 0.45 entering
# a 25-degree banked turn; a motorcycle's lean from +50 to -50 deg, 1.75), while a rate in deg/s
# reads 57 x: 2.5-6.3 rad on the simulated drives of 2 min and longer
TILT_MAX_RAD = 2.0


def tilt_excursion(drive: Drive, column: str) -> tuple[float, int] | None:
    """``(largest angle, first row)``: the largest change (rad) of the angle that the rate
    ``column`` (``wx`` or ``wy``, less its mean over the drive: a gyro's bias) turns within
    :data:`TILT_WINDOW_S`, and the row where that window starts; None without 20 samples."""
    if column not in drive:
        return None
    w = np.asarray(drive[column], dtype=float)
    rows = np.flatnonzero(np.isfinite(w))
    if rows.size < 20:
        return None
    t, w = drive.t[rows], w[rows] - float(np.mean(w[rows]))
    # not across a gap or a jump of the clock (a logger's hour-long jump held a rate of
    # 1e-3 rad/s over 3600 s): only steps of at most 1 s, or a few sample steps
    dt = np.diff(t)
    dt = np.where(dt <= max(1.0, 5.0 * sample_step(drive.t, drive[column])), dt, 0.0)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * dt)))
    end = np.clip(np.searchsorted(t, t + TILT_WINDOW_S), 0, t.size - 1)
    turned = np.abs(angle[end] - angle)
    k = int(np.argmax(turned))
    return float(turned[k]), int(rows[k])


def check_tilt_rate_units(drive: Drive) -> None:
    """Raise :class:`InputError` naming ``wx`` or ``wy`` where the roll or pitch angle the rate
    turns (its mean removed) changes by more than :data:`TILT_MAX_RAD` within
    :data:`TILT_WINDOW_S`.  The range limit (5 rad/s) lets a roll rate in deg/s through on
    any drive short of a rollover, and the methods that read it then take its angle for the
    road's bank (urban_course with ``wx`` in deg/s: fused 9.6 deg of beta RMSE, fused_filter
    21).  Measured on valid drives: 0.02-0.45 rad (the 0.45 entering a 25-degree banked turn;
    the comma2k19 minute 0.018); in deg/s the same drives read 1.1-26 rad, so a short
    manoeuvre in deg/s (a 12 s step steer: 1.7) may pass."""
    for column, what in (("wx", "roll"), ("wy", "pitch")):
        found = tilt_excursion(drive, column)
        if found is None or found[0] <= TILT_MAX_RAD:
            continue
        raise InputError(
            drive.path,
            f"the {what} angle {column} turns (its mean removed) changes by {found[0]:.3g} rad within "
            f"{TILT_WINDOW_S:g} s from this row: expected {column} in rad/s (a road vehicle's {what} "
            f"changes by under {TILT_MAX_RAD:g} rad; in deg/s it reads 57 x); is it in deg/s?",
            column=column,
            row=found[1] + 1,
        )


GNSS_SPEED_RANGE = (0.7, 1.4)  # GNSS speed over the wheels' (rolling radius, slip: +-10 %)
GNSS_MIN_S = 10.0  # s of moving GNSS samples the check needs
GNSS_BASELINE_S = 1.0  # s between the fixes a position speed is taken over


def gnss_speed_ratio(drive: Drive, column: str) -> tuple[float, int] | None:
    """``(median ratio, first row)`` of the GNSS speed (``column`` ``gnss_ve``: the Doppler's
    horizontal speed; ``gnss_e``: the fixes' distance over about :data:`GNSS_BASELINE_S`)
    to the wheels' speed over the samples faster than :data:`MIN_SPEED`, or None without
    both or :data:`GNSS_MIN_S` of such samples."""
    pair = {"gnss_ve": ("gnss_ve", "gnss_vn"), "gnss_e": ("gnss_e", "gnss_n")}[column]
    if any(c not in drive for c in pair) or speed_raw(drive) is None:
        return None
    v = np.abs(vehicle_speed(drive))
    a, b = (np.asarray(drive[c], dtype=float) for c in pair)
    rows = np.flatnonzero(np.isfinite(a) & np.isfinite(b))
    if rows.size < 10:
        return None
    t = drive.t
    if column == "gnss_ve":
        speed = np.hypot(a[rows], b[rows])
        at = rows
    else:  # each fix against the first one a baseline later
        later = np.searchsorted(t[rows], t[rows] + GNSS_BASELINE_S)
        ok = later < rows.size
        first, last = rows[ok], rows[later[ok]]
        speed = np.hypot(a[last] - a[first], b[last] - b[first]) / (t[last] - t[first])
        at = first
    moving = np.isfinite(v[at]) & (v[at] > MIN_SPEED)
    if moving.sum() < 10 or moving.sum() * sample_step(t, a) < GNSS_MIN_S:
        return None
    return float(np.median(speed[moving] / v[at][moving])), int(at[moving][0])


def check_gnss_speed_units(drive: Drive) -> None:
    """Raise :class:`InputError` naming ``gnss_ve`` (or ``gnss_e``) where the GNSS speed over
    the drive's moving samples is not about the wheels' (median ratio outside
    :data:`GNSS_SPEED_RANGE`): a Doppler speed in km/h (3.6), mph (2.24) or knots (1.94),
    positions in km or feet.  The wheels are judged against ``ax`` first
    (:func:`check_longitudinal`), so the GNSS is named.  Such a drive ran: urban_course with
    its Doppler in km/h, fused with 48 % of it flagged; measured ratios on valid drives:
    the simulated ones 0.98-1.02."""
    for column, units in (
        ("gnss_ve", "gnss_ve, gnss_vn in m/s (km/h reads 3.6, mph 2.24, knots 1.94)"),
        ("gnss_e", "gnss_e, gnss_n in m (km reads 0.001, feet 3.28)"),
    ):
        found = gnss_speed_ratio(drive, column)
        if found is None or GNSS_SPEED_RANGE[0] <= found[0] <= GNSS_SPEED_RANGE[1]:
            continue
        what = "Doppler speed" if column == "gnss_ve" else "speed between the fixes"
        raise InputError(
            drive.path,
            f"moving (the first from this row), the GNSS {what} is {found[0]:.3g} x the wheels' "
            f"speed: expected about 1 with {units}",
            column=column,
            row=found[1] + 1,
        )
