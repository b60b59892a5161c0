"""Signal helpers shared by the methods: alignment, speed, GNSS course, standstill, reversing.

Slower sensors leave NaN on rows where they have no sample (contract section 1).  Methods that
need a value at every row use a *zero-order hold* of the latest real sample together with its
age, never an interpolated future value: no sample is invented, and a filter can tell a fresh
measurement (age 0) from a held one.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import WHEEL_SPEEDS, Drive
from sideslip.frames import wrap_angle

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

STANDSTILL_SPEED = 0.1  # m/s: below this the vehicle is taken as standing still
GNSS_COURSE_MIN_SPEED = 3.0  # m/s: below this a Doppler course is too noisy to use


def kernel_input(values: FloatArray) -> FloatArray:
    """``values`` as a read-only, C-contiguous float64 view (copied only when not already
    float64 and contiguous).  numba compiles a kernel once per combination of its arrays'
    types, and read-only is a type: a drive's own columns are read-only, arrays derived from
    them writable, so a kernel fed both compiled once per mix (``ekf_loop``: nine mixes of 4 s
    each in one test run).  Fed through here it compiles once."""
    view = np.ascontiguousarray(values, dtype=np.float64).view()
    view.flags.writeable = False
    return view


def sample_rows(values: FloatArray) -> NDArray[np.intp]:
    """Row indices where a sensor has a real sample (finite value)."""
    return np.flatnonzero(np.isfinite(values))


def hold(values: FloatArray, t: FloatArray, fill: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """Zero-order hold of a sparse series onto every row.

    Returns ``(held, age_s)``: the latest real sample at or before each row, and its age in s.
    Rows before the first sample get ``fill`` with age ``inf``.
    """
    ok = np.isfinite(values)
    idx = np.where(ok, np.arange(values.size), -1)
    np.maximum.accumulate(idx, out=idx)
    held = np.where(idx >= 0, values[np.maximum(idx, 0)], fill)
    age = np.where(idx >= 0, t - t[np.maximum(idx, 0)], np.inf)
    return held.astype(float), age.astype(float)


def sample_step(t: FloatArray, x: FloatArray) -> float:
    """Median spacing (s) of the samples of column ``x`` on the time base ``t``: the table's
    step for a sensor on every row, longer for one slower than the table (NaN between its
    samples: a 20 Hz IMU in a 100 Hz table, 0.05 s).  Its white noise's density is sigma^2
    times this, not times the table's step.  The table's step where ``x`` has under two
    samples."""
    rows = np.flatnonzero(np.isfinite(x))
    if rows.size < 2:
        return float(np.median(np.diff(t))) if t.size > 1 else 0.0
    return float(np.median(np.diff(t[rows])))


def interpolate(values: FloatArray, t: FloatArray, max_gap_s: float = np.inf) -> FloatArray:
    """Linear interpolation between real samples (offline use), NaN across gaps > max_gap_s.

    Outside the first/last sample the series is held constant.  Rows in a gap longer than
    ``max_gap_s`` stay NaN so that callers see the gap.
    """
    ok = np.isfinite(values)
    if not ok.any():
        return np.full_like(t, np.nan)
    out = np.interp(t, t[ok], values[ok])
    if np.isfinite(max_gap_s):
        ts = t[ok]
        k = np.clip(np.searchsorted(ts, t), 1, ts.size - 1) if ts.size > 1 else None
        if k is not None:
            gap = ts[k] - ts[k - 1]
            inside = (t > ts[0]) & (t < ts[-1])
            out[inside & (gap > max_gap_s)] = np.nan
    return out


def _wheel_names(drive: Drive, prefer: str) -> list[str]:
    names = ("v_rl", "v_rr") if prefer == "rear" else WHEEL_SPEEDS
    present = [n for n in names if n in drive]
    if len(present) < (2 if prefer == "rear" else 1):
        present = [n for n in WHEEL_SPEEDS if n in drive]
    return present


def wheel_speed(drive: Drive, prefer: str = "rear") -> FloatArray | None:
    """Vehicle speed (m/s) from wheel speeds: mean of the rear (undriven on FWD cars) or all.

    ``prefer='rear'`` uses the rear pair when both exist, else every wheel present.  Rows with no
    wheel sample stay NaN.  Returns None when the drive has no wheel speed.  Summed one wheel
    at a time (a few bytes per row of temporaries, not a stack of every wheel).
    """
    names = _wheel_names(drive, prefer)
    if not names:
        return None
    count = np.zeros(len(drive))
    total = np.zeros(len(drive))
    for k, name in enumerate(names):
        col = drive[name]
        ok = np.isfinite(col)
        count += ok
        if k == 0:
            total = np.where(ok, col, 0.0)
        else:
            total += np.where(ok, col, 0.0)
        del col, ok
    np.divide(total, np.maximum(count, 1.0), out=total)
    total[count == 0] = np.nan
    return total


def vehicle_speed(drive: Drive) -> FloatArray:
    """Signed longitudinal speed (m/s) on every row, held between samples, never NaN.

    Source order: rear wheel speeds, any wheel speeds, CAN speed, GNSS horizontal speed.  A
    drive with none of them gives zeros.  Use :func:`speed_source` to know which was used.
    """
    raw = speed_raw(drive)
    if raw is None:
        return np.zeros_like(drive.t)
    held, _ = hold(raw, drive.t, fill=float(raw[np.isfinite(raw)][0]) if np.isfinite(raw).any() else 0.0)
    return held


def speed_source(drive: Drive) -> str:
    """Which column(s) :func:`vehicle_speed` reads: 'wheels', 'v_can', 'gnss' or 'none'."""
    if _wheel_names(drive, "rear"):
        return "wheels"
    if "v_can" in drive:
        return "v_can"
    if "gnss_ve" in drive and "gnss_vn" in drive:
        return "gnss"
    return "none"


def speed_raw(drive: Drive) -> FloatArray | None:
    """The speed samples behind :func:`vehicle_speed` (NaN between samples), or None."""
    ws = wheel_speed(drive)
    if ws is not None:
        return ws
    if "v_can" in drive:
        return drive["v_can"]
    if "gnss_ve" in drive and "gnss_vn" in drive:
        return np.hypot(drive["gnss_ve"], drive["gnss_vn"])
    return None


def gnss_course(
    drive: Drive, min_speed: float = GNSS_COURSE_MIN_SPEED
) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
    """GNSS course over ground at GNSS rows above a speed gate (no other gate).

    Returns ``(rows, course_rad, speed_mps)``: course = atan2(v_n, v_e) (ENU, from East,
    counter-clockwise), only where the horizontal GNSS speed exceeds ``min_speed``; from the
    GNSS layer (:func:`sideslip.gnss.course_samples`: Doppler, else differenced positions).
    """
    from sideslip import gnss  # the GNSS layer reads signals.hold: imported here, not above

    cs = gnss.course_samples(drive, None, min_speed, use_positions=True, max_sigma=np.inf)
    return cs.rows, cs.course, cs.speed


def standstill(drive: Drive, speed_threshold: float = STANDSTILL_SPEED) -> BoolArray:
    """Rows where the vehicle stands still (|speed| below ``speed_threshold`` m/s)."""
    return np.abs(vehicle_speed(drive)) < speed_threshold


def reversing(drive: Drive, speed_threshold: float = STANDSTILL_SPEED) -> BoolArray:
    """Rows where the vehicle moves backwards.

    Signed wheel or CAN speeds below ``-speed_threshold`` mark reversing.  Drives whose speed
    sensors report magnitudes only cannot show reversing this way; methods that have a heading
    also compare it with the GNSS course (a course opposite to the heading means reversing).
    """
    return vehicle_speed(drive) < -speed_threshold


def course_from_velocity(ve: FloatArray, vn: FloatArray) -> FloatArray:
    """Course over ground atan2(v_n, v_e), rad, wrapped to [-pi, pi)."""
    return wrap_angle(np.arctan2(vn, ve))


def sample_variance(t: FloatArray, sigma_100hz: float) -> FloatArray:
    """Per-sample variance of a white-noise sensor of fixed density whose 1-sigma is
    ``sigma_100hz`` at 100 Hz: sigma_100Hz^2 * (rate / 100 Hz), the rate from each row's step."""
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.01))
    dt = np.clip(dt, 1e-4, 1.0)
    return np.asarray(sigma_100hz**2 * (0.01 / dt), dtype=float)


