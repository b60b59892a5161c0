"""Roads for the simulator: a path by arc length with bank, grade and friction along it.

A :class:`Road` is sampled on a uniform arc-length grid ``s`` (m).  At each sample it gives the
path point (E, N) in local ENU, the path heading (rad, from East counter-clockwise, unwrapped),
the curvature (1/m, positive turning left), the bank (rad, roll sign: positive lowers the right
edge, pulling the vehicle toward -y), the grade (rad, positive uphill in the direction of
travel), the friction coefficient mu and the elevation ``integral tan(grade) ds`` (m).

Builders: :func:`road_from_pieces` (curvature piecewise linear in s, i.e. straights, clothoids
and arcs, the way roads are designed), :func:`turn` and :func:`straight` to write the pieces,
:func:`road_from_xy` (a path given as a dense polyline, e.g. a lane change y(x)), and
:func:`profile` for bank / grade / mu knots.  :func:`with_roughness` adds seeded small crossfall
and grade irregularities, :func:`with_bumps` speed bumps (elevation humps).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

DS = 0.25  # default arc-length step of the road grid, m


@dataclass(frozen=True)
class Road:
    """A road sampled every ``ds`` metres of path arc length (all arrays shape (M,))."""

    s: FloatArray
    e: FloatArray
    n: FloatArray
    heading: FloatArray
    curvature: FloatArray
    bank: FloatArray
    grade: FloatArray
    mu: FloatArray

    @property
    def ds(self) -> float:
        """Grid step, m."""
        return float(self.s[1] - self.s[0])

    @property
    def length(self) -> float:
        """Path length, m."""
        return float(self.s[-1])

    @property
    def elevation(self) -> FloatArray:
        """Elevation along the path, m: the trapezoidal integral of tan(grade) ds from 0."""
        slope = np.tan(self.grade)
        out = np.zeros_like(slope)
        out[1:] = np.cumsum(0.5 * (slope[1:] + slope[:-1])) * self.ds
        return out

    def at(self, s: float | FloatArray, name: str) -> FloatArray:
        """Linear interpolation of field ``name`` at arc length(s) ``s`` (clamped to the ends)."""
        return np.asarray(np.interp(s, self.s, getattr(self, name)), dtype=float)


# ---- pieces of curvature ------------------------------------------------------------------
Piece = tuple[float, float, float]  # (length m, curvature at start 1/m, curvature at end 1/m)


def straight(length: float) -> list[Piece]:
    """A straight of ``length`` m."""
    return [(float(length), 0.0, 0.0)]


def turn(angle_deg: float, radius: float, transition: float = 20.0) -> list[Piece]:
    """A turn of ``angle_deg`` (positive left) at ``radius`` m with clothoid entry and exit.

    The clothoids (``transition`` m each, curvature linear in s) turn the path by
    ``kappa * transition / 2`` each, the arc by the rest.  A turn too short for its transitions
    shortens them so the arc length is zero.
    """
    kappa = math.copysign(1.0 / radius, angle_deg)
    total = math.radians(abs(angle_deg))
    transition = min(transition, total * radius)
    arc = total * radius - transition
    pieces: list[Piece] = []
    if transition > 0:
        pieces.append((transition, 0.0, kappa))
    if arc > 1e-9:
        pieces.append((arc, kappa, kappa))
    if transition > 0:
        pieces.append((transition, kappa, 0.0))
    return pieces


def profile(s: FloatArray, knots: Sequence[tuple[float, float]], scale: float = 1.0) -> FloatArray:
    """Piecewise-linear profile through ``knots`` = ((s_i, value_i), ...), times ``scale``.

    Constant beyond the first and last knot.  E.g. bank in degrees with ``scale = pi/180``.
    """
    ks = np.array([k[0] for k in knots], dtype=float)
    kv = np.array([k[1] for k in knots], dtype=float)
    return np.asarray(np.interp(s, ks, kv) * scale, dtype=float)


def _geometry_from_curvature(
    curvature: FloatArray, ds: float, e0: float, n0: float, heading0: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    heading = np.empty_like(curvature)
    heading[0] = heading0
    heading[1:] = heading0 + np.cumsum(0.5 * (curvature[1:] + curvature[:-1])) * ds
    # Exact chord of a constant-curvature step would be nicer; the midpoint heading keeps the
    # position error below ds^2 kappa^2 / 24 per step (< 1e-5 m at ds = 0.25 m, R = 10 m).
    mid = 0.5 * (heading[1:] + heading[:-1])
    e = np.empty_like(curvature)
    n = np.empty_like(curvature)
    e[0], n[0] = e0, n0
    e[1:] = e0 + np.cumsum(np.cos(mid)) * ds
    n[1:] = n0 + np.cumsum(np.sin(mid)) * ds
    return e, n, heading


def _road(
    s: FloatArray,
    curvature: FloatArray,
    ds: float,
    start: tuple[float, float, float],
    bank_deg: Sequence[tuple[float, float]],
    grade_pct: Sequence[tuple[float, float]],
    mu: Sequence[tuple[float, float]],
) -> Road:
    """A road from its curvature along s (geometry integrated from ``start`` = (e, n, heading))
    and its bank (deg), grade (%) and friction knot profiles."""
    e, n, heading = _geometry_from_curvature(curvature, ds, *start)
    return Road(
        s=s,
        e=e,
        n=n,
        heading=heading,
        curvature=curvature,
        bank=profile(s, bank_deg, math.pi / 180.0),
        grade=np.arctan(profile(s, grade_pct, 0.01)),
        mu=profile(s, mu),
    )


def road_from_pieces(
    pieces: Sequence[Piece],
    bank_deg: Sequence[tuple[float, float]] = ((0.0, 0.0),),
    grade_pct: Sequence[tuple[float, float]] = ((0.0, 0.0),),
    mu: Sequence[tuple[float, float]] = ((0.0, 0.85),),
    ds: float = DS,
    start: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Road:
    """Build a road from curvature pieces and knot profiles along s.

    ``bank_deg`` knots in degrees (roll sign), ``grade_pct`` in percent (100 tan(grade)),
    ``mu`` as is; ``start`` = (E m, N m, heading rad) of the path's first point.
    """
    length = sum(p[0] for p in pieces)
    m = math.floor(length / ds) + 1
    s = np.arange(m, dtype=np.float64) * ds
    edges = np.concatenate([[0.0], np.cumsum([p[0] for p in pieces])])
    curvature = np.zeros(m)
    for (plen, k0, k1), a in zip(pieces, edges[:-1], strict=True):
        sel = (s >= a) & (s <= a + plen)
        curvature[sel] = k0 + (k1 - k0) * (s[sel] - a) / plen
    return _road(s, curvature, ds, start, bank_deg, grade_pct, mu)


def road_from_xy(
    x: FloatArray,
    y: FloatArray,
    bank_deg: Sequence[tuple[float, float]] = ((0.0, 0.0),),
    grade_pct: Sequence[tuple[float, float]] = ((0.0, 0.0),),
    mu: Sequence[tuple[float, float]] = ((0.0, 0.85),),
    ds: float = DS,
) -> Road:
    """Build a road through a dense, smooth polyline (x East, y North, m).

    The polyline is resampled by arc length; heading and curvature are finite differences
    (the polyline should be sampled at least ten times finer than its smallest radius).
    """
    dx, dy = np.diff(x), np.diff(y)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(dx, dy))])
    m = math.floor(arc[-1] / ds) + 1
    s = np.arange(m, dtype=np.float64) * ds
    heading_poly = np.unwrap(np.arctan2(dy, dx))
    mid_arc = 0.5 * (arc[1:] + arc[:-1])
    heading = np.interp(s, mid_arc, heading_poly)
    curvature = np.gradient(heading, ds)
    return _road(s, curvature, ds, (float(x[0]), float(y[0]), heading[0]), bank_deg, grade_pct, mu)


def _smooth_noise(rng: np.random.Generator, m: int, ds: float, length: float) -> FloatArray:
    """Unit-std Gaussian noise along s with correlation length ``length`` m."""
    width = max(1, round(length / ds))
    kernel_x = np.arange(-3 * width, 3 * width + 1)
    kernel = np.exp(-0.5 * (kernel_x / width) ** 2)
    white = rng.standard_normal(m + 2 * kernel.size)
    out = np.convolve(white, kernel, mode="same")[kernel.size : kernel.size + m]
    std = float(np.std(out))
    return out / std if std > 0 else out


def with_roughness(
    road: Road,
    rng: np.random.Generator,
    bank_std_deg: float = 0.15,
    grade_std_pct: float = 0.2,
    length: float = 8.0,
) -> Road:
    """Add seeded crossfall and grade irregularities (std in deg and %, correlation ``length`` m)."""
    m = road.s.size
    bank = road.bank + np.radians(bank_std_deg) * _smooth_noise(rng, m, road.ds, length)
    grade = np.arctan(np.tan(road.grade) + 0.01 * grade_std_pct * _smooth_noise(rng, m, road.ds, length))
    return replace(road, bank=bank, grade=grade)


def with_bumps(road: Road, s_bumps: Sequence[float], height: float = 0.05, length: float = 5.0) -> Road:
    """Add speed bumps: cosine humps of ``height`` m over ``length`` m centred at ``s_bumps``.

    Heights are those seen by the CG (the suspension already filters the hump), so they are
    smaller than the bump itself.  The hump enters as extra grade d(height)/ds.
    """
    slope = np.tan(road.grade)
    for sb in s_bumps:
        x = road.s - (sb - 0.5 * length)
        sel = (x >= 0) & (x <= length)
        slope[sel] += 0.5 * height * (2 * math.pi / length) * np.sin(2 * math.pi * x[sel] / length)
    return replace(road, grade=np.arctan(slope))
