"""Reference values of the calibrated quantities for a *simulated* drive (tests, benchmarks).

Computed from the drive's reference columns (``ref_*``, the simulator's truth outputs) and the
true sensor errors and vehicle it records in ``drive.meta`` (``truth_sensor``,
``vehicle_params``); never from sensor data and never used by :func:`sideslip.calibrate.calibrate`.
Works for both truths: the package's Magic-Formula two-track model and CommonRoad's multi-body
model (whose axle stiffness nobody here wrote).

* ``cf``, ``cr``: effective axle stiffness as defined in :mod:`sideslip.calibrate.axle_stiffness`,
  the slope through the origin of the axle force (from the true ``f_y = a_y cos(bank) +
  g sin(bank)`` and ``r'``, true mass, inertia and axle positions) against the true axle slip
  (true ``beta``, ``r``, ``v_x`` and road-wheel angle), rows with ``v_x > 5 m/s``,
  ``|f_y| < 0.4 g``, ``|r'| < 0.5 rad/s^2``, slip angles in their exact form
  ``alpha_f = delta - atan(tan(beta) + lf r / v)``, ``alpha_r = atan(lr r / v - tan(beta))``.
  ``slip_gain_k = m lf / (L cr)``; ``understeer_gradient`` the slope of
  ``delta - atan(L r / v)`` (less the ``r'`` term) against ``f_y`` on the same rows.
* ``roll_gradient_rad_per_m_s2``: slope of the true suspension roll (roll - bank) against
  ``f_y`` on the same rows.
* Sensor errors: ``steer_scale = 1 + steer_scale_factor`` and ``steer_offset_rad``; the true
  road-wheel angle is the measured one with these removed.  ``gyro_scale`` (z axis),
  ``gyro_bias_rad_s`` (drive mean), ``wheel_speed_scale`` (the wheels the speed signal uses),
  ``imu_roll_misalignment_rad`` / ``imu_yaw_misalignment_rad`` (x / z angles).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sideslip.drive import Drive
from sideslip.signals import interpolate, wheel_speed
from sideslip.vehicle import G

V_MIN = 5.0
AY_MAX = 0.4 * G
RDOT_MAX = 0.5


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    d = float(x @ x)
    return float(x @ y / d) if d > 0 else math.nan


def reference_calibration(drive: Drive) -> dict[str, Any]:
    """Truth of every calibrated quantity of a simulated drive (see the module docstring)."""
    meta = drive.meta
    ts = meta["truth_sensor"]
    vp = meta["vehicle_params"]
    m, lf, lr, iz = vp["mass"], vp["lf"], vp["lr"], vp["yaw_inertia"]
    L = lf + lr
    t = drive.t
    s_d = 1.0 + float(ts["steer_scale_factor"])
    d0 = float(ts["steer_offset"])
    out: dict[str, Any] = {
        "steer_scale": s_d,
        "steer_offset_rad": d0,
        "gyro_scale": 1.0 + float(ts["gyro_scale_factor"]),
        "gyro_bias_rad_s": float(ts["gyro_bias_mean"][2]),
        "imu_roll_misalignment_rad": float(ts["imu_misalignment"][0]),
        "imu_yaw_misalignment_rad": float(ts["imu_misalignment"][2]),
    }
    wsf = np.asarray(ts["wheel_scale_factor"], dtype=float)
    rear = wheel_speed(drive) is not None and "v_rl" in drive and "v_rr" in drive
    if any(c in drive for c in ("v_fl", "v_fr", "v_rl", "v_rr")):
        out["wheel_speed_scale"] = 1.0 + float(wsf[2:].mean() if rear else wsf.mean())
    else:
        out["wheel_speed_scale"] = 1.0 + float(ts["can_scale_factor"])
    if "steer" not in drive:
        return out
    delta = (interpolate(drive["steer"], t) - d0) / s_d
    beta, r, vx = drive["ref_beta"], drive["ref_r"], drive["ref_vx"]
    bank = drive["ref_bank"] if "ref_bank" in drive else np.zeros_like(t)
    fy = drive["ref_ay"] * np.cos(bank) + G * np.sin(bank)
    rdot = np.gradient(r, t)
    use = (vx > V_MIN) & (np.abs(fy) < AY_MAX) & (np.abs(rdot) < RDOT_MAX) & np.isfinite(delta)
    vv = np.where(use, vx, 1.0)
    tb = np.tan(beta)
    af = (delta - np.arctan(tb + lf * r / vv))[use]
    ar = (np.arctan(lr * r / vv - tb))[use]
    ff = ((m * lr * fy + iz * rdot) / L)[use]
    fr = ((m * lf * fy - iz * rdot) / L)[use]
    cf, cr = _slope(af, ff), _slope(ar, fr)
    # understeer gradient: slope of delta - atan(L r / v) (less the r' term) against f_y
    y = (delta - np.arctan(L * r / vv) - iz * rdot / L * (1.0 / cf + 1.0 / cr))[use]
    X = np.column_stack([fy[use], np.ones(int(use.sum()))])
    kus = float(np.linalg.lstsq(X, y, rcond=None)[0][0]) if use.sum() > 2 else math.nan
    out.update(
        cf=cf,
        cr=cr,
        understeer_gradient=kus,
        slip_gain_k_s2_m=m * lf / (L * cr),
        truth_rows=int(use.sum()),
    )
    if "ref_roll" in drive:
        out["roll_gradient_rad_per_m_s2"] = _slope(fy[use], (drive["ref_roll"] - bank)[use])
    return out
