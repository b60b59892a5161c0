"""Seed 001: the kinematic Kalman filter ``kkf`` (GPS course minus integrated gyro).

State x = [psi (rad), b_gyro (rad/s), s_gyro (-)]; input: gyro yaw rate w_z (rad/s),
psi' = (w_z - b_gyro) / (1 + s_gyro) (seed 001 eq 4; the scale-factor state is frozen at 0
except in the adaptive route of :mod:`sideslip.methods.mkf_adaptive`).  Measurement: GNSS
Doppler course nu (rad) with H = [1 0 0] *only while driving straight* (then beta ~ 0 so
nu ~ psi and the bias is observable); in turns the bias is frozen and the gyro integrated.
Sideslip beta = nu - psi_hat at every fresh GNSS course (eq 6 gives its variance
sigma_beta^2 = P_psi + sigma_nu^2), held between course samples.  A gyro scale factor
integrates into beta through every turn.  The GNSS course (CG-referred, multipath-gated) comes
from :func:`sideslip.gnss.course_at_cg`; the updates from :mod:`sideslip.filters.kalman`.

Straight driving (:func:`straight_flags`): over a causal 1 s window, the bias-corrected
gyro mean |w_z - b| and the GNSS course rate |d nu/dt| both below ``straight_on_rad_s`` for
``straight_hold_s`` enter "straight"; either above ``straight_off_rad_s`` -- or the 0.1 s gyro
mean above it, or speed below the gate, or no recent course -- leaves it at once (hysteresis).

Noise (:class:`KkfSettings`): ``preset="auto"`` (default) takes the gyro white noise from the
drive (:func:`sideslip.signals.white_noise_sigma_100hz`), ``"typical"`` the fixed 0.3 deg/s at
100 Hz of seed 001 Table I (``"paper"`` is the same, by the paper's name); the course noise is
the receiver's (GNSS layer).  The one process density, the gyro-bias random walk, is with
``"auto"`` the factor on the typical value that maximises the likelihood of the course
innovations (:func:`_bias_walk`; 5 filter passes); the presets keep the typical value.  Seed 001
gives no further noise values.

Honest uncertainty: the KKF's beta error in a turn is the heading error integrated from the gyro
(scale factor times the heading change since the last straight, plus bias drift), which the
filter's own P (white gyro noise only) does not contain.  ``beta_std`` therefore adds (i) the
heading change since the last course update on a straight times ``gyro_scale_rel_sigma``
(a MEMS gyro's scale-factor uncertainty, 1-sigma); (ii) the sideslip a banked straight
hides in the heading, k_slip g sin(bank) (k_slip from the vehicle file or
:mod:`sideslip.typical`); (iii) the body-z gyro's under-reading on a bank, the heading change
times 1/cos(bank) - 1; the bank comes from the accelerometer
(:func:`sideslip.signals.gravity_lateral_sin`) when the drive has ``ay``, else
``road_bank_sigma``; (iv) the course's error beyond its stated sigma (``course_check``,
:mod:`sideslip.course_check`): multipath bursts the receiver does not report, read from the
course's change against the gyro's heading change over one course baseline, in turns as on
straights; with Doppler, where the gyro shows no turn, also over pairs 1 s apart, which see a
burst's slowly drifting error (urban_course seed 0 with a 3 m burst every 10 s: 89 % -> 94 %
inside 2 sigma).  The windowed NIS of the course updates
(:func:`sideslip.filters.consistency.nis_consistency`) inflates it where the straights stop
looking straight.

Positions only (no Doppler): the course of every fix over a 1 s baseline (gnss layer), so a
20 Hz receiver's samples overlap.  Thinning them to one per baseline was measured (issue 15's
receiver, 16 scenarios, seed 0): mean beta RMSE 2.64 / 2.35 / 1.74 / 2.60 deg at 2 / 5 / 10 /
20 Hz became 2.81 / 2.22 / 2.12 / 2.26, the 20 Hz CommonRoad limit ramp (multipath bursts)
6.9 deg with 0.87 inside 2 sigma became 3.7 deg with 1.00, urban_course at 2 Hz 8.7 -> 10.3
deg: no better on the whole, not kept.  The course check (iv) covers those bursts instead:
the limit ramp's 6.9 deg now has 0.95 of its errors inside 2 sigma.  The overlapping courses
of one baseline share one error, and their straight updates carry it once: their variance is
scaled by the courses per baseline (:func:`sideslip.course_check.courses_per_error`; mean
beta RMSE on that receiver 2.60 -> 2.36 deg).  Until the bias is known (its variance below
``BIAS_KNOWN_VAR``) the straight updates count one course error per ``COURSE_ERROR_TAU_S``, as
a multipath burst's Doppler errors persist: a first straight of 0.8 s inside a burst had
taught the bias 3 sigma off, 6.2 deg beta RMSE with 23 % inside 2 sigma through the slalom
after it (slalom_low_mu seed 0, a 3 m burst every 10 s), now 4.3 deg with 100 %; over the 16
scenarios x seeds 0-2 with such bursts mean 1.43 -> 1.34 deg, the comparison's Doppler
receiver 1.157 -> 1.053 deg (lowest share 0.96 -> 0.97).  Once the bias is known the updates
are white as the receiver states them (a raw phone gyro's 4 deg/s bias then converges as
before: a 1 s correlation throughout let its heading drift 0.78 deg, 0.16 white).

Low speed, standstill, outages (never NaN): below the gate or when the last course is older
than ``KKF_MAX_COURSE_AGE_S`` (or 1.5 GNSS intervals) beta falls back to 0 with beta_std
``KKF_BETA_PRIOR``; at standstill the gyro reads its bias (pseudo-measurement r = 0).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip import gnss, typical
from sideslip.calibrate.result import Fitted
from sideslip.calibrate.sensors import drive_gyro_bias, gyro_zero_params
from sideslip.course_check import course_excess_variance, courses_per_error, independent_lag_s
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.kalman import predict_ws_nb, update_scalar_ws_nb
from sideslip.filters.nis_windows import binned_nis_consistency
from sideslip.frames import wrap_angle
from sideslip.methods.input_gaps import fill_input, gap_noise_density
from sideslip.methods.mkf import (
    GNSS_COLUMNS,
    SIGMA_BIAS0,
    SIGMA_GYRO_100HZ,
    SIGMA_PSI0,
    _wrap,
    channel_diagnostics,
    initial_heading,
)
from sideslip.methods.mkf_tuning import neg2_log_likelihood
from sideslip.methods.registry import SPEED, register
from sideslip.models.mkf_model import V_GATE
from sideslip.settings import settings_dict
from sideslip.signals import (
    GRAVITY_M_S2,
    STANDSTILL_SPEED,
    causal_mean,
    gravity_lateral_sin,
    hold,
    sample_variance,
    vehicle_speed,
    white_noise_sigma_100hz,
)
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

STRAIGHT_ON = 0.01  # rad/s (0.57 deg/s): enter straight below this |yaw rate| and |course rate|
STRAIGHT_OFF = 0.02  # rad/s: leave straight above this
STRAIGHT_HOLD_S = 1.0  # s: the on-condition must hold this long
STRAIGHT_WINDOW_S = 1.0  # s: causal averaging window of yaw rate and course rate (entry)
STRAIGHT_FAST_S = 0.1  # s: short gyro window that ends 'straight' promptly at a turn entry
SIGMA_BETA_STRAIGHT = math.radians(0.2)  # rad: beta is not exactly 0 on a straight
# s: while the bias is not yet known (P_bb above BIAS_KNOWN_VAR) the straight updates count one
# course error per this span (multipath persists; _kkf_loop), white once it is known
COURSE_ERROR_TAU_S = 1.0
DOPPLER_SLOW_PAIR_S = 1.0  # s: the course check's second Doppler baseline, where not turning
KKF_MAX_COURSE_AGE_S = 1.0  # s: older course -> beta unknown, falls back to 0
KKF_BETA_PRIOR = math.radians(3.0)  # rad: beta_std when the KKF has no fresh beta
SIGMA_SCALE0 = 0.05  # 1-sigma prior of the gyro scale factor state (adaptive route)
Q_BIAS = math.radians(0.005) ** 2  # (rad/s)^2/s: gyro bias random walk (typical)
# factors on Q_BIAS tried by preset "auto" (benchmarks/results/kalman_gps_accuracy.md: the
# course likelihood's pick lowers the mean beta RMSE over the simulated scenarios)
BIAS_WALK_GRID = (0.1, 1.0, 10.0, 100.0, 1000.0)
# the gyro's own straightness test is trusted once the bias 1-sigma is below a third of the
# 'on' threshold; before that (e.g. a raw phone gyro) the GNSS course rate decides
BIAS_KNOWN_VAR = (0.01 / 3.0) ** 2


@dataclass(frozen=True)
class KkfSettings:
    """Noise and options of the KKF.

    preset : "auto" (gyro noise from the drive), "paper" (seed 001 Table I gyro noise) or
        "typical" (= "paper"); module docstring.
    gyro_sigma_100hz_rad_s : rad/s per gyro sample at 100 Hz; None = from the preset.
    gyro_bias_psd_rad2_s3 : (rad/s)^2/s, bias random-walk density; None = the typical
        :data:`Q_BIAS`, times the factor identified from the drive with ``preset="auto"``.
    gyro_scale_rel_sigma : 1-sigma of the gyro scale factor (measured/true - 1) behind the
        turn term of beta_std; 0 turns it off.
    road_bank_sigma : sin of the road bank, 1-sigma, behind the bank terms of beta_std when
        the drive has no ``ay`` (with ``ay`` the bank is taken from the accelerometer).
    straight_on_rad_s, straight_off_rad_s, straight_hold_s : straight detector.
    v_gate_m_s : m/s, course used above this speed only.
    consistency_window_s : s, window of the NIS test of the course updates (0: off).
    zero_gyro : start the bias state at the drive's own gyro zero, with its 1-sigma (the bias
        of its GNSS course windows and standstill over the whole drive,
        :func:`sideslip.calibrate.sensors.drive_gyro_bias`), instead of 0 +- SIGMA_BIAS0,
        where the drive tells it.  A raw phone gyro's 3.9 deg/s took the filter most of the
        comma2k19 minute to learn (beta 3.75 deg, yaw 3.8 deg; 0.34 / 0.12 from the zero).
    course_check : add to beta_std the course's error beyond its stated sigma, read from the
        course's change against the gyro's heading change (:mod:`sideslip.course_check`;
        multipath bursts the receiver does not report).  False: beta_std as without it.
    """

    preset: Literal["auto", "paper", "typical"] = "auto"
    gyro_sigma_100hz_rad_s: float | None = None
    gyro_bias_psd_rad2_s3: float | None = None
    gyro_scale_rel_sigma: float = 0.01
    road_bank_sigma: float = 0.03
    straight_on_rad_s: float = STRAIGHT_ON
    straight_off_rad_s: float = STRAIGHT_OFF
    straight_hold_s: float = STRAIGHT_HOLD_S
    v_gate_m_s: float = V_GATE
    consistency_window_s: float = 10.0
    zero_gyro: bool = True
    course_check: bool = True

    def __post_init__(self) -> None:
        if self.preset not in ("auto", "paper", "typical"):
            raise ValueError(
                f"KkfSettings.preset = {self.preset!r}: expected 'auto', 'paper' or 'typical'"
            )
        g = self.gyro_sigma_100hz_rad_s
        if g is not None and not (math.isfinite(g) and g > 0):
            raise ValueError(f"KkfSettings.gyro_sigma_100hz_rad_s = {g}: expected a number > 0")
        for name in ("gyro_bias_psd_rad2_s3", "gyro_scale_rel_sigma", "road_bank_sigma",
                     "straight_hold_s",
                     "consistency_window_s"):  # fmt: skip
            v = getattr(self, name)
            if v is None and name == "gyro_bias_psd_rad2_s3":
                continue
            if v is None or not (math.isfinite(v) and v >= 0):
                raise ValueError(f"KkfSettings.{name} = {v}: expected a number >= 0")
        if not 0 < self.straight_on_rad_s <= self.straight_off_rad_s:
            raise ValueError(
                f"KkfSettings.straight_on_rad_s = {self.straight_on_rad_s}: expected > 0 and "
                f"<= straight_off_rad_s ({self.straight_off_rad_s})"
            )
        if not (math.isfinite(self.v_gate_m_s) and self.v_gate_m_s > STANDSTILL_SPEED):
            raise ValueError(f"KkfSettings.v_gate_m_s = {self.v_gate_m_s}: expected > 0.1 m/s")


def kkf_gyro_sigma(drive: Drive, settings: KkfSettings) -> tuple[float, str]:
    """Gyro white-noise 1-sigma at 100 Hz (rad/s) and its source."""
    if settings.gyro_sigma_100hz_rad_s is not None:
        return settings.gyro_sigma_100hz_rad_s, "settings"
    if settings.preset == "auto":
        ident = white_noise_sigma_100hz(drive.t, drive["wz"])
        if ident is not None:
            # the heading's process noise must cover every gyro error between two straights
            # (bias instability, scale times r), of which the white noise is a lower bound:
            # the drive raises the typical value for a noisy gyro, never lowers it
            return max(ident, SIGMA_GYRO_100HZ), "drive (second differences of wz), >= typical"
    return SIGMA_GYRO_100HZ, "typical"


def course_rate_window(course_sigma: FloatArray, gnss_dt: float) -> float:
    """Window (s) of the course rate that judges straight driving: STRAIGHT_WINDOW_S, at
    least two GNSS steps, and long enough that the course's own noise leaves the rate (a
    difference over the window, sqrt(2) sigma / window) below STRAIGHT_ON: a Doppler course
    (0.002 rad at 20 m/s) keeps 1 s, a course from 20 Hz fixes over a 1 s baseline (0.03 rad
    as the receiver's sigma has it) needs 4 s; with 1 s, kkf never saw a straight on such a
    drive and its heading drifted with the gyro bias (demo: 33 deg in 56 s)."""
    sig = course_sigma[np.isfinite(course_sigma)]
    need = math.sqrt(2.0) * float(np.median(sig)) / STRAIGHT_ON if sig.size else 0.0
    return max(STRAIGHT_WINDOW_S, 2.0 * gnss_dt, need)


def _course_rate(t: FloatArray, course: FloatArray, window_s: float) -> FloatArray:
    """Causal GNSS course rate (rad/s) on every row: slope of the unwrapped course over the
    last ``window_s``, held until the next course; NaN when unknown or stale."""
    n = t.size
    rows = np.flatnonzero(np.isfinite(course))
    if rows.size < 2:
        return np.full(n, np.nan)
    tc = t[rows]
    nu = np.unwrap(course[rows])
    j = np.searchsorted(tc, tc - window_s, side="left")
    span = tc - tc[j]
    ok = span >= 0.5 * window_s
    rate = np.where(ok, (nu - nu[j]) / np.where(span > 0, span, 1.0), np.nan)
    on_rows = np.full(n, np.nan)
    on_rows[rows] = np.where(ok, rate, np.nan)
    held, age = hold(on_rows, t, fill=np.nan)
    # stale: no fresh course recently (outage / low speed)
    last_course_age = hold(course, t, fill=np.nan)[1]
    stale = max(0.5 * window_s, 1.5 * float(np.median(np.diff(tc))))
    return np.where((age <= window_s) & (last_course_age <= stale), held, np.nan)


@numba.njit(cache=True)
def _straight_step(
    straight: bool, on_time: float, yaw_dev: float, yaw_dev_fast: float, course_rate: float,
    speed: float, dt: float, on: float, off: float, hold_s: float, v_gate: float,
) -> tuple[bool, float]:  # fmt: skip
    """One step of the straight-driving detector with hysteresis; returns (straight, on_time).

    Entry uses the 1 s means (quiet gyro and course); exit also watches the 0.1 s gyro mean so
    that a turn entry ends "straight" within ~0.1 s.
    """
    known = np.isfinite(course_rate) and speed > v_gate
    cond_on = known and abs(yaw_dev) < on and abs(yaw_dev_fast) < off and abs(course_rate) < on
    cond_off = (
        (not known) or abs(yaw_dev) > off or abs(yaw_dev_fast) > off or abs(course_rate) > off
    )
    if straight:
        if cond_off:
            return False, 0.0
        return True, on_time
    on_time = on_time + dt if cond_on else 0.0
    return on_time >= hold_s, on_time


@numba.njit(cache=True)
def _straight_loop(
    t: NDArray, yaw_dev: NDArray, yaw_dev_fast: NDArray, course_rate: NDArray, speed: NDArray,
    on: float, off: float, hold_s: float, v_gate: float,
) -> NDArray:  # fmt: skip
    out = np.zeros(t.size, dtype=np.bool_)
    s = False
    on_time = 0.0
    for k in range(t.size):
        dt = t[k] - t[k - 1] if k > 0 else 0.0
        s, on_time = _straight_step(
            s, on_time, yaw_dev[k], yaw_dev_fast[k], course_rate[k], speed[k], dt, on, off,
            hold_s, v_gate,
        )  # fmt: skip
        out[k] = s
    return out


def straight_flags(
    t: FloatArray,
    yaw_rate: FloatArray,
    course_rate: FloatArray,
    speed: FloatArray,
    on: float = STRAIGHT_ON,
    off: float = STRAIGHT_OFF,
    hold_s: float = STRAIGHT_HOLD_S,
    yaw_rate_fast: FloatArray | None = None,
    v_gate: float = V_GATE,
) -> NDArray[np.bool_]:
    """Straight-driving detector of the KKF (the same state machine the filter runs inside).

    ``yaw_rate``: bias-corrected, 1 s averaged gyro yaw rate (rad/s); ``yaw_rate_fast``: the
    same over 0.1 s (default: ``yaw_rate``); ``course_rate``:
    GNSS course rate (rad/s, NaN = unknown).  Straight when both stay below ``on`` for
    ``hold_s`` seconds at speed above ``v_gate`` (m/s); left as soon as one exceeds ``off``, the
    course rate becomes unknown, or the speed drops below the gate.
    """
    fast = yaw_rate if yaw_rate_fast is None else yaw_rate_fast
    return _straight_loop(
        np.asarray(t, float), np.asarray(yaw_rate, float), np.asarray(fast, float),
        np.asarray(course_rate, float), np.asarray(speed, float), on, off, hold_s, v_gate,
    )  # fmt: skip


def _gyro_variance(t: NDArray, wz: NDArray, sigma_100hz: float) -> NDArray:
    """Per-row variance of the yaw rate the loop integrates (rad/s squared): the gyro's white
    noise, and in a gap of the gyro (the loop holds the last sample) the held rate's error,
    one excursion over the whole gap (:mod:`sideslip.methods.input_gaps`), as the variance
    whose step times dt^2 adds that error's share of the heading variance (a 0.5 s hole in
    the gyro on a race lap turned the heading by degrees that the filter kept as exact)."""
    var = sample_variance(t, sigma_100hz)
    held = fill_input(t, wz, interpolate=False)
    if held.sigma.any():
        dt = np.clip(np.diff(t, prepend=t[0]), 1e-4, None)
        var = var + gap_noise_density(t, held.sigma) / dt
    return var


@numba.njit(cache=True)
def _kkf_loop(
    t: NDArray, wz: NDArray, wz_mean: NDArray, wz_fast: NDArray, gyro_var: NDArray,
    course: NDArray,
    course_var: NDArray, course_rate: NDArray, speed: NDArray, zero_rate: NDArray,
    x0: NDArray, P0: NDArray, q_bias: float, on: float, off: float, hold_s: float,
    v_gate: float, sigma_beta_straight: float, bias_known_var: float, unknown_factor: float,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:  # fmt: skip
    """KKF with state [psi, b_gyro, s_gyro] (s = scale factor; P0[2,2] = 0 freezes it at 0).

    psi' = (w_z - b) / (1 + s) ~ w_z - b - s w_z   (gyro = (1 + s) r + b)
    """
    n = t.size
    x = x0.copy()
    P = P0.copy()
    xs = np.empty((n, 3))
    pd = np.empty((n, 3))
    straight = np.zeros(n, dtype=np.bool_)
    innov = np.full(n, np.nan)
    S = np.full(n, np.nan)
    F = np.eye(3)
    Q = np.zeros((3, 3))
    Gu = np.zeros(3)
    h_psi = np.array([1.0, 0.0, 0.0])
    h_b = np.array([0.0, 1.0, 0.0])
    work = np.zeros((8, 3))  # filters.kalman.workspace(3): no per-row allocation
    w = 0.0
    st = False
    on_time = 0.0
    for k in range(n):
        if np.isfinite(wz[k]):
            w_new = wz[k]
        else:
            w_new = w
        if k > 0:
            dt = t[k] - t[k - 1]
            F[0, 1] = -dt
            F[0, 2] = -dt * w
            Q[0, 0] = gyro_var[k] * dt * dt
            Q[1, 1] = q_bias * dt
            if zero_rate[k - 1]:
                # standing still: heading does not change whatever the gyro reads
                F[0, 1] = 0.0
                F[0, 2] = 0.0
                Gu[0] = 0.0
                Q[0, 0] = 0.0
            else:
                Gu[0] = dt * w
            predict_ws_nb(x, P, F, Q, Gu, work)
        w = w_new
        if zero_rate[k] and np.isfinite(wz[k]):
            # gyro at standstill reads its bias
            update_scalar_ws_nb(x, P, wz[k] - x[1], h_b, gyro_var[k], work)
        dt_k = t[k] - t[k - 1] if k > 0 else 0.0
        yaw_dev = wz_mean[k] - x[1] - x[2] * wz_mean[k]
        yaw_dev_fast = wz_fast[k] - x[1] - x[2] * wz_fast[k]
        if P[1, 1] > bias_known_var:
            # bias not learned yet: a raw gyro (phones carry several deg/s of bias) would never
            # look straight.  Steady straightness is then judged by the GNSS course rate alone,
            # and turn onsets by the bias-free change of the gyro (0.1 s mean minus 1 s mean).
            yaw_dev = 0.0
            yaw_dev_fast = wz_fast[k] - wz_mean[k]
        st, on_time = _straight_step(
            st, on_time, yaw_dev, yaw_dev_fast, course_rate[k], speed[k], dt_k, on, off,
            hold_s, v_gate,
        )  # fmt: skip
        straight[k] = st
        if st and np.isfinite(course[k]):
            nu = _wrap(course[k] - x[0])
            r_k = course_var[k] + sigma_beta_straight * sigma_beta_straight
            if P[1, 1] > bias_known_var:
                # the bias still unknown: a short first straight (a burst's persisting course
                # error) must not teach it as if every epoch were independent
                r_k *= unknown_factor
            S[k] = update_scalar_ws_nb(x, P, nu, h_psi, r_k, work)
            innov[k] = nu
        for i in range(3):
            xs[k, i] = x[i]
            pd[k, i] = P[i, i]
    return xs, pd, straight, innov, S


@numba.njit(cache=True)
def _beta_at_course(
    t: NDArray, course: NDArray, psi: NDArray, var_psi: NDArray, sigma: NDArray,
    innov: NDArray, wz: NDArray, sin_bank: NDArray, speed: NDArray, scale_sigma: float,
    k_slip_g: float, road_sigma: float, max_age: float, v_gate: float, prior: float,
    course_excess: NDArray,
) -> tuple[NDArray, NDArray, NDArray, NDArray]:  # fmt: skip  # pragma: no cover - compiled
    """Sideslip beta = nu - psi at each fresh course (seed 001 eq 6) held to the next, its
    1-sigma with the model-error terms of the module docstring, the filter's own 1-sigma
    (eq 6: sqrt(P_psi + sigma_nu^2)), and the fresh-course flags; one pass, no temporaries.

    Terms of the variance at a fresh course: P_psi + sigma_nu^2 + (scale_sigma x heading
    turned since the last course update on a straight)^2 + (k_slip g sin(bank at that
    update))^2 + (sum |w_z| (1/cos(bank) - 1) dt since it)^2 + the course's error variance
    beyond its stated one (``course_excess``, per row: :mod:`sideslip.course_check`).
    ``sin_bank``: per row, or one value for all rows.  Outside ``max_age`` of the last course
    or below ``v_gate``: beta 0, both 1-sigmas ``prior``.
    """
    n = t.size
    beta = np.zeros(n)
    beta_std = np.full(n, prior)
    own_std = np.full(n, prior)
    fresh = np.zeros(n, dtype=np.bool_)
    any_update = False
    for k in range(n):
        if np.isfinite(innov[k]):
            any_update = True
            break
    one_bank = sin_bank.size == 1
    turned = 0.0  # heading turned since row 0 (integrated gyro)
    tilt_turned = 0.0  # sum |w_z| (1/cos(bank) - 1) dt since row 0
    turned_last = 0.0  # both at the last course update (row 0 before the first)
    tilt_last = 0.0
    last = 0
    beta_h = 0.0
    std_h = prior
    own_h = prior
    t_beta = -np.inf
    for k in range(n):
        if k > 0:
            w = wz[k - 1] if np.isfinite(wz[k - 1]) else 0.0
            dt = t[k] - t[k - 1]
            turned += w * dt
            sb = sin_bank[0] if one_bank else sin_bank[k - 1]
            sb = 0.9 if sb > 0.9 else sb
            tilt = 1.0 / np.sqrt(1.0 - sb * sb) - 1.0
            tilt_turned += abs(w) * tilt * dt
        if np.isfinite(innov[k]):
            turned_last = turned
            tilt_last = tilt_turned
            last = k
        if np.isfinite(course[k]):
            fresh[k] = True
            sg = sigma[k] if np.isfinite(sigma[k]) else 0.0
            own = var_psi[k] + sg * sg
            d_scale = scale_sigma * (turned - turned_last)
            bank = (sin_bank[0] if one_bank else sin_bank[last]) if any_update else road_sigma
            d_bank = k_slip_g * bank
            d_tilt = tilt_turned - tilt_last
            var = own + d_scale * d_scale
            var = var + d_bank * d_bank + d_tilt * d_tilt + course_excess[k]
            b = _wrap(course[k] - psi[k])
            if np.isfinite(b):
                beta_h = b
                t_beta = t[k]
            if np.isfinite(var):
                std_h = np.sqrt(var)
            if np.isfinite(own):
                own_h = np.sqrt(own)
        if t[k] - t_beta <= max_age and abs(speed[k]) > v_gate:
            beta[k] = beta_h
            beta_std[k] = std_h
            own_std[k] = own_h
    return beta, beta_std, own_std, fresh


@dataclass(frozen=True)
class KkfResult:
    """KKF output: beta (held, rad), beta_std, yaw, bias, scale factor, their variances,
    straight flags, rows with a fresh beta (``beta_fresh``), innovations and S."""

    beta: FloatArray
    beta_std: FloatArray
    x: FloatArray
    var: FloatArray
    straight: NDArray[np.bool_]
    beta_fresh: NDArray[np.bool_]
    innov: FloatArray
    S: FloatArray
    beta_std_filter: FloatArray  # eq 6 from the filter's own P (no model-error terms)
    gyro_sigma_100hz: float  # rad/s, the gyro noise the filter ran with, and its source
    gyro_sigma_source: str
    gyro_bias_psd: float = Q_BIAS  # (rad/s)^2/s, the bias walk it ran with
    bias_walk_choice: dict[str, Any] = field(default_factory=dict)  # how it was identified
    gyro_zero: Fitted | None = None  # the drive's zero the bias state started from (zero_gyro)
    course_check: dict[str, Any] = field(default_factory=dict)  # CourseExcess.summary()


def run_kkf(
    drive: Drive,
    vehicle: Vehicle,
    estimate_scale: bool = False,
    scale: float = 0.0,
    settings: KkfSettings | None = None,
) -> KkfResult:
    """Run the KKF; ``estimate_scale`` adds the gyro scale-factor state; ``scale`` is a known
    scale factor removed from the gyro first (w_z / (1 + scale))."""
    st = settings if settings is not None else KkfSettings()
    t = drive.t
    speed = vehicle_speed(drive)
    cm = gnss.course_at_cg(drive, vehicle, speed, st.v_gate_m_s)
    wz = drive["wz"] / (1.0 + scale)
    rows = np.flatnonzero(np.isfinite(cm.course))
    gnss_dt = float(np.median(np.diff(t[rows]))) if rows.size > 1 else 0.1
    del rows
    zero = drive_gyro_bias(drive, vehicle) if st.zero_gyro else None
    bias0, sigma_bias0 = (zero.value / (1.0 + scale), zero.sigma) if zero and zero.informed else (
        0.0, SIGMA_BIAS0)
    x0 = np.array([initial_heading(t, wz - bias0 if bias0 else wz, cm.course, drive), bias0, 0.0])
    P0 = np.diag([SIGMA_PSI0**2, sigma_bias0**2, SIGMA_SCALE0**2 if estimate_scale else 0.0])
    # the yaw-rate lever-arm term of the course (rx r / V) is removed with the raw gyro
    course = np.where(np.isfinite(cm.course), cm.course - cm.hr * np.nan_to_num(wz), np.nan)
    g_sigma, g_source = kkf_gyro_sigma(drive, st)
    # the per-row inputs of every pass, built once (the bias-walk passes share them) and
    # released before the beta series are formed
    inputs = [
        wz, causal_mean(t, wz, STRAIGHT_WINDOW_S), causal_mean(t, wz, STRAIGHT_FAST_S),
        _gyro_variance(t, wz, g_sigma), course, cm.sigma**2,
        _course_rate(t, cm.course, course_rate_window(cm.sigma, gnss_dt)), speed,
        np.abs(speed) < STANDSTILL_SPEED,
    ]  # fmt: skip

    corr = courses_per_error(drive, t, course, gnss_dt)

    def loop(q_bias: float) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        w, w_mean, w_fast, g_var, nu, nu_var, nu_rate, v, still = inputs
        return _kkf_loop(
            t, w, w_mean, w_fast, g_var, nu, nu_var * corr, nu_rate, v, still, x0, P0, q_bias,
            st.straight_on_rad_s, st.straight_off_rad_s,
            st.straight_hold_s, st.v_gate_m_s, SIGMA_BETA_STRAIGHT, BIAS_KNOWN_VAR,
            max(1.0, COURSE_ERROR_TAU_S / max(gnss_dt, 1e-3) / corr),
        )  # fmt: skip

    q_bias, bias_choice = _bias_walk(st, loop)
    xs, pd, straight, innov, S = loop(q_bias)
    inputs.clear()
    # road bank: the car crabs by ~ k_slip g sin(bank) on a banked straight (assumed beta = 0
    # there, so psi takes it), and its body-z gyro under-reads the heading rate by
    # 1/cos(bank) - 1 in turns on the bank; the bank from the accelerometer when present
    yaw_rate = wz - xs[:, 1]
    cue = gravity_lateral_sin(drive, speed, yaw_rate)
    del yaw_rate
    sin_bank = np.array([st.road_bank_sigma]) if cue is None else cue
    k_slip, _ = typical.slip_gain_k(vehicle)
    # the course's errors beyond its stated sigma (multipath bursts), read against the gyro
    rows = np.flatnonzero(np.isfinite(course))
    excess = course_excess_variance(
        t, rows, course[rows], cm.sigma[rows], wz - xs[:, 1], independent_lag_s(drive, t[rows])
    )
    excess_rows = np.zeros(t.size)
    if st.course_check:
        excess_rows[rows] = excess.excess_var
        if "gnss_ve" in drive and rows.size > 1:
            # Doppler: consecutive epochs miss a burst's slowly drifting error; pairs 1 s apart
            # see it.  Taken where the gyro shows no turn (below straight_off_rad_s): in limit
            # transients the 1 s pairs also read the gyro's scale and the slip's change as
            # course error (cr_limit_slalom median sigma 0.74 -> 2.55 deg when taken there)
            slow = course_excess_variance(
                t, rows, course[rows], cm.sigma[rows], wz - xs[:, 1], DOPPLER_SLOW_PAIR_S
            )
            calm = np.abs(wz - xs[:, 1])[rows] < st.straight_off_rad_s
            excess_rows[rows] = np.maximum(excess_rows[rows], np.where(calm, slow.excess_var, 0.0))
    beta, beta_std, beta_std_filter, fresh = _beta_at_course(
        t, course, xs[:, 0], pd[:, 0], cm.sigma, innov, wz, sin_bank, speed,
        st.gyro_scale_rel_sigma, k_slip * GRAVITY_M_S2, st.road_bank_sigma,
        max(KKF_MAX_COURSE_AGE_S, 1.5 * gnss_dt), st.v_gate_m_s, KKF_BETA_PRIOR, excess_rows,
    )  # fmt: skip
    return KkfResult(beta, beta_std, xs, pd, straight, fresh, innov, S, beta_std_filter,
                     g_sigma, g_source, q_bias, bias_choice, zero,
                     {**excess.summary(), "applied": st.course_check})  # fmt: skip


def _bias_walk(
    st: KkfSettings, loop: Callable[[float], tuple[NDArray, ...]]
) -> tuple[float, dict[str, Any]]:
    """The gyro-bias walk density and how it was chosen: explicit, typical (presets "paper",
    "typical"), or with "auto" the factor on :data:`Q_BIAS` of :data:`BIAS_WALK_GRID` that
    maximises the likelihood of the course innovations (sum of ln S + nu^2/S, Mehra 1970; the
    KKF's only process density, seen through the heading at the straights' course updates)."""
    if st.gyro_bias_psd_rad2_s3 is not None:
        return st.gyro_bias_psd_rad2_s3, {}
    if st.preset != "auto":
        return Q_BIAS, {}
    scores: dict[str, float] = {}
    best, factor = math.inf, 1.0
    for f in BIAS_WALK_GRID:
        out = loop(f * Q_BIAS)
        score, n = neg2_log_likelihood(out[3], out[4])
        scores[f"{f:g}"] = score
        if n and score < best:
            best, factor = score, f
    return factor * Q_BIAS, {
        "factor": factor,
        "criterion": "max likelihood of the course innovations (straights) over factors on the "
        "typical bias walk",
        "course_neg2_log_likelihood_by_factor": scores,
    }


@register(
    "kkf",
    columns=("wz", SPEED, GNSS_COLUMNS),
    summary="kinematic Kalman filter [psi, b_gyro]: beta = GNSS course - integrated gyro",
    paper="seed 001 eqs 4, 6",
    settings=KkfSettings,
    accelerometer="cg_causal",
)
def kkf(drive: Drive, vehicle: Vehicle, settings: KkfSettings | None = None) -> Estimate:
    """Kinematic Kalman filter of seed 001; see the module docstring."""
    st = settings if settings is not None else KkfSettings()
    res = run_kkf(drive, vehicle, settings=st)
    t = drive.t
    wz, _ = hold(drive["wz"], t)
    with np.errstate(invalid="ignore", divide="ignore"):
        nis = np.where(res.S > 0, res.innov**2 / res.S, np.nan)
    inflation = np.ones(t.size)
    health = np.zeros(t.size)
    health_params: dict[str, object] = {"criterion": "off"}
    if st.consistency_window_s > 0:
        cons = binned_nis_consistency(t, nis, 1, st.consistency_window_s)
        inflation, health, health_params = cons.inflation, cons.health, cons.summary(t)
    g_sigma, g_source = res.gyro_sigma_100hz, res.gyro_sigma_source
    series = {
        "beta": res.beta,
        "beta_std": res.beta_std * np.sqrt(inflation),
        "r": wz - res.x[:, 1],  # bias-corrected gyro (the KKF's yaw-rate input)
        "yaw": wrap_angle(res.x[:, 0]),
        "gyro_bias": res.x[:, 1],
        "yaw_std": np.sqrt(np.maximum(res.var[:, 0], 0.0) * inflation),
        "gyro_bias_std": np.sqrt(np.maximum(res.var[:, 1], 0.0)),
        "health": health,
    }
    params = {
        "straight_fraction": float(np.mean(res.straight)),
        "straight_on_rad_s": st.straight_on_rad_s,
        "straight_off_rad_s": st.straight_off_rad_s,
        "straight_hold_s": st.straight_hold_s,
        "v_gate_mps": st.v_gate_m_s,
        "gyro_bias_rad_s": float(res.x[-1, 1]),
        "gyro_bias_rad_s_sigma": float(np.sqrt(max(res.var[-1, 1], 0.0))),
        "noise": {
            "gyro_sigma_100hz_rad_s": g_sigma,
            "gyro_sigma_source": g_source,
            "course_sigma": "gnss_vel_std / V (floor 0.1 deg), GNSS layer",
            "gyro_bias_psd_rad2_s3": res.gyro_bias_psd,
            "gyro_bias_psd_source": "drive" if res.bias_walk_choice else "settings / preset",
            "gyro_bias_psd_identification": res.bias_walk_choice or None,
        },
        "residuals": {"course": channel_diagnostics(res.innov, res.S)},
        "course_check": res.course_check,
        "health": health_params,
        "settings": settings_dict(st),
    }
    if res.gyro_zero is not None:
        params["gyro_bias_start"] = {**gyro_zero_params(res.gyro_zero, subtracted=False),
                                     "else": "0 +- SIGMA_BIAS0 (the drive does not tell it)"}
    return Estimate("kkf", t, series, params, {"course": res.innov, "course_nis": nis})
