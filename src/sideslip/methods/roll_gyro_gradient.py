"""The suspension roll gradient from the roll gyro in the drive's lateral transients.

Seed 003's suspension roll is ``phi_s = G_phi a_ym`` (eq 43, ``G_phi = m h / k`` rad per m/s^2
of measured lateral specific force).  Vehicle files give ``k`` and ``h`` roughly: a file with a
15 % heavier car, a CG 30 % higher and a roll stiffness 30 % lower than the truth doubles
``G_phi``, and the fused estimator, which takes ``g phi_s`` out of the accelerometer to get the
tyres' force, then misreads the force by 15 % at the limit (CommonRoad limit slalom: beta RMSE
0.23 -> 1.7 deg with 75 % of errors inside 2 sigma).

The roll gyro measures the body's roll rate: the suspension's plus the road's bank rate.  Over
a window of ``WINDOW_S`` seconds the road's bank changes slowly and smoothly, so the roll angle
(the gyro integrated) and ``a_ym``, each less its centred moving average over the window (which
removes a constant and a linear trend exactly: the gyro's bias and a bank ramp), keep the
suspension's part, and ``G_phi`` is their least-squares ratio.  The roll's own dynamics (a
damped mode near 1.5-2 Hz) lag ``a_ym`` little at driving frequencies.  Measured on the
simulator and CommonRoad's multi-body model (file value / identified): limit slalom 0.0144 /
0.0144, CommonRoad slalom 0.0107 / 0.0109, race lap 0.0050 / 0.0051, step steer 0.0082 /
0.0088 rad per m/s^2.

Guards (the vehicle file's value is kept otherwise, the reason in the params): the high-passed
``a_ym`` must reach ``MIN_AY_RMS`` (rms: a drive of steady arcs and straights has no transients
to fit), the fit must explain ``MIN_R2`` of the high-passed roll (where the bank changes with
the curve, as on banked tracks, the ratio is the bank's, not the suspension's: there R^2 falls
to 0.4-0.7 at a high-passed a_ym of 0.1-0.6 m/s^2), the value must be plausible
(:data:`sideslip.methods.roll_gradient.PLAUSIBLE`), and it replaces the file's only where it
contradicts it by more than ``FILE_Z`` sigma (:meth:`RollGradient.validated`).  The 1-sigma is
the formal one (one independent sample per window) with a relative ``SYSTEMATIC_REL`` (the
roll mode's lag, the accelerometer's scale) in quadrature.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sideslip.methods.roll_gradient import PLAUSIBLE, RollGradient

FloatArray = NDArray[np.float64]

WINDOW_S = 2.0  # s: the high-pass's moving average (bank ramps and the gyro bias removed)
SMOOTH_S = 0.2  # s: a centred moving average on the roll and a_ym alike (sensor noise)
MIN_SPEED_M_S = 5.0  # rows slower than this are not used (parking, standstill)
MIN_AY_RMS = 0.2  # m/s^2: rms of the high-passed a_ym the fit needs
MIN_R2 = 0.8  # share of the high-passed roll the fit must explain
SYSTEMATIC_REL = 0.1  # relative 1-sigma of the roll mode's lag and the accelerometer's scale


def _centred_mean(x: FloatArray, half: int) -> FloatArray:
    """Mean over rows i - half ... i + half, the window cut at the drive's ends."""
    n = x.size
    c = np.concatenate(([0.0], np.cumsum(x)))
    out = np.empty(n)
    k = 2 * half + 1
    if n > 2 * half:
        out[half : n - half] = (c[k:] - c[: n + 1 - k]) / k
    edge = np.r_[0 : min(half, n), max(n - half, 0) : n]  # the rows whose windows are cut
    lo = np.maximum(edge - half, 0)
    hi = np.minimum(edge + half, n - 1) + 1
    out[edge] = (c[hi] - c[lo]) / (hi - lo)
    return out


def identify_roll_gradient_from_gyro(
    t: FloatArray, wx: FloatArray, ay: FloatArray, speed: FloatArray
) -> RollGradient:
    """``G_phi`` (rad per m/s^2) from the roll gyro ``wx`` (rad/s) and the lateral specific
    force ``ay`` (m/s^2, low-passed as the caller wants) on rows faster than
    :data:`MIN_SPEED_M_S` (``speed``, m/s); see the module docstring.  NaN rows of ``wx`` or
    ``ay`` count as zero roll rate / are left out."""
    n = t.size
    if n < 10:
        return RollGradient(math.nan, math.inf, 0, 0, False, "drive too short: file value used")
    step = float(np.median(np.diff(t)))
    half = max(round(0.5 * WINDOW_S / step), 1)
    # the same centred low-pass on both (no relative lag): the accelerometer's noise would
    # otherwise shrink the ratio (noise in the regressor) and lower R^2
    smooth = max(round(0.5 * SMOOTH_S / step), 1)
    ok_ay = np.isfinite(ay)
    ay_s = _centred_mean(np.where(ok_ay, ay, 0.0), smooth)
    ay_hp = ay_s - _centred_mean(ay_s, half)
    use = ok_ay & (np.abs(speed) > MIN_SPEED_M_S)
    use[: half + smooth] = False  # the rows whose windows the drive's ends cut
    use[max(n - half - smooth, 0) :] = False
    rows = int(use.sum())
    if rows * step < 2.0 * WINDOW_S:
        return RollGradient(math.nan, math.inf, rows, 0, False, "too few moving rows: file value used")
    x = ay_hp[use]
    sxx = float(np.sum(x * x))
    ay_rms = math.sqrt(sxx / rows)
    if ay_rms < MIN_AY_RMS:  # (checked before the roll is integrated: most drives stop here)
        return RollGradient(
            math.nan, math.inf, rows, 0, False,
            f"lateral transients of {ay_rms:.2f} m/s^2 rms (< {MIN_AY_RMS}): file value used",
        )  # fmt: skip
    roll = _centred_mean(np.cumsum(np.nan_to_num(wx) * np.gradient(t)), smooth)
    y = (roll - _centred_mean(roll, half))[use]
    value = float(np.sum(x * y) / sxx)
    res = y - value * x
    r2 = 1.0 - float(np.var(res)) / max(float(np.var(y)), 1e-30)
    per_window = 2 * half + 1  # rows per independent sample
    formal = float(np.std(res)) / math.sqrt(sxx) * math.sqrt(per_window)
    sigma = math.hypot(formal, SYSTEMATIC_REL * abs(value))
    windows = int(rows // per_window)
    reason = ""
    if r2 < MIN_R2:
        reason = f"the roll follows a_y with R^2 {r2:.2f} (< {MIN_R2}: bank changes with the curves)"
    elif not PLAUSIBLE[0] <= value <= PLAUSIBLE[1]:
        reason = f"{value:.4g} rad per m/s^2 outside the plausible {PLAUSIBLE}"
    if reason:
        return RollGradient(value, sigma, rows, windows, False, reason + ": file value used")
    return RollGradient(value, sigma, rows, windows, True, f"roll gyro in lateral transients (R^2 {r2:.2f})")
