"""Initial alignment of seed 004's EKF (offline): yaw and CG position at the first row from the
first >= 30 m of dead reckoning fitted to the GNSS fixes (2-D Kabsch)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sideslip.models.kinematic import (
    enu_rate,
    lever_arm_enu,
    rear_axle_speed,
    rear_axle_yaw_rate,
    steer_yaw_rate,
)
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

ALIGN_DISTANCE_M = 30.0  # travel needed for the initial heading alignment
ALIGN_WINDOW_S = 60.0  # GNSS fixes used for the alignment: at most this long before it ends


def _held(values: FloatArray) -> FloatArray:
    """Linear interpolation over NaN (held at the ends); zeros when the column is empty."""
    ok = np.isfinite(values)
    if not ok.any():
        return np.zeros_like(values)
    idx = np.arange(values.size)
    return np.interp(idx, idx[ok], values[ok])


def initial_alignment(
    t: FloatArray,
    v_rl: FloatArray,
    v_rr: FloatArray,
    steer: FloatArray,
    gnss_e: FloatArray,
    gnss_n: FloatArray,
    vehicle: Vehicle,
) -> dict[str, Any]:
    """Yaw and CG position at the first row by fitting dead reckoning to GNSS fixes.

    Dead reckoning with speed from eq 2.5 and yaw rate from the steering, eq 2.2 (the rear-wheel
    difference, eq 2.6, is not used here: an uncalibrated 0.5 % left/right tyre-radius
    difference is a yaw-rate error of 0.06 rad/s at 10 m/s), heading 0 at row 0, gives a track
    in a frame rotated by the unknown initial yaw.  Once it has travelled ``ALIGN_DISTANCE_M``,
    the rotation theta and translation c that best map the dead-reckoned antenna track onto
    the GNSS fixes (least squares, 2-D Kabsch) give yaw0 = theta and the CG at row 0 = c.
    Without steering samples eq 2.6 is used.  Returns a dict with ``ok``, ``yaw0``,
    ``yaw0_std``, ``e0``, ``n0``, ``t_aligned``, ``residual_m``.
    """
    fixes = np.flatnonzero(np.isfinite(gnss_e) & np.isfinite(gnss_n))
    out: dict[str, Any] = {"ok": False, "yaw0": 0.0, "yaw0_std": math.pi, "t_aligned": None,
                           "residual_m": None}
    if fixes.size == 0:
        out.update(e0=0.0, n0=0.0)
        return out
    out.update(e0=float(gnss_e[fixes[0]]), n0=float(gnss_n[fixes[0]]))
    v = rear_axle_speed(_held(v_rl), _held(v_rr))
    if np.isfinite(steer).any():
        r = steer_yaw_rate(v, _held(steer), vehicle.wheelbase)
    else:
        r = rear_axle_yaw_rate(_held(v_rl), _held(v_rr), vehicle.track_rear)
    dt = np.diff(t, prepend=t[0])
    psi = np.cumsum(r * dt)
    de, dn = enu_rate(v, vehicle.lr * r, psi)
    pe = np.cumsum(de * dt)
    pn = np.cumsum(dn * dt)
    ax, ay = vehicle.gnss_xyz[0], vehicle.gnss_xyz[1]
    oe, on = lever_arm_enu(psi, ax, ay)
    ae, an = pe + oe, pn + on  # dead-reckoned antenna track, heading frame of row 0
    travelled = np.hypot(ae[fixes] - ae[fixes[0]], an[fixes] - an[fixes[0]])
    far = np.flatnonzero(travelled >= ALIGN_DISTANCE_M)
    if far.size == 0:
        return out
    j1 = fixes[far[0]]
    use = fixes[(fixes <= j1) & (t[fixes] >= t[j1] - ALIGN_WINDOW_S)]
    a = np.column_stack([ae[use], an[use]])
    b = np.column_stack([gnss_e[use], gnss_n[use]])
    a_c = a - a.mean(axis=0)
    b_c = b - b.mean(axis=0)
    cross = np.sum(a_c[:, 0] * b_c[:, 1] - a_c[:, 1] * b_c[:, 0])
    dot = np.sum(a_c[:, 0] * b_c[:, 0] + a_c[:, 1] * b_c[:, 1])
    theta = math.atan2(cross, dot)
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    shift = b.mean(axis=0) - rot @ a.mean(axis=0)
    resid = b - (a @ rot.T + shift)
    rms = float(np.sqrt(np.mean(np.sum(resid**2, axis=1)) / 2.0))
    spread = float(np.sqrt(np.mean(np.sum(a_c**2, axis=1))))
    # heading 1-sigma: fit noise over the spread of the track, GNSS drift over the stretch
    # (about 1 m over 30 m), and the dead-reckoned heading change's error (steering scale
    # and understeer, 10 %), at least 1 deg.
    turn = float(np.max(psi[: j1 + 1]) - np.min(psi[: j1 + 1]))
    yaw_std = math.hypot(
        rms / max(spread * math.sqrt(use.size), 1e-3), 1.0 / ALIGN_DISTANCE_M, 0.1 * turn
    )
    out.update(
        ok=True,
        yaw0=float(math.atan2(math.sin(theta), math.cos(theta))),
        yaw0_std=max(yaw_std, math.radians(1.0)),
        e0=float(shift[0]),
        n0=float(shift[1]),
        t_aligned=float(t[j1]),
        residual_m=rms,
    )
    return out