def white_noise_sigma_100hz(t: FloatArray, x: FloatArray, max_dt: float = 0.05) -> float | None:
    """1-sigma at 100 Hz of a sensor's white noise, identified from the drive itself.

    The second difference of consecutive samples, x_k+1 - 2 x_k + x_k-1, has variance
    6 sigma^2 for white noise, while a vehicle signal sampled at 20 Hz or faster contributes
    little (its second difference is ~ x'' dt^2).  A robust scale (1.4826 x median absolute
    deviation) ignores manoeuvres and glitches.  The per-sample sigma is referred to 100 Hz by
    sqrt(100 Hz / rate).  None with fewer than 200 usable triples or slower sampling than
    ``max_dt``.
    """
    n_ok = int(np.count_nonzero(np.isfinite(x)))
    if n_ok < 203:
        return None
    d2, steps = _second_differences(np.asarray(t, dtype=float), np.asarray(x, dtype=float), max_dt)
    if d2.size < 200:
        return None
    step = float(np.median(steps))
    del steps
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    sigma = 1.4826 * mad / np.sqrt(6.0)
    return float(sigma * np.sqrt(step / 0.01))


@numba.njit(cache=True)
def _second_differences(t: FloatArray, x: FloatArray, max_dt: float
                        ) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """x_k+1 - 2 x_k + x_k-1 over consecutive finite samples, and the step t_k+1 - t_k, where
    both steps are at most ``max_dt`` and within 10 % of each other (one pass, no copies)."""
    n = x.size
    n_ok = 0
    for i in range(n):
        if math.isfinite(x[i]):
            n_ok += 1
    d2 = np.empty(max(n_ok - 2, 0))
    steps = np.empty(max(n_ok - 2, 0))
    m = 0
    seen = 0
    t1 = x1 = t2 = x2 = 0.0  # the previous finite sample (1) and the one before (2)
    for i in range(n):
        if not math.isfinite(x[i]):
            continue
        if seen >= 2:
            dt_new = t[i] - t1
            dt_old = t1 - t2
            if dt_new <= max_dt and dt_old <= max_dt and abs(dt_new - dt_old) < 0.1 * dt_new:
                d2[m] = x[i] - 2.0 * x1 + x2
                steps[m] = dt_new
                m += 1
        t2, x2 = t1, x1
        t1, x1 = t[i], x[i]
        seen += 1
    return d2[:m], steps[:m]


