"""Dead reckoning from yaw rate and wheel speed, with optional slip and roll (seed 000, eqs 1-4).

Seed 000 (Takikawa et al., Robomech J 8:5, 2021), per step dt:

    (1) E_t = E_{t-1} + V cos(psi + beta) dt
    (2) N_t = N_{t-1} + V sin(psi + beta) dt
    (3) psi_t = psi_{t-1} + (psi'_imu - b_gyro) / (cos(theta) cos(phi)) dt
    (4) V = SF * V_can * cos(theta)

Symbols and units: E, N (m, ENU) trace the CG; psi (rad) yaw of the body x axis from East,
counter-clockwise; beta (rad) sideslip at the CG; psi'_imu (rad/s) the z gyro; b_gyro (rad/s)
its bias, *measured minus true* (the paper writes ``+ delta psi'``, the same offset with the
opposite sign); theta pitch and phi roll (rad, ISO signs; both enter only through cosines, so
their signs do not matter here); SF the wheel-speed scale factor (true over measured); V (m/s)
the horizontal speed.

Eq 3's division by cos(theta) cos(phi) projects a body rate onto the vertical: a vehicle turning
at Omega about the vertical with roll phi and pitch theta has w_z = Omega cos(phi) cos(theta)
(the rest shows on w_x, w_y), so Omega = w_z / (cos(phi) cos(theta)).  It assumes the rotation is
about the vertical (no roll/pitch rates), which holds in steady cornering.

Wheel speeds measure the longitudinal body speed v_x, not the speed along the velocity vector;
``dead_reckon`` therefore moves ``V / cos(beta)`` along ``psi + beta`` (the paper's V is the
velocity magnitude; the two agree to O(beta^2)).

Every function is vectorised (cumulative sums, trapezoidal rule) and finite on finite input.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def _cumtrapz(t: FloatArray, y: FloatArray) -> FloatArray:
    """Cumulative trapezoidal integral of y over t, starting at 0 (the steps computed in place:
    one temporary the length of the drive besides the time steps)."""
    y = np.asarray(y, dtype=float)
    out = np.zeros_like(y)
    if y.size > 1:
        step = y[1:] + y[:-1]
        step *= 0.5
        step *= np.diff(t)
        np.cumsum(step, out=out[1:])
    return out


def horizontal_yaw_rate(
    wz: ArrayLike,
    gyro_bias: ArrayLike = 0.0,
    roll: ArrayLike | None = None,
    pitch: ArrayLike | None = None,
    gyro_scale: float = 1.0,
) -> FloatArray:
    """Eq 3 integrand: the rate of the heading about the vertical, rad/s.

    ``(gyro_scale * wz - gyro_bias) / (cos(pitch) cos(roll))``; ``roll``/``pitch`` None means 0.
    ``gyro_scale`` multiplies the raw gyro (1 = no scale-factor correction).
    """
    rate = gyro_scale * np.asarray(wz, dtype=float) - np.asarray(gyro_bias, dtype=float)
    denom = np.ones_like(rate)
    if roll is not None:
        denom = denom * np.cos(np.asarray(roll, dtype=float))
    if pitch is not None:
        denom = denom * np.cos(np.asarray(pitch, dtype=float))
    return np.asarray(rate / np.maximum(denom, 0.1), dtype=float)


def integrate_heading(t: ArrayLike, rate: ArrayLike, yaw0: float = 0.0, start: int = 0) -> FloatArray:
    """Eq 3: yaw (rad, unwrapped) from a horizontal yaw rate, equal to ``yaw0`` at row ``start``."""
    tt = np.asarray(t, dtype=float)
    psi = _cumtrapz(tt, np.asarray(rate, dtype=float))
    return np.asarray(psi - psi[start] + yaw0, dtype=float)


def horizontal_speed(
    speed: ArrayLike, scale_factor: float = 1.0, pitch: ArrayLike | None = None
) -> FloatArray:
    """Eq 4: V = SF * V_can * cos(theta), m/s."""
    v = scale_factor * np.asarray(speed, dtype=float)
    if pitch is not None:
        v = v * np.cos(np.asarray(pitch, dtype=float))
    return np.asarray(v, dtype=float)


def dead_reckon(
    t: ArrayLike,
    speed: ArrayLike,
    yaw: ArrayLike,
    beta: ArrayLike | None = None,
    e0: float = 0.0,
    n0: float = 0.0,
    start: int = 0,
) -> tuple[FloatArray, FloatArray]:
    """Eqs 1-2: East/North (m) of the CG, equal to (e0, n0) at row ``start``.

    ``speed`` is the horizontal longitudinal speed (eq 4, m/s), ``yaw`` the heading (rad),
    ``beta`` the sideslip at the CG (rad; None = no slip correction).  With beta the point moves
    ``speed / cos(beta)`` along ``yaw + beta`` (see module docstring).
    """
    tt = np.asarray(t, dtype=float)
    v = np.asarray(speed, dtype=float)
    course = np.asarray(yaw, dtype=float)
    if beta is not None:
        b = np.clip(np.asarray(beta, dtype=float), -1.2, 1.2)
        course = course + b
        v = v / np.cos(b)
    e = _cumtrapz(tt, v * np.cos(course))
    n = _cumtrapz(tt, v * np.sin(course))
    return np.asarray(e - e[start] + e0, dtype=float), np.asarray(n - n[start] + n0, dtype=float)
