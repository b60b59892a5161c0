"""Tyre forces of the simulator's truth model: Pacejka Magic Formula with load sensitivity.

Lateral force of one tyre (Pacejka, *Tire and Vehicle Dynamics*, 3rd ed. 2012, eq 4.49)::

    F_y = D sin(C atan(B a - E (B a - atan(B a))))       a: slip angle, rad
    D   = mu_eff F_z,   mu_eff = mu (1 - p_mu (F_z - F_z0) / F_z0)   (clamped >= 0.5 mu)
    C_a(F_z) = C_a0 (F_z / F_z0) ** p_load                cornering stiffness, N/rad
    B   = C_a(F_z) / (C D)

so the slope at zero slip, ``B C D``, equals the per-tyre cornering stiffness ``C_a0`` at the
nominal load ``F_z0`` (the vehicle file's per-axle ``cf``/``cr`` halved) on any road friction:
at small slip the truth model agrees with the linear single-track model, at large slip it
saturates at ``mu F_z``.  ``p_load < 1`` makes the stiffness grow sub-linearly with load, so a
lateral load transfer lowers the axle's total stiffness and peak force (Pacejka sec. 1.3).

Longitudinal force is not integrated through wheel-spin dynamics: the driver's drive and brake
torques give each tyre a force ``F_x`` (capped at 95 % of ``D``, an ideal ABS / traction
control); the lateral force is reduced by the friction ellipse
``F_y = F_y0 sqrt(1 - (F_x / D)^2)`` (Pacejka sec. 4.3.2, "combined slip, simple approach"),
and the longitudinal slip ``kappa`` that this force needs is the quasi-static inverse of the
longitudinal Magic Formula ``F_x = D sin(C_x atan(B_x kappa))`` with slip stiffness
``C_kappa = c_kappa F_z`` (N per unit slip), ``B_x = C_kappa / (C_x D)``.  Wheel speeds then
carry the real tyre slip: ``omega R = v_long + kappa |v_long|`` (SAE slip definition).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit


@dataclass(frozen=True)
class TyreShape:
    """Magic Formula shape factors shared by all four tyres (dimensionless).

    c_y, e_y         lateral shape and curvature factors (C = 1.3 is Pacejka's typical lateral
                     value; E < 0 widens the peak)
    load_exponent    p_load in C_a ~ F_z ** p_load (0.8: sub-linear load sensitivity)
    mu_load          p_mu: friction falls by this fraction per unit relative load increase
    c_x              longitudinal shape factor (1.65, Pacejka's typical value)
    slip_stiffness   c_kappa: longitudinal slip stiffness per unit load (N/N per unit slip)
    """

    c_y: float = 1.3
    e_y: float = -0.3
    load_exponent: float = 0.8
    mu_load: float = 0.1
    c_x: float = 1.65
    slip_stiffness: float = 20.0


@njit(cache=True)
def friction_peak(fz: float, mu: float, fz0: float, mu_load: float) -> float:
    """Peak force D = mu_eff F_z of one tyre, N (0 when the tyre has lifted)."""
    if fz <= 0.0:
        return 0.0
    factor = 1.0 - mu_load * (fz - fz0) / fz0
    if factor < 0.5:
        factor = 0.5
    return mu * factor * fz


@njit(cache=True)
def lateral_force(
    alpha: float,
    fz: float,
    peak: float,
    c_alpha0: float,
    fz0: float,
    c_y: float,
    e_y: float,
    load_exponent: float,
) -> float:
    """Pure-slip lateral force F_y (N) at slip angle ``alpha`` (rad), positive for alpha > 0.

    ``peak`` is D from :func:`friction_peak`; ``c_alpha0`` the per-tyre cornering stiffness
    (N/rad) at the nominal load ``fz0`` (N).
    """
    if fz <= 1.0 or peak <= 1e-9:
        return 0.0
    c_alpha = c_alpha0 * (fz / fz0) ** load_exponent
    b = c_alpha / (c_y * peak)
    ba = b * alpha
    return peak * math.sin(c_y * math.atan(ba - e_y * (ba - math.atan(ba))))


@njit(cache=True)
def combined_lateral(fy0: float, fx: float, peak: float) -> float:
    """Lateral force reduced by the friction ellipse for a longitudinal force ``fx`` (N)."""
    if peak <= 1e-9:
        return 0.0
    ratio = fx / peak
    rest = 1.0 - ratio * ratio
    if rest < 0.0:
        rest = 0.0
    return fy0 * math.sqrt(rest)


@njit(cache=True)
def longitudinal_slip(fx: float, fz: float, peak: float, c_x: float, slip_stiffness: float) -> float:
    """Longitudinal slip kappa (-) that the tyre needs to transmit ``fx`` (N), pre-peak branch."""
    if fz <= 1.0 or peak <= 1e-9:
        return 0.0
    ratio = fx / peak
    if ratio > 0.999:
        ratio = 0.999
    elif ratio < -0.999:
        ratio = -0.999
    bx = slip_stiffness * fz / (c_x * peak)
    return math.tan(math.asin(ratio) / c_x) / bx
