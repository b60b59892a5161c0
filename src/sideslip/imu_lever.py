"""The accelerometer's specific force moved from where the IMU sits to the centre of gravity.

An accelerometer at ``l`` (m from the CG, vehicle axes x forward, y left, z up; the vehicle
file's ``imu_xyz``) on a rigid body turning at ``omega`` reads

    f_imu = f_cg + omega' x l + omega x (omega x l)

(the acceleration of a point of a rigid body; e.g. Titterton & Weston, *Strapdown Inertial
Navigation Technology*, 2nd ed., 2004, sec. 10.4.2 on lever-arm effects), so

    f_cg = f_imu - omega' x l - (omega (omega . l) - l |omega|^2)

with ``omega = (p, q, r)`` = (wx, wy, wz), the x and y rows written out below.  A phone on
the windscreen 1.2 m ahead of the CG reads ``r' l_x`` more lateral force in every transient (1 rad/s^2 on a
race lap: 1.2 m/s^2) and ``r^2 l_x`` less longitudinal force in every turn.  Estimators whose
kinematics and force balance hold at the CG take the moved force: :func:`drive_at_cg` gives
it to every registered method that does not read ``imu_xyz`` itself
(:func:`sideslip.methods.registry.run_method`).

The angular acceleration is the gyro's difference quotient over a span: centred over 0.1 s
off-line, trailing over 0.04 s for a causal filter (its lag, half the span, against the gyro
noise the quotient amplifies: with the 0.1 s trailing span fused_filter on race_lap with the
IMU 1.2 m ahead went 0.165 -> 0.206 deg, with 0.04 s to 0.171; fg_batch with a centred
0.04 s span took 0.074 m/s^2 of gyro noise into a_y, step_steer 0.016 -> 0.021, with 0.1 s
0.017).  Gyro biases cancel in it; in the
centripetal terms they enter as ``2 r b l``, a few mm/s^2.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.signals import hold
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

SPAN_CENTRED_S = 0.1  # s: the angular acceleration's difference span off-line
SPAN_TRAILING_S = 0.04  # s: ... and for a causal filter


def angular_acceleration(
    t: FloatArray, w: FloatArray, span_s: float | None = None, causal: bool = False
) -> FloatArray:
    """d w / dt (rad/s^2) of a rate ``w`` (rad/s) sampled at ``t`` (s, increasing): the
    difference quotient over ``span_s`` (default :data:`SPAN_CENTRED_S`, or
    :data:`SPAN_TRAILING_S` when ``causal``), centred (trailing when ``causal``; one-sided at
    the ends), 0 on a drive of one row."""
    if span_s is None:
        span_s = SPAN_TRAILING_S if causal else SPAN_CENTRED_S
    n = t.size
    if n < 2:
        return np.zeros(n)
    dt = float(np.median(np.diff(t)))
    h = max(1, round(0.5 * span_s / dt)) if dt > 0 else 1
    k = np.arange(n)
    if causal:
        lo, hi = np.clip(k - 2 * h, 0, n - 1), k
    else:
        lo, hi = np.clip(k - h, 0, n - 1), np.clip(k + h, 0, n - 1)
    span = t[hi] - t[lo]
    rate = np.zeros(n)
    ok = span > 0
    rate[ok] = (w[hi] - w[lo])[ok] / span[ok]
    return rate


def specific_force_at_cg(
    t: FloatArray,
    ax: FloatArray,
    ay: FloatArray,
    wx: FloatArray,
    wy: FloatArray,
    wz: FloatArray,
    lever_m: tuple[float, float, float],
    causal: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """Longitudinal and lateral specific force (m/s^2) at the CG from an accelerometer at
    ``lever_m`` = (l_x, l_y, l_z) m from it (module docstring); the inputs themselves when the
    lever arm is zero.  Rates in rad/s (``wx``, ``wy``, ``wz`` = p, q, r), finite."""
    lx, ly, lz = (float(v) for v in lever_m)
    if lx == 0.0 and ly == 0.0 and lz == 0.0:
        return ax, ay
    p, q, r = wx, wy, wz
    dp = angular_acceleration(t, p, causal=causal) if (ly or lz) else 0.0
    dq = angular_acceleration(t, q, causal=causal) if (lx or lz) else 0.0
    dr = angular_acceleration(t, r, causal=causal) if (lx or ly) else 0.0
    w_dot_l = p * lx + q * ly + r * lz
    w2 = p * p + q * q + r * r
    # omega' x l and omega x (omega x l) = omega (omega . l) - l |omega|^2, x and y rows
    ax_cg = ax - (dq * lz - dr * ly) - (p * w_dot_l - lx * w2)
    ay_cg = ay - (dr * lx - dp * lz) - (q * w_dot_l - ly * w2)
    return np.asarray(ax_cg, dtype=float), np.asarray(ay_cg, dtype=float)


def drive_at_cg(drive: Drive, vehicle: Vehicle, causal: bool) -> tuple[Drive, str | None]:
    """The drive with its ``ax``/``ay`` moved from ``vehicle.imu_xyz`` to the CG (for a
    ``causal`` method with the trailing angular acceleration: it stays causal), and a note for
    the estimate's params; the drive itself and None when the file puts the IMU at the CG or
    the drive has no accelerometer.  Rows without an accelerometer sample stay NaN."""
    lever = tuple(float(v) for v in vehicle.imu_xyz)
    if lever == (0.0, 0.0, 0.0) or not ("ax" in drive or "ay" in drive):
        return drive, None
    t = drive.t
    # gyro gaps held at the last sample (0 where a rate is absent)
    wx, wy, wz = (hold(drive[k], t)[0] if k in drive else np.zeros(t.size) for k in ("wx", "wy", "wz"))
    ax = drive["ax"] if "ax" in drive else np.zeros(t.size)
    ay = drive["ay"] if "ay" in drive else np.zeros(t.size)
    arm = (lever[0], lever[1], lever[2])
    ax_cg, ay_cg = specific_force_at_cg(t, ax, ay, wx, wy, wz, arm, causal=causal)
    data = dict(drive.data)
    for name, moved in (("ax", ax_cg), ("ay", ay_cg)):
        if name in drive:
            col = np.asarray(drive.data[name])
            data[name] = np.where(np.isfinite(col), moved, np.nan).astype(col.dtype)
    note = (
        f"accelerometer moved from the vehicle file's imu_xyz {list(lever)} m to the CG "
        "(omega' x l + omega x (omega x l) taken off; sideslip.imu_lever)"
    )
    return replace(drive, data=data), note
