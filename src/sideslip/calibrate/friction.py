"""The road's friction coefficient from the drive's own understeer angle, where the drive
used most of it.

The steering relation of the single-track model without its linear-tyre step (Gillespie 1992,
ch. 6; seed 003 eqs 1-2 for the axle forces) reads, for small angles::

    delta - L r / v = alpha_f(F_yf) - alpha_r(F_yr)              (the understeer angle)

with ``alpha_a(F)`` the slip angle an axle needs for its lateral force ``F`` (per unit mass,
``F_yf = (l_r f_y + (I_z/m) r') / L``, ``F_yr = (l_f f_y - (I_z/m) r') / L``).  In the linear
range that is the understeer gradient times ``f_y`` and says nothing of friction; as an axle
approaches ``mu g`` times its load share its slip grows faster than its force, and how much
faster names ``mu``.  The axle curve is the estimator's own (``fused``'s brush curve,
Pacejka 2012 sec. 3.2.2, or the simplified Magic Formula), inverted in closed form
(:func:`axle_slip`): the fitted ``mu`` is the one that curve needs, in the same force units
(the roll gain's gravity term taken out as ``fused`` takes it out).

Fit: on the steering relation's 0.1 s grid (:func:`sideslip.calibrate.steer_zero.
steer_signals`, yaw rate and steer zeroed with the drive's own zeros), every ``mu`` of a grid
from the drive's friction floor to ``MU_MAX`` is scored by weighted least squares over the
rows faster than ``MIN_SPEED_MPS``, with a steering offset and the front axle's stiffness
scale as nuisance parameters (the front axle seen through the steering sensor carries the
steering system's compliance, which users' files leave out: a front scale of 0.5-1.5 x the
file's is allowed, the rear is the file's).  The rows are weighted by the relation's error,
``STEER_SIGMA`` plus ``GRADIENT_REL`` of the linear understeer angle, and counted once per
``CORRELATION_S`` (the residuals of a smoothed relation are not white).  ``mu`` is reported
only where the drive decides it: the profile's ``Delta cost <= 1`` interval is bounded below
``MU_MAX``, and the drive used at least ``USE_MIN`` of the fitted ``mu`` (its 99.5th
percentile of ``|f_y| / g``): below the limit a wrong stiffness in the file bends the
relation as a lower ``mu`` does (load transfer, roll steer and compliance add their own
errors), and a drive that never went near its limit says nothing about it.

Measured (the comparison's scenarios, seeds 0-2, ``benchmarks/results/friction.md``): the
CommonRoad BMW on mu 0.6 gives 0.55-0.57 on its limit ramp and slalom with the right file
(the multi-body tyres' axle peak under load transfer), 0.55-0.60 with files 30 % soft or
stiff; the simulated race lap on mu 1.05 gives 0.97-0.99; the other drives, which stay below
their limit, are left alone.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.result import Fitted, left_alone
from sideslip.calibrate.sensors import drive_gyro_bias, subtracted_zero
from sideslip.calibrate.steer_zero import drive_steer_offset, steer_signals, subtracted_offset
from sideslip.drive import Drive
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

MU_MAX = 1.6  # the grid's top: dry asphalt with road tyres is 0.9-1.2, racing slicks 1.5
MU_STEP = 0.01
COARSE_STEP = 0.05
# the drive must have used this share of the fitted mu to inform it: at the limit the
# understeer angle grows by several times the linear model's error; below it a file 30 % stiff
# bends the relation as a lower mu does (suburban_outages, 0.33 g on mu 0.9, 72 % of a fitted
# 0.46 +- 0.04: fused without GNSS 0.03 -> 1.87 deg).  Measured with 70 %: the limit drives of
# the comparison and the Revs lap used 92-100 % of their fitted mu; the fits at 67-79 % were
# right or far off (slalom_low_mu, stiff file, 0.24 on 0.25; dlc_bank, rough file, 0.57 on
# 0.85; benchmarks/results/friction.md)
USE_MIN = 0.9
MIN_SPEED_MPS = 5.0  # below it L r / v is a difference of large terms
MAX_LONG_ACCEL = 2.0  # m/s^2: harder braking or traction shares the friction (combined slip)
STEER_SIGMA = math.radians(0.1)  # road-wheel steer after the 0.5 s mean: noise, quantisation
GRADIENT_REL = 0.1  # the linear understeer angle's error: load transfer, roll steer, camber
CORRELATION_S = 1.0  # s: one independent residual per this long
FRONT_SCALE = (0.5, 1.5)  # the front axle's stiffness scale allowed as nuisance
MIN_ROWS_S = 5.0  # s of usable rows below which the drive is not used
FLOOR_PERCENTILE = 99.5
DUGOFF_RATIO_MAX = 0.99  # Dugoff's curve reaches the limit only at infinite slip


def axle_slip(f: FloatArray, c: float, f_max: FloatArray | float, shape: float = 0.0) -> FloatArray:
    """``tan(alpha)`` an axle needs for the lateral force ``f`` (per unit mass, m/s^2), the
    inverse of :func:`sideslip.models.axle_force.axle_lateral_force`: cornering stiffness
    ``c`` (m/s^2 per unit ``tan alpha``), force limit ``f_max`` = mu g times the load share.
    Brush curve (``shape == 0``): ``F / f_max = 1 - (1 - |u|)^3`` with ``u = c z / (3 f_max)``;
    Dugoff (``shape < 0``): ``z = F / c`` up to half the limit, ``f_max^2 / (4 c (f_max - F))``
    beyond, with the force capped at :data:`DUGOFF_RATIO_MAX` of the limit (the curve reaches
    it at infinite slip); Magic Formula with shape factor ``S``:
    ``z = tan(asin(F / f_max) / S) S f_max / c``.  Forces at or beyond the limit give the slip
    at the limit."""
    ratio = np.minimum(np.abs(f) / f_max, 1.0)
    if shape == 0.0:
        z = (1.0 - np.cbrt(1.0 - ratio)) * 3.0 * f_max / c
    elif shape < 0.0:
        r = np.minimum(ratio, DUGOFF_RATIO_MAX)
        z = np.where(r <= 0.5, r * f_max / c, f_max / (4.0 * c * (1.0 - r)))
    else:
        z = np.tan(np.arcsin(ratio) / shape) * shape * f_max / c
    return np.asarray(np.sign(f) * z, dtype=float)


def _profile(
    um: FloatArray, ff: FloatArray, fr: FloatArray, w: FloatArray, mus: FloatArray,
    c_f: float, c_r: float, share_f: float, share_r: float, shape: float,
) -> FloatArray:  # fmt: skip
    """Weighted least-squares cost of each ``mu`` with the steering offset and the front
    stiffness scale profiled out (the model is linear in both: ``z_f`` scales as 1 / s_f)."""
    cost = np.empty(mus.size)
    lo, hi = 1.0 / FRONT_SCALE[1], 1.0 / FRONT_SCALE[0]
    sw = float(np.sum(w))
    for i, mu in enumerate(mus):
        a = axle_slip(ff, c_f, mu * G * share_f, shape)  # front at the file's stiffness
        y = um + axle_slip(fr, c_r, mu * G * share_r, shape)  # = offset + k a, k = 1 / s_f
        am, ym = float(np.sum(w * a)) / sw, float(np.sum(w * y)) / sw
        da, dy = a - am, y - ym
        saa = float(np.sum(w * da * da))
        k = float(np.sum(w * da * dy)) / saa if saa > 0.0 else 1.0
        k = min(max(k, lo), hi)
        res = dy - k * da
        cost[i] = float(np.sum(w * res * res))
    return cost


def drive_friction(
    drive: Drive,
    vehicle: Vehicle,
    roll_gain: float = 0.0,
    shape: float = 0.0,
    gyro_zero: Fitted | None = None,
) -> Fitted:
    """The drive's road friction ``mu`` (dimensionless) from its understeer angle (module
    docstring), or not informed (the value nan) where the drive does not decide it.
    ``roll_gain`` (rad per m/s^2): the suspension's roll gain, whose gravity term is taken out
    of the lateral acceleration as the estimator takes it out; ``shape``: the axle curve
    (0 brush, -1 Dugoff, > 1 Magic Formula shape factor); ``gyro_zero``: the drive's gyro zero if the
    caller has it."""
    name = "mu"
    if "steer" not in drive or "wz" not in drive or "ay" not in drive:
        return left_alone(name, math.nan, "", "no steer, yaw-rate or lateral-acceleration column")
    keys = ("mass", "lf", "lr", "cf", "cr")
    if not all(math.isfinite(getattr(vehicle, k)) and getattr(vehicle, k) > 0 for k in keys):
        return left_alone(name, math.nan, "", "the vehicle file lacks mass, axle positions or stiffness")
    if gyro_zero is None:
        gyro_zero = drive_gyro_bias(drive, vehicle)
    sig = steer_signals(drive, subtracted_zero(gyro_zero))
    if sig.ay is None or sig.steer is None or sig.t.size < 3:
        return left_alone(name, math.nan, "", "too few rows")
    steer = sig.steer - subtracted_offset(drive_steer_offset(drive, vehicle, gyro_zero, sig))
    lf, lr = vehicle.lf, vehicle.lr
    wb = lf + lr
    fy = sig.ay / (1.0 + G * roll_gain)  # the tyres' force per mass (models.fused_process)
    r_dot = np.gradient(sig.wz, sig.t)
    # without a yaw inertia in the file, I_z = m l_f l_r (dynamic index 1, as fused assumes)
    iz = vehicle.yaw_inertia if math.isfinite(vehicle.yaw_inertia) else vehicle.mass * lf * lr
    iz_m = iz / vehicle.mass
    ff = (lr * fy + iz_m * r_dot) / wb
    fr = (lf * fy - iz_m * r_dot) / wb
    ax = np.gradient(sig.speed, sig.t)
    v = sig.speed
    ok = np.isfinite(ff) & np.isfinite(fr) & np.isfinite(steer) & np.isfinite(v) & np.isfinite(ax)
    ok &= (v > MIN_SPEED_MPS) & (np.abs(ax) < MAX_LONG_ACCEL)
    dt = float(np.median(np.diff(sig.t)))
    if ok.sum() * dt < MIN_ROWS_S:
        why = f"under {MIN_ROWS_S:g} s of rows faster than {MIN_SPEED_MPS:g} m/s"
        return left_alone(name, math.nan, "", why)
    ff, fr, v, steer, fy = ff[ok], fr[ok], v[ok], steer[ok], fy[ok]
    r = sig.wz[ok]
    um = steer - wb * r / v
    c_f, c_r = vehicle.cf / vehicle.mass, vehicle.cr / vehicle.mass
    sd = STEER_SIGMA + GRADIENT_REL * np.abs(ff / c_f - fr / c_r)
    # counted once per CORRELATION_S: the cost is a chi^2 of that many independent residuals
    w = (min(dt / CORRELATION_S, 1.0)) / sd**2
    floor = float(np.percentile(np.abs(fy), FLOOR_PERCENTILE)) / G
    lo = max(floor, 0.05)
    if lo >= MU_MAX - MU_STEP:
        return left_alone(name, math.nan, "", f"the drive's lateral acceleration exceeds {MU_MAX:g} g")
    args = (um, ff, fr, w)
    consts = (c_f, c_r, lr / wb, lf / wb, shape)
    # a coarse grid, then MU_STEP over the coarse interval and one coarse step either side
    coarse = np.append(np.arange(lo, MU_MAX, COARSE_STEP), MU_MAX)
    cost_c = _profile(*args, coarse, *consts)
    near = np.flatnonzero(cost_c <= cost_c.min() + 1.0)
    a, b = coarse[max(near[0] - 1, 0)], coarse[min(near[-1] + 1, coarse.size - 1)]
    mus = np.append(np.arange(a, b, MU_STEP), b)
    cost = _profile(*args, mus, *consts)
    best = int(np.argmin(cost))
    inside = mus[cost <= cost[best] + 1.0]
    mu, top = float(mus[best]), float(inside.max())
    source = (
        f"understeer angle over {ok.sum() * dt:.0f} s faster than {MIN_SPEED_MPS:g} m/s; "
        f"the drive used {floor:.2f} g"
    )
    if top >= MU_MAX - 0.5 * MU_STEP:
        return left_alone(name, math.nan, "", f"not bounded: {source}, any mu above {inside.min():.2f} fits")
    if floor < USE_MIN * mu:
        return left_alone(
            name, math.nan, "",
            f"{source}, {floor / mu:.0%} of the fitted {mu:.2f} (under {USE_MIN:.0%}: below the "
            "limit a stiffness error in the file bends the relation as a lower mu does)",
        )  # fmt: skip
    sigma = max(0.5 * (top - float(inside.min())), MU_STEP)
    return Fitted(name, mu, sigma, int(ok.sum()), source, True, "")
