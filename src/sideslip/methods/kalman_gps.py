"""Seed 001: kinematic and model-based Kalman filters with GPS course (Bevly-style GPS/INS).

Three registered methods:

``kkf`` -- kinematic Kalman filter (seed 001 eq 4).
    State x = [psi (rad), b_gyro (rad/s)]; input: gyro yaw rate w_z (rad/s),
    psi' = w_z - b_gyro.  Measurement: GNSS Doppler course nu (rad) with H = [1 0] *only while
    driving straight* (then beta ~ 0 so nu ~ psi and the bias is observable); in turns H = 0,
    the bias is frozen and the gyro integrated.  Sideslip beta = nu - psi_hat at every fresh
    GNSS course (eq 6 gives its variance sigma_beta^2 = P_psi + sigma_nu^2), held between
    course samples.  A gyro scale factor integrates into beta through every turn.

``mkf`` -- model-based Kalman filter (seed 001 eq 5).
    State x = [beta (rad), r (rad/s), psi (rad), b_gyro (rad/s)];
    input u = [delta (front road-wheel angle, rad), bank (rad, roll sign; zero here)];
    measurements: gyro w_z = r + b_gyro every IMU row; GNSS course nu = psi + beta at GNSS rows.
    Dynamics: the linear single-track model of :mod:`sideslip.models.single_track` (seed 001
    eq 1) with psi' = r, b' = 0 (+ random walk).  Exact discretisation of every row step
    (A_d = exp(A T), B_d by the zero-order-hold integral, Q_d by Van Loan instead of the
    paper's first-order Q_d ~ B_w Q_c B_w' T), tabulated over the distinct (speed, T) pairs
    of the drive with the speed quantised to 0.2 % (``SPEED_LOG_STEP``); Joseph-form scalar
    updates (eq 2) in the order gyro, course; 1-sigma from P.  Process noise: steering-input
    noise through B plus white disturbances on beta' and r' and a bias random walk (``Q_*``).

Optional columns read when present (the registry lists the required ones): ``gnss_vn`` with
``gnss_ve`` (or ``gnss_e``/``gnss_n``), ``gnss_vel_std`` (course noise), ``wx`` (antenna
lever-arm roll-rate term).

``mkf_adaptive`` -- the paper's route back into the model (sec. VI): a KKF with a gyro
    scale-factor state identifies the scale factor from the heading change over each turn; the
    gyro is corrected and a second KKF pass gives sideslip in the turns; front and rear
    cornering stiffness are then identified by least squares from the tyre slip angles and the
    quasi-static axle forces (:func:`identify_cornering_stiffness`) and the MKF is rerun with
    them.  Offline (two passes over the whole drive).

Signs re-derived (package conventions, not the paper's figure): course nu = psi + beta with
yaw from East counter-clockwise; bank enters with the roll sign as in single_track (seed 001
writes + m g sin(phi_b) with the opposite bank sign).  The GNSS antenna at lever arm
(rx, ry, rz) from the CG sees v_y,ant = v_y + r rx - p rz, so its course is
nu_ant = psi + beta + (rx/V) r - (rz/V) p: the MKF puts (rx/V) in H and both filters remove
the roll-rate term with the measured w_x (when the drive has it); beta is thus at the CG.

Straight driving (KKF, :func:`straight_flags`): over a causal 1 s window, the bias-corrected
gyro mean |w_z - b| and the GNSS course rate |d nu/dt| both below ``STRAIGHT_ON`` for
``STRAIGHT_HOLD_S`` enter "straight"; either above ``STRAIGHT_OFF`` -- or the 0.1 s gyro mean
above it, or speed below the gate, or no recent course -- leaves it at once (hysteresis).

Low speed, standstill, reversing, outages (documented behaviour, never NaN):
* below ``V_GATE`` or reversing, the MKF swaps the single-track dynamics (singular at V = 0)
  for the kinematic relation beta -> lr/L delta (first order, time constant ``TAU_LOW_S``) and
  a random-walk yaw rate carried by the gyro; the GNSS course is used above the gate only
  (reversing: course + pi).  At standstill (|v| < 0.1 m/s) a pseudo-measurement r = 0 makes
  the gyro bias observable in both filters (an addition to the paper, standard for cars).
* KKF: below the gate or when the last course is older than ``KKF_MAX_COURSE_AGE_S`` (or
  1.5 GNSS intervals, for slow receivers) beta falls back to 0 with beta_std
  ``KKF_BETA_PRIOR``.  The course-rate window stretches to two GNSS intervals likewise.
* GNSS outages: the MKF runs on model + gyro (its beta_std grows); the KKF integrates the gyro.
* Rows where a sensor has no sample (NaN) are not measurements; inputs are zero-order held.
* GNSS course outliers (multipath): a sample whose change since the last accepted one departs
  from the gyro-integrated heading change by more than ``OUTLIER_SIGMAS`` sigma (plus a
  sideslip-rate allowance) is dropped by both filters; after ``OUTLIER_MAX_RUN`` rejections in
  a row the next sample is accepted so a real jump (e.g. after an outage) re-synchronises.

Noise values are typical automotive MEMS / Doppler-receiver specifications (not tuned to any
drive): gyro 0.3 deg/s at 100 Hz (seed 001 Table I), Doppler velocity 0.1 m/s per axis unless
the drive gives ``gnss_vel_std``.

Valid for the linear tyre range (|a_y| below ~0.4 g); the MKF's beta is biased when the vehicle
file is wrong (see its residual diagnostics in ``params['residuals']``) and on banked roads
(bank is taken as zero: the drive has no bank measurement).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.filters.kalman import (
    normalised_innovations,
    predict_nb,
    steady_state,
    update_scalar_nb,
    whiteness,
)
from sideslip.frames import wrap_angle
from sideslip.methods.registry import SPEED, register
from sideslip.models.single_track import continuous_arrays, van_loan
from sideslip.signals import STANDSTILL_SPEED, gnss_course, hold, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

# ---- gates --------------------------------------------------------------------------------
V_GATE = 3.0  # m/s: GNSS course and single-track model used above this speed only
TAU_LOW_S = 0.3  # s: low-speed beta relaxes to the kinematic lr/L delta with this time constant
SPEED_LOG_STEP = 0.002  # speed quantisation of the discretised model (0.2 % relative)

# ---- sensor noise (typical specifications) --------------------------------------------------
SIGMA_GYRO_100HZ = math.radians(0.3)  # rad/s per sample at 100 Hz (white; variance ~ rate)
SIGMA_GNSS_VEL = 0.1  # m/s per horizontal axis when the drive has no gnss_vel_std
SIGMA_COURSE_FLOOR = math.radians(0.1)  # rad: antenna / multipath floor of the course
SIGMA_ZERO_RATE = 1.0e-3  # rad/s: pseudo-measurement r = 0 at standstill

# ---- MKF process noise (continuous power spectral densities) ------------------------------
Q_STEER = math.radians(0.3) ** 2  # rad^2 s: steering input / tyre-force model error
Q_BETA = math.radians(0.1) ** 2  # rad^2/s: lateral force disturbance (wind, bank, grade)
Q_YAW_RATE = math.radians(1.0) ** 2  # (rad/s)^2/s: yaw moment disturbance
Q_BIAS = math.radians(0.005) ** 2  # (rad/s)^2/s: gyro bias random walk
Q_BETA_LOW = math.radians(2.0) ** 2  # rad^2/s: low-speed kinematic beta
Q_YAW_RATE_LOW = 1.0  # (rad/s)^2/s: low speed, r carried by the gyro alone
SIGMA_BETA0 = math.radians(2.0)
SIGMA_R0 = 0.05
SIGMA_PSI0 = math.radians(20.0)
SIGMA_BIAS0 = math.radians(1.0)
# the gyro's own straightness test is trusted once the bias 1-sigma is below a third of the
# 'on' threshold; before that (e.g. a raw phone gyro) the GNSS course rate decides
BIAS_KNOWN_VAR = (0.01 / 3.0) ** 2

# ---- KKF -----------------------------------------------------------------------------------
STRAIGHT_ON = 0.01  # rad/s (0.57 deg/s): enter straight below this |yaw rate| and |course rate|
STRAIGHT_OFF = 0.02  # rad/s: leave straight above this
STRAIGHT_HOLD_S = 1.0  # s: the on-condition must hold this long
STRAIGHT_WINDOW_S = 1.0  # s: causal averaging window of yaw rate and course rate (entry)
STRAIGHT_FAST_S = 0.1  # s: short gyro window that ends 'straight' promptly at a turn entry
SIGMA_BETA_STRAIGHT = math.radians(0.2)  # rad: beta is not exactly 0 on a straight
KKF_MAX_COURSE_AGE_S = 1.0  # s: older course -> beta unknown, falls back to 0
KKF_BETA_PRIOR = math.radians(3.0)  # rad: beta_std when the KKF has no fresh beta
SIGMA_SCALE0 = 0.05  # 1-sigma prior of the gyro scale factor state (adaptive route)

# ---- cornering-stiffness identification -----------------------------------------------------
ID_AY_MIN = 1.0  # m/s^2: enough excitation
ID_AY_MAX = 0.5 * 9.80665  # m/s^2: near-linear tyres (seed 001 test-track turn: 0.4 g)
ID_RDOT_MAX = 0.1  # rad/s^2: quasi-steady
ID_SPEED_MIN = 5.0  # m/s
ID_MIN_SAMPLES = 20
ID_CLAMP = (0.33, 3.0)  # identified / file value limits
ID_R2_MIN = 0.7  # share of the axle-force variance the fit must explain to be adopted
ID_BETA_STD_MAX = math.radians(0.5)  # rad: only KKF sideslip this certain is used
ID_SCALE_STD_MAX = 0.01  # the scale-factor estimate is used only when this certain
WHITENESS_LAGS = 20
# Heuristic limit of the gyro residual colour (sum of squared autocorrelations over 20 lags of
# the 100 Hz gyro innovations) above which the vehicle file is flagged: white noise gives
# ~20/n; on simulated flat-road drives in the linear range the right file stays below ~0.3,
# a file 30 % off in cornering stiffness or of another vehicle gives 0.7-17, and so do an
# unmodelled bank or tyres beyond the linear range (benchmarks/results/kalman_gps_accuracy.md).
# The course channel (10 Hz) is coloured by a gyro scale factor too, so it is reported but not
# used for the verdict.  The Ljung-Box 'white' flag itself rejects any real model over
# thousands of 100 Hz samples.
RESIDUAL_COLOUR_MAX = 0.5

GNSS_COLUMNS = ("gnss_ve", "gnss_e")  # Doppler velocity, else differenced positions
OUTLIER_SIGMAS = 4.0  # course sample rejected beyond this many sigma of the gyro-predicted step
OUTLIER_BETA_RATE = 0.2  # rad/s: allowance for the sideslip change between two course samples
OUTLIER_MAX_RUN = 5  # after this many rejections in a row the next sample is accepted (re-sync)


# ==========================================================================================
# sensor preparation shared by both filters (and the FilterPy peer)
# ==========================================================================================
@dataclass(frozen=True)
class CourseMeasurements:
    """Fresh GNSS course on the drive's rows (NaN where none), corrected to the CG.

    ``course``: rad, roll-rate lever-arm term removed; ``sigma``: 1-sigma (rad); ``hr``: the
    yaw-rate lever-arm coefficient rx/V (s) of the measurement model.
    """

    course: FloatArray
    sigma: FloatArray
    hr: FloatArray


def _course_measurements(drive: Drive, vehicle: Vehicle, speed: FloatArray) -> CourseMeasurements:
    n = len(drive)
    course = np.full(n, np.nan)
    sigma = np.full(n, np.nan)
    hr = np.zeros(n)
    rows, nu, gspeed = gnss_course(drive, V_GATE)
    # forward driving above the gate only: reversing flips the course by pi (added here so that
    # nu = psi + beta holds), and the wheel speed confirms the GNSS speed
    fwd = np.abs(speed[rows]) > V_GATE
    rows, nu, gspeed = rows[fwd], nu[fwd], gspeed[fwd]
    rev = speed[rows] < 0
    nu = np.where(rev, nu + np.pi, nu)
    rx, _, rz = (float(c) for c in vehicle.gnss_xyz)
    if "wx" in drive and rz != 0.0:
        p, _ = hold(drive["wx"], drive.t)
        nu = nu + rz * p[rows] / gspeed
    sv = np.full(rows.size, SIGMA_GNSS_VEL)
    if "gnss_vel_std" in drive:
        vs = drive["gnss_vel_std"][rows]
        sv = np.where(np.isfinite(vs) & (vs > 0), vs, SIGMA_GNSS_VEL)
    sig = np.hypot(sv / gspeed, SIGMA_COURSE_FLOOR)
    bad = _course_outliers(
        drive.t, rows, nu, sig, drive["wz"], OUTLIER_SIGMAS, OUTLIER_BETA_RATE, OUTLIER_MAX_RUN
    )
    rows, nu, sig, rev, gspeed = rows[~bad], nu[~bad], sig[~bad], rev[~bad], gspeed[~bad]
    course[rows] = wrap_angle(nu)
    sigma[rows] = sig
    hr[rows] = np.where(rev, -rx, rx) / gspeed
    return CourseMeasurements(course, sigma, hr)


@numba.njit(cache=True)
def _course_outliers(
    t: NDArray, rows: NDArray, course: NDArray, sigma: NDArray, wz: NDArray,
    n_sigma: float, beta_rate: float, max_run: int,
) -> NDArray:  # fmt: skip
    """Reject course samples (multipath) whose change since the last accepted sample differs
    from the gyro-integrated heading change by more than n_sigma combined sigmas plus a sideslip
    allowance beta_rate * dt.  Returns a bool mask over ``rows``."""
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


def _gyro_variance(t: FloatArray) -> FloatArray:
    """Per-sample gyro variance: sigma_100Hz^2 * (rate / 100 Hz) (white noise of fixed PSD)."""
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.01))
    dt = np.clip(dt, 1e-4, 1.0)
    return SIGMA_GYRO_100HZ**2 * (0.01 / dt)


# ==========================================================================================
# MKF: model tables, loop
# ==========================================================================================
@dataclass(frozen=True)
class MkfNoise:
    """Continuous process-noise densities of the MKF (see module constants for units)."""

    q_steer: float = Q_STEER
    q_beta: float = Q_BETA
    q_yaw_rate: float = Q_YAW_RATE
    q_bias: float = Q_BIAS


def mkf_continuous(
    vehicle: Vehicle, speed: NDArray, noise: MkfNoise = MkfNoise()
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Continuous 4-state MKF matrices at N speeds: A (N,4,4), B (N,4,2), Qc (N,4,4).

    x = [beta, r, psi, b_gyro], u = [delta, bank].  Process noise enters as
    w = [w_delta (through the steering column of B), w_beta, w_r] plus a bias random walk.
    """
    a2, b2, _, _ = continuous_arrays(vehicle, speed)
    n = a2.shape[0]
    A = np.zeros((n, 4, 4))
    A[:, :2, :2] = a2
    A[:, 2, 1] = 1.0
    B = np.zeros((n, 4, 2))
    B[:, :2, :] = b2
    Gw = np.zeros((n, 4, 3))
    Gw[:, :2, 0] = b2[:, :, 0]
    Gw[:, 0, 1] = 1.0
    Gw[:, 1, 2] = 1.0
    qd = np.diag([noise.q_steer, noise.q_beta, noise.q_yaw_rate])
    Qc = Gw @ qd @ np.transpose(Gw, (0, 2, 1))
    Qc[:, 3, 3] = noise.q_bias
    return A, B, Qc


