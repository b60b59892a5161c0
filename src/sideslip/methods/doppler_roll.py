"""Roll angle and lateral-accelerometer error from heading consistency in curves (seed 000).

Sign restatement.  Seed 000 writes (eq 13) G_y,imu = psi' V - g sin(phi) with its own roll sign.
Here roll is ISO 8855 (right side down positive) and the accelerometer's lateral channel reads
``a_y,m = a_y + g sin(phi)`` (package docstring: gravity pulls towards -y when the right side is
down, and an accelerometer reads specific force, acceleration minus gravity).  With
a_y ~ psi' V in quasi-steady driving, the paper's equations become, in our convention::

    (13)  a_y,m = psi' V + g sin(phi) + b_ay            b_ay: accelerometer bias, measured - true
    (16)  phi = arcsin((a_y,m - b_ay - psi' V) / g)      (used exactly: see roll_from_lateral)
    (17-19) psi_{t+n} - psi_t = int_t^{t+n} w_h / cos(phi(b_ay)) dt

The paper's delta G_y is the correction *added* to the reading, delta G_y = -b_ay.  (Eq 16's
roll sign is opposite to the paper's; eq 19 is even in phi, so the scan is unaffected.)

Why eq 19 holds: a vehicle turning at Omega about the vertical with roll phi has
w_z = Omega cos(phi) (eq 3), so the gyro integrated without 1/cos(phi) under-reads the heading
change of a curve by about phi^2/2; only the right phi closes the heading change measured by
GNSS.  ``w_h`` here is the gyro corrected for offset and scale (doppler_heading) and pitch.

Scan: for each curve window (|yaw rate| above ``r_on`` for at least ``min_curve_s``, extended to
straight driving at both ends) the heading change comes from the Doppler course at the two ends
(median over +-1.5 s of straight driving, multipath epochs flagged by the heading fit left out,
minus the modelled antenna sideslip); delta G_y is scanned over [-1.5, 1.5] m/s^2 (paper
default, step 0.01) and each curve's closure ``dpsi_GNSS - int w_h / cos(phi(delta)) dt`` is
evaluated.  Two things the paper leaves implicit are handled:

* 1/cos(phi) - 1 ~ phi^2 / 2 > 0 multiplies every turn like a gyro scale factor, and gyro scale
  factors of 0.2-0.5 % are common in MEMS; a residual scale factor s is therefore solved with
  delta G_y (closure = s x turn, least squares over the curves, for every delta).  They stay
  separable: d(turn)/d(delta) ~ turn x phi / g has the same sign in left and right turns (the
  body rolls out of the turn), a scale factor's follows the turn's sign.
* A curve's closure is a parabola in delta G_y, so a curve alone has two roots (phi and about
  -phi) or one vertex; its sensitivity to delta G_y varies a hundred-fold between a flat 30 deg
  bend and a superelevated 90 deg curve.

Combination over curves, all reported in ``params``:
**joint** (default): least squares of all curves' closures (minimum of the summed squared
closures, parabolic refinement, with a residual gyro scale solved alongside); outlier curves
are dropped one at a time while the worst externally studentised closure exceeds 4.
Default because it weights every curve by how strongly it pins delta G_y and it has no
two-root ambiguity; on our urban course and highway it was within
0.02 m/s^2 of the truth where the plain median and mean of per-curve minima were 0.06-0.14 off.
**mean** (the paper's choice) and **median** of per-curve minima (the minimum nearest the joint
value), and their **weighted median** (weights: squared sensitivity), for comparison.
1-sigma of delta G_y: the closures' rms scatter (kept curves) over sqrt(sum of squared
sensitivities).
When it exceeds ``DGY_MAX_STD`` (0.15 m/s^2, ~0.9 deg of roll) the curves carry too little roll
to identify delta G_y: it is set to 0 and ``params['dGy_note']`` says so; with fewer than
``MIN_CURVES`` (5) usable curve windows, likewise.

Assumptions: a_y = psi' V + v_y' where the paper has psi' V alone; the caller supplies v_y' from
the modelled sideslip (v_y = V beta_r + l_r r at the CG; without it the urban roll error's std
was 0.45 deg instead of 0.06 deg, turn entries at 5 m/s having l_r r' ~ 1 m/s^2); both sides are
smoothed by a 0.5 s centred moving average; roll about the vertical-turn axis only; b_ay
constant over the drive (the paper: "did not vary considerably over time").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.frames import wrap_angle
from sideslip.methods.doppler_heading import CourseSamples
from sideslip.methods.doppler_stats import t_factor
from sideslip.models.dead_reckoning import _cumtrapz
from sideslip.vehicle import G

FloatArray = NDArray[np.float64]

SCAN_RANGE = (-1.5, 1.5)  # m/s^2, the paper's delta G_y range
SCAN_STEP = 0.01  # m/s^2
R_ON = 0.03  # rad/s: yaw rate marking a curve (about 1.7 deg/s)
R_OFF = 0.01  # rad/s: yaw rate taken as straight at a window end
END_HALF_S = 1.5  # s: course samples on each side of a window end
MIN_CURVE_S = 3.0  # s
MAX_WINDOW_S = 120.0  # s (the paper: 100 s windows)
MIN_TURN_RAD = np.radians(20.0)
MIN_SPEED = 5.0  # m/s
COMBINE = ("joint", "weighted_median", "median", "mean")
CLOSURE_FLOOR = np.radians(0.05)  # rad: floor of a curve's heading-closure 1-sigma
MIN_CURVES = 5  # curves needed: delta G_y and the residual gyro scale, with residual to spare
DGY_MAX_STD = 0.15  # m/s^2: above this 1-sigma (~0.9 deg of roll) delta G_y is not applied


def _weighted_median(values: FloatArray, weights: FloatArray) -> float:
    """The value below which half the total weight lies."""
    order = np.argsort(values)
    cw = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cw, 0.5 * cw[-1])])


def _two_parameter_std(
    slopes: FloatArray, turns: FloatArray, sigma: float, with_scale: bool
) -> float:
    """Formal 1-sigma of delta G_y (m/s^2) from the closures' scatter ``sigma`` (rad).

    Linearised at the joint value each closure is ``slope_c delta + s turn_c``; with the gyro
    scale s solved alongside, delta's variance is sigma^2 over the Schur complement
    ``sum slope^2 - (sum slope turn)^2 / sum turn^2`` (not over sum slope^2 alone, which would
    ignore how much the scale can mimic delta G_y -- all curves of one direction make the two
    inseparable).
    """
    info = float(np.sum(slopes**2))
    if with_scale:
        tt = float(np.sum(turns**2))
        if tt > 0:
            info -= float(np.sum(slopes * turns)) ** 2 / tt
    return float(sigma / np.sqrt(info)) if info > 1e-300 else np.inf


def moving_average(x: FloatArray, width: int) -> FloatArray:
    """Centred moving average over ``width`` rows (shrinking at the ends), NaN-free input."""
    if width <= 1 or x.size == 0:
        return np.asarray(x, dtype=float)
    c = np.concatenate(([0.0], np.cumsum(x)))
    half = width // 2
    i = np.arange(x.size)
    lo = np.clip(i - half, 0, x.size)
    hi = np.clip(i + half + 1, 0, x.size)
    return np.asarray((c[hi] - c[lo]) / (hi - lo), dtype=float)


def roll_from_lateral(
    ay_m: FloatArray,
    yaw_rate: FloatArray,
    speed: FloatArray,
    ay_bias: float | FloatArray = 0.0,
    transient: float | FloatArray = 0.0,
) -> FloatArray:
    """Eq 16 in our sign, without the small-roll shortcut on a_y: roll (rad).

    a_y = psi' V + ``transient`` (m/s^2): the paper takes a_y = psi' V; at urban speeds the
    sideslip's own rate matters (v_y ~ l_r r, so a_y = r V + l_r r' at the CG, and an
    accelerometer x_imu ahead of the CG adds x_imu r'); the caller passes (l_r + x_imu) r'.

    The lateral specific force of a body rolled by phi is ``a_y cos(phi) + g sin(phi)``
    (a_y = psi' V in the heading frame); solving it exactly,
    ``phi = arcsin(x / sqrt(a_y^2 + g^2)) - atan2(a_y, g)`` with x = a_y,m - b_ay.  The paper's
    eq 16, arcsin((x - a_y) / g), drops cos(phi) on a_y: 0.15 deg apart at a_y = 4 m/s^2,
    phi = 6 deg, and biased the same way in every curve, so the exact form is used.
    """
    a = np.asarray(yaw_rate * speed + transient, dtype=float)
    x = np.asarray(ay_m, dtype=float) - ay_bias
    hyp = np.hypot(a, G)
    return np.asarray(np.arcsin(np.clip(x / hyp, -1.0, 1.0)) - np.arctan2(a, G), dtype=float)


@dataclass(frozen=True)
class CurveWindow:
    """Rows [start, stop] of a curve window and its GNSS heading change (rad)."""

    start: int
    stop: int
    dpsi_gnss: float


@dataclass(frozen=True)
class AyBiasScan:
    """Result of :func:`scan_ay_bias`.  ``ay_bias`` = -delta G_y (m/s^2, measured - true)."""

    ay_bias: float
    ay_bias_mean: float
    ay_bias_median: float
    ay_bias_wmedian: float
    ay_bias_joint: float
    ay_bias_std: float
    per_curve: list[float] = field(default_factory=list)
    weights: list[float] = field(default_factory=list)
    n_curves: int = 0
    combine: str = "joint"
    reason: str = ""
    formal_std: float = float("inf")
    jackknife_std: float = float("inf")

    def params(self) -> dict[str, object]:
        applied = self.reason == ""
        return {
            # naming convention: the bias (measured - true) with its 1-sigma; the value is the
            # joint fit's even when it was not applied (then ay_bias_applied is False)
            "ay_bias_m_s2": self.ay_bias_joint if np.isfinite(self.ay_bias_joint) else 0.0,
            "ay_bias_m_s2_sigma": self.ay_bias_std,
            "ay_bias_applied": applied,
            "ay_bias_note": self.reason,
            "dGy_formal_std_mps2": self.formal_std,
            "dGy_jackknife_std_mps2": self.jackknife_std,
            "dGy_mps2": -self.ay_bias,
            "ay_bias_mps2": self.ay_bias,
            "dGy_mean_mps2": -self.ay_bias_mean,
            "dGy_median_mps2": -self.ay_bias_median,
            "dGy_weighted_median_mps2": -self.ay_bias_wmedian,
            "dGy_joint_mps2": -self.ay_bias_joint,
            "dGy_std_mps2": self.ay_bias_std,
            "dGy_combine": self.combine,
            "dGy_curves": self.n_curves,
            "dGy_per_curve_mps2": [-v for v in self.per_curve],
            "dGy_per_curve_weight": self.weights,
            "dGy_note": self.reason,
        }


def _course_at(
    row: int, t: FloatArray, samples: CourseSamples, offset: FloatArray, half_s: float,
    good: NDArray[np.bool_] | None = None, ts: FloatArray | None = None,
) -> float | None:
    """Median of the (offset-corrected) course within +-half_s of ``row``, or None.

    ``ts``: the course samples' times ``t[samples.rows]`` when the caller has them (one
    gather per drive instead of one per curve end, which was quadratic in the drive's length).

    The median (of the course unwrapped about its first sample) resists a multipath epoch;
    ``good`` masks samples already flagged as outliers by the heading fit.
    """
    if samples.rows.size == 0:
        return None
    if ts is None:
        ts = t[samples.rows]
    lo, hi = np.searchsorted(ts, [t[row] - half_s, t[row] + half_s + 1e-9])
    keep = np.arange(lo, hi)
    if good is not None:
        keep = keep[good[lo:hi]]
    if keep.size < 3:
        return None
    c = samples.course[keep] - offset[keep]
    c = c[0] + wrap_angle(c - c[0])
    return float(np.median(c))


def curve_windows(
    t: FloatArray,
    rate: FloatArray,
    speed: FloatArray,
    samples: CourseSamples,
    course_offset: FloatArray,
    r_on: float = R_ON,
    r_off: float = R_OFF,
    good: NDArray[np.bool_] | None = None,
) -> list[CurveWindow]:
    """Curve windows that start and end in straight driving with GNSS course at both ends.

    ``rate``: bias-corrected vertical yaw rate, rad/s, on every row (smoothed by the caller).
    ``good``: course samples usable (not rejected as multipath by the heading fit).
    """
    n = t.size
    if n < 3:
        return []
    dt = float(np.median(np.diff(t)))
    turning = (np.abs(rate) > r_on) & (speed > MIN_SPEED)
    edges = np.diff(np.concatenate(([0], turning.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    straight = np.abs(rate) < r_off
    integ = _cumtrapz(t, rate)
    out: list[CurveWindow] = []
    last_stop = -1
    max_ext = round(20.0 / dt)
    # course samples around each end: +-1.5 s, wider for slow receivers (three epochs at least)
    gnss_dt = float(np.median(np.diff(t[samples.rows]))) if samples.rows.size > 1 else 0.1
    half = max(END_HALF_S, 1.5 * gnss_dt)
    ts = t[samples.rows]
    for s0_, s1_ in zip(starts, stops, strict=True):
        s0, s1 = int(s0_), int(s1_)
        if (s1 - s0) * dt < MIN_CURVE_S or s0 <= last_stop:
            continue
        a = s0
        while a > max(0, s0 - max_ext) and not straight[a]:
            a -= 1
        b = s1
        while b < min(n - 1, s1 + max_ext) and not straight[b]:
            b += 1
        if not (straight[a] and straight[b]) or (t[b] - t[a]) > MAX_WINDOW_S:
            continue
        a = max(a - round(1.0 / dt), 0)  # a little straight driving at each end
        b = min(b + round(1.0 / dt), n - 1)
        ca = _course_at(a, t, samples, course_offset, half, good, ts)
        cb = _course_at(b, t, samples, course_offset, half, good, ts)
        if ca is None or cb is None:
            continue
        turn = integ[b] - integ[a]
        if abs(turn) < MIN_TURN_RAD:
            continue
        dpsi = turn + float(wrap_angle(cb - ca - turn))
        out.append(CurveWindow(int(a), int(b), dpsi))
        last_stop = b
    return out


# fast-math without 'nnan' / 'ninf': a gap's NaN still comes out as NaN
@numba.njit(cache=True, fastmath={"nsz", "arcp", "contract", "afn", "reassoc"})
def _turned(t: FloatArray, rate_h: FloatArray, ay_m: FloatArray, centripetal: FloatArray,
            grid: FloatArray) -> FloatArray:
    """The curve's turn (rad, trapezoid rule) for each delta G_y of ``grid``: the integral of
    ``rate_h / cos(phi)``, phi from :func:`roll_from_lateral` with b_ay = -delta G_y.

    ``cos(phi)`` without a transcendental per grid value: with ``y = (a_y,m + delta G_y) /
    hypot(a, g)`` and ``c = atan2(a, g)``, ``phi = asin(y) - c``, so ``cos(phi) =
    sqrt(1 - y^2) cos(c) + y sin(c)``, ``cos(c) = g / hypot(a, g)``, ``sin(c) = a / hypot``.
    """
    n_g = grid.size
    out = np.zeros(n_g)
    prev = np.zeros(n_g)
    for i in range(t.size):
        a = centripetal[i]
        inv_hyp = 1.0 / math.sqrt(a * a + G * G)
        half_dt = 0.5 * (t[i] - t[i - 1]) if i > 0 else 0.0
        for j in range(n_g):  # contiguous: vectorised by the compiler
            y = min(max((ay_m[i] + grid[j]) * inv_hyp, -1.0), 1.0)
            cos_phi = (math.sqrt(1.0 - y * y) * G + y * a) * inv_hyp
            f = rate_h[i] / max(cos_phi, 0.1)
            out[j] += half_dt * (f + prev[j])
            prev[j] = f
    return out


def scan_ay_bias(
    t: FloatArray,
    rate_h: FloatArray,
    ay_m: FloatArray,
    centripetal: FloatArray,
    windows: list[CurveWindow],
    combine: str = "joint",
    scan_range: tuple[float, float] = SCAN_RANGE,
    step: float = SCAN_STEP,
    fit_scale: bool = True,
    max_std: float = DGY_MAX_STD,
    min_curves: int = MIN_CURVES,
) -> AyBiasScan:
    """Scan eq 19 over delta G_y for every curve window; see the module docstring.

    ``rate_h``: gyro rate corrected for offset, scale and pitch, not for roll (rad/s).
    ``ay_m``: lateral accelerometer (m/s^2), ``centripetal``: psi' V (+ the transient term of
    :func:`roll_from_lateral`) (m/s^2), both smoothed;
    roll for a candidate delta G_y is :func:`roll_from_lateral` with b_ay = -delta G_y.
    ``combine``: 'weighted_median' (default), 'median', 'mean' (the paper) or 'joint'
    (minimum of the summed costs, i.e. least squares over all curves' closures).
    ``fit_scale``: also solve a residual gyro scale factor with delta G_y (three curves or
    more).  Needed because the roll term itself acts on each curve like a scale factor
    (1/cos(phi) - 1 ~ phi^2/2 > 0 multiplies every turn), so a heading fit that estimates the
    gyro scale with a wrong roll has already absorbed part of it.  delta G_y stays separable:
    its effect d(turn)/d(delta) ~ turn * phi / g has the same sign in left and right turns
    (phi follows the turn), a scale factor's has the sign of the turn.
    """
    if combine not in COMBINE:
        raise ValueError(f"combine must be one of {', '.join(COMBINE)}, not {combine!r}")
    grid = np.arange(scan_range[0], scan_range[1] + step / 2, step)  # delta G_y values
    turned_all = []
    for w in windows:
        sl = slice(w.start, w.stop + 1)
        turned_all.append(_turned(t[sl], rate_h[sl], ay_m[sl], centripetal[sl], grid))
    if not turned_all:
        return AyBiasScan(0.0, 0.0, 0.0, 0.0, 0.0, np.inf, [], [], 0, combine,
                          "no curve window with GNSS course at both ends: delta G_y set to 0")
    turned = np.array(turned_all)  # (curves, grid)
    dpsi = np.array([w.dpsi_gnss for w in windows])[:, None]
    closure = dpsi - turned
    n_c = len(windows)
    use_scale = fit_scale and n_c >= 3

    def solve(mask: NDArray[np.bool_]) -> tuple[int, FloatArray]:
        """Joint least squares over the curves in ``mask``: grid index and s per grid value."""
        ca, ta = closure[mask], turned[mask]
        sc = np.zeros(grid.size)
        if use_scale and mask.sum() >= 3:
            # a residual gyro scale factor s closes every curve in proportion to its turn;
            # for each delta G_y it is solved by least squares over the curves
            sc = np.clip(np.sum(ca * ta, axis=0) / np.maximum(np.sum(ta * ta, axis=0), 1e-12),
                         -0.05, 0.05)
        return int(np.argmin(np.sum((ca - sc * ta) ** 2, axis=0))), sc

    def rms(mask: NDArray[np.bool_], j: int, sc: FloatArray) -> float:
        r = closure[mask, j] - sc[j] * turned[mask, j]
        dof = max(int(mask.sum()) - (2 if use_scale else 1), 1)
        return max(float(np.sqrt(np.sum(r * r) / dof)), CLOSURE_FLOOR)

    def refine(mask: NDArray[np.bool_], j: int, sc: FloatArray) -> float:
        """Grid minimum ``j`` refined by a parabola through the summed costs, m/s^2."""
        cost = np.sum((closure[mask] - sc * turned[mask]) ** 2, axis=0)
        value = float(grid[j])
        if 0 < j < grid.size - 1:
            den = cost[j - 1] - 2.0 * cost[j] + cost[j + 1]
            if den > 0:
                value += float(np.clip(0.5 * (cost[j - 1] - cost[j + 1]) / den, -1.0, 1.0) * step)
        return value

    def leave_one_out(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp],
                                                         FloatArray, FloatArray]:
        """:func:`solve` for every curve of ``mask`` left out in turn, from the sums over
        ``mask`` minus each curve's share: O(curves x grid), not O(curves^2 x grid).

        Returns the curves (indices), each fit's grid index, scale factors and summed costs
        (rows: left-out curve; the cost is expanded, sum c^2 - 2 s sum c t + s^2 sum t^2).
        """
        idx = np.flatnonzero(mask)
        ca, ta = closure[idx], turned[idx]
        ct, tt, cc = ca * ta, ta * ta, ca * ca
        ct_o, tt_o, cc_o = ct.sum(axis=0) - ct, tt.sum(axis=0) - tt, cc.sum(axis=0) - cc
        sc = np.zeros_like(ct_o)
        if use_scale and idx.size - 1 >= 3:
            sc = np.clip(ct_o / np.maximum(tt_o, 1e-12), -0.05, 0.05)
        cost = np.maximum(cc_o - 2.0 * sc * ct_o + sc * sc * tt_o, 0.0)
        return idx, np.argmin(cost, axis=1), sc, cost

    def refine_rows(cost: FloatArray, j: NDArray[np.intp]) -> FloatArray:
        """:func:`refine` for each row of ``cost`` (a cost over the grid) at its index j."""
        r = np.arange(j.size)
        jj = np.clip(j, 1, grid.size - 2)
        cm, c0, cp = cost[r, jj - 1], cost[r, jj], cost[r, jj + 1]
        den = cm - 2.0 * c0 + cp
        ok = (j > 0) & (j < grid.size - 1) & (den > 0)
        off = np.clip(0.5 * (cm - cp) / np.where(ok, den, 1.0), -1.0, 1.0) * step
        return np.asarray(grid[j] + np.where(ok, off, 0.0), dtype=float)

    def jackknife_std(mask: NDArray[np.bool_]) -> float:
        """Delete-one-curve jackknife 1-sigma of the joint value (Efron & Tibshirani 1993,
        ch. 11): the spread across curves, whatever the closures' error model."""
        if mask.sum() < 4:
            return np.inf
        _idx, j, _sc, cost = leave_one_out(mask)
        vals = refine_rows(cost, j)
        n = vals.size
        return float(np.sqrt((n - 1) / n * np.sum((vals - vals.mean()) ** 2)))

    # outlier curves (a multipath end, a transient): externally studentised residuals -- each
    # curve's closure against the fit of the others, over the others' scatter; the worst goes
    # while above 4 (least squares alone would spread one bad curve over all)
    active = np.ones(n_c, dtype=bool)
    while active.sum() > 4:
        idx, j, sc, cost = leave_one_out(active)
        r = np.arange(idx.size)
        dof = max(idx.size - 1 - (2 if use_scale else 1), 1)
        spread = np.maximum(np.sqrt(cost[r, j] / dof), CLOSURE_FLOOR)
        score = np.abs(closure[idx, j] - sc[r, j] * turned[idx, j]) / spread
        worst = int(np.argmax(score))
        if score[worst] <= 4.0:
            break
        active[idx[worst]] = False
    joint, scale = solve(active)
    sigma_cl = rms(active, joint, scale)
    C = (closure - scale[joint] * turned) ** 2
    j0, j1 = max(joint - 1, 0), min(joint + 1, grid.size - 1)
    slopes = (turned[:, j1] - turned[:, j0]) / max(grid[j1] - grid[j0], step)
    joint_v = refine(active, joint, scale)
    formal_std = _two_parameter_std(slopes[active], turned[active, joint], sigma_cl, use_scale)
    jack_std = jackknife_std(active)
    dof = max(int(active.sum()) - (2 if use_scale else 1), 1)
    joint_std = max(formal_std * t_factor(dof), jack_std)
    picks: list[float] = []
    weights: list[float] = []
    for c, slope in zip(C, slopes, strict=True):
        interior = np.flatnonzero((c[1:-1] <= c[:-2]) & (c[1:-1] <= c[2:])) + 1
        if interior.size == 0:
            continue
        k = interior[np.argmin(np.abs(interior - joint))]
        den = c[k - 1] - 2.0 * c[k] + c[k + 1]
        off = 0.5 * (c[k - 1] - c[k + 1]) / den if den > 0 else 0.0
        picks.append(float(grid[k] + np.clip(off, -1.0, 1.0) * step))
        # weight: squared sensitivity of this curve's closure to delta G_y at the joint value
        weights.append(float(slope * slope))
    if not picks:
        return AyBiasScan(0.0, 0.0, 0.0, 0.0, 0.0, np.inf, [], [], 0, combine,
                          "no curve gave an interior minimum: delta G_y set to 0")
    arr, wts = np.array(picks), np.array(weights)
    if wts.sum() <= 0:
        wts = np.ones_like(arr)
    mean, median = float(arr.mean()), float(np.median(arr))
    wmedian = _weighted_median(arr, wts)
    chosen = {"weighted_median": wmedian, "median": median, "mean": mean, "joint": joint_v}[combine]
    std = joint_std
    reason = ""
    if active.sum() < min_curves:
        reason = (f"only {int(active.sum())} usable curves (at least {min_curves} needed to solve "
                  "delta G_y with the gyro scale): set to 0")
        chosen = 0.0
    elif not np.isfinite(std) or std > max_std:
        reason = (f"delta G_y = {chosen:.3f} +- {std:.2g} m/s^2 from {int(active.sum())} curves is "
                  f"too uncertain (limit {max_std}): the curves carry too little roll; set to 0")
        chosen = 0.0
    # the scan finds delta G_y (added to the reading); the bias is its negative
    return AyBiasScan(
        ay_bias=-chosen, ay_bias_mean=-mean, ay_bias_median=-median, ay_bias_wmedian=-wmedian,
        ay_bias_joint=-joint_v, ay_bias_std=float(std), per_curve=[-v for v in picks],
        weights=[float(x) for x in wts / wts.sum()], n_curves=int(active.sum()),
        combine=combine, reason=reason, formal_std=formal_std * t_factor(dof),
        jackknife_std=jack_std,
    )
