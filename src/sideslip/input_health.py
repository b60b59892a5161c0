"""What the inputs themselves say about each row: dropouts, clock jumps, implausible wheel speeds.

A method's own ``health`` comes from its residuals (windowed NIS, output error), and those cannot
see information that is *missing*: a filter coasting through a sensor dropout fits its few
measurements perfectly.  This module flags, once for every method, the rows where an input the
method reads is unusable, and :func:`sideslip.methods.registry.run_method` combines it with the
method's own health (the larger of the two wins):

* **dropout**: a per-row input the method requires (IMU, speed, steering — not GNSS, whose
  outages the methods' own covariance carries) has had no finite sample for longer than
  ``max(5 x its median sample interval, 0.2 s)``; health rises linearly to 1 over the next
  second of silence;
* **clock jump**: a time step longer than ``max(1 s, 50 x the median step)`` carries no
  continuity; the rows of the next ``recover_s`` seconds are flagged (1 at the jump, decaying
  linearly), the time a filter needs to re-converge;
* **implausible wheel speed**: the speed the method reads changes faster than any road vehicle
  can accelerate or brake (``|dv| > 1.5 g dt + 0.5 m/s`` over spans of at least 0.1 s;
  tyre-road friction limits the body to about 1.2 g): a locked or spinning wheel, a CAN
  glitch.  From that sample on, the row stays flagged until the speed again agrees with the
  accelerometer-integrated speed from the last trusted sample (within ``1 m/s + 10 %``), at
  most ``MAX_EVENT_S``.

One compiled pass per input (O(N), a few bytes per row of temporaries) plus the short forward
scan of each wheel-speed event.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.vehicle import G

FloatArray = NDArray[np.float64]

IMPLAUSIBLE_ACCEL = 1.5 * G  # m/s^2: beyond what tyre-road friction (~1.2 g) allows the body
WHEEL_AGREE_ABS = 1.0  # m/s: wheel speed back within this (+10 %) of the ax-integrated speed
MAX_EVENT_S = 10.0  # s: longest span one implausible jump keeps the wheels flagged
JUMP_SPAN_S = 0.1  # s: speed changes are judged over at least this span
JUMP_NOISE = 0.5  # m/s: allowance for wheel-speed noise and quantisation over that span


@numba.njit(cache=True)
def _sample_intervals(values: FloatArray, t: FloatArray) -> FloatArray:  # pragma: no cover
    """Time steps (s) between consecutive finite samples of ``values``."""
    n_ok = 0
    for k in range(values.size):
        if math.isfinite(values[k]):
            n_ok += 1
    out = np.empty(max(n_ok - 1, 0))
    last, j = -1, 0
    for k in range(values.size):
        if math.isfinite(values[k]):
            if last >= 0:
                out[j] = t[k] - t[last]
                j += 1
            last = k
    return out


@numba.njit(cache=True)
def _dropout(values: FloatArray, t: FloatArray, allowed: float,
             out: FloatArray) -> None:  # pragma: no cover - compiled
    """out = max(out, clip(age - allowed, 0, 1)), age = time since the last finite sample
    (0 before the first: the method's prior covers it)."""
    last = -1
    for k in range(values.size):
        if math.isfinite(values[k]):
            last = k
        if last >= 0:
            h = min(max((t[k] - t[last] - allowed) / 1.0, 0.0), 1.0)
            if h > out[k]:
                out[k] = h


def dropout_health(values: FloatArray, t: FloatArray, out: FloatArray | None = None) -> FloatArray:
    """0 while the sensor reports, rising to 1 over a second past its allowed silence.

    ``out``: an array to raise in place to the larger of itself and this health (memory)."""
    health = np.zeros(t.size) if out is None else out
    steps = _sample_intervals(np.asarray(values, dtype=float), t)
    if steps.size < 1:
        return health
    interval = float(np.median(steps))
    del steps
    _dropout(np.asarray(values, dtype=float), t, max(5.0 * interval, 0.2), health)
    return health


def clock_jump_health(t: FloatArray, recover_s: float = 5.0) -> FloatArray:
    """1 on the first row after a clock jump, decaying to 0 over ``recover_s`` seconds."""
    out = np.zeros(t.size)
    if t.size < 3:
        return out
    dt = np.diff(t)
    limit = max(1.0, 50.0 * float(np.median(dt)))
    for k in np.flatnonzero(dt > limit) + 1:
        span = (t >= t[k]) & (t < t[k] + recover_s)
        out[span] = np.maximum(out[span], 1.0 - (t[span] - t[k]) / recover_s)
    return out


def wheel_speed_health(speed: FloatArray, t: FloatArray, ax: FloatArray | None) -> FloatArray:
    """1 from a physically impossible speed change until the speed rejoins the ax-integrated
    speed (module docstring); 0 elsewhere."""
    out = np.zeros(t.size)
    starts = _jump_starts(speed, t, IMPLAUSIBLE_ACCEL, JUMP_SPAN_S, JUMP_NOISE)
    if starts.size == 0:
        return out
    ax_held = np.zeros(t.size)
    if ax is not None:
        ok = np.isfinite(ax)
        if ok.any():
            ax_held = np.interp(t, t[ok], ax[ok])
    end_prev = -1
    for start in starts:  # the last trusted sample before each event
        if start <= end_prev:
            continue
        stop = int(np.searchsorted(t, t[start] + MAX_EVENT_S, side="right"))
        seg = slice(start, stop)
        v_pred = speed[start] + np.concatenate(
            ([0.0], np.cumsum(0.5 * (ax_held[seg][1:] + ax_held[seg][:-1]) * np.diff(t[seg])))
        )
        v_meas = speed[seg]
        bad = np.isfinite(v_meas) & (np.abs(v_meas - v_pred) > WHEEL_AGREE_ABS + 0.1 * np.abs(v_pred))
        bad[0] = False
        after = np.flatnonzero(bad)
        if after.size == 0:
            continue
        # flagged from the first disagreeing sample to the last one before agreement returns
        first = after[0]
        agree = np.flatnonzero(~bad[first:] & np.isfinite(v_meas[first:]))
        last = first + (agree[0] if agree.size else bad.size - first)
        out[start + first : start + last] = 1.0
        end_prev = start + last
    return out


@numba.njit(cache=True)
def _jump_starts(speed: FloatArray, t: FloatArray, accel: float, span_s: float, noise: float
                 ) -> NDArray[np.int64]:  # pragma: no cover - compiled
    """Rows of the first sample of each run of implausible speed changes: over at least
    ``span_s`` (to the first later sample at or past it, else the last sample) the speed
    changes by more than ``accel`` dt + ``noise``.  Finite samples only."""
    n = speed.size
    last_ok, n_ok = -1, 0
    for k in range(n):
        if math.isfinite(speed[k]):
            last_ok = k
            n_ok += 1
    starts = [0 for _ in range(0)]
    if n_ok < 3:
        return np.empty(0, dtype=np.int64)
    p = 0
    prev_jump = False
    for i in range(n):
        if not math.isfinite(speed[i]):
            continue
        target = t[i] + span_s
        while p < n and (not math.isfinite(speed[p]) or t[p] < target):
            p += 1
        later = p if p < n else last_ok
        jump = later > i and abs(speed[later] - speed[i]) > accel * (t[later] - t[i]) + noise
        if jump and not prev_jump:
            starts.append(i)
        prev_jump = jump
    out = np.empty(len(starts), dtype=np.int64)
    for j in range(len(starts)):
        out[j] = starts[j]
    return out


PER_ROW_INPUTS = frozenset(
    ("ax", "ay", "az", "wx", "wy", "wz", "steer", "v_fl", "v_fr", "v_rl", "v_rr", "v_can")
)


def input_health(drive: Drive, columns: Iterable[str], speed: FloatArray | None = None) -> FloatArray:
    """Per-row input health (0 good ... 1 unusable) for a method reading ``columns``.

    ``speed``: the speed samples the method reads (wheel speeds or ``v_can``; NaN between
    samples), checked for implausible changes against ``ax`` when the drive has it.
    """
    t = drive.t
    health = clock_jump_health(t)
    for name in columns:
        if name in PER_ROW_INPUTS and name in drive:
            dropout_health(drive[name], t, out=health)
    if speed is not None:
        ax = drive["ax"] if "ax" in drive else None
        np.maximum(health, wheel_speed_health(np.asarray(speed, dtype=float), t, ax), out=health)
    return health