def _low_speed_continuous(vehicle: Vehicle, noise: MkfNoise) -> tuple[FloatArray, ...]:
    A = np.zeros((4, 4))
    A[0, 0] = -1.0 / TAU_LOW_S
    A[2, 1] = 1.0
    B = np.zeros((4, 2))
    B[0, 0] = vehicle.lr / vehicle.wheelbase / TAU_LOW_S
    Qc = np.diag([Q_BETA_LOW, Q_YAW_RATE_LOW, 0.0, noise.q_bias])
    return A, B, Qc


@numba.njit(cache=True)
def _expm_nb(M: NDArray) -> NDArray:
    """Matrix exponential by scaling and squaring with a 16-term Taylor series.

    The norm is scaled below 0.25 first, where the truncation error of 16 terms is below
    0.25^17 / 17! ~ 1e-25 relative: exact to double precision.  Used for the small (<= 8 x 8)
    discretisation matrices of one IMU step, where it is ~50x faster than scipy's batched expm.
    """
    n = M.shape[0]
    norm = 0.0
    for i in range(n):
        row = 0.0
        for j in range(n):
            row += abs(M[i, j])
        norm = max(norm, row)
    sq = 0
    while norm > 0.25:
        norm *= 0.5
        sq += 1
    A = M / (2.0**sq)
    E = np.eye(n)
    term = np.eye(n)
    for k in range(1, 17):
        term = term @ A / k
        E += term
    for _ in range(sq):
        E = E @ E
    return E