def causal_mean(t: FloatArray, x: FloatArray, window_s: float) -> FloatArray:
    """Causal moving mean over ``window_s`` of the finite samples (0 where none yet).

    The mean over the rows j with t_j > t_k - window_s, j <= k, from prefix sums (one compiled
    pass, 24 B/row of temporaries)."""
    tt = np.ascontiguousarray(t, dtype=float)
    return np.asarray(_causal_mean(tt, np.ascontiguousarray(x, dtype=float), tt - window_s))


@numba.njit(cache=True)
def _causal_mean(t: FloatArray, x: FloatArray, start: FloatArray
                 ) -> FloatArray:  # pragma: no cover - compiled
    n = t.size
    cv = np.empty(n + 1)
    cc = np.empty(n + 1)
    cv[0] = 0.0
    cc[0] = 0.0
    for i in range(n):
        ok = math.isfinite(x[i])
        cv[i + 1] = cv[i] + (x[i] if ok else 0.0)
        cc[i + 1] = cc[i] + (1.0 if ok else 0.0)
    out = np.empty(n)
    j = 0
    for i in range(n):
        while j < n and t[j] <= start[i]:  # searchsorted(t, t - window, side="right")
            j += 1
        cnt = cc[i + 1] - cc[j]
        out[i] = (cv[i + 1] - cv[j]) / max(cnt, 1.0) if cnt > 0 else 0.0
    return out


GRAVITY_M_S2 = 9.80665


def gravity_lateral_sin(
    drive: Drive, speed: FloatArray, yaw_rate: FloatArray, window_s: float = 2.0
) -> FloatArray | None:
    """|sin| of the body's total roll against gravity (road bank + suspension roll), per row,
    from the accelerometer: the lateral specific force a_y minus the kinematic lateral
    acceleration V r is g sin(roll + bank) (plus V beta', small over ``window_s``, over which
    both are averaged causally).  ``yaw_rate``: bias-corrected r (rad/s) per row, e.g. a
    filter's estimate (a raw gyro's bias times V would swamp the cue).  None when the drive
    has no ``ay``.

    An independent cue of the gravity component that a flat-road vehicle model ignores; on a
    flat road it is the suspension roll (~ roll gradient * a_y) only.
    """
    if "ay" not in drive:
        return None
    t = drive.t
    ay, _ = hold(drive["ay"], t)
    diff = causal_mean(t, ay - np.abs(speed) * yaw_rate, window_s)
    return np.asarray(np.clip(np.abs(diff) / GRAVITY_M_S2, 0.0, 1.0), dtype=float)
