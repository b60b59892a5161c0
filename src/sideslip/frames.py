"""Angles and frames: wrapping, unwrapping, rotations, geodetic <-> local ENU (WGS-84)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

WGS84_A = 6378137.0  # semi-major axis, m
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)

FloatArray = NDArray[np.float64]


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """Wrap angles (rad) to [-pi, pi)."""
    a = np.asarray(angle, dtype=float)
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=float)


def unwrap_angle(angle: ArrayLike) -> FloatArray:
    """Unwrap an angle series (rad), skipping NaN samples (they stay NaN)."""
    a = np.asarray(angle, dtype=float).copy()
    ok = np.isfinite(a)
    a[ok] = np.unwrap(a[ok])
    return a


def angle_diff(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Wrapped difference a - b (rad) in [-pi, pi)."""
    return wrap_angle(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))


def rot_x(phi: float) -> FloatArray:
    """Rotation matrix about x by phi (rad): maps body vectors to the rotated-from frame."""
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(theta: float) -> FloatArray:
    """Rotation matrix about y by theta (rad)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(psi: float) -> FloatArray:
    """Rotation matrix about z by psi (rad)."""
    c, s = np.cos(psi), np.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def geodetic_to_ecef(lat_deg: ArrayLike, lon_deg: ArrayLike, h: ArrayLike) -> FloatArray:
    """WGS-84 geodetic (deg, deg, m) to ECEF (m), shape (..., 3)."""
    lat = np.radians(np.asarray(lat_deg, dtype=float))
    lon = np.radians(np.asarray(lon_deg, dtype=float))
    h = np.asarray(h, dtype=float)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    x = (n + h) * np.cos(lat) * np.cos(lon)
    y = (n + h) * np.cos(lat) * np.sin(lon)
    z = (n * (1.0 - WGS84_E2) + h) * np.sin(lat)
    return np.stack([x, y, z], axis=-1)


def ecef_to_enu_matrix(lat_deg: float, lon_deg: float) -> FloatArray:
    """Rotation R_enu_ecef at a geodetic origin (deg): v_enu = R @ v_ecef."""
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    sl, cl = np.sin(lat), np.cos(lat)
    so, co = np.sin(lon), np.cos(lon)
    return np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])


def geodetic_to_enu(
    lat_deg: ArrayLike,
    lon_deg: ArrayLike,
    h: ArrayLike,
    origin: tuple[float, float, float],
) -> FloatArray:
    """WGS-84 geodetic (deg, deg, m) to local ENU (m) about ``origin`` = (lat, lon, h)."""
    ecef = geodetic_to_ecef(lat_deg, lon_deg, h)
    ecef0 = geodetic_to_ecef(origin[0], origin[1], origin[2])
    rot = ecef_to_enu_matrix(origin[0], origin[1])
    return np.asarray((ecef - ecef0) @ rot.T, dtype=float)


def enu_to_geodetic(
    enu: ArrayLike, origin: tuple[float, float, float]
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Local ENU (m) about ``origin`` back to WGS-84 geodetic (deg, deg, m) (Bowring)."""
    rot = ecef_to_enu_matrix(origin[0], origin[1])
    ecef = np.asarray(enu, dtype=float) @ rot + geodetic_to_ecef(*origin)
    x, y, z = ecef[..., 0], ecef[..., 1], ecef[..., 2]
    b = WGS84_A * (1.0 - WGS84_F)
    ep2 = (WGS84_A**2 - b**2) / b**2
    p = np.hypot(x, y)
    th = np.arctan2(z * WGS84_A, p * b)
    lat = np.arctan2(z + ep2 * b * np.sin(th) ** 3, p - WGS84_E2 * WGS84_A * np.cos(th) ** 3)
    lon = np.arctan2(y, x)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    h = p / np.cos(lat) - n
    return np.degrees(lat), np.degrees(lon), h
