"""The rear stiffness ``fused`` learned, checked against a straight line through its own slip.

``fused`` learns the rear axle's stiffness as a scale ``s_r`` of the vehicle file's ``C_r`` in
the brush curve (:mod:`sideslip.models.axle_force`): the curve's slope at zero slip, with the
curve bending towards ``mu F_z`` above it.  Its 1-sigma from the smoother (the last node's
variance) holds the noise of the relation's updates only, as if the brush curve were the
tyre; a real axle's curve bends differently (Magic Formula, load transfer, compliance), and
the smoother then moves ``s_r`` to wherever the curve's bend fits the drive's forces, which
the formal sigma does not carry.  Measured on the comparison's 16 scenarios (seed 0, right
and 30 %-soft files), against the reference of :mod:`sideslip.calibrate.truth`: with GNSS
Doppler half the scales were more than 2 sigma off (race_lap 0.902 +- 0.017 against 0.733,
cr_limit_slalom 0.693 +- 0.045 against 1.006).

The check: the secant ``s_sec``, the slope through the origin of the rear-axle force per
mass against the rear slip angle of the estimate itself, over the file's ``C_r / m``, on the
rows the reference uses (faster than ``V_MIN``, ``|f_y|`` below ``FY_MAX``, ``|r'|`` below
``RDOT_MAX``; :mod:`sideslip.calibrate.truth`) where the axle force exceeds the learning
threshold (``FusedSettings.stiffness_curve_accel``: nearer zero a noisy regressor biases a
slope).  It is what a linear single-track model (``fg_batch``, the observers, ``mkf``) takes
from this drive.  Where the tyre curve fits, the two agree; where they differ, the
difference is how much the stiffness depends on the curve assumed (model-form uncertainty),
and it enters the reported sigma: ``hypot(sigma_formal, |s_r - s_sec|)``.  A drive without
``MIN_SECONDS`` of such rows keeps the formal sigma and says so.

Without GNSS Doppler a second check: nothing but the tyre relation and the lateral
kinematics pin ``v_y`` there, so on a drive without lateral transients the scale is barely
the drive's at all, yet the smoother's sigma shrinks as if it were (urban_course without GNSS,
file 30 % soft: 1.005 +- 0.105 against 1.419; with the right file 0.916: the estimate follows
the file, not the tyres).  The estimator is run once more with the scale's prior mean moved by
``PRIOR_SHIFT``; the share of the shift the estimate keeps is, for a linear-Gaussian
posterior, ``sigma_post^2 / sigma_prior^2`` (the posterior mean's derivative by the prior
mean), so ``sigma_prior sqrt(share)`` is the sigma the drive's information actually gives, and
it replaces the formal sigma where it is larger.  A scale held at a bound of its range
(``SCALE_MIN`` / ``SCALE_MAX`` of :mod:`sideslip.models.fused_measurements`: the relation
asked for beyond it) is no estimate, and its sigma is at least the prior's.  Reported:
``rear_stiffness_scale_sigma = hypot(max(sigma_formal, sigma_prior sqrt(share)), |s_r - s_sec|)``
(``fused_filter``: its last node's scale and sigma, the secant over its own causal slip).
Measured by ``benchmarks/stiffness_sigma.py``.

The rear slip angle is ``atan(l_r r / v_x - tan(beta))`` (CG sideslip moved to the rear
axle) and the force ``(l_f f_y - (I_z / m) r') / L`` (the single track's force and moment
balance, seed 003 eqs 1-2), ``f_y`` the low-passed lateral force per mass ``fused``'s axle
relation uses and ``r'`` the rate of the estimate's yaw rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sideslip.vehicle import G

FloatArray = NDArray[np.float64]

V_MIN = 5.0  # m/s: the reference's speed gate (sideslip.calibrate.truth)
FY_MAX = 0.4 * G  # m/s^2: the reference's force range
RDOT_MAX = 0.5  # rad/s^2: the reference's yaw-acceleration gate
MIN_SECONDS = 2.0  # s of rows below which the drive gives no secant
PRIOR_SHIFT = 0.25  # the prior-sensitivity run's move of the scale's prior mean (half its sigma)


@dataclass(frozen=True)
class RearSecant:
    """The secant scale ``scale`` (of the file's ``C_r``) from ``seconds`` of rows."""

    scale: float
    seconds: float


def rear_secant(
    t: FloatArray,
    beta: FloatArray,
    r: FloatArray,
    vx: FloatArray,
    f_y: FloatArray,
    geometry: tuple[float, float, float, float],
    min_force: float,
) -> RearSecant | None:
    """The secant of the module docstring; ``geometry = (l_f, l_r, I_z / m, C_r / m)`` (m, m,
    m^2, m/s^2 per rad), ``f_y`` in m/s^2, ``min_force`` the learning threshold (m/s^2).
    None where the drive has under ``MIN_SECONDS`` of rows."""
    lf, lr, iz_m, cr_m = geometry
    if t.size < 3 or not cr_m > 0.0:
        return None
    r_dot = np.gradient(r, t)
    f_rear = (lf * f_y - iz_m * r_dot) / (lf + lr)
    fast = np.isfinite(beta) & np.isfinite(r) & np.isfinite(f_rear) & (vx > V_MIN)
    rows = fast & (np.abs(f_y) < FY_MAX) & (np.abs(r_dot) < RDOT_MAX) & (np.abs(f_rear) > min_force)
    seconds = float(np.sum(np.gradient(t)[rows]))
    if seconds < MIN_SECONDS:
        return None
    alpha = np.arctan(lr * r[rows] / vx[rows] - np.tan(beta[rows]))
    denom = float(alpha @ alpha)
    if not denom > 0.0:
        return None
    return RearSecant(float(alpha @ f_rear[rows] / denom / cr_m), seconds)


def prior_share(scale: float, scale_shifted: float) -> float:
    """Share (0-1) of the prior mean's move ``PRIOR_SHIFT`` that the estimate kept: 0 where
    the drive alone decides the scale, 1 where the prior does."""
    return min(abs(scale_shifted - scale) / PRIOR_SHIFT, 1.0)


def model_form_params(
    scale: float,
    sigma_formal: float,
    secant: RearSecant | None,
    prior: tuple[float, float] | None = None,
    held_sigma: float | None = None,
) -> dict[str, Any]:
    """The params ``fused`` reports for its rear stiffness beyond the scale itself: the
    formal sigma, the secant, the prior check's share (``prior = (share, prior sigma)``, None
    where it did not run) and the sigma with both terms (module docstring).  ``held_sigma``:
    the scale is held at a bound of its range (the relation asked for more or less), so it is
    no estimate, and its sigma is at least this (the prior's)."""
    out: dict[str, Any] = {"rear_stiffness_scale_sigma_formal": sigma_formal}
    sigma = sigma_formal
    if prior is not None:
        share, prior_sigma = prior
        out["rear_stiffness_scale_prior_share"] = share
        sigma = max(sigma, prior_sigma * math.sqrt(share))
    if held_sigma is not None:
        sigma = max(sigma, held_sigma)
    if secant is None or not math.isfinite(secant.scale):
        out["rear_stiffness_scale_sigma"] = sigma
        out["rear_stiffness_scale_secant"] = None
        out["rear_stiffness_scale_secant_note"] = (
            f"under {MIN_SECONDS:g} s of rear-axle force beyond the learning threshold below "
            f"{FY_MAX / G:.1f} g: no secant, no model-form term in the sigma"
        )
        return out
    out["rear_stiffness_scale_sigma"] = math.hypot(sigma, scale - secant.scale)
    out["rear_stiffness_scale_secant"] = secant.scale
    out["rear_stiffness_scale_secant_seconds"] = secant.seconds
    return out
