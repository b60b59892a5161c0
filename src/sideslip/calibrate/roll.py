"""Suspension roll gradient and the IMU's yaw / roll mounting misalignment.

Accelerometer model (``sideslip.simulate.sensors``; ISO axes, roll right-side-down positive):
a body rolled by ``phi = bank + phi_s`` reads ``a_y,m = a_y + g sin(phi) - psi_m a_x + b_y`` and
``a_x,m = a_x - g sin(theta) + psi_m a_y + b_x`` (``theta = -grade + pitch_s``, the grade from
the vertical Doppler) with ``psi_m`` the yaw misalignment, and
``a_z,m = g cos(phi) - a_y sin(phi) - phi_m a_y + b_z`` with ``phi_m`` the roll misalignment;
the gyro reads ``w_y,m = theta' + r sin(phi) + phi_m r + b_wy``.

Roll gradient ``k_phi`` (rad per m/s^2 of lateral tyre force per mass, steady state
``phi_s = k_phi f_y``; seed 003 eq 43 gives ``m h / k``, the truth model's
``m h / (k - m g h)`` adds the gravity moment): from GNSS rows in the linear, quasi-steady range,
``(a_y,m - a_y,kin) = g k_phi a_y,kin - psi_m a_x,kin + offset`` with ``a_y,kin = |v| d(course)/dt``,
``a_x,kin = d|v|/dt`` and an offset and slope per ``WINDOW_S`` window (accelerometer bias, roll
misalignment, crossfall).  Assumes the road's bank does not follow the turns: superelevated
curves add ``g bank / a_y`` to ``g k_phi`` (flagged in the note, not detectable here).
A road whose bank varies (seen on its straights, where ``a_y,m - a_y,kin = g bank``) widens
the 1-sigma by what that variation could add if it followed the turns (:func:`_bank_allowance`).
A fit outside 0.0005-0.05 rad/(m/s^2) is no suspension's (a bank that follows the turns,
e.g. a banked track turn, drives it negative) and is rejected.  Left and right turns, and the
rows of small and larger lateral jerk (roll lags a fast a_y), are also fitted apart; where they
disagree beyond their noise (a bank that changes with the turns, roll dynamics), half the
excess is added to the 1-sigma.
The same GNSS rows give ``psi_m`` twice (the a_y and a_x relations), averaged by their variances.

Roll misalignment ``phi_m``: ``a_z,m = -(phi_m + bank) a_y - k_phi a_y^2 + offset`` and
``w_y,m = (phi_m + bank) r + k_phi v r^2 + offset`` on rows faster than 5 m/s with ``a_y = v r``
(per window), averaged by their variances.  The road's bank in the turns enters exactly like
the misalignment (both roll the sensor), so its 1-sigma carries ``CROSSFALL_SIGMA`` and it is
left at 0 (with the measured sensor roll in the note) unless that is small against the prior.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.fit import (
    clusters_of,
    fit_robust,
    informed,
    project_windows,
    window_ids,
)
from sideslip.calibrate.prepare import (
    AY_LINEAR_MAX,
    JERK_MAX,
    RATE_S,
    SMOOTH_S,
    STEER_GRID_S,
    V_GNSS_MIN,
    Signals,
    derivative,
    moving_mean,
)
from sideslip.calibrate.result import Fitted, left_alone
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

WINDOW_S = 30.0  # s: nuisance window (offset + slope) of the roll relations
ROLL_PRIOR_REL = 0.5  # prior 1-sigma of the file's roll gradient, fraction
ROLL_SIGMA_ABS = 0.002  # rad/(m/s^2): without a file value, "informed" means sigma below this
MISALIGN_PRIOR = math.radians(2.0)  # prior 1-sigma of a mounting misalignment, rad
MIN_CLUSTERS = 4
# plausible suspension roll gradients, rad/(m/s^2): a body rolls outwards (> 0); 0.05 is ~28 deg/g
ROLL_GRADIENT_MIN = 0.0005
ROLL_GRADIENT_MAX = 0.05
LR_MIN_ROWS = 20  # rows beyond 1 m/s^2 each way for the left / right check
STRAIGHT_AY = 0.3  # m/s^2: straight rows for the bank-variation allowance
GNSS_DT_MAX = 0.5  # s: the roll relation needs GNSS at 2 Hz or faster (quasi-steady a_y over 2 epochs)
# The roll misalignment and the road's bank in turns enter every relation together (the sensor
# sees bank + suspension roll + misalignment).  Road crossfall is 1-3 deg (drainage), so the
# misalignment's 1-sigma includes 2 deg of unknown mean bank: it is "informed" only when a
# user's drive is on level ground, which the drive itself cannot show.
CROSSFALL_SIGMA = math.radians(2.0)


def file_roll_gradient(vehicle: Vehicle) -> float:
    """Steady-state roll per lateral specific force the file implies, m h / (k - m g h)."""
    if vehicle.missing(["mass", "cg_height", "roll_axis_height", "roll_stiffness"]):
        return math.nan
    h = vehicle.cg_height - vehicle.roll_axis_height
    denom = vehicle.roll_stiffness - vehicle.mass * G * h
    return vehicle.mass * h / denom if denom > 0 else math.nan


def _combine(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    wa, wb = 1.0 / a[1] ** 2, 1.0 / b[1] ** 2
    return (wa * a[0] + wb * b[0]) / (wa + wb), 1.0 / math.sqrt(wa + wb)


def _bank_allowance(y: FloatArray, a: FloatArray, window: NDArray[np.intp]) -> float:
    """1-sigma (rad/(m/s^2)) a varying road bank may add to the roll gradient.

    On straight rows ``y = a_y,m - a_y,kin`` is ``g bank`` plus a constant: the spread of its
    per-window means (robust, 1.4826 MAD) is the road's bank variation ``sigma_b`` (rad).  A
    bank that changes with the turns moves the slope by up to ``sigma_b / rms(a_y)``; over
    ``N`` independent turning windows it averages as ``1 / sqrt(N)``.
    """
    g = int(window.max()) + 1 if window.size else 0
    if g == 0:
        return 0.0
    straight = np.abs(a) < STRAIGHT_AY
    cnt = np.bincount(window[straight], minlength=g)
    mean = np.bincount(window[straight], weights=y[straight], minlength=g) / np.maximum(cnt, 1)
    m = mean[cnt >= 10]
    turning = np.abs(a) > 1.0
    n_turn = int(np.sum(np.bincount(window[turning], minlength=g) >= 5))
    if m.size < 3 or n_turn == 0:
        return 0.0
    sigma_b = 1.4826 * float(np.median(np.abs(m - np.median(m)))) / G
    rms_a = float(np.sqrt(np.mean(a[turning] ** 2)))
    return sigma_b / rms_a / math.sqrt(n_turn)


def roll_from_gnss(sig: Signals, vehicle: Vehicle) -> tuple[Fitted, tuple[float, float, int] | None]:
    """Roll gradient (Fitted) and the yaw misalignment (value, sigma, rows) from GNSS rows."""
    name, unit = "roll_gradient_rad_per_m_s2", "rad/(m/s^2)"
    before = file_roll_gradient(vehicle)
    if not sig.has_gnss or sig.ay is None or sig.g_dt > GNSS_DT_MAX:
        why = (
            "no GNSS Doppler" if not sig.has_gnss else "no ay column" if sig.ay is None
            else f"GNSS every {sig.g_dt:.1f} s is too slow to follow turn entries"
        )  # fmt: skip
        return left_alone(name, before, unit, f"{why}: the roll gradient is not observable"), None
    rows = sig.g_rows
    tg = sig.t[rows]
    ay_kin = sig.g_ay
    ax_kin = sig.g_ax
    jerk = derivative(tg, np.nan_to_num(ay_kin))
    use = (
        sig.g_valid
        & np.isfinite(sig.ay[rows])
        & (np.abs(np.nan_to_num(ay_kin, nan=99.0)) < AY_LINEAR_MAX)
        & (np.abs(jerk) < JERK_MAX)
    )
    win = window_ids(tg, use, WINDOW_S, 2.5 * sig.g_dt)
    sel = win >= 0
    if sel.sum() < 50:
        return left_alone(name, before, unit, "too few GNSS rows in the linear range"), None
    tw, w = tg[sel], win[sel]
    # the kinematic a_y is a centred difference over `span`: the same box on the accelerometer
    span = max(RATE_S, 2.0 * sig.g_dt)
    ay_m = moving_mean(sig.t, sig.ay, span)[rows] if sig.g_dt > SMOOTH_S else sig.ay[rows]
    ax_m = (
        (moving_mean(sig.t, sig.ax, span)[rows] if sig.g_dt > SMOOTH_S else sig.ax[rows])
        if sig.ax is not None
        else None
    )
    ya = ay_m[sel] - ay_kin[sel]
    Xa = np.column_stack([ay_kin[sel], ax_kin[sel]])
    P = project_windows(w, tw, np.column_stack([ya, Xa]))
    cl = clusters_of(tw, segment=w)
    prior_k = before if math.isfinite(before) else 0.0
    prior_sd_k = ROLL_PRIOR_REL * before if math.isfinite(before) else math.inf
    fit, keep = fit_robust(
        P[:, 1:], P[:, 0], cl, np.array([G * prior_k, 0.0]), np.array([G * prior_sd_k, G * MISALIGN_PRIOR])
    )
    sd = fit.sigma()
    k_phi, k_sd = float(fit.theta[0]) / G, float(sd[0]) / G
    a = ay_kin[sel]
    k_sd = math.hypot(k_sd, _bank_allowance(ya, a, w))
    # the steadier half of the rows apart: roll lags a fast-changing a_y (a slalom), which shows
    # as a different slope on the rows of small lateral jerk
    steady = np.abs(jerk[sel]) < 0.5 * JERK_MAX
    if steady.sum() >= 30 and (~steady).sum() >= 30:
        fs, _ = fit_robust(P[steady, 1:], P[steady, 0], cl[steady])
        fq, _ = fit_robust(P[~steady, 1:], P[~steady, 0], cl[~steady])
        if fs.clusters >= MIN_CLUSTERS and fq.clusters >= MIN_CLUSTERS:
            d = float(fs.theta[0] - fq.theta[0]) / G
            noise = float(fs.cov[0, 0] + fq.cov[0, 0]) / G**2
            k_sd = math.sqrt(k_sd**2 + max(0.0, d * d - noise) / 4.0)
    # left and right turns apart: a bank that changes with the turns shows as disagreement
    Xlr = np.column_stack([np.where(a > 0, a, 0.0), np.where(a < 0, a, 0.0), ax_kin[sel]])
    Plr = project_windows(w, tw, np.column_stack([ya, Xlr]))
    both = min(int((a > 1.0).sum()), int((a < -1.0).sum())) >= LR_MIN_ROWS
    flr, _ = fit_robust(Plr[:, 1:], Plr[:, 0], cl)
    if both and flr.clusters >= MIN_CLUSTERS:
        d = float(flr.theta[0] - flr.theta[1]) / G
        noise = float(flr.cov[0, 0] + flr.cov[1, 1] - 2 * flr.cov[0, 1]) / G**2
        k_sd = math.sqrt(k_sd**2 + max(0.0, d * d - noise) / 4.0)
    ok = fit.clusters >= MIN_CLUSTERS and (
        informed(k_sd, prior_sd_k) if math.isfinite(prior_sd_k) else k_sd < ROLL_SIGMA_ABS
    )
    plausible = ROLL_GRADIENT_MIN < k_phi < ROLL_GRADIENT_MAX
    if ok and not plausible:
        why = (
            f"fit {k_phi:.4f} rad/(m/s^2) is no suspension's: the road's bank follows the turns"
            if k_phi <= ROLL_GRADIENT_MIN
            else f"fit {k_phi:.4f} rad/(m/s^2) is beyond any car's roll"
        )
        return left_alone(name, before, unit, why, sigma=prior_sd_k), None
    rows_used = int(keep.sum())
    roll = (
        Fitted(
            name,
            k_phi,
            k_sd,
            rows_used,
            f"a_y,m - v dcourse/dt vs a_y,kin per {WINDOW_S:g} s window, |a_y|<0.4 g, quasi-steady",
            True,
            unit,
            before,
            None,
            "assumes the bank does not follow the turns (superelevation would add to it)",
        )
        if ok
        else left_alone(
            name, before, unit, "the drive's lateral accelerations do not tell it", sigma=prior_sd_k
        )
    )
    psi_a = (-float(fit.theta[1]), float(sd[1]))
    # a_x relation: a_x,m - a_x,kin = psi_m a_y + c a_x + offset
    if ax_m is not None:
        okx = np.isfinite(ax_m[sel])
        # body a_x = d|v|/dt cos(beta) - a_y sin(beta), beta = lr kappa - K f_y: the kinematic
        # part lr a_y^2 / v^2 is removed, the tyre part (K a_y^2) is the a_y^2 regressor
        kin_beta = vehicle.lr * ay_kin[sel] / sig.g_speed[sel] ** 2
        yx = ax_m[sel] - ax_kin[sel] - G * np.sin(sig.g_grade[sel]) + ay_kin[sel] * kin_beta
        yx = np.where(okx, yx, 0.0)
        Xx = np.column_stack([Xa, ay_kin[sel] ** 2])
        Px = project_windows(w, tw, np.column_stack([yx, Xx]))
        fx, _ = fit_robust(
            Px[okx, 1:], Px[okx, 0], cl[okx], None, np.array([G * MISALIGN_PRIOR, math.inf, math.inf])
        )
        if fx.clusters >= MIN_CLUSTERS:
            psi_a = _combine(psi_a, (float(fx.theta[0]), float(fx.sigma()[0])))
    return roll, (psi_a[0], psi_a[1], rows_used)


def roll_misalignment(sig: Signals, gyro_bias: float, gyro_scale: float) -> tuple[float, float, int] | None:
    """Roll misalignment (value rad, sigma rad, rows) from a_z and w_y against a_y = v r."""
    step = max(1, round(STEER_GRID_S / max(float(np.median(np.diff(sig.t))), 1e-6))) if sig.t.size > 1 else 1
    idx = np.arange(0, sig.t.size, step)
    t = sig.t[idx]
    v = sig.speed[idx]
    r = (sig.wz[idx] - gyro_bias) / gyro_scale
    ay = v * r
    use = (
        np.isfinite(v)
        & np.isfinite(r)
        & (v > V_GNSS_MIN)
        & (np.abs(np.nan_to_num(ay, nan=99.0)) < AY_LINEAR_MAX)
    )
    estimates: list[tuple[float, float]] = []
    rows = 0
    for col, kind in ((sig.az, "az"), (sig.wy, "wy")):
        if col is None:
            continue
        y = col[idx]
        u = use & np.isfinite(y)
        win = window_ids(t, u, WINDOW_S, 1.0)
        sel = win >= 0
        if sel.sum() < 50:
            continue
        if kind == "az":
            X = np.column_stack([ay[sel], ay[sel] ** 2])
            sign = -1.0
        else:
            X = np.column_stack([r[sel], v[sel] * r[sel] ** 2])
            sign = 1.0
        P = project_windows(win[sel], t[sel], np.column_stack([y[sel], X]))
        fit, keep = fit_robust(
            P[:, 1:],
            P[:, 0],
            clusters_of(t[sel], segment=win[sel]),
            None,
            np.array([MISALIGN_PRIOR * (G if kind == "az" else 1.0), math.inf]),
        )
        if fit.clusters < MIN_CLUSTERS:
            continue
        estimates.append((sign * float(fit.theta[0]), float(fit.sigma()[0])))
        rows = max(rows, int(keep.sum()) * step)
    if not estimates:
        return None
    value, sd = estimates[0]
    for e in estimates[1:]:
        value, sd = _combine((value, sd), e)
    return value, sd, rows


def misalignment_fits(
    sig: Signals, yaw: tuple[float, float, int] | None, gyro_bias: float, gyro_scale: float
) -> tuple[Fitted, Fitted]:
    """The Fitted yaw and roll mounting misalignments (rad)."""
    yname, rname = "imu_yaw_misalignment_rad", "imu_roll_misalignment_rad"
    if yaw is not None and informed(yaw[1], MISALIGN_PRIOR):
        yfit = Fitted(
            yname,
            yaw[0],
            yaw[1],
            yaw[2],
            "a_y,m vs a_x,kin and a_x,m vs a_y,kin (GNSS), per window",
            True,
            "rad",
            0.0,
        )
    else:
        yfit = left_alone(yname, 0.0, "rad", "needs GNSS accelerations: not observable here")
    rm = roll_misalignment(sig, gyro_bias, gyro_scale)
    if rm is None:
        rfit = left_alone(rname, 0.0, "rad", "needs az or wy in turns: not observable here")
    else:
        sd = math.hypot(rm[1], CROSSFALL_SIGMA)
        if informed(sd, MISALIGN_PRIOR):
            rfit = Fitted(
                rname,
                rm[0],
                sd,
                rm[2],
                "a_z,m vs a_y and w_y,m vs r (a_y = v r), per window, v > 5 m/s",
                True,
                "rad",
                0.0,
                None,
                "sensor roll in turns; 1-sigma includes the road's crossfall",
            )
        else:
            rfit = left_alone(
                rname, 0.0, "rad",
                f"not separable from the road's crossfall in turns (sensor roll in turns "
                f"{math.degrees(rm[0]):.2f} +- {math.degrees(rm[1]):.2f} deg = misalignment + mean bank)",
            )  # fmt: skip
    return yfit, rfit