@numba.njit(cache=True)
def _discretise_nb(
    A: NDArray, B: NDArray, Qc: NDArray, dt: NDArray
) -> tuple[NDArray, NDArray, NDArray]:
    k, n, m = B.shape
    Ad = np.empty((k, n, n))
    Bd = np.empty((k, n, m))
    Qd = np.empty((k, n, n))
    for i in range(k):
        # stiff models over long steps (time-stamp gaps): discretise a short step h = dt/2^j
        # with ||A|| h <= 0.5 (Van Loan is ill-conditioned for large ||A|| dt, its blocks
        # grow like exp(||A|| dt)), then double exactly j times.
        anorm = 0.0
        for r in range(n):
            row = 0.0
            for c in range(n):
                row += abs(A[i, r, c])
            anorm = max(anorm, row)
        h = dt[i]
        j = 0
        while anorm * h > 0.5:
            h *= 0.5
            j += 1
        Mz = np.zeros((n + m, n + m))
        Mz[:n, :n] = A[i] * h
        Mz[:n, n:] = B[i] * h
        Ez = _expm_nb(Mz)
        Mv = np.zeros((2 * n, 2 * n))
        Mv[:n, :n] = -A[i] * h
        Mv[:n, n:] = Qc[i] * h
        Mv[n:, n:] = A[i].T * h
        Ev = _expm_nb(Mv)
        ad = np.ascontiguousarray(Ev[n:, n:].T)
        q = ad @ np.ascontiguousarray(Ev[:n, n:])
        q = 0.5 * (q + q.T)
        a = np.ascontiguousarray(Ez[:n, :n])
        b = np.ascontiguousarray(Ez[:n, n:])
        for _ in range(j):  # x(2h) = a (a x + b u + w1) + b u + w2
            q = a @ q @ a.T + q
            q = 0.5 * (q + q.T)
            b = a @ b + b
            a = a @ a
        Ad[i] = a
        Bd[i] = b
        Qd[i] = q
    return Ad, Bd, Qd


