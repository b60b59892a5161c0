"""Gaps in the fused estimator's IMU inputs: how a missing sample is filled and how wrong the
fill may be.

The gyro and accelerometer are inputs of the process model, not measurements: a row without
a sample still needs a value.  The smoother fills a gap by linear interpolation between the
samples either side of it (it has the later one), the causal filter holds the last sample.
Either fill is wrong by however much the signal changed inside the gap, and integrated into the
heading and the velocities that error is not the gyro's white noise: a 0.5 s hole in the yaw
gyro on a race lap (0.5 rad/s of yaw rate changing within it) turned the heading by degrees,
and with the fill taken as exact the filter kept the error as sideslip after the gap.

The fill's error sigma is read from the drive itself (how much the signal changes over the
gap's span elsewhere in the drive), and the process noise of the states the input drives
grows by it for the length of the gap.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["Filled", "causal_between_samples", "fill_input", "gap_increments", "gap_noise_density"]


class Filled(NamedTuple):
    """A sensor column with its gaps filled: ``values``; the 1-sigma error of the input over
    the interval ending at each row (0 where the row and the one before it carry samples one
    table step apart); the length (s) of the gap each row lies in (0 outside gaps)."""

    values: FloatArray
    sigma: FloatArray
    gap_s: FloatArray


_SPAN_POINTS = 12  # spans of the change statistic, log-spaced from the row step to the gap
_MAX_POINTS = 20000  # sample times the statistic is taken over (evenly thinned)
# a step of the table this many times its median is a pause of the logger (rows missing, not
# cells): the input over it is the sample before it, held
PAUSE_STEPS = 3.0
# two samples of a column at most this many times its median sample spacing apart bound no gap
REGULAR_SPACING = 1.5


def fill_input(t: FloatArray, values: FloatArray, interpolate: bool) -> Filled:
    """A sensor column with its gaps filled, the fill's 1-sigma error per row and the gaps'
    lengths (:class:`Filled`).

    ``interpolate``: linear interpolation between the samples either side (off-line; the
    error then grows towards the middle of a gap, with the span to the nearer sample), else
    the last sample held (causal; the error grows with the time since it).  Before the first
    and after the last sample the nearest sample is held.  The sigma at a span ``tau`` is the
    root-mean-square change of the signal over ``tau`` across the whole drive (its own
    dynamics, and twice its white noise's variance at short spans); 0 on rows with a sample,
    except a row that follows a pause of the logger (a table step over :data:`PAUSE_STEPS`
    times the median): the input held over that step is wrong by the change over the step.
    A column with no sample at all is 0 everywhere, with sigma 0 (the caller decides what a
    missing sensor means).  A row between two samples at most :data:`REGULAR_SPACING` times
    the column's median sample spacing apart is no gap (a sensor slower than the table):
    filled, with sigma 0."""
    n = t.size
    v = np.asarray(values, dtype=float)
    ok = np.isfinite(v)
    step = np.diff(t, prepend=t[0]) if n else np.zeros(0)
    pause = step > PAUSE_STEPS * float(np.median(step[1:])) if n > 2 else np.zeros(n, dtype=bool)
    if not ok.any() or (ok.all() and not pause.any()):
        none = np.broadcast_to(np.float64(0.0), (n,))  # read-only zeros without the memory
        return Filled(v.copy() if ok.all() else np.zeros(n), none, none)
    sigma = np.zeros(n)
    ts, vs = t[ok], v[ok]
    rows = np.arange(n)
    prev = np.where(ok, rows, -1)
    np.maximum.accumulate(prev, out=prev)
    nxt = np.where(ok, rows, n)
    nxt = np.minimum.accumulate(nxt[::-1])[::-1]
    before = np.where(prev >= 0, t - t[np.maximum(prev, 0)], np.inf)
    after = np.where(nxt < n, t[np.minimum(nxt, n - 1)] - t, np.inf)
    if interpolate:
        filled = np.interp(t, ts, vs)
        span = np.minimum(before, after)
    else:
        filled = np.where(prev >= 0, v[np.maximum(prev, 0)], vs[0])
        span = np.where(prev >= 0, before, after)
    # rows between two samples no further apart than the column's own spacing allows are not
    # a gap: a sensor slower than the table (a 20 Hz IMU in a 100 Hz table, NaN between its
    # samples) is filled there as its own rate gives it.  A column at the table's rate has
    # its spacing the table's step, so one missing row is a gap as before.  (Every row between
    # two 20 Hz samples taken for a gap: the Revs lap's fused 0.41 -> 1.31 deg.)
    own_step = float(np.median(np.diff(ts))) if ts.size > 1 else np.inf
    regular = (before + after <= REGULAR_SPACING * own_step) | (np.minimum(before, after) < own_step) & (
        np.isinf(before) | np.isinf(after)
    )  # between two samples, or within one spacing before the first or after the last
    gap = ~ok & ~regular
    length = np.where(gap, np.minimum(before + after, t[-1] - t[0]), 0.0)
    paused = pause & ok
    span = np.where(paused, step, span)
    length = np.where(paused, step, length)
    need = gap | paused
    if need.any():
        sigma[need] = _change_sigma(ts, vs, span[need])
    return Filled(filled, sigma, length)


def _change_sigma(ts: FloatArray, vs: FloatArray, span: FloatArray) -> FloatArray:
    """RMS of ``v(t + tau) - v(t)`` over the drive's samples, at each ``tau`` of ``span``
    (interpolated in log tau between a few spans; beyond the drive's length the largest)."""
    out = np.zeros(span.size)
    total = float(ts[-1] - ts[0])
    if ts.size < 3 or total <= 0.0:
        return out
    step = float(np.median(np.diff(ts)))
    lo = max(step, 1e-3)
    hi = min(max(float(span.max()), lo), 0.5 * total)
    grid = np.geomspace(lo, max(hi, lo * 1.0001), _SPAN_POINTS)
    base = ts[:: max(1, ts.size // _MAX_POINTS)]
    rms = np.empty(grid.size)
    for m, tau in enumerate(grid):
        t0 = base[base + tau <= ts[-1]]
        d = np.interp(t0 + tau, ts, vs) - np.interp(t0, ts, vs)
        rms[m] = float(np.sqrt(np.mean(d * d))) if d.size else 0.0
    rms = np.maximum.accumulate(rms)  # a longer span never changes the signal less
    tau = np.clip(span, grid[0], grid[-1])
    out[:] = np.interp(np.log(tau), np.log(grid), rms)
    return out


def gap_increments(t: FloatArray, sigma: FloatArray) -> FloatArray:
    """Per row, the variance the fill error adds to its own integral over the interval ending
    at the row (rad^2 for a gyro, (m/s)^2 for an accelerometer).  Inside one gap the error is
    one and the same excursion, not white: its integral's variance at time T is S(T)^2, with
    S the integral of ``sigma`` since the gap began, so the interval adds S_i^2 - S_(i-1)^2,
    and a gap adds (integral of sigma over it)^2 in all: the heading error of a rate held
    wrong throughout.  Rows with sigma 0 end a gap."""
    n = t.size
    if n < 2 or not (sigma > 0.0).any():
        return np.zeros(n)
    dt = np.diff(t, prepend=t[0])
    c = np.cumsum(sigma * dt)
    real = sigma <= 0.0
    start = np.where(real, np.arange(n), -1)
    np.maximum.accumulate(start, out=start)
    s = c - np.where(start >= 0, c[np.maximum(start, 0)], 0.0)
    s_prev = np.concatenate(([0.0], s[:-1]))
    s_prev[real] = 0.0
    return np.asarray(np.where(real, 0.0, s * s - s_prev * s_prev), dtype=float)


def gap_noise_density(t: FloatArray, sigma: FloatArray) -> FloatArray:
    """:func:`gap_increments` per second of each row's interval (variance per second; 0 on
    the first row): the process noise density of the fill error's integral."""
    inc = gap_increments(t, sigma)
    dt = np.diff(t, prepend=t[0])
    return np.asarray(np.where(dt > 0.0, inc / np.where(dt > 0.0, dt, 1.0), 0.0), dtype=float)


def causal_between_samples(
    t: FloatArray, rows: NDArray[np.intp], values: FloatArray, nodes: NDArray[np.intp], max_span_s: float
) -> FloatArray:
    """A column of a sensor slower than its table (``values`` holding the sample at ``rows``
    on the rows up to the next one) linearly interpolated between two samples at most
    ``max_span_s`` apart wherever the later sample is in by the node (of the sorted row
    indices ``nodes``) that closes the row's step; held where it is not (a causal filter
    whose node precedes the next sample cannot read it) and outside the samples.  The
    sample rows keep their values."""
    n = t.size
    out = np.array(values, dtype=float, copy=True)
    if rows.size < 2 or nodes.size == 0:
        return out
    r = np.arange(n)
    k = np.searchsorted(rows, r, side="right") - 1  # the sample at or before each row
    inside = (k >= 0) & (k < rows.size - 1)
    kk = np.clip(k, 0, rows.size - 2)
    a, b = rows[kk], rows[kk + 1]
    # the node closing each row's step: the first node after the row (the last row: itself)
    m = np.searchsorted(nodes, r, side="right")
    closing = np.where(m < nodes.size, nodes[np.minimum(m, nodes.size - 1)], n - 1)
    ok = inside & (b <= closing) & (t[b] - t[a] <= max_span_s) & (r != a)
    w = np.where(ok, (t - t[a]) / np.where(t[b] > t[a], t[b] - t[a], 1.0), 0.0)
    out[ok] = values[a[ok]] + w[ok] * (values[b[ok]] - values[a[ok]])
    return out
