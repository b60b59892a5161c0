"""The lateral accelerometer against the yaw rate and speed: units a range check cannot see.

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

import numpy as np

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.signals import speed_raw, vehicle_speed

MIN_SPEED = 5.0  # m/s: slower, the slip angles' share of the lateral motion grows
MIN_CENTRIPETAL = 2.0  # m/s^2: |v w_z| of the rows taken as turning (a road bank is less)
MIN_TURNING_S = 10.0  # s of turning rows the check needs
MIN_CORRELATION = 0.8
SLOPE_RANGE = (0.2, 1.8)  # SI 0.62-1.19 measured; ay in g 0.10, wz in deg/s 0.017, ft/s^2 3.3


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
    if rows.sum() < 50 or rows.sum() * drive.dt_median < MIN_TURNING_S:
        return None
    xa, ya = x[rows] - x[rows].mean(), ay[rows] - ay[rows].mean()
    sxx, syy = float(np.sum(xa * xa)), float(np.sum(ya * ya))
    if sxx <= 0.0 or syy <= 0.0:
        return None
    sxy = float(np.sum(xa * ya))
    return sxy / sxx, sxy / np.sqrt(sxx * syy), int(np.flatnonzero(rows)[0])


def check_lateral_units(drive: Drive) -> float | None:
    """Raise :class:`InputError` naming column ``ay`` when the lateral specific force and the
    yaw rate times speed are tightly related with a slope outside :data:`SLOPE_RANGE` (see
    the module docstring); returns the slope, or None where the drive cannot tell."""
    found = lateral_slope(drive)
    if found is None:
        return None
    slope, corr, first = found
    if corr >= MIN_CORRELATION and not SLOPE_RANGE[0] <= slope <= SLOPE_RANGE[1]:
        raise InputError(
            drive.path,
            f"in turns (the first from this row) ay follows {slope:.3g} x speed x wz (correlation "
            f"{corr:.2f}): expected about 1 with ay in m/s^2, wz in rad/s and the speed in m/s "
            "(ay in g reads 0.10, wz in deg/s 0.017, ay in ft/s^2 3.3)",
            column="ay",
            row=first + 1,
        )
    return slope