def _discretise_batch(
    A: FloatArray, B: FloatArray, Qc: FloatArray, dt: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Exact ZOH discretisation (A_d, B_d) and Van Loan process noise Q_d for a batch of
    (A, B, Qc, dt): the same block exponentials as ``single_track.discretise``/``van_loan``."""
    return _discretise_nb(
        np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(B, dtype=float),
        np.ascontiguousarray(Qc, dtype=float), np.ascontiguousarray(dt, dtype=float),
    )  # fmt: skip


@dataclass(frozen=True)
class MkfProblem:
    """Everything the MKF loop consumes (also run by the FilterPy peer).

    ``Ad``/``Bd``/``Qd``: table of discrete models (K,4,4)/(K,4,2)/(K,4,4); ``idx[k]``: the
    entry propagating row k-1 to k; ``u`` (N,2) inputs [delta, bank]; ``gyro`` (N) with NaN
    where no sample and ``gyro_var`` its variance; ``course``/``course_var``/``hr`` GNSS
    course; ``zero_rate`` rows at standstill; ``x0``, ``P0`` the prior; ``low`` rows in the
    low-speed mode.
    """

    Ad: FloatArray
    Bd: FloatArray
    Qd: FloatArray
    idx: NDArray[np.intp]
    u: FloatArray
    gyro: FloatArray
    gyro_var: FloatArray
    course: FloatArray
    course_var: FloatArray
    hr: FloatArray
    zero_rate: NDArray[np.bool_]
    x0: FloatArray
    P0: FloatArray
    low: NDArray[np.bool_]


def _model_tables(
    vehicle: Vehicle, t: FloatArray, speed: FloatArray, noise: MkfNoise
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.intp], NDArray[np.bool_]]:
    """Discretised models for each row step, tabulated by (quantised log-speed, dt)."""
    n = t.size
    dt = np.diff(t, prepend=t[0])
    dt[0] = 0.0
    v_prev = np.concatenate(([speed[0]], speed[:-1]))
    low = (np.abs(v_prev) < V_GATE) | (v_prev < 0)
    vbin = np.where(low, -1, np.round(np.log(np.maximum(np.abs(v_prev), V_GATE)) / SPEED_LOG_STEP))
    dbin = np.round(dt * 1e6)
    keys = (vbin + 2.0) * 2.0**32 + dbin  # exact in float64: both parts are small integers
    ukeys, inv = np.unique(keys, return_inverse=True)
    inv = inv.reshape(n)
    uniq = np.stack([np.floor(ukeys / 2.0**32) - 2.0, np.mod(ukeys, 2.0**32)], axis=1)
    k = uniq.shape[0]
    A = np.zeros((k, 4, 4))
    B = np.zeros((k, 4, 2))
    Qc = np.zeros((k, 4, 4))
    fast = uniq[:, 0] >= 0
    if fast.any():
        a, b, q = mkf_continuous(vehicle, np.exp(uniq[fast, 0] * SPEED_LOG_STEP), noise)
        A[fast], B[fast], Qc[fast] = a, b, q
    if (~fast).any():
        a, b, q = _low_speed_continuous(vehicle, noise)
        A[~fast], B[~fast], Qc[~fast] = a, b, q
    Ad, Bd, Qd = (np.ascontiguousarray(m) for m in _discretise_batch(A, B, Qc, uniq[:, 1] * 1e-6))
    return Ad, Bd, Qd, inv.astype(np.intp), low


def _initial_heading(t: FloatArray, wz: FloatArray, course: FloatArray) -> float:
    """psi(t0) from the first fresh course minus the gyro integrated up to it (beta ~ 0)."""
    rows = np.flatnonzero(np.isfinite(course))
    if rows.size == 0:
        return 0.0
    j = int(rows[0])
    w = np.nan_to_num(wz[:j])
    turned = float(np.sum(w * np.diff(t[: j + 1]))) if j > 0 else 0.0
    return float(course[j] - turned)


def mkf_problem(
    drive: Drive,
    vehicle: Vehicle,
    bank: FloatArray | None = None,
    noise: MkfNoise = MkfNoise(),
) -> MkfProblem:
    """Assemble the MKF inputs from a drive (bank: known road bank per row, default zero)."""
    t = drive.t
    speed = vehicle_speed(drive)
    steer, _ = hold(drive["steer"], t) if "steer" in drive else (np.zeros_like(t), None)
    u = np.zeros((t.size, 2))  # C-contiguous rows for the numba loop
    u[:, 0] = steer
    if bank is not None:
        u[:, 1] = np.nan_to_num(np.asarray(bank, dtype=float))
    Ad, Bd, Qd, idx, low = _model_tables(vehicle, t, speed, noise)
    cm = _course_measurements(drive, vehicle, speed)
    wz = drive["wz"]
    x0 = np.array([0.0, 0.0, _initial_heading(t, wz, cm.course), 0.0])
    P0 = np.diag([SIGMA_BETA0, SIGMA_R0, SIGMA_PSI0, SIGMA_BIAS0]) ** 2
    return MkfProblem(
        Ad, Bd, Qd, idx, u, wz, _gyro_variance(t), cm.course, cm.sigma**2, cm.hr,
        np.abs(speed) < STANDSTILL_SPEED, x0, P0, low,
    )  # fmt: skip


@numba.njit(cache=True)
def _wrap(a: float) -> float:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@numba.njit(cache=True)
def _mkf_loop(
    Ad: NDArray, Bd: NDArray, Qd: NDArray, idx: NDArray, u: NDArray,
    gyro: NDArray, gyro_var: NDArray, course: NDArray, course_var: NDArray, hr: NDArray,
    zero_rate: NDArray, x0: NDArray, P0: NDArray, zero_rate_var: float,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray]:  # fmt: skip
    n = u.shape[0]
    x = x0.copy()
    P = P0.copy()
    xs = np.empty((n, 4))
    pd = np.empty((n, 4))
    ig = np.full(n, np.nan)
    sg = np.full(n, np.nan)
    ic = np.full(n, np.nan)
    sc = np.full(n, np.nan)
    h_r = np.array([0.0, 1.0, 0.0, 0.0])
    h_g = np.array([0.0, 1.0, 0.0, 1.0])
    h_c = np.zeros(4)
    for k in range(n):
        if k > 0:
            j = idx[k]
            predict_nb(x, P, Ad[j], Qd[j], Bd[j] @ u[k - 1])
        if zero_rate[k]:
            update_scalar_nb(x, P, -x[1], h_r, zero_rate_var)
        if np.isfinite(gyro[k]):
            nu = gyro[k] - x[1] - x[3]
            sg[k] = update_scalar_nb(x, P, nu, h_g, gyro_var[k])
            ig[k] = nu
        if np.isfinite(course[k]):
            h_c[0] = 1.0
            h_c[1] = hr[k]
            h_c[2] = 1.0
            nu = _wrap(course[k] - (x[0] + hr[k] * x[1] + x[2]))
            sc[k] = update_scalar_nb(x, P, nu, h_c, course_var[k])
            ic[k] = nu
        for i in range(4):
            xs[k, i] = x[i]
            pd[k, i] = P[i, i]
    return xs, pd, ig, sg, ic, sc


@dataclass(frozen=True)
class MkfResult:
    """States (N,4), their variances (N,4), and the innovations with their variances S."""

    x: FloatArray
    var: FloatArray
    gyro_innov: FloatArray
    gyro_s: FloatArray
    course_innov: FloatArray
    course_s: FloatArray


def run_mkf_problem(prob: MkfProblem) -> MkfResult:
    """Run the MKF loop (numba) on an assembled problem."""
    out = _mkf_loop(
        prob.Ad, prob.Bd, prob.Qd, prob.idx, prob.u, prob.gyro, prob.gyro_var, prob.course,
        prob.course_var, prob.hr, prob.zero_rate, prob.x0, prob.P0, SIGMA_ZERO_RATE**2,
    )  # fmt: skip
    return MkfResult(*out)


def channel_diagnostics(innov: FloatArray, s: FloatArray, lags: int = WHITENESS_LAGS) -> dict[str, Any]:
    """Normalised-innovation statistics and Ljung-Box whiteness of one measurement channel."""
    z = normalised_innovations(innov, s)
    z = z[np.isfinite(z)]
    d: dict[str, Any] = whiteness(z, lags).as_dict()
    d["mean"] = float(np.mean(z)) if z.size else 0.0
    d["rms"] = float(np.sqrt(np.mean(z**2))) if z.size else 0.0
    return d


def residual_diagnostics(res: MkfResult, lags: int = WHITENESS_LAGS) -> dict[str, Any]:
    """Normalised-innovation statistics and Ljung-Box whiteness per measurement channel.

    A correct model gives zero-mean, unit-variance ('nis_mean' ~ 1), white residuals; a wrong
    vehicle file shows as a biased / coloured residual (seed 001 sec. V).  At GNSS rows only
    for the course; at every IMU row for the gyro.
    """
    gyro = channel_diagnostics(res.gyro_innov, res.gyro_s, lags)
    course = channel_diagnostics(res.course_innov, res.course_s, lags)
    suspect = gyro["colour"] > RESIDUAL_COLOUR_MAX
    return {
        "gyro": gyro,
        "course": course,
        "colour_limit": RESIDUAL_COLOUR_MAX,
        "verdict": "model mismatch suspected (coloured residuals)" if suspect else "consistent",
    }


def _mkf_estimate(
    name: str, drive: Drive, vehicle: Vehicle, params: dict[str, Any], bank: FloatArray | None
) -> Estimate:
    prob = mkf_problem(drive, vehicle, bank)
    res = run_mkf_problem(prob)
    sd = np.sqrt(np.maximum(res.var, 0.0))
    series = {
        "beta": res.x[:, 0],
        "r": res.x[:, 1],
        "yaw": wrap_angle(res.x[:, 2]),
        "gyro_bias": res.x[:, 3],
        "beta_std": sd[:, 0],
        "r_std": sd[:, 1],
        "yaw_std": sd[:, 2],
        "gyro_bias_std": sd[:, 3],
    }
    params = dict(params)
    params.update(
        {
            "cf": vehicle.cf,
            "cr": vehicle.cr,
            "bank_input": "given" if bank is not None else "zero",
            "v_gate_mps": V_GATE,
            "low_speed_fraction": float(np.mean(prob.low)),
            "gnss_course_updates": int(np.isfinite(prob.course).sum()),
            "residuals": residual_diagnostics(res),
        }
    )
    return Estimate(name, drive.t, series, params)


def run_mkf(drive: Drive, vehicle: Vehicle, bank: FloatArray | None = None) -> Estimate:
    """The MKF on a drive; ``bank`` (rad per row) as a known input, else zero (bank-unaware)."""
    return _mkf_estimate("mkf", drive, vehicle, {}, bank)


@register(
    "mkf",
    columns=("wz", "steer", SPEED, GNSS_COLUMNS),
    summary="model-based Kalman filter [beta, r, psi, b_gyro] with gyro + GNSS course",
    paper="seed 001 eqs 1-3, 5",
    vehicle_params=("mass", "yaw_inertia", "lf", "lr", "cf", "cr"),
)
def mkf(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Model-based Kalman filter of seed 001; see the module docstring."""
    return run_mkf(drive, vehicle)


# ==========================================================================================
# KKF
# ==========================================================================================
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


def _moving_mean(t: FloatArray, x: FloatArray, window_s: float) -> FloatArray:
    """Causal moving mean over ``window_s`` of the finite samples (held where none)."""
    v = np.where(np.isfinite(x), x, 0.0)
    c = np.isfinite(x).astype(float)
    cv = np.concatenate(([0.0], np.cumsum(v)))
    cc = np.concatenate(([0.0], np.cumsum(c)))
    j = np.searchsorted(t, t - window_s, side="right")
    i = np.arange(t.size) + 1
    cnt = cc[i] - cc[j]
    return np.where(cnt > 0, (cv[i] - cv[j]) / np.maximum(cnt, 1.0), 0.0)


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
) -> NDArray[np.bool_]:
    """Straight-driving detector of the KKF (the same state machine the filter runs inside).

    ``yaw_rate``: bias-corrected, 1 s averaged gyro yaw rate (rad/s); ``yaw_rate_fast``: the
    same over 0.1 s (default: ``yaw_rate``); ``course_rate``:
    GNSS course rate (rad/s, NaN = unknown).  Straight when both stay below ``on`` for
    ``hold_s`` seconds at speed above :data:`V_GATE`; left as soon as one exceeds ``off``, the
    course rate becomes unknown, or the speed drops below the gate.
    """
    fast = yaw_rate if yaw_rate_fast is None else yaw_rate_fast
    return _straight_loop(
        np.asarray(t, float), np.asarray(yaw_rate, float), np.asarray(fast, float),
        np.asarray(course_rate, float), np.asarray(speed, float), on, off, hold_s, V_GATE,
    )  # fmt: skip


