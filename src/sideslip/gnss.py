"""The GNSS measurement layer: course, speed, position and Doppler samples of a drive.

Every method that reads GNSS takes its samples from here, so that the speed gate, the receiver
sigma defaults, the course noise model and the Gauss-Markov error model are written once.

Conventions (contract section 1): GNSS columns hold a value on the rows where the receiver
delivered a fix and NaN elsewhere; positions ``gnss_e``/``gnss_n`` (m, local ENU), Doppler
velocity ``gnss_ve``/``gnss_vn`` (m/s), receiver 1-sigmas ``gnss_pos_std`` (m, per horizontal
axis) and ``gnss_vel_std`` (m/s, per horizontal axis).  Missing columns read as all-NaN
(:func:`column`); missing or non-positive receiver sigmas fall back to
:data:`POS_SIGMA_DEFAULT_M` / :data:`VEL_SIGMA_DEFAULT_M_S`.

Course noise (one model for every method): with independent velocity errors of 1-sigma
``sigma_v`` per axis, the course atan2(v_n, v_e) has 1-sigma ``sigma_v / V`` (first order in
sigma_v / V), to which an antenna / multipath floor :data:`COURSE_SIGMA_FLOOR_RAD` adds in
quadrature:  ``sigma_course = hypot(sigma_v / V, floor)``.  Samples are used above a speed gate
(the first-order model needs sigma_v << V; each method passes its gate, default
:data:`COURSE_MIN_SPEED_M_S`) and while ``sigma_course`` is below
:data:`COURSE_SIGMA_MAX_RAD` (a receiver that says its velocity is poor is not a heading
sensor).

GNSS error as a first-order Gauss-Markov process  e' = -e / tau + w  with stationary 1-sigma
``sigma``: exactly discretised over a step dt as  e_k+1 = phi e_k + w_k,  phi = exp(-dt/tau),
var(w_k) = sigma^2 (1 - phi^2)  (:func:`gauss_markov`; Brown & Hwang, *Introduction to Random
Signals and Applied Kalman Filtering*, 4th ed., 2012, sec. 4.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.frames import wrap_angle
from sideslip.signals import hold, speed_source, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

VEL_SIGMA_DEFAULT_M_S = 0.1  # Doppler velocity 1-sigma per axis when the drive gives none
POS_SIGMA_DEFAULT_M = 1.5  # standalone code-phase position 1-sigma per axis when none given
POS_WHITE_FRACTION = 0.45  # share of the position 1-sigma that is white from fix to fix
COURSE_SIGMA_FLOOR_RAD = math.radians(0.1)  # antenna / multipath floor of the Doppler course
COURSE_SIGMA_MAX_RAD = math.radians(5.0)  # poorer course samples are not used
CONSECUTIVE_MAX_HZ = 1.5  # fixes at this rate or slower: velocity from consecutive fixes
DIFFERENCE_BASELINE_S = 1.0  # faster fixes: velocity over this baseline, centred
COURSE_MIN_SPEED_M_S = 3.0  # default speed gate of the course
JUMP_WINDOW_S = 0.3  # a fast receiver's fix is checked against its neighbours this far each side
JUMP_SIGMAS = 6.0  # ... and dropped beyond this many robust scales of the drive's own residuals
JUMP_FLOOR_M = 0.5  # ... and never for less than this (smooth receivers have cm-level scatter)
SPEED_AGREE_SIGMAS = 4.0  # a course sample's GNSS speed within this many velocity sigmas ...
SPEED_AGREE_FRACTION = 0.15  # ... plus this share of the wheels' speed (scale, slip) of it


def column(drive: Drive, name: str) -> FloatArray:
    """The column ``name`` of the drive, or all-NaN (no sample anywhere) when it is absent."""
    if name in drive:
        return np.asarray(drive[name], dtype=float)
    return np.full(len(drive), np.nan)


def _sigma_or_default(values: FloatArray, default: float, floor: float = 0.0) -> FloatArray:
    """Receiver sigmas: ``default`` where missing or non-positive, at least ``floor``."""
    return np.where(np.isfinite(values) & (values > 0), np.maximum(values, floor), default)


@numba.njit(cache=True)
def gauss_markov_nb(dt: float, tau_s: float, sigma: float) -> tuple[float, float]:
    """Exact discretisation of a first-order Gauss-Markov error of time constant ``tau_s``
    and stationary 1-sigma ``sigma`` over one step ``dt``: ``(phi, q)`` with
    ``phi = exp(-dt / tau)`` and the driving-noise variance ``q = sigma^2 (1 - phi^2)``
    (module docstring).  ``tau_s = inf`` gives a constant (phi = 1, q = 0), ``tau_s <= 0``
    white noise (phi = 0, q = sigma^2).  The one implementation: compiled filter loops call
    it per step, :func:`gauss_markov` over arrays."""
    if math.isinf(tau_s):
        phi = 1.0
    elif tau_s <= 0.0:
        phi = 0.0
    else:
        phi = math.exp(-dt / tau_s)
    return phi, sigma * sigma * (1.0 - phi * phi)


@numba.njit(cache=True)
def _gauss_markov_array(dt: NDArray, tau_s: float, sigma: float) -> tuple[NDArray, NDArray]:
    phi = np.empty(dt.size)
    q = np.empty(dt.size)
    for i in range(dt.size):
        phi[i], q[i] = gauss_markov_nb(dt[i], tau_s, sigma)
    return phi, q


def gauss_markov(dt: float | FloatArray, tau_s: float, sigma: float) -> tuple[FloatArray, FloatArray]:
    """:func:`gauss_markov_nb` over an array (or scalar) of steps ``dt``: ``(phi, q)``."""
    d = np.asarray(dt, dtype=float)
    phi, q = _gauss_markov_array(np.ascontiguousarray(d.ravel()), float(tau_s), float(sigma))
    return phi.reshape(d.shape), q.reshape(d.shape)


@dataclass(frozen=True)
class VelocitySamples:
    """GNSS horizontal velocity at the rows with a sample.  ``source``: 'doppler' or
    'positions' (differenced fixes, assigned to the later fix), '' when the drive has none."""

    rows: IntArray
    ve: FloatArray
    vn: FloatArray
    sigma: FloatArray  # m/s per axis
    source: str

    @property
    def speed(self) -> FloatArray:
        return np.hypot(self.ve, self.vn)


def velocity_samples(
    drive: Drive,
    use_positions: bool = True,
    default_sigma_m_s: float = VEL_SIGMA_DEFAULT_M_S,
    floor_sigma_m_s: float = 0.0,
) -> VelocitySamples:
    """Doppler velocity, else (``use_positions``) differenced GNSS positions.

    The 1-sigma is ``gnss_vel_std`` (``default_sigma_m_s`` where the drive gives none, at
    least ``floor_sigma_m_s``: a filter's floor for receivers that claim too much) for Doppler and
    sqrt(2) w sigma_pos / dt for differenced fixes, w = :data:`POS_WHITE_FRACTION` the share of
    the position error that changes from fix to fix (the slow part cancels in the difference;
    the same split as the seed-004 EKF's GNSS model).  Fixes up to
    :data:`CONSECUTIVE_MAX_HZ` are differenced with the previous one (stamped at the later);
    faster ones over :data:`DIFFERENCE_BASELINE_S` centred on the fix (the fixes nearest
    half a baseline before and after, where no gap lies between), since over one 50 ms step
    of a 20 Hz receiver the white noise alone turns the course by tens of degrees, and a
    baseline ending at the fix would lag the course by half the baseline in every turn.  A fast
    receiver's fixes that jump off their neighbours (:func:`jumped_fixes`) are left out first.
    """
    empty = VelocitySamples(np.zeros(0, dtype=np.intp), np.zeros(0), np.zeros(0), np.zeros(0), "")
    if "gnss_ve" in drive and "gnss_vn" in drive:
        ve, vn = drive["gnss_ve"], drive["gnss_vn"]
        rows = np.flatnonzero(np.isfinite(ve) & np.isfinite(vn))
        sig = _sigma_or_default(column(drive, "gnss_vel_std")[rows], default_sigma_m_s, floor_sigma_m_s)
        return VelocitySamples(rows, ve[rows], vn[rows], sig, "doppler")
    if not use_positions or "gnss_e" not in drive or "gnss_n" not in drive:
        return empty
    pos = position_samples(drive, drop_jumps=True)
    if pos.rows.size < 2:
        return empty
    tf = drive.t[pos.rows]
    if np.median(np.diff(tf)) >= 1.0 / CONSECUTIVE_MAX_HZ:
        dt = np.diff(tf)
        ve = np.diff(pos.e) / dt
        vn = np.diff(pos.n) / dt
        sig = math.sqrt(2.0) * POS_WHITE_FRACTION * np.maximum(pos.sigma[1:], pos.sigma[:-1]) / dt
        return VelocitySamples(pos.rows[1:], ve, vn, sig, "positions")
    half = 0.5 * DIFFERENCE_BASELINE_S
    step = float(np.median(np.diff(tf)))
    tol = 0.25 * step  # time stamps carry rounding: a fix a hair inside half counts
    a = np.searchsorted(tf, tf - half + tol, side="right") - 1  # last fix at or before t - half
    b = np.searchsorted(tf, tf + half - tol, side="left")  # first fix at or after t + half
    ok = (a >= 0) & (b < tf.size)
    a, b, k = a[ok], b[ok], np.flatnonzero(ok)
    dt = tf[b] - tf[a]
    # no gap inside the baseline: its fixes span at most the baseline and two fix steps
    ok = dt <= DIFFERENCE_BASELINE_S + 2.5 * step
    a, b, k, dt = a[ok], b[ok], k[ok], dt[ok]
    ve = (pos.e[b] - pos.e[a]) / dt
    vn = (pos.n[b] - pos.n[a]) / dt
    sig = math.sqrt(2.0) * POS_WHITE_FRACTION * np.maximum(pos.sigma[a], pos.sigma[b]) / dt
    return VelocitySamples(pos.rows[k], ve, vn, sig, "positions")


def jumped_fixes(tf: FloatArray, e: FloatArray, n: FloatArray) -> NDArray[np.bool_]:
    """Isolated multipath fixes of a fast receiver (True where a fix jumps off its neighbours).

    Each fix is predicted from the fixes within :data:`JUMP_WINDOW_S` on either side, moved to
    its time with the median of their consecutive velocities (an isolated jump spoils two of
    those differences, the median ignores them), and the prediction is the median over those
    neighbours.  The miss is scored against the drive's own scatter: fixes beyond
    :data:`JUMP_SIGMAS` robust scales (1.4826 MAD of all misses; at least :data:`JUMP_FLOOR_M`)
    are flagged.  Curvature inside the window costs 0.5 a tau^2, under 0.2 m at 1 g.  Too few
    neighbours (a slow receiver, edges of a gap) flag nothing.
    """
    m = tf.size
    flagged = np.zeros(m, dtype=bool)
    if m < 5:
        return flagged
    step = float(np.median(np.diff(tf)))
    w = round(JUMP_WINDOW_S / step) if step > 0 else 0
    if w < 2 or m < 2 * w + 1:
        return flagged
    dt = np.diff(tf)
    with np.errstate(divide="ignore", invalid="ignore"):
        v_e = np.where(dt > 0, np.diff(e) / dt, np.nan)
        v_n = np.where(dt > 0, np.diff(n) / dt, np.nan)
    pad = np.full(w, np.nan)
    # consecutive velocities k-w .. k+w-1 around fix k (2w of them)
    win_ve = np.lib.stride_tricks.sliding_window_view(np.concatenate([pad, v_e, pad]), 2 * w)
    win_vn = np.lib.stride_tricks.sliding_window_view(np.concatenate([pad, v_n, pad]), 2 * w)
    ve_k = np.nanmedian(win_ve[:m], axis=1)
    vn_k = np.nanmedian(win_vn[:m], axis=1)
    offsets = np.r_[np.arange(-w, 0), np.arange(1, w + 1)]
    idx = np.arange(m)[:, None] + offsets[None, :]
    inside = (idx >= 0) & (idx < m)
    j = np.clip(idx, 0, m - 1)
    near = inside & (np.abs(tf[j] - tf[:, None]) <= JUMP_WINDOW_S + 0.5 * step)
    lag = tf[:, None] - tf[j]
    pred_e = np.where(near, e[j] + ve_k[:, None] * lag, np.nan)
    pred_n = np.where(near, n[j] + vn_k[:, None] * lag, np.nan)
    enough = near.sum(axis=1) >= w
    if not enough.any():
        return flagged
    with np.errstate(invalid="ignore"):
        miss = np.hypot(e - np.nanmedian(np.where(enough[:, None], pred_e, 0.0), axis=1),
                        n - np.nanmedian(np.where(enough[:, None], pred_n, 0.0), axis=1))  # fmt: skip
    ok = enough & np.isfinite(miss)
    if ok.sum() < 5:
        return flagged
    scale = 1.4826 * float(np.median(np.abs(miss[ok] - np.median(miss[ok]))))
    limit = max(float(np.median(miss[ok])) + JUMP_SIGMAS * scale, JUMP_FLOOR_M)
    flagged[ok] = miss[ok] > limit
    return flagged


BASELINE_COURSE_M = 10.0  # travel over which a course from fixes is taken (initial heading)
BASELINE_SPREAD_RAD = math.radians(10.0)  # its fixes' directions agree within this


def course_from_fixes(
    drive: Drive, baseline_m: float = BASELINE_COURSE_M, max_span_s: float = 5.0
) -> tuple[float, float, float] | None:
    """Course (rad, ENU from East) over the first ``baseline_m`` the antenna travels within
    ``max_span_s``, from the fixes, with the times (s) of the baseline's first fix and of
    the fix that closes it; None when the fixes never cover it.  Two fixes a twentieth of a
    second apart give a course of +-10 deg from 0.1 m of noise (and any multipath jump, or a
    receiver that repeats its first position, gives nonsense); a 10 m baseline about 1 deg.

    A baseline counts only where the wheels (or CAN speed) confirm the travel: the distance
    between its fixes within 2 m or 20 % of the distance the speed integrates to (a car
    standing at the start of a drive with multipath fixes 8 m off once gave a course 174 deg
    wrong, which the filter took 100 s to unlearn), and the directions to the next five fixes
    beyond it agree within :data:`BASELINE_SPREAD_RAD` of their mean."""
    ok = np.flatnonzero(np.isfinite(column(drive, "gnss_e")) & np.isfinite(column(drive, "gnss_n")))
    if ok.size < 3:
        return None
    e, n, tf = drive["gnss_e"][ok], drive["gnss_n"][ok], drive.t[ok]
    odometer = None
    if speed_source(drive) in ("wheels", "v_can"):
        v = np.abs(vehicle_speed(drive))
        odometer = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(drive.t))))[ok]
    first = 0
    if odometer is not None:  # start where the car has begun to move
        moved = np.flatnonzero(odometer - odometer[0] > 0.5)
        first = max(int(moved[0]) - 1, 0) if moved.size else ok.size
    for i in range(first, min(ok.size - 1, first + 400)):
        d = np.hypot(e[i + 1 :] - e[i], n[i + 1 :] - n[i])
        far = np.flatnonzero(d > baseline_m)
        if not far.size or tf[i + 1 + far[0]] - tf[i] >= max_span_s:
            continue
        j = i + 1 + far[0]
        if odometer is not None:
            travelled = odometer[j] - odometer[i]
            if abs(d[far[0]] - travelled) > max(2.0, 0.2 * travelled):
                continue
        js = np.arange(j, min(j + 5, ok.size))
        courses = np.arctan2(n[js] - n[i], e[js] - e[i])
        mean = float(np.angle(np.exp(1j * courses).sum()))
        if np.max(np.abs(wrap_angle(courses - mean))) > BASELINE_SPREAD_RAD:
            continue
        return mean, float(tf[i]), float(tf[j])
    return None


@dataclass(frozen=True)
class CourseSamples:
    """Fresh GNSS course over ground at the rows that pass the gates.

    ``course`` (rad, ENU from East counter-clockwise, of the vehicle's heading direction: turned
    by pi where it reverses), ``speed`` (m/s, GNSS horizontal speed), ``sigma`` (rad, 1-sigma of
    the course, module docstring), ``reversing`` (bool per sample).
    """

    rows: IntArray
    course: FloatArray
    speed: FloatArray
    sigma: FloatArray
    reversing: NDArray[np.bool_]


def course_sigma(vel_sigma: FloatArray, speed: FloatArray) -> FloatArray:
    """1-sigma (rad) of a Doppler course: hypot(sigma_v / V, :data:`COURSE_SIGMA_FLOOR_RAD`)."""
    return np.hypot(vel_sigma / np.maximum(speed, 1e-9), COURSE_SIGMA_FLOOR_RAD)


def course_samples(
    drive: Drive,
    signed_speed: FloatArray | None = None,
    min_speed: float = COURSE_MIN_SPEED_M_S,
    use_positions: bool = True,
    max_sigma: float = COURSE_SIGMA_MAX_RAD,
) -> CourseSamples:
    """GNSS course samples above the speed gate ``min_speed`` (m/s) and below ``max_sigma``.

    ``signed_speed`` (per row, e.g. signed wheel speeds): where given, a sample is used only
    when ``|signed_speed|`` also exceeds the gate (the vehicle's own speed confirms the GNSS
    speed), and its course is turned by pi where ``signed_speed < 0`` (reversing), so that
    course = yaw + beta holds, and a sample whose GNSS speed disagrees with it by more than
    :data:`SPEED_AGREE_SIGMAS` velocity sigmas plus :data:`SPEED_AGREE_FRACTION` of it is
    dropped.  The course sigma divides by the GNSS speed, so a multipath error that adds speed
    shrinks its own sigma: at low speed, where the honest samples stay above ``max_sigma``,
    only such outliers passed (a positions-only 20 Hz drive pulling off at 4 m/s kept its
    multipath samples, 154 deg off with a 3 deg sigma, and turned ``mkf``'s yaw by 150 deg);
    the agreement check and the jump check of the fixes (:func:`jumped_fixes`) remove them.
    Without Doppler velocity the course comes from differenced positions (``use_positions``).
    """
    vel = velocity_samples(drive, use_positions)
    speed = vel.speed
    keep = np.isfinite(speed) & (speed > min_speed)
    rev = np.zeros(vel.rows.size, dtype=bool)
    if signed_speed is not None:
        s = np.asarray(signed_speed, dtype=float)[vel.rows]
        keep &= np.abs(s) > min_speed
        keep &= np.abs(speed - np.abs(s)) <= SPEED_AGREE_SIGMAS * vel.sigma + SPEED_AGREE_FRACTION * np.abs(s)
        rev = s < 0.0
    sig = course_sigma(vel.sigma, speed)
    keep &= sig <= max_sigma
    course = np.arctan2(vel.vn[keep], vel.ve[keep])
    rev = rev[keep]
    course = np.where(rev, wrap_angle(course + np.pi), course)
    return CourseSamples(vel.rows[keep], course, speed[keep], sig[keep], rev)


@dataclass(frozen=True)
class SpeedSamples:
    """GNSS horizontal speed (m/s) and its 1-sigma at the rows with a sample."""

    rows: IntArray
    speed: FloatArray
    sigma: FloatArray


def speed_samples(drive: Drive, use_positions: bool = True) -> SpeedSamples:
    """GNSS ground speed |v| with the per-axis velocity 1-sigma (|v| has the same 1-sigma to
    first order when sigma_v << V)."""
    vel = velocity_samples(drive, use_positions)
    return SpeedSamples(vel.rows, vel.speed, vel.sigma)


@dataclass(frozen=True)
class PositionSamples:
    """GNSS fixes: rows, ``e``/``n`` (m, ENU) and their 1-sigma per axis (m)."""

    rows: IntArray
    e: FloatArray
    n: FloatArray
    sigma: FloatArray

    def median_sigma(self) -> float:
        """Median receiver 1-sigma of the fixes (the default when there are none)."""
        return float(np.median(self.sigma)) if self.sigma.size else POS_SIGMA_DEFAULT_M


def position_samples(
    drive: Drive,
    default_sigma_m: float = POS_SIGMA_DEFAULT_M,
    floor_sigma_m: float = 0.0,
    drop_jumps: bool = False,
) -> PositionSamples:
    """GNSS position fixes with ``gnss_pos_std`` (``default_sigma_m`` where the drive gives
    none, at least ``floor_sigma_m``); ``drop_jumps``: without a fast receiver's fixes that
    jump off their neighbours (:func:`jumped_fixes`; fixes slower than
    :data:`CONSECUTIVE_MAX_HZ` are kept as they are)."""
    e, n = column(drive, "gnss_e"), column(drive, "gnss_n")
    rows = np.flatnonzero(np.isfinite(e) & np.isfinite(n))
    if drop_jumps and rows.size > 1 and np.median(np.diff(drive.t[rows])) < 1.0 / CONSECUTIVE_MAX_HZ:
        rows = rows[~jumped_fixes(drive.t[rows], e[rows], n[rows])]
    sig = _sigma_or_default(column(drive, "gnss_pos_std")[rows], default_sigma_m, floor_sigma_m)
    return PositionSamples(rows, e[rows], n[rows], sig)


def doppler_samples(
    drive: Drive, default_sigma_m_s: float = VEL_SIGMA_DEFAULT_M_S, floor_sigma_m_s: float = 0.0
) -> VelocitySamples:
    """Doppler velocity samples only (never differenced positions)."""
    return velocity_samples(drive, False, default_sigma_m_s, floor_sigma_m_s)


@numba.njit(cache=True)
def course_outliers(
    t: NDArray, rows: NDArray, course: NDArray, sigma: NDArray, wz: NDArray,
    n_sigma: float, beta_rate: float, max_run: int,
) -> NDArray:  # fmt: skip
    """Multipath test of course samples against the gyro: a sample whose change since the last
    accepted one differs from the gyro-integrated heading change by more than ``n_sigma``
    combined sigmas plus a sideslip allowance ``beta_rate`` * dt (rad/s * s) is rejected;
    after ``max_run`` rejections in a row the next is accepted (re-synchronises after a real
    jump).  Returns a bool mask over ``rows`` (True = outlier)."""
    bad = np.zeros(rows.size, dtype=np.bool_)
    last = -1
    run = 0
    for i in range(rows.size):
        if last < 0:
            last = i
            continue
        a, b = rows[last], rows[i]
        turn = 0.0
        for k in range(a, b):
            if np.isfinite(wz[k]):
                turn += wz[k] * (t[k + 1] - t[k])
        d = (course[i] - course[last] - turn + np.pi) % (2.0 * np.pi) - np.pi
        lim = n_sigma * np.sqrt(sigma[i] ** 2 + sigma[last] ** 2) + beta_rate * (t[b] - t[a])
        if abs(d) > lim and run < max_run:
            bad[i] = True
            run += 1
        else:
            last = i
            run = 0
    return bad


# multipath test of the course against the gyro (used by the seed-001 filters)
OUTLIER_SIGMAS = 4.0  # course sample rejected beyond this many sigma of the gyro-predicted step
OUTLIER_BETA_RATE = 0.2  # rad/s: allowance for the sideslip change between two course samples
OUTLIER_MAX_RUN = 5  # after this many rejections in a row the next sample is accepted (re-sync)


@dataclass(frozen=True)
class CourseAtCg:
    """Fresh GNSS course on the drive's rows (NaN where none), referred to the CG.

    ``course``: rad, the antenna's roll-rate lever-arm term removed; ``sigma``: 1-sigma (rad);
    ``hr``: the yaw-rate lever-arm coefficient rx/V (s) of the measurement model
    nu_ant = psi + beta + (rx/V) r - (rz/V) p  (v_y,ant = v_y + r rx - p rz).
    """

    course: FloatArray
    sigma: FloatArray
    hr: FloatArray


def course_at_cg(
    drive: Drive, vehicle: Vehicle, speed: FloatArray, min_speed: float = COURSE_MIN_SPEED_M_S
) -> CourseAtCg:
    """Course samples (:func:`course_samples`, speed confirmed by the signed ``speed``) on every
    row, with the roll-rate lever-arm term removed using ``wx`` when the drive has it, and the
    multipath outliers of :func:`course_outliers` (against ``wz``) dropped."""
    n = len(drive)
    course = np.full(n, np.nan)
    sigma = np.full(n, np.nan)
    hr = np.zeros(n)
    cs = course_samples(drive, speed, min_speed)
    rows, nu, gspeed, sig, rev = cs.rows, cs.course, cs.speed, cs.sigma, cs.reversing
    rx, _, rz = (float(c) for c in vehicle.gnss_xyz)
    if "wx" in drive and rz != 0.0:
        p, _ = hold(drive["wx"], drive.t)
        nu = nu + rz * p[rows] / gspeed
    if "wz" in drive and rows.size:
        bad = course_outliers(
            drive.t, rows, nu, sig, drive["wz"], OUTLIER_SIGMAS, OUTLIER_BETA_RATE, OUTLIER_MAX_RUN
        )
        rows, nu, sig, rev, gspeed = rows[~bad], nu[~bad], sig[~bad], rev[~bad], gspeed[~bad]
    course[rows] = wrap_angle(nu)
    sigma[rows] = sig
    hr[rows] = np.where(rev, -rx, rx) / gspeed
    return CourseAtCg(course, sigma, hr)
