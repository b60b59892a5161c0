"""The GNSS Doppler's latency from its course rate against the lateral accelerometer (tyre-free).

:func:`sideslip.gnss_latency.identify_doppler_latency` times the Doppler speed against the
wheels, so a drive at constant speed (a step steer, a slalom at one speed, a race lap whose
wheels slip) leaves it undecided.  Such drives turn, and in a turn the Doppler velocity's
course rate lags the accelerometer the same way.  The antenna's acceleration normal to its
path is its speed times the course rate, ``v chi'`` (kinematics: no tyre, no slip angle and no
heading enter it), and the lateral accelerometer reads that acceleration tilted by the body's
roll and bank: ``a_y,m = a_n / cos(beta) + g sin(phi) + b_y`` (ISO roll; seed 000 eq 13 in our
sign), with ``beta`` a few degrees at most.

Model, per Doppler epoch ``k`` with both neighbours ``k -+ 1`` (consecutive epochs)::

    v_k wrap(chi_{k+1} - chi_{k-1}) / (t_{k+1} - t_{k-1}) = k_a A(t - tau) + c

``A`` the accelerometer's lateral reading averaged over the same span (the course difference is
the span's mean course rate), moved to the antenna (rigid body: plus ``dx r'`` and minus ``dz
p'`` for an antenna ``dx`` ahead of and ``dz`` above the IMU, ``p`` the roll rate) and less
``a_x sin(beta_kin)`` (the body's lateral reading is ``a_n cos(beta) + a_t sin(beta)``; the
kinematic sideslip ``l_r r / v``, large at parking speeds, stands for beta), ``k_a`` the gain
from the reading to the path's acceleration (below 1 by the suspension's roll tilt) and ``c``
the accelerometer's bias and a steady bank.  ``A(t - tau)`` is linearised, ``A(t - tau0) -
dtau A'``, and iterated: the accelerometer is moved by the last estimate and the residual
``dtau`` solved again, so neither the linearisation nor the central difference's attenuation of
``A'`` (sin(x) / x: 10 % in a 0.5 Hz slalom) biases the result.  An antenna the vehicle file
misplaces along x leads the course rate by ``dx r' / (v r)`` ~ ``dx / v``, so the fit reads it
as a latency of ``-dx / v``; taken at that latency, the Doppler's course in a turn is right
again (both move it by ``r`` times the same time).  Receivers slower than 5 Hz are left to the
speed fit (:data:`MAX_EPOCH_SPACING_S`).

Where the road's bank changes in the turns (the car's roll is not just its suspension's), the
gravity term moves with ``A`` and reads as lag; with a roll gyro the fit is also solved with the
roll angle it integrates, ``g phi`` (its gain free, a constant and a drift per
:data:`ROLL_SEGMENT_S` for the gyro's bias), and that fit is taken where it explains the course
rate better (residual scale below :data:`ROLL_FIT_GAIN` of the plain fit's): on a flat slalom
the roll follows ``A`` and adds only collinearity.  Solved with Huber weights (multipath), the
epochs inside the rate's span counted as one sample.

Measured (simulator, seed 0, 10 Hz Doppler 0 / 50 / 100 ms late; the speed fit's sigma in
brackets): race_lap +0.002 / +0.052 / +0.102 +- 0.006 s (0.05 s), slalom_low_mu -0.005 / +0.045 /
+0.095 +- 0.016 (hours), cr_slalom -0.004 / +0.046 / +0.096 +- 0.011, cr_limit_slalom -0.007 /
+0.042 / +0.091 +- 0.007-0.008 (CommonRoad's multi-body truth), dlc_bank (bank changes: the roll
fit) -0.004 / +0.042 / +0.089 +- 0.021, two_turns_gyro_sf +- 0.041, step_steer (one turn)
+- 0.059; gentle drives (urban, highway) +- 0.04-0.08.  The antenna's roll-rate term moves
these by -0.005 to -0.017 s and halves cr_limit_slalom's sigma (0.015 without it).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from sideslip import gnss
from sideslip.drive import Drive
from sideslip.frames import wrap_angle
from sideslip.signals import interpolate, reversing, sample_step
from sideslip.vehicle import G

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

MIN_SPEED_M_S = 3.0  # epochs slower than this are left out (course noise)
MIN_EPOCHS = 50  # epochs needed for an estimate
# the span's mean course rate times the speed at its centre is the mean normal acceleration
# only while neither changes much within the span: at 1 Hz (suburban_outages: braking into
# the turns) the fit read +0.034 +- 0.004 s at a true 0, so slower receivers are left to the
# speed fit (5 Hz receivers pass: their stamps' median spacing may read a hair over 0.2 s,
# 0.20000000000000284 on a table of 0.01 s rows, and real stamps jitter by milliseconds)
MAX_EPOCH_SPACING_S = 0.2
EPOCH_SPACING_TOLERANCE = 1.05
RATE_HALF_S = 0.25  # half-span of the central difference of the averaged accelerometer
MAX_SPAN_FACTOR = 2.5  # k-1 .. k+1 span at most this many median epoch spacings (no gaps)
ITERATIONS = 4  # accelerometer moved by the estimate and the residual solved again
GAIN_RANGE = (0.5, 1.5)  # k_a outside: the fit does not describe a lag (bank, bad data)
ROLL_FIT_GAIN = 0.9  # the roll fit is taken where its residual scale is below this share
ROLL_SEGMENT_S = 120.0  # the integrated roll gyro's offset and drift: one pair per segment
HUBER_K = 1.5  # Huber threshold, in robust sigmas of the residual
MIN_ROLL_GYRO_SHARE = 0.95  # of the rows: a roll gyro with more gaps is not integrated
REGULAR_SPACING = 1.5  # samples at most this x their median spacing apart bound no gap


Lookup = Callable[[FloatArray, FloatArray], FloatArray]


def _lookup(t: FloatArray) -> Lookup:
    """``f(q, values)``: ``values`` (sampled on ``t``) linearly interpolated at the times ``q``,
    held at the ends (as ``np.interp``).  On a uniform time base (the usual logger) the index
    is computed, not searched: four times faster on an hour's drive."""
    step = (t[-1] - t[0]) / max(t.size - 1, 1)
    if t.size < 2 or step <= 0.0 or np.max(np.abs(np.diff(t) - step)) > 1e-6 * step:
        return lambda q, values: np.interp(q, t, values)
    last = t.size - 1

    def uniform(q: FloatArray, values: FloatArray) -> FloatArray:
        pos = np.clip((q - t[0]) / step, 0.0, float(last))
        i = np.minimum(pos.astype(np.intp), last - 1)
        frac = pos - i
        return values[i] * (1.0 - frac) + values[i + 1] * frac

    return uniform