@numba.njit(cache=True)
def _kkf_loop(
    t: NDArray, wz: NDArray, wz_mean: NDArray, wz_fast: NDArray, gyro_var: NDArray,
    course: NDArray,
    course_var: NDArray, course_rate: NDArray, speed: NDArray, zero_rate: NDArray,
    x0: NDArray, P0: NDArray, q_bias: float, on: float, off: float, hold_s: float,
    v_gate: float, sigma_beta_straight: float, bias_known_var: float,
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
            predict_nb(x, P, F, Q, Gu)
        w = w_new
        if zero_rate[k] and np.isfinite(wz[k]):
            # gyro at standstill reads its bias
            update_scalar_nb(x, P, wz[k] - x[1], h_b, gyro_var[k])
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
            S[k] = update_scalar_nb(
                x, P, nu, h_psi, course_var[k] + sigma_beta_straight * sigma_beta_straight
            )
            innov[k] = nu
        for i in range(3):
            xs[k, i] = x[i]
            pd[k, i] = P[i, i]
    return xs, pd, straight, innov, S


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


def run_kkf(
    drive: Drive, vehicle: Vehicle, estimate_scale: bool = False, scale: float = 0.0
) -> KkfResult:
    """Run the KKF; ``estimate_scale`` adds the gyro scale-factor state; ``scale`` is a known
    scale factor removed from the gyro first (w_z / (1 + scale))."""
    t = drive.t
    speed = vehicle_speed(drive)
    cm = _course_measurements(drive, vehicle, speed)
    wz = drive["wz"] / (1.0 + scale)
    wz_mean = _moving_mean(t, wz, STRAIGHT_WINDOW_S)
    wz_fast = _moving_mean(t, wz, STRAIGHT_FAST_S)
    rows = np.flatnonzero(np.isfinite(cm.course))
    gnss_dt = float(np.median(np.diff(t[rows]))) if rows.size > 1 else 0.1
    crate = _course_rate(t, cm.course, max(STRAIGHT_WINDOW_S, 2.0 * gnss_dt))
    zero_rate = np.abs(speed) < STANDSTILL_SPEED
    x0 = np.array([_initial_heading(t, wz, cm.course), 0.0, 0.0])
    P0 = np.diag([SIGMA_PSI0**2, SIGMA_BIAS0**2, SIGMA_SCALE0**2 if estimate_scale else 0.0])
    # the yaw-rate lever-arm term of the course (rx r / V) is removed with the raw gyro
    course = np.where(np.isfinite(cm.course), cm.course - cm.hr * np.nan_to_num(wz), np.nan)
    xs, pd, straight, innov, S = _kkf_loop(
        t, wz, wz_mean, wz_fast, _gyro_variance(t), course, cm.sigma**2, crate, speed, zero_rate,
        x0, P0, Q_BIAS, STRAIGHT_ON, STRAIGHT_OFF, STRAIGHT_HOLD_S, V_GATE, SIGMA_BETA_STRAIGHT,
        BIAS_KNOWN_VAR,
    )  # fmt: skip
    fresh = np.isfinite(course)
    beta_f = np.where(fresh, wrap_angle(np.nan_to_num(course) - xs[:, 0]), np.nan)
    std_f = np.where(fresh, np.sqrt(pd[:, 0] + np.nan_to_num(cm.sigma) ** 2), np.nan)
    beta_h, age = hold(beta_f, t, fill=0.0)
    std_h, _ = hold(std_f, t, fill=KKF_BETA_PRIOR)
    ok = (age <= max(KKF_MAX_COURSE_AGE_S, 1.5 * gnss_dt)) & (np.abs(speed) > V_GATE)
    beta = np.where(ok, beta_h, 0.0)
    beta_std = np.where(ok, std_h, KKF_BETA_PRIOR)
    return KkfResult(beta, beta_std, xs, pd, straight, fresh, innov, S)


@register(
    "kkf",
    columns=("wz", SPEED, GNSS_COLUMNS),
    summary="kinematic Kalman filter [psi, b_gyro]: beta = GNSS course - integrated gyro",
    paper="seed 001 eqs 4, 6",
)
def kkf(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Kinematic Kalman filter of seed 001; see the module docstring."""
    res = run_kkf(drive, vehicle)
    wz, _ = hold(drive["wz"], drive.t)
    series = {
        "beta": res.beta,
        "beta_std": res.beta_std,
        "r": wz - res.x[:, 1],  # bias-corrected gyro (the KKF's yaw-rate input)
        "yaw": wrap_angle(res.x[:, 0]),
        "gyro_bias": res.x[:, 1],
        "yaw_std": np.sqrt(np.maximum(res.var[:, 0], 0.0)),
        "gyro_bias_std": np.sqrt(np.maximum(res.var[:, 1], 0.0)),
    }
    params = {
        "straight_fraction": float(np.mean(res.straight)),
        "straight_on_rad_s": STRAIGHT_ON,
        "straight_off_rad_s": STRAIGHT_OFF,
        "straight_hold_s": STRAIGHT_HOLD_S,
        "v_gate_mps": V_GATE,
        "residuals": {"course": channel_diagnostics(res.innov, res.S)},
    }
    return Estimate("kkf", drive.t, series, params)


# ==========================================================================================
# cornering-stiffness identification and the adaptive MKF
# ==========================================================================================
def identify_cornering_stiffness(
    t: FloatArray,
    beta: FloatArray,
    yaw_rate: FloatArray,
    steer: FloatArray,
    speed: FloatArray,
    vehicle: Vehicle,
    use: NDArray[np.bool_],
) -> dict[str, Any]:
    """Least-squares front/rear cornering stiffness (per axle, N/rad) from measured sideslip.

    Slip angles (seed 001 eq 1):  alpha_f = delta - beta - lf r / V,  alpha_r = -beta + lr r / V.
    Axle forces from the quasi-static balance with a_y = V r (steady state, bank ignored):
        F_yf = (m lr a_y + I_z r') / L,   F_yr = (m lf a_y - I_z r') / L.
    Then cf = sum(F_yf alpha_f) / sum(alpha_f^2) and likewise cr, over rows ``use`` with
    ID_AY_MIN <= |a_y| <= ID_AY_MAX, |r'| <= ID_RDOT_MAX and V >= ID_SPEED_MIN.  With fewer than
    ID_MIN_SAMPLES rows, or a fit explaining less than ID_R2_MIN of either axle force, the
    file's values are kept ("identified": False); results are clamped to ID_CLAMP times the
    file's values.
    """
    L = vehicle.wheelbase
    v = np.maximum(np.abs(speed), 1e-3)
    rdot = np.gradient(_moving_mean(t, yaw_rate, 0.5), t) if t.size > 2 else np.zeros_like(t)
    ay = v * yaw_rate
    sel = (
        use
        & np.isfinite(beta)
        & (np.abs(ay) >= ID_AY_MIN)
        & (np.abs(ay) <= ID_AY_MAX)
        & (np.abs(rdot) <= ID_RDOT_MAX)
        & (v >= ID_SPEED_MIN)
    )
    n = int(sel.sum())
    out: dict[str, Any] = {"n_samples": n, "cf": vehicle.cf, "cr": vehicle.cr, "identified": False}
    if n < ID_MIN_SAMPLES:
        return out
    b, r, d, vv, a, rd = beta[sel], yaw_rate[sel], steer[sel], v[sel], ay[sel], rdot[sel]
    af = d - b - vehicle.lf * r / vv
    ar = -b + vehicle.lr * r / vv
    ff = (vehicle.mass * vehicle.lr * a + vehicle.yaw_inertia * rd) / L
    fr = (vehicle.mass * vehicle.lf * a - vehicle.yaw_inertia * rd) / L
    cf = float(ff @ af / (af @ af)) if af @ af > 0 else vehicle.cf
    cr = float(fr @ ar / (ar @ ar)) if ar @ ar > 0 else vehicle.cr
    r2f = 1.0 - float(np.sum((ff - cf * af) ** 2) / max(float(ff @ ff), 1e-12))
    r2r = 1.0 - float(np.sum((fr - cr * ar) ** 2) / max(float(fr @ fr), 1e-12))
    good = r2f >= ID_R2_MIN and r2r >= ID_R2_MIN and cf > 0 and cr > 0
    lo, hi = ID_CLAMP
    out.update(
        {
            "cf_raw": cf,
            "cr_raw": cr,
            "r2_front": r2f,
            "r2_rear": r2r,
            "identified": bool(good),
        }
    )
    if good:
        out["cf"] = float(np.clip(cf, lo * vehicle.cf, hi * vehicle.cf))
        out["cr"] = float(np.clip(cr, lo * vehicle.cr, hi * vehicle.cr))
    return out


def identify_from_kkf(drive: Drive, vehicle: Vehicle) -> dict[str, Any]:
    """Seed 001 sec. VI route: scale factor from a KKF with a scale state (used when its
    1-sigma is below ID_SCALE_STD_MAX, i.e. a turn between two straights was seen), gyro
    corrected, KKF sideslip in the turns, then :func:`identify_cornering_stiffness` at
    fresh-course rows whose KKF beta_std is below ID_BETA_STD_MAX."""
    first = run_kkf(drive, vehicle, estimate_scale=True)
    scale_std = float(np.sqrt(max(first.var[-1, 2], 0.0)))
    scale = float(np.clip(first.x[-1, 2], -0.1, 0.1)) if scale_std < ID_SCALE_STD_MAX else 0.0
    res = run_kkf(drive, vehicle, scale=scale)
    t = drive.t
    wz, _ = hold(drive["wz"], t)
    r = (wz - res.x[:, 1]) / (1.0 + scale)
    steer, _ = hold(drive["steer"], t)
    speed = vehicle_speed(drive)
    # only fresh KKF sideslip whose heading is known well (after a straight, not too long ago)
    use = res.beta_fresh & (res.beta_std < ID_BETA_STD_MAX)
    beta = np.where(use, res.beta, np.nan)
    ident = identify_cornering_stiffness(t, beta, r, steer, speed, vehicle, use)
    ident["gyro_scale_factor"] = scale
    ident["gyro_scale_factor_std"] = scale_std
    return ident


@register(
    "mkf_adaptive",
    columns=("wz", "steer", SPEED, GNSS_COLUMNS),
    summary="MKF with cornering stiffness identified from KKF sideslip (offline, 2 passes)",
    paper="seed 001 sec. VI",
    vehicle_params=("mass", "yaw_inertia", "lf", "lr", "cf", "cr"),
)
def mkf_adaptive(drive: Drive, vehicle: Vehicle) -> Estimate:
    """MKF rerun with cornering stiffness identified from the KKF; see the module docstring."""
    ident = identify_from_kkf(drive, vehicle)
    tuned = vehicle.with_changes(cf=ident["cf"], cr=ident["cr"])
    params = {"identification": ident, "cf_file": vehicle.cf, "cr_file": vehicle.cr}
    return _mkf_estimate("mkf_adaptive", drive, tuned, params, None)


# ==========================================================================================
# seed 001 Table I: steady-state accuracy from the discrete Riccati equation
# ==========================================================================================
TABLE_I_RATES = (5.0, 20.0, 50.0, 100.0)
TABLE_I_SPEED = 30.0
# Measurement noise at 100 Hz from seed 001 Table I's 100 Hz row.  The extracted header reads
# "sigma_beta_hat (deg), sigma_r_hat (deg/s), sigma_r (deg/s), sigma_nu (deg)": we take the
# third and fourth columns as the sensor noises (gyro 0.3 deg/s, GPS course 0.0382 deg) and the
# first two as the filter's predicted errors -- the only reading where the estimated yaw rate
# (0.2845) is better than the gyro (0.3), as a filter's must be.
TABLE_I_SIGMA_GYRO_100HZ = math.radians(0.3)
TABLE_I_SIGMA_COURSE_100HZ = math.radians(0.0382)
# seed 001 Table I as printed: sigma_beta_hat (deg), sigma_r_hat (deg/s), sigma_r gyro (deg/s),
# sigma_nu course (deg)
TABLE_I_PAPER = {
    5.0: (0.0348, 0.0636, 0.0671, 0.0086),
    20.0: (0.0697, 0.1272, 0.1342, 0.0171),
    50.0: (0.1101, 0.2012, 0.2121, 0.0270),
    100.0: (0.1558, 0.2845, 0.3, 0.0382),
}


@dataclass(frozen=True)
class TableIModel:
    """The MKF's time-invariant discrete model at one speed and rate (for Table I)."""

    F: FloatArray
    G: FloatArray
    Q: FloatArray
    H: FloatArray
    R: FloatArray


def table_one_model(
    vehicle: Vehicle,
    rate_hz: float,
    speed: float = TABLE_I_SPEED,
    sigma_gyro_100hz: float = TABLE_I_SIGMA_GYRO_100HZ,
    sigma_course_100hz: float = TABLE_I_SIGMA_COURSE_100HZ,
    noise: MkfNoise = MkfNoise(),
) -> TableIModel:
    """Discrete MKF model at ``speed`` sampled at ``rate_hz``; both measurements every sample,
    their noise 1-sigma growing as sqrt(rate) (fixed noise density)."""
    A, B, Qc = mkf_continuous(vehicle, np.array([speed]), noise)
    dt = 1.0 / rate_hz
    Ad, Qd = van_loan(A[0], Qc[0], dt)
    _, Bd, _ = _discretise_batch(A, B, Qc, np.array([dt]))
    H = np.array([[0.0, 1.0, 0.0, 1.0], [1.0, 0.0, 1.0, 0.0]])
    f = math.sqrt(rate_hz / 100.0)
    R = np.diag([(sigma_gyro_100hz * f) ** 2, (sigma_course_100hz * f) ** 2])
    return TableIModel(Ad, Bd[0], Qd, H, R)


def table_one(
    vehicle: Vehicle,
    rates: tuple[float, ...] = TABLE_I_RATES,
    speed: float = TABLE_I_SPEED,
    noise: MkfNoise = MkfNoise(),
) -> list[dict[str, float]]:
    """Seed 001 Table I: steady-state 1-sigma (after the update) of beta, r, psi and b_gyro at
    each rate, with the measurement 1-sigmas, in degrees (deg/s for rates)."""
    rows = []
    for rate in rates:
        m = table_one_model(vehicle, rate, speed, noise=noise)
        ss = steady_state(m.F, m.H, m.Q, m.R)
        sd = np.degrees(np.sqrt(np.diag(ss.P_post)))
        rows.append(
            {
                "rate_hz": float(rate),
                "sigma_gyro_deg_s": float(np.degrees(np.sqrt(m.R[0, 0]))),
                "sigma_course_deg": float(np.degrees(np.sqrt(m.R[1, 1]))),
                "sigma_beta_deg": float(sd[0]),
                "sigma_r_deg_s": float(sd[1]),
                "sigma_yaw_deg": float(sd[2]),
                "sigma_bias_deg_s": float(sd[3]),
            }
        )
    return rows
