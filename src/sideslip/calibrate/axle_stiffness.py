"""Effective axle cornering stiffness, steering scale / offset, understeer gradient, slip gain K.

Definition (what is identified, and what the tests compare with the simulator's truth): the
*effective* cornering stiffness of an axle is the least-squares slope, through the origin, of
the axle's lateral force against its single-track slip angle over the drive's rows in the
linear range (``|f_y| < 0.4 g``)::

    alpha_f = delta - beta - lf r / v          F_yf = (m lr f_y + I_z r') / L
    alpha_r = lr r / v - beta                  F_yr = (m lf f_y - I_z r') / L

(seed 001 eq 1 read as force balance; ``f_y`` the lateral tyre force per mass in the road
plane).  It lumps what the linear single-track model leaves out: lateral load transfer (with
the Magic Formula's ``C_a ~ F_z^0.8`` the axle's slope falls as the load moves outwards), the
tyre curve's bending at larger slip, the friction ellipse of drive forces, compliance.  At zero
slip it equals the per-tyre ``C_a0`` of ``sideslip.simulate.tyre`` times two (the file's
nominal ``cf``/``cr``); on a drive it is a few per cent lower.  It is the stiffness a linear
estimator (mkf, kf_linear, fg_*) should be given.

Relations (all with the calibrated gyro ``r = (w_z - b_g) / s_g``, speed ``v = v_w / s_w``
and ``f_y = a_y,m / (1 + g k_phi)``, i.e. the accelerometer less the suspension roll's gravity
part; its bias is absorbed by the offsets):

1. Steering (no GNSS needed; kinematic relation with understeer, cf. ``r = v delta / (L +
   K_us v^2)``), on rows faster than 3 m/s, ``|f_y| < 0.4 g``, ``|r'| < 0.5 rad/s^2``::

       delta_m = s_d (atan(L r / v) + F_yf / cf - F_yr / cr) + delta_0

   with the measured steer ``delta_m = s_d delta + delta_0`` (``s_d`` = steer scale, measured /
   true).  Low speed (``atan(L r/v)``) tells ``s_d``, speed variety separates the understeer
   term ``K_us f_y = (m/L)(lr/cf - lf/cr) f_y`` from it, and ``r'`` transients the sum
   ``1/cf + 1/cr``.
2. Rear slip from GNSS (seed 000's ``beta_r = -K a_y``), on GNSS rows faster than 5 m/s::

       -atan(lr r / v - tan(nu - psi)) = -F_yr / cr + offset + slope t   (per 30 s window)

   ``nu`` the Doppler course at the CG, ``psi`` the calibrated gyro heading (its unknown
   offset and bias drift are the window's nuisance).

   A residual gyro scale error ``e`` turns the heading into ``psi (1 + e)``; ``e psi`` is a
   regressor with the gyro fit's 1-sigma as prior (the heading error grows through a turn, which
   a window's offset and slope cannot take).

Both are fitted together by Gauss-Newton on ``theta = [s_d, delta_0, 1/cf, 1/cr, e]`` with weak
priors from the file (steer scale 1 +- 0.1, offset 0 +- 3 deg, stiffness +-50 %), each relation
weighted by its own residual variance; 1-sigma from the cluster-robust covariance
(:mod:`sideslip.calibrate.fit`).  ``K = m lf / (L cr)`` (``Vehicle.slip_gain_k``).

Steering ratio: the ``steer`` column is the road-wheel angle, converted by the user from the
steering-wheel angle with the file's ratio: ``steer = delta_sw / R_file``.  With the true
ratio ``R`` the true road-wheel angle is ``delta_sw / R``, so ``s_d = R / R_file`` and the
corrected ratio is ``R = R_file s_d``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.fit import (
    INFORMED_SHARE,
    clusters_of,
    fit_linear,
    informed,
    project_windows,
    window_ids,
)
from sideslip.calibrate.prepare import (
    AY_LINEAR_MAX,
    RDOT_MAX,
    SMOOTH_S,
    STEER_GRID_S,
    V_STEER_MIN,
    Signals,
    derivative,
    moving_mean,
)
from sideslip.calibrate.result import Fitted, left_alone
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

WINDOW_S = 30.0  # s: nuisance window of the GNSS rear-slip relation
STEER_SCALE_PRIOR = 0.1  # prior 1-sigma of the steer scale, fraction
STEER_OFFSET_PRIOR = math.radians(3.0)  # prior 1-sigma of the steer offset, rad
STIFFNESS_PRIOR_REL = 0.5  # prior 1-sigma of 1/cf, 1/cr relative to the file's
GN_ITERATIONS = 8
# 1 - corr^2 of the kinematic and the tyre-force regressors of the steering relation below which
# the steer scale is not told apart from the understeer (one speed, one turn radius)
SEPARATION_MIN = 0.03
# a vehicle file's explicit understeer gradient is taken as a prior of this relative 1-sigma
# (a rough file's tyre data are 20-35 % off) plus a floor, rad/(m/s^2)
KUS_FILE_REL = 0.3
KUS_FILE_FLOOR = 3.0e-4
SCALE_FROM_GNSS_MAX = 0.012  # curvature-scale sigma below this: gyro / wheel scales came from GNSS
OUTLIER_SIGMAS = 5.0
# lateral accelerometer offset (bias ~0.05 m/s^2 plus roll misalignment 0.1 deg x g): it moves
# delta_0 by K_us times itself, which the drive cannot tell from a steering-sensor offset
AY_OFFSET_SIGMA = 0.06
# the vehicle's own straight-running steer (alignment, tyre ply steer / conicity) enters the
# offset like the sensor's and cannot be told from it: an allowance of 0.015 deg road wheel
STEER_OFFSET_FLOOR = math.radians(0.015)
MIN_ROWS = 50


@dataclass(frozen=True)
class SensorCal:
    """Sensor calibration the relations use: gyro bias (rad/s) and scale, wheel scale, roll
    gradient (rad/(m/s^2)), the relative 1-sigma of the curvature scale s_w / s_g and of the
    gyro scale (the prior of the heading-scale term of the rear-slip relation), and of the
    tyre-force scale ``1 / (1 + g k_phi)`` (from the roll gradient's 1-sigma)."""

    gyro_bias: float
    gyro_scale: float
    wheel_scale: float
    roll_gradient: float
    curvature_scale_sigma: float
    gyro_scale_sigma: float
    force_scale_sigma: float


def _steer_rows(sig: Signals, vehicle: Vehicle, cal: SensorCal) -> dict[str, FloatArray] | None:
    if sig.steer is None:
        return None
    dtm = float(np.median(np.diff(sig.t))) if sig.t.size > 1 else 1.0
    step = max(1, round(STEER_GRID_S / max(dtm, 1e-6)))
    r_all = (sig.wz - cal.gyro_bias) / cal.gyro_scale
    rdot_all = derivative(sig.t, np.nan_to_num(r_all))
    idx = np.arange(0, sig.t.size, step)
    v = sig.speed[idx] / cal.wheel_scale
    r = r_all[idx]
    rdot = rdot_all[idx]
    if sig.ay is not None:
        fy = sig.ay[idx] / (1.0 + G * cal.roll_gradient)
    else:
        fy = v * r
    use = (
        np.isfinite(v) & np.isfinite(r) & np.isfinite(fy) & np.isfinite(sig.steer[idx])
        & (v > V_STEER_MIN) & (np.abs(np.nan_to_num(fy, nan=99.0)) < AY_LINEAR_MAX)
        & (np.abs(rdot) < RDOT_MAX) & ~sig.standstill[idx]
    )  # fmt: skip
    if use.sum() < MIN_ROWS:
        return None
    L = vehicle.wheelbase
    iz = vehicle.yaw_inertia if math.isfinite(vehicle.yaw_inertia) else 0.0
    fy, r, rdot, v = fy[use], r[use], rdot[use], v[use]
    return {
        "t": sig.t[idx][use],
        "y": sig.steer[idx][use],
        "kin": np.arctan(L * r / v),
        "ff": (vehicle.mass * vehicle.lr * fy + iz * rdot) / L,
        "fr": (vehicle.mass * vehicle.lf * fy - iz * rdot) / L,
        "v": v,
        "a": np.abs(fy),
        "step": np.full(1, float(step)),
    }


def _rear_rows(sig: Signals, vehicle: Vehicle, cal: SensorCal) -> dict[str, FloatArray] | None:
    if not sig.has_gnss:
        return None
    rows = sig.g_rows
    tg = sig.t[rows]
    psi = (sig.yaw_int[rows] - cal.gyro_bias * sig.t[rows]) / cal.gyro_scale
    beta = sig.g_course - psi
    if sig.g_dt < SMOOTH_S:
        beta = moving_mean(tg, beta, SMOOTH_S)
    r_all = (sig.wz - cal.gyro_bias) / cal.gyro_scale
    rdot = derivative(sig.t, np.nan_to_num(r_all))[rows]
    r = r_all[rows]
    v = sig.g_speed
    fy = sig.ay[rows] / (1.0 + G * cal.roll_gradient) if sig.ay is not None else sig.g_ay
    use = (
        sig.g_valid & np.isfinite(beta) & np.isfinite(r) & np.isfinite(fy)
        & (np.abs(np.nan_to_num(fy, nan=99.0)) < AY_LINEAR_MAX) & (np.abs(rdot) < RDOT_MAX)
    )  # fmt: skip
    win = window_ids(tg, use, WINDOW_S, 2.5 * sig.g_dt)
    sel = win >= 0
    if sel.sum() < MIN_ROWS:
        return None
    iz = vehicle.yaw_inertia if math.isfinite(vehicle.yaw_inertia) else 0.0
    L = vehicle.wheelbase
    # exact rear slip: alpha_r = atan(lr r / v - tan(beta)); y = -alpha_r = -F_yr / cr
    y = -np.arctan(vehicle.lr * r[sel] / v[sel] - np.tan(beta[sel]))
    fr = (vehicle.mass * vehicle.lf * fy[sel] - iz * rdot[sel]) / L
    # a gyro scale error e = s_g,true / s_g - 1 adds e (psi - psi_0) to beta: a regressor
    P = project_windows(win[sel], tg[sel], np.column_stack([y, fr, psi[sel]]))
    return {
        "t": tg[sel], "y": P[:, 0], "fr": P[:, 1], "psi": P[:, 2], "win": win[sel], "v": v[sel],
        "a": np.abs(fy[sel]),
    }  # fmt: skip


def _residuals(
    theta: FloatArray, s: dict[str, FloatArray] | None, g: dict[str, FloatArray] | None
) -> tuple[list[FloatArray], list[FloatArray]]:
    """Residuals of each relation and minus their Jacobians (so that ``res ~ J d_theta``)."""
    sd, d0, wf, wr, eps = theta
    parts_r, parts_J = [], []
    if s is not None:
        inner = s["kin"] + wf * s["ff"] - wr * s["fr"]
        parts_r.append(s["y"] - (sd * inner + d0))
        J = np.column_stack([inner, np.ones_like(inner), sd * s["ff"], -sd * s["fr"], 0.0 * inner])
        parts_J.append(J)
    if g is not None:
        parts_r.append(g["y"] + wr * g["fr"] - eps * g["psi"])
        J = np.zeros((g["y"].size, 5))
        J[:, 3] = -g["fr"]
        J[:, 4] = g["psi"]
        parts_J.append(J)
    return parts_r, parts_J


def _gauss_newton(
    s: dict[str, FloatArray] | None,
    g: dict[str, FloatArray] | None,
    prior_mean: FloatArray,
    prior_sd: FloatArray,
    robust: bool,
    extra: tuple[FloatArray, float, float] | None = None,
) -> tuple[FloatArray, FloatArray, int, dict[str, FloatArray] | None, dict[str, FloatArray] | None]:
    """Gauss-Newton on both relations; returns theta, cov, clusters and the rows kept.

    ``extra = (a, value, sigma)``: a prior on the linear quantity ``a' theta`` (the file's own
    understeer gradient), one pseudo-row weighted by ``1 / sigma^2``.
    """
    theta = np.where(np.isfinite(prior_mean), prior_mean, 0.0).astype(float)
    cov = np.diag(np.where(np.isfinite(prior_sd), prior_sd**2, 0.0))
    clusters = 0
    for it in range(GN_ITERATIONS):
        res, J = _residuals(theta, s, g)
        if robust and it == 1:  # after one step: drop outliers (multipath, kerbs) per relation
            masks = []
            for rr in res:
                mad = 1.4826 * float(np.median(np.abs(rr - np.median(rr))))
                masks.append(np.abs(rr - np.median(rr)) <= OUTLIER_SIGMAS * max(mad, 1e-12))
            k = 0
            if s is not None:
                s = _subset(s, masks[k])
                k += 1
            if g is not None:
                g = _subset(g, masks[k])
            res, J = _residuals(theta, s, g)
        if sum(rr.size for rr in res) < MIN_ROWS:
            break
        # each relation weighted by its own residual variance (both in rad)
        sig2 = [max(float(np.mean(rr**2)), 1e-14) for rr in res]
        if extra is not None:
            res.append(np.array([extra[1] - float(extra[0] @ theta)]))
            J.append(extra[0][None, :])
            sig2.append(extra[2] ** 2)
        weights = np.concatenate([np.full(rr.size, 1.0 / v2) for rr, v2 in zip(res, sig2, strict=True)])
        cl_parts = []
        offset = 0
        if s is not None:
            c = clusters_of(s["t"])
            cl_parts.append(c + offset)
            offset += int(c.max()) + 1 if c.size else 0
        if g is not None:
            c = clusters_of(g["t"], segment=g["win"].astype(np.intp))
            cl_parts.append(c + offset)
            offset += int(c.max()) + 1 if c.size else 0
        if extra is not None:
            cl_parts.append(np.array([offset], dtype=np.intp))
        fit = fit_linear(
            np.vstack(J), np.concatenate(res), np.concatenate(cl_parts), prior_mean - theta, prior_sd, weights
        )
        theta = theta + fit.theta
        cov, clusters = fit.cov, fit.clusters
        if np.max(np.abs(fit.theta) / np.where(np.isfinite(prior_sd), prior_sd, 1.0)) < 1e-6:
            break
    return theta, cov, clusters, s, g


def _subset(rows: dict[str, FloatArray], mask: NDArray[np.bool_]) -> dict[str, FloatArray]:
    return {key: (val[mask] if val.size == mask.size else val) for key, val in rows.items()}


def _split(
    rows: dict[str, FloatArray] | None, key: str, split: float, low: bool
) -> dict[str, FloatArray] | None:
    if rows is None:
        return None
    mask = rows[key] < split if low else rows[key] >= split
    return _subset(rows, mask) if mask.sum() >= MIN_ROWS else None


def _separation(s: dict[str, FloatArray] | None) -> float:
    """1 - corr^2 of the kinematic and tyre-force regressors (0: steer scale and understeer
    cannot be told apart)."""
    if s is None or s["y"].size < 3:
        return 0.0
    if not (np.std(s["kin"]) > 0.0 and np.std(s["ff"]) > 0.0):
        return 0.0  # a constant regressor (straight driving): nothing to tell apart
    c = float(np.corrcoef(s["kin"], s["ff"])[0, 1])
    return 1.0 - c * c if np.isfinite(c) else 0.0


def _excited(s: dict[str, FloatArray] | None) -> bool:
    """Steering rows with turns (95th percentile |f_y| above 1 m/s^2) at varied operating points."""
    if s is None or s["y"].size < MIN_ROWS:
        return False
    return bool(np.percentile(s["a"], 95) > 1.0 and _separation(s) > SEPARATION_MIN)


def fit_axles(sig: Signals, vehicle: Vehicle, cal: SensorCal) -> list[Fitted]:
    """Identify steer scale/offset, cf, cr, K_us, K (see the module docstring).

    The 1-sigma adds the *operating-point spread*: the same fit on the rows below and above
    the median speed, and below and above the median |f_y|; where two halves differ by more
    than their noise, half the excess (the larger of the two splits; a half whose own
    1-sigma is above half the prior's does not count)
    (``var_sys = ((a' d)^2 - a' (C_lo + C_hi) a) / 4`` for a quantity ``a' theta``) is added, as
    the effective stiffness of real tyres depends on where it is measured.  When the steering
    rows cannot tell the steer scale from the understeer (one operating point, ``1 - corr^2``
    of the two regressors below ``SEPARATION_MIN``), the other parameters carry the spread of
    refits with the scale pinned at its prior +- 1-sigma.
    """
    s = _steer_rows(sig, vehicle, cal)
    g = _rear_rows(sig, vehicle, cal)
    cf0 = vehicle.cf if math.isfinite(vehicle.cf) else math.nan
    cr0 = vehicle.cr if math.isfinite(vehicle.cr) else math.nan
    prior_mean = np.array([1.0, 0.0, 1.0 / cf0 if cf0 > 0 else 0.0, 1.0 / cr0 if cr0 > 0 else 0.0, 0.0])
    prior_sd = np.array([
        STEER_SCALE_PRIOR, STEER_OFFSET_PRIOR,
        STIFFNESS_PRIOR_REL / cf0 if cf0 > 0 else math.inf,
        STIFFNESS_PRIOR_REL / cr0 if cr0 > 0 else math.inf,
        max(cal.gyro_scale_sigma, 1e-4),
    ])  # fmt: skip
    if s is None and g is None:
        return _nothing(vehicle, "too few rows in the linear range (steer, speed, yaw rate)")
    separation = _separation(s)  # before outliers are dropped (dropping can fake variety)
    extra = None
    if math.isfinite(vehicle.understeer_gradient_given):
        # the file's own understeer gradient is information too: a prior of 30 % (rough files)
        kus_file = vehicle.understeer_gradient_given
        a_kus = (
            np.array([0.0, 0.0, vehicle.mass * vehicle.lr, -vehicle.mass * vehicle.lf, 0.0])
            / vehicle.wheelbase
        )
        extra = (a_kus, kus_file, KUS_FILE_REL * abs(kus_file) + KUS_FILE_FLOOR)
    theta, cov, clusters, s, g = _gauss_newton(s, g, prior_mean, prior_sd, True, extra)
    separation = min(separation, _separation(s))
    halves = []
    for key in ("v", "a"):  # speed, then lateral acceleration
        split = float(np.median(np.concatenate([x[key] for x in (s, g) if x is not None])))
        parts = [(_split(s, key, split, low), _split(g, key, split, low)) for low in (True, False)]
        if not all(_excited(ps) for ps, _pg in parts):
            continue  # a half of straight driving or one operating point tells nothing to compare
        lo = _gauss_newton(parts[0][0], parts[0][1], prior_mean, prior_sd, False, extra)
        hi = _gauss_newton(parts[1][0], parts[1][1], prior_mean, prior_sd, False, extra)
        if lo[2] >= 4 and hi[2] >= 4:
            halves.append((lo, hi))

    prior_var = np.where(np.isfinite(prior_sd), prior_sd, 1e6) ** 2

    def sys_var(a: FloatArray) -> float:
        out = 0.0
        a_prior = float(np.sqrt(a**2 @ prior_var))
        for lo, hi in halves:
            s_lo, s_hi = float(np.sqrt(a @ lo[1] @ a)), float(np.sqrt(a @ hi[1] @ a))
            if max(s_lo, s_hi) > INFORMED_SHARE * a_prior:
                continue  # a half that barely tells the quantity shows its prior, not a spread
            d = float(a @ (lo[0] - hi[0]))
            out = max(out, max(0.0, d * d - s_lo**2 - s_hi**2) / 4.0)
        return out

    n_s = int(s["y"].size * s["step"][0]) if s is not None else 0
    n_g = int(g["y"].size) if g is not None else 0
    separable = separation > SEPARATION_MIN
    if not separable and s is not None:
        # the drive cannot tell the steer scale from the understeer: the other parameters are
        # refitted with the scale pinned at +- its prior 1-sigma, and half the spread is added
        shifted = []
        for sign in (-1.0, 1.0):
            pm, ps = prior_mean.copy(), prior_sd.copy()
            pm[0], ps[0] = theta[0] + sign * STEER_SCALE_PRIOR, 1e-6
            shifted.append(_gauss_newton(s, g, pm, ps, False, extra)[0])
        d = 0.5 * (shifted[1] - shifted[0])
        d[0] = 0.0
        cov = cov + np.outer(d, d)
    return _results(vehicle, theta, cov, sys_var, prior_sd, n_s, n_g, clusters, cal, separable)


def _nothing(vehicle: Vehicle, why: str) -> list[Fitted]:
    return [
        left_alone("steer_scale", 1.0, "-", why),
        left_alone("steer_offset_rad", 0.0, "rad", why),
        left_alone("cf", vehicle.cf, "N/rad", why, "cf"),
        left_alone("cr", vehicle.cr, "N/rad", why, "cr"),
        left_alone(
            "understeer_gradient", vehicle.understeer_gradient, "rad/(m/s^2)", why, "understeer_gradient"
        ),
        left_alone("slip_gain_k_s2_m", vehicle.slip_gain_k, "s^2/m", why),
        left_alone("steering_ratio", vehicle.steering_ratio, "-", why, "steering_ratio"),
    ]


def _results(
    vehicle: Vehicle,
    theta: FloatArray,
    cov: FloatArray,
    sys_var: Callable[[FloatArray], float],
    prior_sd: FloatArray,
    n_s: int,
    n_g: int,
    clusters: int,
    cal: SensorCal,
    separable: bool,
) -> list[Fitted]:
    m, lf, lr, L = vehicle.mass, vehicle.lf, vehicle.lr, vehicle.wheelbase
    eye = np.eye(theta.size)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0) + np.array([sys_var(e) for e in eye]))
    src_s = "steering relation (v > 3 m/s, |f_y| < 0.4 g, |r'| < 0.5 rad/s^2)"
    src_g = "GNSS rear slip (course - gyro heading, v > 5 m/s, |f_y| < 0.4 g)"
    enough = clusters >= 4
    out: list[Fitted] = []
    # steer scale: the curvature r/v carries the gyro / wheel scale uncertainty
    sd_scale = math.hypot(float(sd[0]), float(theta[0]) * cal.curvature_scale_sigma)
    note_s = (
        ""
        if cal.curvature_scale_sigma < SCALE_FROM_GNSS_MAX
        else ("relative to gyro and wheel scales taken as 1 (no GNSS to tell them)")
    )
    if n_s and enough and separable and informed(sd_scale, STEER_SCALE_PRIOR):
        out.append(Fitted("steer_scale", float(theta[0]), sd_scale, n_s, src_s, True, "-", 1.0, None, note_s))
    else:
        why = (
            "no steering rows at varied speeds"
            if separable or not n_s
            else ("one operating point: the steer scale cannot be told from the understeer")
        )
        out.append(left_alone("steer_scale", 1.0, "-", why))
    kus_now = float(np.array([0.0, 0.0, m * lr / L, -m * lf / L, 0.0]) @ theta)
    sd_d0 = math.sqrt(float(sd[1]) ** 2 + (kus_now * AY_OFFSET_SIGMA) ** 2 + STEER_OFFSET_FLOOR**2)
    if n_s and enough and informed(sd_d0, STEER_OFFSET_PRIOR):
        out.append(
            Fitted(
                "steer_offset_rad",
                float(theta[1]),
                sd_d0,
                n_s,
                src_s,
                True,
                "rad",
                0.0,
                None,
                "includes K_us times the accelerometer's lateral bias",
            )
        )
    else:
        out.append(left_alone("steer_offset_rad", 0.0, "rad", "no steering rows"))
    srcs = " + ".join(x for x, n in ((src_s, n_s), (src_g, n_g)) if n)
    for k, key, n_rows in ((2, "cf", n_s), (3, "cr", n_s + n_g)):
        w, w_sd = float(theta[k]), float(sd[k])
        before = getattr(vehicle, key)
        w_sd = math.hypot(w_sd, w * cal.force_scale_sigma)
        if enough and w > 0 and informed(w_sd, float(prior_sd[k])) and 1e3 <= 1.0 / w <= 5e6:
            out.append(
                Fitted(
                    key,
                    1.0 / w,
                    w_sd / w**2,
                    n_rows,
                    srcs,
                    True,
                    "N/rad",
                    before,
                    key,
                    "effective axle stiffness (linear range, load transfer included)",
                )
            )
        else:
            out.append(
                left_alone(
                    key,
                    before,
                    "N/rad",
                    "the drive separates only the understeer combination" if n_s else "no rows to tell it",
                    key,
                )
            )
    # understeer gradient K_us = m/L (lr wf - lf wr)
    grad = np.array([0.0, 0.0, m * lr / L, -m * lf / L, 0.0])
    kus = float(grad @ theta)
    kus_sd = float(
        math.sqrt(max(grad @ cov @ grad, 0.0) + sys_var(grad) + (kus * cal.force_scale_sigma) ** 2)
    )
    prior_kus = math.hypot(*(grad[2:4] * np.where(np.isfinite(prior_sd[2:4]), prior_sd[2:4], 1.0)))
    if n_s and enough and informed(kus_sd, prior_kus) and abs(kus) < 0.05:
        out.append(
            Fitted(
                "understeer_gradient",
                kus,
                kus_sd,
                n_s,
                src_s,
                True,
                "rad/(m/s^2)",
                vehicle.understeer_gradient,
                "understeer_gradient",
                "per lateral tyre force f_y",
            )
        )
    else:
        out.append(
            left_alone(
                "understeer_gradient",
                vehicle.understeer_gradient,
                "rad/(m/s^2)",
                "no steering rows at varied lateral acceleration",
                "understeer_gradient",
            )
        )
    cr_fit = out[3]
    if cr_fit.informed:
        kk = m * lf / (L * cr_fit.value)
        out.append(
            Fitted(
                "slip_gain_k_s2_m",
                kk,
                kk * cr_fit.sigma / cr_fit.value,
                cr_fit.rows,
                cr_fit.source,
                True,
                "s^2/m",
                vehicle.slip_gain_k,
                None,
                "K = m lf / (L cr), seed 000",
            )
        )
    else:
        out.append(left_alone("slip_gain_k_s2_m", vehicle.slip_gain_k, "s^2/m", "cr not identified"))
    st = out[0]
    if st.informed and math.isfinite(vehicle.steering_ratio):
        ratio = vehicle.steering_ratio * st.value
        out.append(
            Fitted(
                "steering_ratio",
                ratio,
                vehicle.steering_ratio * st.sigma,
                st.rows,
                "file ratio x steer scale",
                True,
                "-",
                vehicle.steering_ratio,
                "steering_ratio",
                "steer = wheel angle / file ratio, so true ratio = file ratio x steer scale",
            )
        )
    else:
        why = "the file gives no steering ratio to correct" if st.informed else "steer scale not identified"
        out.append(left_alone("steering_ratio", vehicle.steering_ratio, "-", why, "steering_ratio"))
    return out
