"""Gyro zero from the rear wheels' speed difference: a drive without GNSS still tells it.

A rear axle that is not steered turns at the yaw rate: its wheels roll at ``v -+ r T / 2``, so
``r = (v_rr - v_rl) / T`` with ``T`` the rear track (ISO axes, a left turn speeds up the right
wheel).  The ABS wheel speeds carry two errors that matter here: the wheels' rolling radii
differ (wear, pressure, load: a few tenths of a percent), which reads as a yaw rate
``eps v / T`` growing with speed, and the effective track differs from the drawn one (tyre
deflection), a scale on the yaw rate.  Over windows of ``WINDOW_S`` of driving

    mean(w_z) = b_g + c mean(v_rr - v_rl) + k mean(v)

with ``c = s_g / T_eff`` (gyro scale over the effective track) and ``k = -s_g eps / T``, fitted
robustly with priors on ``c`` (the file's track, ``TRACK_PRIOR_REL``) and ``k`` (radius
mismatch ``RADIUS_MISMATCH_PRIOR``).  ``b_g`` and ``k`` are told apart only where the speed
varies; on a drive at one speed the fit's 1-sigma says so and the zero stays untold.  Windows
with drive or brake force (``|a_x| > AX_MAX``: the driven wheels slip) or hard cornering
(``|a_y| > AY_MAX``: the inner wheel unloads and slips) are left out, as are walking pace and
reversing.  The yaw rate from wheel speeds is the textbook ABS yaw-rate estimate (e.g.
Gustafsson et al., "Sensor fusion for accurate computation of yaw rate and absolute
velocity", SAE 2001-01-1064); the drive's own gyro zero from it is what
:func:`sideslip.calibrate.sensors.drive_gyro_bias` falls back to where GNSS course and
standstill do not tell the zero.

Measured on the comma2k19 highway minute with its GNSS removed (phone gyro, no standstill):
-3.86 +- 0.06 deg/s against -3.88 from the reference pose (benchmarks/results/gyro_zero_wheels.md).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.fit import clusters_of, fit_robust, halves_sigma, informed, window_ids, window_means
from sideslip.calibrate.prepare import MAX_GAP_S
from sideslip.calibrate.result import Fitted, left_alone
from sideslip.drive import Drive
from sideslip.signals import interpolate

FloatArray = NDArray[np.float64]

WINDOW_S = 1.0  # s: the windows averaged (wheel-speed quantisation averages out)
MIN_SPEED = 3.0  # m/s: below this the wheel pulses are coarse (and reversing is left out)
AX_MAX = 1.0  # m/s^2: beyond this the driven wheels slip
AY_MAX = 4.0  # m/s^2: beyond this the inner wheel unloads and slips
MIN_WINDOWS = 20  # windows of driving (20 s): fewer cannot separate bias and radius mismatch
TRACK_DEFAULT = 1.55  # m: a passenger car's rear track where the file gives none
TRACK_PRIOR_REL = 0.15  # prior 1-sigma of the effective track over the file's, fraction
TRACK_PRIOR_REL_NO_FILE = 0.3  # the same without a track in the file
RADIUS_MISMATCH_PRIOR = 0.005  # prior 1-sigma of the rear wheels' rolling-radius difference
GYRO_BIAS_PRIOR = 0.02  # rad/s: prior 1-sigma of the gyro bias (~1 deg/s), as the course fit
INFORMED_SHARE = 0.25  # told when the fit shrinks the bias's 1-sigma to this share of its prior
NAME, UNIT = "gyro_bias_rad_s", "rad/s"


def wheel_gyro_zero(drive: Drive, track_rear: float = math.nan) -> Fitted:
    """The gyro zero b_g (rad/s) from the rear wheels' speed difference (module docstring);
    ``track_rear`` the vehicle file's rear track (m; NaN: a passenger car's, with a wider
    prior).  Not informed without rear wheel speeds and a gyro, with fewer than
    ``MIN_WINDOWS`` usable windows, or where the fit's 1-sigma stays above ``INFORMED_SHARE``
    of the 1 deg/s prior (one speed all drive long)."""
    if not all(name in drive for name in ("wz", "v_rl", "v_rr")):
        return left_alone(NAME, 0.0, UNIT, "no rear wheel speeds (v_rl, v_rr) or no gyro")
    t = drive.t
    wz = interpolate(drive["wz"], t, MAX_GAP_S)
    v_rl = interpolate(drive["v_rl"], t, MAX_GAP_S)
    v_rr = interpolate(drive["v_rr"], t, MAX_GAP_S)
    speed = 0.5 * (v_rl + v_rr)
    usable = np.isfinite(wz) & (np.nan_to_num(v_rl) > MIN_SPEED) & (np.nan_to_num(v_rr) > MIN_SPEED)
    window = window_ids(t, usable, WINDOW_S, MAX_GAP_S)
    # a window with a gap in the accelerometer is left out (its mean is inf)
    accel = [
        np.nan_to_num(interpolate(drive[n], t, MAX_GAP_S), nan=np.inf) if n in drive else np.zeros_like(t)
        for n in ("ax", "ay")
    ]
    columns = np.column_stack([t, wz, v_rr - v_rl, speed, *accel])
    means, count = window_means(window, columns)
    full = count >= max(3.0, 0.5 * float(np.median(count))) if count.size else count.astype(bool)
    full &= (np.abs(means[:, 4]) < AX_MAX) & (np.abs(means[:, 5]) < AY_MAX)
    if int(full.sum()) < MIN_WINDOWS:
        why = f"too little steady driving on rear wheel speeds ({MIN_WINDOWS} s)"
        return left_alone(NAME, 0.0, UNIT, why)
    starts, y, dv, v = means[full, 0], means[full, 1], means[full, 2], means[full, 3]
    has_track = math.isfinite(track_rear) and track_rear > 0.0
    track = track_rear if has_track else TRACK_DEFAULT
    rel = TRACK_PRIOR_REL if has_track else TRACK_PRIOR_REL_NO_FILE
    X = np.column_stack([np.ones(starts.size), dv, v])
    prior_mean = np.array([0.0, 1.0 / track, 0.0])
    prior_sd = np.array([GYRO_BIAS_PRIOR, rel / track, RADIUS_MISMATCH_PRIOR / track])
    fit, keep = fit_robust(X, y, clusters_of(starts), prior_mean, prior_sd)
    sd = halves_sigma(X, y, starts, prior_mean, prior_sd, fit.sigma())
    if not (informed(float(sd[0]), GYRO_BIAS_PRIOR, INFORMED_SHARE) and fit.clusters >= 4):
        return left_alone(
            NAME, 0.0, UNIT,
            f"rear wheel speeds: bias {math.degrees(fit.theta[0]):.2f} +- "
            f"{math.degrees(sd[0]):.2f} deg/s, not told apart from the wheels' radius mismatch "
            "(too little change of speed)",
        )  # fmt: skip
    return Fitted(
        NAME, float(fit.theta[0]), float(sd[0]), int(count[full][keep].sum()),
        f"gyro vs rear wheel speed difference over {WINDOW_S:g} s windows "
        f"(track {track:.2f} m {'from the file' if has_track else 'assumed'}, fitted with the "
        "radius mismatch)",
        True, UNIT, 0.0,
    )  # fmt: skip