def _span_mean(at: Lookup, cum: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Mean over ``[lo, hi]`` of the signal whose running integral is ``cum`` (``at``: its
    :func:`_lookup`)."""
    return np.asarray((at(hi, cum) - at(lo, cum)) / (hi - lo), dtype=float)


def _running_integral(t: FloatArray, values: FloatArray) -> FloatArray:
    """Trapezoidal running integral of ``values`` on ``t``, starting at 0."""
    steps = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return np.concatenate(([0.0], np.cumsum(steps)))


def _within(values: FloatArray, w: FloatArray, seg: IntArray, ramp: FloatArray | None) -> FloatArray:
    """``values`` (n, m) less their weighted least-squares fit, per segment ``seg``, on a
    constant (and the ``ramp`` where given): the nuisance regressors taken out by
    Frisch-Waugh-Lovell, so that a long drive's per-segment offsets cost O(n), not an (n x
    2 segments) design matrix."""
    m = values.shape[1]
    nseg = int(seg.max()) + 1
    cells = (seg[:, None] + nseg * np.arange(m)[None, :]).ravel()

    def per_segment(x: FloatArray) -> FloatArray:  # (n,) -> (nseg,)
        return np.asarray(np.bincount(seg, weights=x, minlength=nseg), dtype=float)

    def per_segment_column(x: FloatArray) -> FloatArray:  # (n, m) -> (nseg, m)
        sums = np.bincount(cells, weights=x.ravel(), minlength=nseg * m)
        return np.asarray(sums, dtype=float).reshape(m, nseg).T

    s0 = np.maximum(per_segment(w), 1e-300)
    sv = per_segment_column(w[:, None] * values)
    if ramp is None:
        return values - (sv / s0[:, None])[seg]
    s1, s2 = per_segment(w * ramp), per_segment(w * ramp * ramp)
    srv = per_segment_column((w * ramp)[:, None] * values)
    det = s0 * s2 - s1 * s1
    ok = det > 1e-12 * s0 * np.maximum(s2, 1e-300)
    safe = np.where(ok, det, 1.0)[:, None]
    a = np.where(ok[:, None], (s2[:, None] * sv - s1[:, None] * srv) / safe, sv / s0[:, None])
    b = np.where(ok[:, None], (s0[:, None] * srv - s1[:, None] * sv) / safe, 0.0)
    return np.asarray(values - a[seg] - b[seg] * ramp[:, None], dtype=float)


def _huber(
    X: FloatArray, y: FloatArray, seg: IntArray, ramp: FloatArray | None
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """Huber-weighted least squares of ``y`` on ``X`` plus a constant (and ``ramp``) per
    segment ``seg``: the coefficients of ``X``, their unscaled inverse normal matrix and the
    residuals; None where ``X`` is singular once the segments' offsets are taken out."""
    w = np.ones(y.size)
    beta = np.zeros(X.shape[1])
    resid = y
    xw = X
    for _ in range(6):
        both = _within(np.column_stack([X, y]), w * w, seg, ramp)
        xw, yw = both[:, :-1] * w[:, None], both[:, -1] * w
        beta = np.asarray(np.linalg.lstsq(xw, yw, rcond=None)[0], dtype=float)
        resid = both[:, -1] - both[:, :-1] @ beta
        scale = 1.4826 * float(np.median(np.abs(resid)))
        if scale <= 0.0:
            break
        w = np.sqrt(np.minimum(1.0, HUBER_K * scale / np.maximum(np.abs(resid), 1e-12)))
    try:
        inv = np.asarray(np.linalg.inv(xw.T @ xw), dtype=float)
    except np.linalg.LinAlgError:
        return None
    return beta, inv, resid


