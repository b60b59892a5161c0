"""Gyro zero from the steering: a drive without GNSS, standstill or wheel speeds still bounds it.

In the steady-state single-track model the road-wheel angle is the kinematic (Ackermann) angle
plus the understeer angle (Gillespie 1992, eq 6-15; Rajamani 2012, eq 3.32, seed 003's bicycle
model at steady state):

    delta - delta_0 = L r / v + K_us a_y

with ``delta_0`` the steering sensor's zero together with the car's own straight-running steer,
``L`` the wheelbase and ``K_us`` the understeer gradient (rad/(m/s^2)).  The lateral
accelerometer reads what the tyres carry, a bank's gravity pull included, so ``K_us a_y`` holds
on a banked straight too.  Solved for the measured yaw rate ``w_z = s_g r + b_g`` and averaged
over windows of ``WINDOW_S`` of driving:

    mean(w_z) = b_g + s mean(v (delta - K_us a_y)) / L - d mean(v) / L

with ``s`` the steering's scale against the file (steering ratio, the gyro's scale and the
tyres' departure from the linear range together) and ``d = s delta_0``.  ``b_g`` and ``d`` are
told apart where the speed varies; at one speed only their sum ``b_g - d v / L`` is, and the
prior on the steering zero (``STEER_ZERO_PRIOR``: the simulator draws 0.1 deg road wheel, a
CAN sensor after alignment sits a few hundredths) bounds the gyro zero to ``v sigma_d / L``
(0.03 rad/s at 25 m/s).  That is loose, but it is what tells a 16 deg bank at the start of a
drive from a gyro bias of 6 deg/s: on a straight the bank needs no steering, the bias would
need 0.7 deg of it.

The file's understeer gradient enters as a consider parameter (``KUS_REL`` of itself: the fit
is repeated with it scaled and the move added to the 1-sigma); the 1-sigma is cluster-robust
and widened by the disagreement of the drive's halves (:mod:`sideslip.calibrate.fit`).

Used by ``fused`` as the gyro-bias state's prior where the drive has no GNSS (its heading
relation would tell the bias); the fit is a look at the whole drive, which the causal filter
takes as a calibration of the gyro only with ``whole_drive_calibration``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sideslip.calibrate.fit import clusters_of, window_ids, window_means
from sideslip.calibrate.prepare import MAX_GAP_S
from sideslip.calibrate.result import Fitted, left_alone
from sideslip.drive import Drive
from sideslip.signals import interpolate, speed_raw
from sideslip.typical import understeer_gradient
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

WINDOW_S = 1.0  # s: the windows averaged
MIN_SPEED = 3.0  # m/s: walking pace and reversing left out
AY_MAX = 4.0  # m/s^2: beyond this the tyres leave their linear range
AX_MAX = 3.0  # m/s^2: hard braking / traction shifts the axle loads and the understeer
STEER_RATE_MAX = math.radians(0.5)  # rad/s road wheel: the windows the yaw response keeps up with
# rad road wheel: the relation's own error (transients the rate gate lets through, the
# understeer's nonlinearity, roll steer), a systematic term v RELATION_SIGMA / L on the zero.
# Measured on 366 pieces (gyro_zero_steer.md): without it 96.6 % of the simulated and 81 % of
# the 16 real pieces were inside 2 sigma, with 0.04 deg 99.1 / 87.5 %, with 0.08 deg 99.7 / 100 %
RELATION_SIGMA = math.radians(0.08)
WINDOW_NOISE_FLOOR = 1.0e-3  # rad/s: floor of a window's noise in the relation
MIN_WINDOWS = 10  # windows of driving (10 s)
GYRO_BIAS_PRIOR = 0.1  # rad/s: the prior of fused's gyro-bias state (raw phone gyros: 4 deg/s)
STEER_SCALE_PRIOR = 0.3  # prior 1-sigma of the steering's scale, fraction
STEER_ZERO_PRIOR = math.radians(0.2)  # prior 1-sigma of the steering zero, rad road wheel
KUS_REL = 0.3  # a rough file's understeer gradient is 30 % off
NAME, UNIT = "gyro_bias_rad_s", "rad/s"


PRIOR_MEAN = np.array([0.0, 1.0, 0.0])
PRIOR_SD = np.array([GYRO_BIAS_PRIOR, STEER_SCALE_PRIOR, STEER_ZERO_PRIOR])


def _posterior(X: FloatArray, y: FloatArray, cluster: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
    """Mean and 1-sigma of the relation's parameters with the priors in absolute terms.

    :func:`sideslip.calibrate.fit.fit_linear` weighs its prior by the rows' residual scale,
    which a steady turn at one speed drives to zero (the three columns are constant there, so
    the rows fit any split of their sum exactly and the prior must pick it): here the windows'
    noise is the residuals' own scale with a floor (``WINDOW_NOISE_FLOOR``), the prior keeps its
    own weight, and the 1-sigma is the cluster-robust sandwich (Cameron & Miller 2015, eq 11)."""
    p_inv = np.diag(1.0 / PRIOR_SD**2)
    noise = WINDOW_NOISE_FLOOR**2
    for _ in range(3):
        H = X.T @ X / noise + p_inv
        theta = np.linalg.solve(H, X.T @ y / noise + p_inv @ PRIOR_MEAN)
        res = y - X @ theta
        noise = max(float(np.mean(res**2)), WINDOW_NOISE_FLOOR**2)
    H_inv = np.linalg.inv(X.T @ X / noise + p_inv)
    _, inv = np.unique(cluster, return_inverse=True)
    g = int(inv.max()) + 1
    scores = np.zeros((g, X.shape[1]))
    np.add.at(scores, inv, X * (res / noise)[:, None])
    scale = g / (g - X.shape[1]) if g > X.shape[1] else 1.0
    cov = H_inv @ (scores.T @ scores * scale + p_inv) @ H_inv
    # the sandwich can fall below the model-based covariance with few clusters: keep the larger
    sd = np.sqrt(np.maximum(np.diag(cov), np.diag(H_inv)))
    return theta, sd


def _fit(
    starts: FloatArray, y: FloatArray, v_delta: FloatArray, v_ay: FloatArray, v: FloatArray, kus: float,
    wb: float,
) -> tuple[float, float]:  # fmt: skip
    """(b_g, 1-sigma) of the windows' relation (module docstring) with understeer ``kus``,
    widened by the disagreement of the drive's two halves beyond their own noise (as
    :func:`sideslip.calibrate.fit.halves_sigma`)."""
    X = np.column_stack([np.ones(y.size), (v_delta - kus * v_ay) / wb, -v / wb])
    theta, sd = _posterior(X, y, clusters_of(starts))
    half = starts < np.median(starts)
    if half.sum() >= MIN_WINDOWS // 2 and (~half).sum() >= MIN_WINDOWS // 2:
        t1, s1 = _posterior(X[half], y[half], clusters_of(starts[half]))
        t2, s2 = _posterior(X[~half], y[~half], clusters_of(starts[~half]))
        sd = np.sqrt(sd**2 + np.maximum(0.0, (t1 - t2) ** 2 - s1**2 - s2**2) / 4.0)
    return float(theta[0]), float(sd[0])


def _untold(why: str) -> Fitted:
    return left_alone(NAME, 0.0, UNIT, why, sigma=GYRO_BIAS_PRIOR)


def steer_gyro_zero(drive: Drive, vehicle: Vehicle) -> Fitted:
    """The gyro zero b_g (rad/s) from the steering relation (module docstring); ``vehicle``:
    the file (wheelbase, understeer gradient or the tyres behind it).  Not informed without
    ``wz``, ``ay``, ``steer`` and a speed, or with fewer than ``MIN_WINDOWS`` windows of
    driving inside the gates; otherwise the fit's posterior, which at one speed all drive long
    is no narrower than the steering zero's prior allows."""
    if not all(name in drive for name in ("wz", "ay", "steer")):
        return _untold("no gyro, lateral accelerometer or steering")
    raw = speed_raw(drive)
    if raw is None:
        return _untold("no speed column")
    t = drive.t
    wb = float(vehicle.lf + vehicle.lr)
    kus, _ = understeer_gradient(vehicle)
    speed = interpolate(raw, t, MAX_GAP_S)
    wz = interpolate(drive["wz"], t, MAX_GAP_S)
    ay = interpolate(drive["ay"], t, MAX_GAP_S)
    delta = interpolate(drive["steer"], t, MAX_GAP_S)
    ax = interpolate(drive["ax"], t, MAX_GAP_S) if "ax" in drive else np.zeros_like(t)
    usable = (
        np.isfinite(wz) & np.isfinite(ay) & np.isfinite(delta) & np.isfinite(ax)
        & (np.nan_to_num(speed) > MIN_SPEED) & (np.abs(np.nan_to_num(ay, nan=np.inf)) < AY_MAX)
        & (np.abs(np.nan_to_num(ax, nan=np.inf)) < AX_MAX)
    )  # fmt: skip
    window = window_ids(t, usable, WINDOW_S, MAX_GAP_S)
    safe = np.where(usable, 1.0, 0.0)
    tc = (t - t[0]) * safe
    d0 = np.nan_to_num(delta) * safe
    columns = np.column_stack(
        [t, np.nan_to_num(wz) * safe, np.nan_to_num(speed * delta) * safe, np.nan_to_num(speed * ay) * safe,
         np.nan_to_num(speed) * safe, tc, tc * tc, d0, tc * d0]
    )  # fmt: skip
    means, count = window_means(window, columns)
    full = count >= max(3.0, 0.5 * float(np.median(count))) if count.size else count.astype(bool)
    # the steering's rate over each window (least-squares slope): the yaw rate lags a moving
    # steer by the yaw response's time constant, which the steady-state relation leaves out
    var_t = means[:, 6] - means[:, 5] ** 2
    rate = (means[:, 8] - means[:, 5] * means[:, 7]) / np.where(var_t > 0.0, var_t, np.inf)
    full &= np.abs(rate) < STEER_RATE_MAX
    if int(full.sum()) < MIN_WINDOWS:
        why = f"too little driving inside the steering relation's gates ({MIN_WINDOWS} s)"
        return _untold(why)
    starts, y, v_delta, v_ay, v = (means[full, j] for j in range(5))
    bias, sd = _fit(starts, y, v_delta, v_ay, v, kus, wb)
    moved, _ = _fit(starts, y, v_delta, v_ay, v, kus * (1.0 + KUS_REL), wb)
    sigma = math.sqrt(sd**2 + (moved - bias) ** 2 + (RELATION_SIGMA * float(np.mean(v)) / wb) ** 2)
    if not (math.isfinite(bias) and math.isfinite(sigma)):
        return _untold("the steering relation's fit did not converge")
    return Fitted(
        NAME, bias, min(sigma, GYRO_BIAS_PRIOR), int(count[full].sum()),
        f"gyro vs the steering's kinematic and understeer yaw rate over {WINDOW_S:g} s windows "
        f"(wheelbase {wb:.2f} m, understeer gradient {kus:.4f} rad/(m/s^2) +- {KUS_REL:.0%}, steering "
        f"zero prior +- {math.degrees(STEER_ZERO_PRIOR):g} deg)",
        True, UNIT, 0.0,
    )  # fmt: skip
