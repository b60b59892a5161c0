"""Lateral force of an axle: the Fiala brush model with a friction limit.

The brush model of a tyre with a parabolic contact-pressure distribution and one friction
coefficient (Fiala 1954, as derived in Pacejka, *Tire and Vehicle Dynamics*, 3rd ed., 2012,
sec. 3.2.2, eqs 3.14-3.16 for the lateral force; the same form is used for whole axles, e.g.
Hindiyeh & Gerdes 2014).  With ``z = tan(alpha)`` (alpha the axle's slip angle, positive
when the force it produces is positive, ISO 8855), cornering stiffness ``C`` and force
limit ``F = mu F_z``::

    z_sl = 3 F / C                                   (full-sliding slip, tan alpha_sl)
    F_y  = C z - C^2 / (3 F) |z| z + C^3 / (27 F^2) z^3     for |z| < z_sl
    F_y  = F sign(z)                                          for |z| >= z_sl

which is linear (``C z``) at small slip, saturates smoothly at ``F``, and has the slope
``dF_y/dz = C (1 - |z| / z_sl)^2``.  Forces here are per unit vehicle mass (m/s^2): ``C`` in
m/s^2 per unit ``z`` (N/rad over kg) and ``F`` = mu g times the axle's static load share.

Two other curves are options of the estimator (``FusedSettings.axle_curve_shape``): a
simplified Magic Formula (:func:`magic_force`) and Dugoff's (:func:`dugoff_force`), both more
linear than the brush at moderate utilisation.

The model is the estimator's (``fused``) and not the simulator's: the simulator's tyres are
Pacejka's Magic Formula with load transfer, so tests never grade the estimator on its own
tyre curve.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


@numba.njit(cache=True)
def fiala_force(z: float, c: float, f_max: float) -> tuple[float, float, float, float]:
    """Brush-model axle force and its derivatives (module docstring).

    ``z`` tan of the slip angle (-), ``c`` cornering stiffness > 0, ``f_max`` force limit
    mu F_z > 0 (both per unit mass).  Returns ``(F_y, dF_y/dz, dF_y/dc, dF_y/df_max)``.
    """
    z_sl = 3.0 * f_max / c
    az = abs(z)
    if az >= z_sl:
        s = 1.0 if z >= 0.0 else -1.0
        return f_max * s, 0.0, 0.0, s
    u = z / z_sl  # signed, |u| < 1
    # F_y = F (3u - 3|u|u + u^3) with F = f_max: a function of u = c z / (3 f_max)
    fy = f_max * (3.0 * u - 3.0 * abs(u) * u + u * u * u)
    dfdu = f_max * 3.0 * (1.0 - abs(u)) ** 2
    du_dz = 1.0 / z_sl
    du_dc = z / (3.0 * f_max)
    du_df = -u / f_max
    g = 3.0 * u - 3.0 * abs(u) * u + u * u * u
    return fy, dfdu * du_dz, dfdu * du_dc, g + dfdu * du_df


@numba.njit(cache=True)
def magic_force(z: float, c: float, f_max: float, shape: float) -> tuple[float, float, float, float]:
    """Simplified Magic Formula axle force, held at its peak beyond it, and its derivatives.

    ``F_y = F sin(S atan(B z))`` with ``B = c / (S F)`` (so that the slope at zero slip is the
    cornering stiffness ``c``), ``F = f_max`` and the shape factor ``S`` (> 1; Pacejka 2012,
    sec. 4.3.2, eq. 4.49 with E = 0; S about 1.3 for lateral forces of passenger-car tyres).
    Beyond the peak, ``|B z| >= tan(pi / (2 S))``, the force is held at ``F`` (a monotonic
    curve: the estimator never has two slips for one force).  At moderate utilisation it is
    more linear than the brush curve (secant at 42 % of the limit: 0.93 against 0.85), as
    measured tyres are.  Returns ``(F_y, dF_y/dz, dF_y/dc, dF_y/df_max)``.
    """
    b = c / (shape * f_max)
    x = b * z
    if abs(x) >= math.tan(0.5 * math.pi / shape):
        s = 1.0 if z >= 0.0 else -1.0
        return f_max * s, 0.0, 0.0, s
    th = shape * math.atan(x)
    sn, cs = math.sin(th), math.cos(th)
    k = shape * cs / (1.0 + x * x)  # d sin(th) / dx
    return f_max * sn, f_max * k * b, k * z / shape, sn - k * x


@numba.njit(cache=True)
def dugoff_force(z: float, c: float, f_max: float) -> tuple[float, float, float, float]:
    """Dugoff's axle force (pure lateral slip) and its derivatives.

    Dugoff, Fancher & Segel, SAE 700377 (1970): ``F_y = c z f(lam)``, ``lam = f_max / (2 c |z|)``,
    ``f = 1`` for ``lam >= 1`` else ``(2 - lam) lam``; so linear up to half the limit
    (``|z| <= f_max / (2 c)``), beyond it ``F_y = sign(z) (f_max - f_max^2 / (4 c |z|))``,
    which approaches ``f_max`` with a slope that never reaches 0 (C1 at the knee).  Returns
    ``(F_y, dF_y/dz, dF_y/dc, dF_y/df_max)``.
    """
    az = abs(z)
    if 2.0 * c * az <= f_max:
        return c * z, c, z, 0.0
    s = 1.0 if z >= 0.0 else -1.0
    q = f_max * f_max / (4.0 * c * az)
    return s * (f_max - q), q / az, s * q / c, s * (1.0 - 2.0 * q / f_max)


@numba.njit(cache=True)
def axle_lateral_force(z: float, c: float, f_max: float, shape: float) -> tuple[float, float, float, float]:
    """The estimator's axle curve: :func:`fiala_force` when ``shape == 0``, :func:`dugoff_force`
    when ``shape < 0``, else :func:`magic_force` with that shape factor."""
    if shape == 0.0:
        return fiala_force(z, c, f_max)
    if shape < 0.0:
        return dugoff_force(z, c, f_max)
    return magic_force(z, c, f_max, shape)


def lateral_force(alpha: ArrayLike, c: float, f_max: float) -> FloatArray:
    """Vectorised :func:`fiala_force` over slip angles ``alpha`` (rad): ``F_y`` only."""
    a = np.asarray(alpha, dtype=float)
    z = np.tan(a)
    z_sl = 3.0 * f_max / c
    u = np.clip(z / z_sl, -1.0, 1.0)
    return np.asarray(f_max * (3.0 * u - 3.0 * np.abs(u) * u + u**3), dtype=float)


def sliding_slip_angle(c: float, f_max: float) -> float:
    """Slip angle (rad) at which the axle slides completely, atan(3 F / C)."""
    return math.atan(3.0 * f_max / c)