def _sampled(t: FloatArray, x: FloatArray) -> FloatArray:
    """Column ``x`` linearly interpolated between its samples where they are at most
    :data:`REGULAR_SPACING` of their own median spacing apart, NaN in its gaps: an IMU slower
    than the table (NaN between its samples) is read at its own rate, not as gaps everywhere
    (the fit read nothing from a 50 Hz IMU in a 100 Hz table)."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    if ok.all() or ok.sum() < 2:
        return x
    filled = interpolate(x, t, REGULAR_SPACING * sample_step(t, x))
    filled[ok] = x[ok]
    return filled


def lateral_doppler_latency(
    drive: Drive, lever_x_m: float = 0.0, lever_z_m: float = 0.0, lr_m: float = 0.0
) -> tuple[float, float, float] | None:
    """The Doppler's latency ``tau`` (s: an epoch stamped at t reports the velocity at
    t - tau), its 1-sigma and the gain ``k_a``, from the course rate against the lateral
    accelerometer (module docstring).  ``lever_x_m``: the antenna ahead of the IMU (m).  None
    without Doppler, ``ay`` and ``wz``, with under :data:`MIN_EPOCHS` usable epochs, or where
    the fit's gain is outside :data:`GAIN_RANGE`."""
    if not all(name in drive for name in ("gnss_ve", "gnss_vn", "ay", "wz")):
        return None
    dop = gnss.doppler_samples(drive)
    if dop.rows.size < MIN_EPOCHS + 2:
        return None
    t = drive.t
    tc = t[dop.rows]
    course = np.arctan2(dop.vn, dop.ve)
    speed = dop.speed
    k = np.arange(1, tc.size - 1)
    lo, hi = tc[k - 1], tc[k + 1]
    span = hi - lo
    spacing = float(np.median(np.diff(tc)))
    if spacing > MAX_EPOCH_SPACING_S * EPOCH_SPACING_TOLERANCE:
        return None
    ay = _sampled(t, drive["ay"])
    wz = _sampled(t, drive["wz"])
    bad = ~(np.isfinite(ay) & np.isfinite(wz))
    # reversing (a signed wheel or CAN speed): the path's left is the body's right there
    cum_bad = _running_integral(t, (bad | reversing(drive)).astype(float))
    cum_ay = _running_integral(t, np.where(bad, 0.0, ay))
    wz_clean = np.where(bad, 0.0, wz)
    wx_clean = None
    wx_raw = _sampled(t, drive["wx"]) if "wx" in drive else np.full(t.size, np.nan)
    if "wx" in drive:
        wx_clean = np.where(np.isfinite(wx_raw), wx_raw, 0.0)
    edge = RATE_HALF_S + 1.0
    use = (
        (span > 0.0) & (span <= MAX_SPAN_FACTOR * 2.0 * spacing)
        & (np.minimum(np.minimum(speed[k - 1], speed[k]), speed[k + 1]) > MIN_SPEED_M_S)
        & (tc[k] - t[0] > edge) & (t[-1] - tc[k] > edge)
    )  # fmt: skip
    # no sensor gap and no reversing anywhere the accelerometer is read (the span, moved by
    # up to +-1 s)
    at = _lookup(t)
    use &= (at(hi + 1.0, cum_bad) - at(lo - 1.0, cum_bad)) == 0.0
    if int(use.sum()) < MIN_EPOCHS:
        return None
    k, lo, hi, span = k[use], lo[use], hi[use], span[use]
    y = speed[k] * wrap_angle(course[k + 1] - course[k - 1]) / span

    cum_corr = None
    if lr_m and "ax" in drive:
        # the body's lateral reading is a_n cos(beta) + a_t sin(beta): the kinematic sideslip
        # l_r r / v of a car whose rear axle does not slide (large at parking speeds) times the
        # longitudinal reading is taken off, before the span's mean
        v_row = np.interp(t, tc, speed)
        beta_kin = np.arctan(lr_m * wz_clean / np.maximum(v_row, MIN_SPEED_M_S))
        ax_row = np.asarray(drive["ax"], dtype=float)
        corr = np.where(np.isfinite(ax_row), ax_row, 0.0) * np.sin(beta_kin)
        cum_corr = _running_integral(t, np.where(bad, 0.0, corr))

    # one running quantity whose change over a span, over the span, is the reading there: the
    # integrated accelerometer (less a_x sin(beta_kin)) plus dx r - dz p (their changes over
    # the span are the integrals of dx r' - dz p')
    moved = cum_ay if cum_corr is None else cum_ay - cum_corr
    if lever_x_m:
        moved = moved + lever_x_m * wz_clean
    if lever_z_m and wx_clean is not None:
        moved = moved - lever_z_m * wx_clean

    def reading(shift: float) -> FloatArray:
        """The accelerometer over each epoch's span moved ``shift`` seconds earlier, at the
        antenna."""
        return _span_mean(at, moved, lo - shift, hi - shift)

    roll = None
    wx_ok = np.isfinite(wx_raw)
    if wx_ok.mean() >= MIN_ROLL_GYRO_SHARE:
        # the roll gyro's gaps (an IMU's first rows, dropouts) interpolated: a gap of a few
        # rows took the roll term away (dlc_bank with the IMU 20 ms late: no fit at all)
        wx = np.interp(t, t[wx_ok], wx_raw[wx_ok])
        roll = G * _running_integral(t, wx - float(np.median(wx)))
    per_sample = max(2.0 * RATE_HALF_S / spacing, 1.0)
    one_segment = np.zeros(k.size, dtype=np.intp)
    since = tc[k] - tc[k[0]]
    seg = (since // ROLL_SEGMENT_S).astype(np.intp)  # the roll fit's offset-and-drift segments
    ramp = since / ROLL_SEGMENT_S - seg
    best: tuple[float, float, float, float] | None = None  # tau, sigma, gain, residual scale
    for with_roll in (False, True) if roll is not None else (False,):
        tau = 0.0
        fit = None
        for _ in range(ITERATIONS):
            a = reading(tau)
            a_rate = (reading(tau - RATE_HALF_S) - reading(tau + RATE_HALF_S)) / (2.0 * RATE_HALF_S)
            if with_roll and roll is not None:
                phi = 0.5 * (at(hi - tau, roll) + at(lo - tau, roll))
                fit = _huber(np.column_stack([a, -a_rate, phi]), y, seg, ramp)
            else:
                fit = _huber(np.column_stack([a, -a_rate]), y, one_segment, None)
            if fit is None or not np.isfinite(fit[0][:2]).all() or fit[0][0] <= 0.0:
                fit = None
                break
            step = float(fit[0][1] / fit[0][0])
            tau = min(max(tau + step, -0.5), 1.0)
            if abs(step) < 1e-4:
                break
        if fit is None:
            continue
        coef, inv, resid = fit
        gain = float(coef[0])
        if not GAIN_RANGE[0] <= gain <= GAIN_RANGE[1]:
            continue
        scale = 1.4826 * float(np.median(np.abs(resid)))
        sigma = math.sqrt(max(float(inv[1, 1]), 0.0) * per_sample) * scale / gain
        if best is None or (with_roll and scale < ROLL_FIT_GAIN * best[3]):
            best = (tau, sigma, gain, scale)
    if best is None or not math.isfinite(best[1]):
        return None
    return best[0], best[1], best[2]
