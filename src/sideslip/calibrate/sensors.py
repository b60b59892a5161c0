"""Wheel-speed scale, gyro bias and gyro scale from GNSS Doppler and standstill.

Wheel-speed scale (measured / true) ``s_w``: on straight, unaccelerated GNSS rows
(``|a_x| < AX_MAX``, ``|course rate| < STRAIGHT_RATE``, faster than 5 m/s), the speed the
drive's methods use (``sideslip.signals.speed_raw``: rear wheels, else all wheels, else CAN)
against the 3-D Doppler speed, ``v_wheel = s_w v_gnss`` (seed 004's wheel-speed scale state,
seed 000's SF = 1 / s_w).  Tyre longitudinal slip (0.1-0.3 % on driven wheels at cruise) cannot
be told from a radius error and is added to the 1-sigma as ``SLIP_SIGMA``.

Gyro (``w_z = s_g r + b_g``): over non-overlapping windows of ``GYRO_WINDOW_S`` between GNSS
epochs of one run, the integrated gyro against the course change,
``int w_z dt = s_g (nu_1 - nu_0) + b_g T`` (the sideslip change over a window, which averages
out over a turn's entry and exit, is the residual; the spread between the drive's two halves
beyond their noise is added to the 1-sigma), and at standstill (wheels and GNSS at rest)
``int w_z dt = b_g T`` over 1 s pieces (seed 001's zero-rate update).  Without GNSS only the
bias is told, from standstill; the scale is left at 1 and said so.  ``b_g`` is the drive's
average bias (the bias walks; the robust 1-sigma covers the walk between stops).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.fit import clusters_of, fit_robust, halves_sigma, informed
from sideslip.calibrate.prepare import GyroSignals, Signals, gyro_signals
from sideslip.calibrate.result import Fitted, left_alone, zero_params
from sideslip.calibrate.wheel_yaw import wheel_gyro_zero
from sideslip.drive import Drive
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

AX_MAX = 0.5  # m/s^2: little drive/brake slip
STRAIGHT_RATE = 0.05  # rad/s: the wheels of both sides and the CG share the speed
SLIP_SIGMA = 0.0015  # tyre longitudinal slip at cruise, fraction (not separable from radius)
GYRO_WINDOW_S = 2.0  # s: window of the gyro-vs-course relation
GYRO_SCALE_PRIOR = 0.05  # prior 1-sigma of the gyro scale (MEMS: 0.2-2 %), fraction
GYRO_BIAS_PRIOR = 0.02  # rad/s: prior 1-sigma of the gyro bias (~1 deg/s)
MIN_ROWS = 20
MIN_WINDOWS = 20  # GNSS windows (40 s of driving): fewer cannot average the sideslip changes out
MIN_STILL_S = 5.0  # s of standstill that tell the bias alone
# a shorter drive (at least MIN_WINDOWS_RAW windows, 10 s) still tells the bias of an
# uncalibrated gyro: a fit at least RAW_BIAS_MIN and RAW_BIAS_SIGMAS of its 1-sigma from 0,
# degrees per second that a drive's sideslip changes (a few degrees over the drive: a tenth of
# a degree per second over 20 s) cannot fake.  A calibrated gyro's tenths (the simulator's
# 0.2 deg/s rms) stay as recorded: on banked_turn (28 s) a 0.12 +- 0.02 deg/s fit of a 0.09
# truth took seed 002's graph from 0.022 to 0.029 deg.  As recorded, seed 002's graph, its
# fixed-lag form and the linear KF kept a 5.3 deg/s bias on dlc_bank (30 s, positions only:
# 0.41 deg beta RMSE with 35 % inside 2 sigma); benchmarks/results/gyro_zero_short.md
MIN_WINDOWS_RAW = 5
RAW_BIAS_SIGMAS = 4.0
RAW_BIAS_MIN = math.radians(0.5)  # rad/s: beyond a calibrated MEMS gyro's turn-on bias


def wheel_speed_scale(sig: Signals) -> Fitted:
    """The wheel/CAN speed scale s_w (measured / true) from the GNSS Doppler speed."""
    name, unit = "wheel_speed_scale", "-"
    if not sig.has_gnss:
        return left_alone(name, 1.0, unit, "no GNSS Doppler: the speed scale is not observable")
    rows = sig.g_rows
    v = sig.speed[rows]
    sel = (
        sig.g_valid
        & np.isfinite(v)
        & (np.abs(np.nan_to_num(sig.g_ax, nan=9.0)) < AX_MAX)
        & (np.abs(np.nan_to_num(sig.g_course_rate, nan=9.0)) < STRAIGHT_RATE)
    )
    if sel.sum() < MIN_ROWS:
        return left_alone(name, 1.0, unit, "too few straight, steady GNSS rows above 5 m/s")
    x = sig.g_speed[sel][:, None]
    fit, keep = fit_robust(x, v[sel], clusters_of(sig.t[rows][sel]))
    if fit.clusters < 4:
        return left_alone(name, 1.0, unit, "too few independent stretches of straight driving")
    sigma = math.hypot(float(fit.sigma()[0]), SLIP_SIGMA)
    return Fitted(
        name, float(fit.theta[0]), sigma, int(keep.sum()),
        f"speed ({sig.speed_source}) vs GNSS Doppler speed, straight |a_x|<{AX_MAX:g} m/s^2",
        True, unit, 1.0, None, "1-sigma includes 0.15 % tyre slip",
    )  # fmt: skip


def gyro_bias_scale(sig: Signals | GyroSignals) -> tuple[Fitted, Fitted]:
    """Gyro bias b_g (rad/s) and scale s_g (measured / true) from course changes and standstill."""
    X_parts: list[FloatArray] = []
    y_parts: list[FloatArray] = []
    t_parts: list[FloatArray] = []
    n_gnss = 0
    if sig.has_gnss:
        k = max(1, round(GYRO_WINDOW_S / sig.g_dt))
        j0 = np.arange(0, sig.g_rows.size - k, k)
        j1 = j0 + k
        ok = (sig.g_run[j0] == sig.g_run[j1]) & (
            sig.t[sig.g_rows[j1]] - sig.t[sig.g_rows[j0]] < 1.5 * k * sig.g_dt
        )
        j0, j1 = j0[ok], j1[ok]
        r0, r1 = sig.g_rows[j0], sig.g_rows[j1]
        dpsi = sig.g_course[j1] - sig.g_course[j0]
        dt = sig.t[r1] - sig.t[r0]
        X_parts.append(np.column_stack([dpsi, dt]))
        y_parts.append(sig.yaw_int[r1] - sig.yaw_int[r0])
        t_parts.append(sig.t[r0])
        n_gnss = int(j0.size)
    # standstill: 1 s pieces
    still = np.flatnonzero(sig.standstill)
    n_still = 0
    if still.size:
        piece = np.floor(sig.t[still]).astype(np.int64)
        brk = np.flatnonzero((np.diff(piece) != 0) | (np.diff(still) != 1)) + 1
        starts = np.concatenate([[0], brk])
        ends = np.concatenate([brk, [still.size]]) - 1
        a, b = still[starts], still[ends]
        dt = sig.t[b] - sig.t[a]
        use = dt > 0.5
        a, b, dt = a[use], b[use], dt[use]
        X_parts.append(np.column_stack([np.zeros(a.size), dt]))
        y_parts.append(sig.yaw_int[b] - sig.yaw_int[a])
        t_parts.append(sig.t[a])
        n_still = int(np.sum(b - a + 1))
    bias_name, scale_name = "gyro_bias_rad_s", "gyro_scale"
    if not X_parts or sum(p.shape[0] for p in X_parts) < 3:
        return (
            left_alone(bias_name, 0.0, "rad/s", "no GNSS course and no standstill"),
            left_alone(scale_name, 1.0, "-", "no GNSS course: the gyro scale is not observable"),
        )
    X = np.vstack(X_parts)
    y = np.concatenate(y_parts)
    tt = np.concatenate(t_parts)
    order = np.argsort(tt, kind="stable")
    X, y, tt = X[order], y[order], tt[order]
    prior_mean = np.array([1.0, 0.0])
    prior_sd = np.array([GYRO_SCALE_PRIOR, GYRO_BIAS_PRIOR])
    fit, keep = fit_robust(X, y, clusters_of(tt), prior_mean, prior_sd)
    # the two halves of the drive apart: a spread beyond their noise (sideslip changes that
    # do not average out, bias walk) is added to the 1-sigma
    sd = halves_sigma(X, y, tt, prior_mean, prior_sd, fit.sigma())
    src_bits = []
    if n_gnss:
        src_bits.append(f"course change over {GYRO_WINDOW_S:g} s windows")
    if n_still:
        src_bits.append("standstill")
    src = "gyro integral vs " + " + ".join(src_bits)
    kept = np.empty_like(keep)
    kept[order] = keep
    epochs_per_window = max(1, round(GYRO_WINDOW_S / sig.g_dt)) if n_gnss else 0
    rows_gnss = int(kept[:n_gnss].sum()) * epochs_per_window
    rows_still = n_still if kept[n_gnss:].any() else 0
    n_windows = int(kept[:n_gnss].sum())
    enough_windows = n_windows >= MIN_WINDOWS
    enough_still = n_still * float(np.median(np.diff(sig.t))) >= MIN_STILL_S if n_still else False
    b_fit = abs(float(fit.theta[1]))
    raw_gyro = n_windows >= MIN_WINDOWS_RAW and b_fit >= max(RAW_BIAS_MIN, RAW_BIAS_SIGMAS * float(sd[1]))
    bias_ok = (
        informed(float(sd[1]), GYRO_BIAS_PRIOR, 0.25)
        and fit.clusters >= 4
        and (enough_windows or enough_still or raw_gyro)
    )
    scale_ok = (
        n_gnss > 0 and informed(float(sd[0]), GYRO_SCALE_PRIOR) and fit.clusters >= 4 and enough_windows
    )
    bias = (
        Fitted(bias_name, float(fit.theta[1]), float(sd[1]), rows_gnss + rows_still, src, True, "rad/s", 0.0)
        if bias_ok
        else left_alone(
            bias_name,
            0.0,
            "rad/s",
            "too little standstill (5 s) or GNSS course (40 s; 10 s for a bias beyond 0.5 deg/s and 4 sigma)",
        )
    )
    scale = (
        Fitted(scale_name, float(fit.theta[0]), float(sd[0]), rows_gnss, src, True, "-", 1.0)
        if scale_ok
        else left_alone(scale_name, 1.0, "-", "too little GNSS course in turns (40 s): not observable")
    )
    return bias, scale


def drive_gyro_bias(drive: Drive, vehicle: Vehicle) -> Fitted:
    """The drive's own gyro zero: :func:`gyro_bias_scale`'s bias from the GNSS course windows
    and the standstill of the whole drive, prepared alone
    (:func:`~sideslip.calibrate.prepare.gyro_signals`: a few passes over the rows, no more;
    ``sideslip calibrate`` fits the same relation on the heading rate corrected for tilt, which
    moves a bias little: comma2k19 minute -3.889 deg/s here, -3.933 there, -3.884 from the
    reference pose); where those do not tell it, the rear wheels' speed difference
    (:func:`~sideslip.calibrate.wheel_yaw.wheel_gyro_zero`, with the file's rear track).
    ``vehicle``: the file (its GNSS antenna lever arm and rear track).

    For the methods whose papers assume a zeroed gyro (seed 002's graph, seed 003's observers):
    a raw MEMS gyro carries degrees per second (the comma2k19 phone: -3.9 deg/s), which those
    models read as yaw.  Without Doppler velocity the course comes from differenced GNSS
    positions (noisier: the fit's own 1-sigma decides whether it informs the bias).  Not
    informed (the value 0) when the drive has neither 40 s of GNSS course nor 5 s of
    standstill nor 20 s of rear wheel speeds at changing speed, or the fits' 1-sigma stays
    above a quarter of the 1 deg/s prior."""
    sig = gyro_signals(drive, vehicle.gnss_xyz)
    bias, _scale = gyro_bias_scale(sig)
    if bias.informed and sig.course_source != "Doppler" and sig.has_gnss:
        bias = replace(bias, source=f"{bias.source} (course from GNSS {sig.course_source})")
    if not bias.informed:
        wheels = wheel_gyro_zero(drive, vehicle.track_rear)
        if wheels.informed:
            return wheels
        bias = replace(bias, note=f"{bias.note}; {wheels.note}")
    return bias


ZERO_SIGNIFICANCE = 2.0  # a zero is subtracted when |b| exceeds this many of its 1-sigma


def subtracted_zero(zero: Fitted) -> float:
    """The part of the drive's gyro zero a method without a bias state subtracts (rad/s): the
    zero where the drive tells it and it differs from 0 by more than ``ZERO_SIGNIFICANCE`` of
    its 1-sigma, else 0.  A calibrated gyro (bias near 0) then keeps its samples rather than
    take on the fit's noise (positions-only course: 1-sigma up to 0.18 deg/s on the simulated
    race lap); a raw gyro's degrees per second are far beyond it."""
    if not zero.informed or abs(zero.value) <= ZERO_SIGNIFICANCE * zero.sigma:
        return 0.0
    return zero.value


def gyro_zero_params(zero: Fitted, subtracted: bool = True) -> dict[str, object]:
    """A method's params entries for the drive's gyro zero (:func:`drive_gyro_bias`);
    ``subtracted``: the method subtracts it (:func:`subtracted_zero`) rather than starting a
    bias state from it."""
    zeroed = not subtracted or subtracted_zero(zero) != 0.0
    return zero_params(zero, "gyro_zero_rad_s", "gyro_zero", zeroed, ZERO_SIGNIFICANCE)
