"""The GNSS receiver's latency, identified from the drive without any tyre model.

A receiver stamps its fixes late: a fix stamped at t reports where the antenna was at t - tau
(tau 0-200 ms for consumer receivers).  On an arc the resulting along-track offset of the fixes
looks like a course error, that is like sideslip (``sideslip.methods.fused``), so a latency
identified against the tyres takes their errors for delay.  Along the track it is different:
the speed the fixes give lags the wheels' speed by tau wherever the car speeds up or slows
down, and neither the tyres nor the slip angle enter that relation.

Model, per fix (fixes faster than 1.5 Hz, whose velocity :func:`sideslip.gnss.velocity_samples`
takes over a 1 s baseline centred on the fix)::

    s_gnss = k s_w - k tau s_w' - k (s_w max(s_w', 0) / (g C_drive) + s_w min(s_w', 0) / (g C_brake)) - r l_y

with ``s_w`` the wheel (or CAN) speed averaged over the same baseline, ``s_w'`` its rate, ``k``
the wheel-speed scale, ``r l_y`` the antenna's lateral lever arm (the antenna's speed is
``v_x - r l_y``: an antenna left of the centreline runs slower in a left turn, by 0.15 m/s at
0.3 rad/s and 0.5 m; ``r`` the gyro's, its standstill bias removed), and the slip term the
wheels' longitudinal slip, which grows with the
speed times the acceleration (slip ratio a / (g C), Pacejka 2012, sec. 1.3; driven and braked
wheels slip differently: a rear-driven race car +6 % driving at 5 m/s^2, -3.5 % braking at
8 m/s^2): without it, slip reads as latency (race lap: +0.19 s at a true 0).  The fixes' speed
is a chord's over the baseline and is turned into the arc's with the heading the gyro turned
(sin(x) / x of half that angle).  Solved by least squares with Huber weights (multipath); the
1-sigma counts the fixes inside one baseline as one sample (their velocities share fixes).

Measured (simulator, 20 Hz fixes, true latency 0 / 0.05 / 0.15 s): urban_course 0.011 / 0.061 /
0.162 +- 0.039 s, demo -0.001 / 0.050 / 0.151 +- 0.067, suburban_outages -0.021 / 0.029 / 0.131
+- 0.024, race_lap 0.054 / 0.111 / 0.228 +- 0.033-0.041 (asymmetric slip at the limit); drives
at constant speed (step steer, two turns, urban highway) return a sigma of seconds: the drive
does not inform the latency, and its posterior with the prior stays at the prior's 0
(:meth:`LatencyEstimate.posterior_mean`).

The lateral lever arm ``l_y`` comes with it (tyre-free too); the longitudinal one ``l_x`` does
not: it moves the antenna's track along its own tangent, which on an arc is the sideslip's
kinematic part ``l r / v`` of another point of the body, so only a tyre model tells it from
slip.  A tyre-free fit of the course against ``r / v`` and ``a_y`` (the rear axle's slip is
proportional to the force, so speed changes in turns separate the two) was measured on the 16
simulated scenarios with 20 Hz fixes: 1-sigma 0.27 m at best (urban_course, 0.30 m against 0.5
true), metres on most; and the fused estimator given the exact ``l_x`` scored no better (mean
beta RMSE 0.078 -> 0.082 deg with the right file, 0.120 -> 0.145 with a 30 %-soft one), so it
is not identified here (``FusedSettings.identify_gnss_calibration`` does it against the tyres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip import doppler_latency_lateral, gnss
from sideslip.drive import Drive
from sideslip.signals import vehicle_speed
from sideslip.vehicle import G

FloatArray = NDArray[np.float64]

MIN_TURN_RATE_RAD_S = 0.05  # l_y is fitted only on a drive whose yaw rate reaches this
STANDSTILL_SPEED_M_S = 0.05  # the gyro's bias for l_y: its median below this speed
MIN_SPEED_M_S = 3.0  # fixes below this speed are not used (wheel pulses, course noise)
MIN_FIXES = 100  # fixes needed for an estimate
RATE_STEP_S = 0.25  # half-step of the central difference of the averaged wheel speed
HUBER_K = 1.5  # Huber threshold, in robust sigmas of the residual
# GNSS Doppler (identify_doppler_latency): the wheels' speed averaged over +-DOPPLER_HALF_S
# around the epoch (a Doppler velocity is instantaneous, not a chord's), and only where it
# changes slower than DOPPLER_MAX_RATE_M_S2: beyond, the wheels' slip is no longer linear in
# the speed times its rate (race_lap, true latency 0: +0.044 +- 0.013 s with every epoch,
# -0.063 +- 0.046 s below 3 m/s^2, i.e. the drive does not inform it)
DOPPLER_HALF_S = 0.05
DOPPLER_MAX_RATE_M_S2 = 3.0


@dataclass(frozen=True)
class LatencyEstimate:
    """``latency_s`` (s, the fixes report the antenna ``latency_s`` before their stamp) with
    its 1-sigma ``sigma_s``, the wheel-speed scale ``wheel_scale`` (GNSS speed / wheel speed)
    and the number of fixes used."""

    latency_s: float
    sigma_s: float
    wheel_scale: float
    fixes: int
    lever_y_m: float = 0.0  # the antenna's lateral lever arm, m left of the centreline
    lever_y_sigma_m: float = math.inf  # its 1-sigma (inf: the drive did not turn)
    # the Doppler's two fits (identify_doppler_latency): speed against the wheels, course rate
    # against the lateral accelerometer; NaN / inf where that fit has no estimate
    speed_s: float = math.nan
    speed_sigma_s: float = math.inf
    lateral_s: float = math.nan
    lateral_sigma_s: float = math.inf

    def lever_y_posterior(self, prior_m: float, prior_sigma_m: float) -> tuple[float, float]:
        """The antenna's lateral lever arm (m) and its 1-sigma from this estimate and a prior
        N(``prior_m``, ``prior_sigma_m``^2) (the vehicle file's value and its trust)."""
        p2, s2 = prior_sigma_m**2, self.lever_y_sigma_m**2
        if not math.isfinite(s2):
            return prior_m, prior_sigma_m
        mean = prior_m + (self.lever_y_m - prior_m) * p2 / (p2 + s2)
        return float(mean), float(1.0 / math.sqrt(1.0 / p2 + 1.0 / max(s2, 1e-18)))

    def posterior_mean(self, prior_sigma_s: float) -> float:
        """The latency (s) this estimate and a prior N(0, ``prior_sigma_s``^2) give together:
        ``latency_s prior^2 / (prior^2 + sigma^2)``, held to the range receivers have
        (-0.1 ... 0.5 s).  A drive that does not inform it (sigma of seconds) leaves 0."""
        p2 = prior_sigma_s**2
        mean = self.latency_s * p2 / (p2 + self.sigma_s**2)
        return float(min(max(mean, -0.1), 0.5))

    def posterior_sigma(self, prior_sigma_s: float) -> float:
        """1-sigma (s) of :meth:`posterior_mean`: 1 / sqrt(1 / prior^2 + 1 / sigma^2)."""
        return float(1.0 / math.sqrt(1.0 / prior_sigma_s**2 + 1.0 / max(self.sigma_s, 1e-9) ** 2))


def _window_mean(t: FloatArray, cum: FloatArray, centre: FloatArray, half: float) -> FloatArray:
    """Mean over [centre - half, centre + half] of the signal whose running integral is ``cum``
    (``cum[i]`` the integral up to ``t[i]``)."""
    lo = np.clip(np.searchsorted(t, centre - half), 0, t.size - 1)
    hi = np.clip(np.searchsorted(t, centre + half), 0, t.size - 1)
    span = t[hi] - t[lo]
    return np.asarray((cum[hi] - cum[lo]) / np.where(span > 0, span, np.nan), dtype=float)


def identify_latency(drive: Drive) -> LatencyEstimate | None:
    """The receiver latency from the fixes' speed against the wheels (module docstring); None
    without fixes faster than 1.5 Hz (or with Doppler, whose epochs this does not time), a
    speed signal, a z gyro, or :data:`MIN_FIXES` fixes above :data:`MIN_SPEED_M_S`."""
    vel = gnss.velocity_samples(drive)
    if vel.source != "positions" or vel.rows.size < MIN_FIXES or "wz" not in drive:
        return None
    t = drive.t
    fix_t = t[gnss.position_samples(drive).rows]
    if np.median(np.diff(fix_t)) >= 1.0 / gnss.CONSECUTIVE_MAX_HZ:
        return None
    speed = vehicle_speed(drive)
    if not np.isfinite(speed).any():
        return None
    dt = np.gradient(t)
    half = 0.5 * gnss.DIFFERENCE_BASELINE_S
    tc = t[vel.rows]
    cum_s = np.concatenate(([0.0], np.cumsum(np.nan_to_num(speed) * dt)))[1:]
    cum_r = np.concatenate(([0.0], np.cumsum(np.nan_to_num(drive["wz"]) * dt)))[1:]
    s_w = _window_mean(t, cum_s, tc, half)
    ahead = _window_mean(t, cum_s, tc + RATE_STEP_S, half)
    s_rate = (ahead - _window_mean(t, cum_s, tc - RATE_STEP_S, half)) / (2.0 * RATE_STEP_S)
    # the fixes' velocity is a chord's over the baseline: the arc's speed is longer by the
    # heading turned over it (x / sin x of half the angle)
    turned = _window_mean(t, cum_r, tc, half) * gnss.DIFFERENCE_BASELINE_S
    x = np.maximum(0.5 * np.abs(turned), 1e-9)
    s_gnss = vel.speed * x / np.sin(np.minimum(x, 1.5))
    use = (
        np.isfinite(s_w) & np.isfinite(s_rate) & np.isfinite(s_gnss) & (s_w > MIN_SPEED_M_S)
        & (tc - t[0] > half + RATE_STEP_S) & (t[-1] - tc > half + RATE_STEP_S)
    )  # fmt: skip
    if int(use.sum()) < MIN_FIXES:
        return None
    sw, sr, y = s_w[use], s_rate[use], s_gnss[use]
    X = np.column_stack([sw, -sr, -sw * np.maximum(sr, 0.0) / G, -sw * np.minimum(sr, 0.0) / G])
    step = float(np.median(np.diff(tc)))
    per_baseline = max(gnss.DIFFERENCE_BASELINE_S / step, 1.0)  # fixes sharing one baseline
    fit = _huber_fit(X, y, per_baseline)
    if fit is None:
        return None
    beta, cov = fit
    k = float(beta[0])
    if not (math.isfinite(k) and k > 0.5):
        return None
    var_tau = float(cov[1, 1])
    if not (math.isfinite(var_tau) and var_tau >= 0.0):
        return None
    lever_y, lever_y_sigma = _lever_y(drive, speed, turned[use], X, y, per_baseline)
    return LatencyEstimate(
        float(beta[1]) / k, math.sqrt(var_tau) / k, k, int(use.sum()), lever_y, lever_y_sigma
    )


def identify_doppler_latency(
    drive: Drive, lever_x_m: float = 0.0, lever_z_m: float = 0.0, lr_m: float = 0.0
) -> LatencyEstimate | None:
    """The latency of the GNSS Doppler velocity (s: an epoch stamped at t reports the velocity
    at t - tau), from two tyre-free fits combined: its speed against the wheels'
    (:func:`_doppler_latency_from_speed`) and its course rate against the lateral accelerometer
    (:func:`sideslip.doppler_latency_lateral.lateral_doppler_latency`; ``lever_x_m``,
    ``lever_z_m`` the antenna ahead of and above the IMU, ``lr_m`` the CG to the rear axle,
    m).  The first needs speed changes, the second turns; each carries its own sigma and both
    are in the result (``speed_*``, ``lateral_*``).  Combined by their inverse variances;
    where they disagree beyond their sigmas (chi^2 of the difference above 1) the combined
    sigma grows by sqrt(chi^2) (Birge ratio), so two fits that contradict each other do not
    decide the latency.  None where neither fit has an estimate.

    Measured (simulator, seed 0, 10 Hz Doppler 0 / 50 / 100 ms late), speed fit: urban_course
    +0.005 / +0.055 / +0.106 +- 0.006 s, demo +0.000 / +0.051 / +0.101 +- 0.010,
    suburban_outages -0.008 / +0.043 / +0.093 +- 0.005; race_lap, urban_highway and drives at
    constant speed a sigma of 0.05 s to hours.  The lateral fit decides race_lap (+- 0.006 s),
    cr_limit_slalom (+- 0.008), cr_slalom (+- 0.011), slalom_low_mu (+- 0.016) and dlc_bank
    (+- 0.021)."""
    speed_fit = _doppler_latency_from_speed(drive)
    lateral = doppler_latency_lateral.lateral_doppler_latency(drive, lever_x_m, lever_z_m, lr_m)
    if lateral is None:
        return speed_fit
    lat_s, lat_sigma, _ = lateral
    if speed_fit is None or not math.isfinite(speed_fit.sigma_s) or speed_fit.sigma_s <= 0.0:
        fixes = 0 if speed_fit is None else speed_fit.fixes
        scale = 1.0 if speed_fit is None else speed_fit.wheel_scale
        return LatencyEstimate(lat_s, lat_sigma, scale, fixes, lateral_s=lat_s, lateral_sigma_s=lat_sigma)
    w_speed, w_lat = 1.0 / speed_fit.sigma_s**2, 1.0 / lat_sigma**2
    mean = (w_speed * speed_fit.latency_s + w_lat * lat_s) / (w_speed + w_lat)
    sigma = 1.0 / math.sqrt(w_speed + w_lat)
    chi2 = (speed_fit.latency_s - lat_s) ** 2 / (speed_fit.sigma_s**2 + lat_sigma**2)
    sigma *= math.sqrt(max(chi2, 1.0))
    return LatencyEstimate(
        float(mean), float(sigma), speed_fit.wheel_scale, speed_fit.fixes,
        speed_s=speed_fit.latency_s, speed_sigma_s=speed_fit.sigma_s,
        lateral_s=lat_s, lateral_sigma_s=lat_sigma,
    )  # fmt: skip


def _doppler_latency_from_speed(drive: Drive) -> LatencyEstimate | None:
    """The Doppler's latency from its speed against the wheels', the fixes' model above without
    the chord (a Doppler velocity is the antenna's at its epoch) and without the lever arm, over
    the epochs above :data:`MIN_SPEED_M_S` whose speed changes slower than
    :data:`DOPPLER_MAX_RATE_M_S2`.  The wheels are the clock: a latency of the wheel or CAN
    speed comes out with the opposite sign.  None without Doppler, a speed signal or
    :data:`MIN_FIXES` such epochs."""
    if "gnss_ve" not in drive or "gnss_vn" not in drive:
        return None
    dop = gnss.doppler_samples(drive)
    speed = vehicle_speed(drive)
    if dop.rows.size < MIN_FIXES or not np.isfinite(speed).any():
        return None
    t = drive.t
    tc = t[dop.rows]
    cum_s = np.concatenate(([0.0], np.cumsum(np.nan_to_num(speed) * np.gradient(t))))[1:]
    s_w = _window_mean(t, cum_s, tc, DOPPLER_HALF_S)
    ahead = _window_mean(t, cum_s, tc + RATE_STEP_S, DOPPLER_HALF_S)
    s_rate = (ahead - _window_mean(t, cum_s, tc - RATE_STEP_S, DOPPLER_HALF_S)) / (2.0 * RATE_STEP_S)
    y = dop.speed
    edge = DOPPLER_HALF_S + RATE_STEP_S
    use = (
        np.isfinite(s_w) & np.isfinite(s_rate) & np.isfinite(y) & (s_w > MIN_SPEED_M_S)
        & (np.abs(s_rate) < DOPPLER_MAX_RATE_M_S2) & (tc - t[0] > edge) & (t[-1] - tc > edge)
    )  # fmt: skip
    if int(use.sum()) < MIN_FIXES:
        return None
    sw, sr, y = s_w[use], s_rate[use], y[use]
    X = np.column_stack([sw, -sr, -sw * np.maximum(sr, 0.0) / G, -sw * np.minimum(sr, 0.0) / G])
    # the wheel-speed rate's window spans 2 RATE_STEP_S: epochs inside it share its errors
    per_window = max(2.0 * RATE_STEP_S / float(np.median(np.diff(tc[use]))), 1.0)
    fit = _huber_fit(X, y, per_window)
    if fit is None:
        return None
    beta, cov = fit
    k = float(beta[0])
    var_tau = float(cov[1, 1])
    if not (math.isfinite(k) and k > 0.5 and math.isfinite(var_tau) and var_tau >= 0.0):
        return None
    tau, sigma = float(beta[1]) / k, math.sqrt(var_tau) / k
    return LatencyEstimate(tau, sigma, k, int(use.sum()), speed_s=tau, speed_sigma_s=sigma)


def _huber_fit(X: FloatArray, y: FloatArray, per_baseline: float) -> tuple[FloatArray, FloatArray] | None:
    """Least squares of ``y`` on ``X`` with Huber weights (multipath), iteratively reweighted;
    the coefficients and their covariance, the fixes inside one baseline counted as one
    sample (``per_baseline`` of them share fixes); None where ``X`` is singular."""
    w = np.ones(y.size)
    beta = np.zeros(X.shape[1])
    scale = 0.0
    for _ in range(6):
        beta = np.asarray(np.linalg.lstsq(X * w[:, None], y * w, rcond=None)[0], dtype=float)
        resid = y - X @ beta
        scale = 1.4826 * float(np.median(np.abs(resid)))
        if scale <= 0.0:
            break
        w = np.sqrt(np.minimum(1.0, HUBER_K * scale / np.maximum(np.abs(resid), 1e-12)))
    xtx = (X * w[:, None]).T @ (X * w[:, None])
    try:
        cov = np.asarray(scale**2 * np.linalg.inv(xtx) * per_baseline, dtype=float)
    except np.linalg.LinAlgError:
        return None
    return beta, cov


def _lever_y(
    drive: Drive, speed: FloatArray, turned: FloatArray, X: FloatArray, y: FloatArray, per_baseline: float
) -> tuple[float, float]:
    """The antenna's lateral lever arm (m) and its 1-sigma from the speeds' fit ``X``, ``y``
    with two more columns: ``-r`` (the yaw rate over each baseline, ``turned`` / baseline, the
    gyro's standstill bias removed) and the nuisance ``r^2 / s_w``: the antenna's lateral
    velocity (v_y + r l_x) adds (v_y + r l_x)^2 / (2 v) to its speed, and the driven wheels'
    cornering drag slips them in every turn; both grow with r^2 whichever way the car turns,
    and on a circuit driven one way round r^2 and r go together (race_lap: l_y -0.28 +- 0.14 m
    at a true 0 without it).  The latency is taken from the fit without them (with them,
    race_lap's moves 0.123 -> 0.149 s at a true 0.05).  (0, inf) where the drive does not turn
    (its yaw rate never reaches :data:`MIN_TURN_RATE_RAD_S`)."""
    wz = np.asarray(drive["wz"], dtype=float)
    still = (np.abs(speed) < STANDSTILL_SPEED_M_S) & np.isfinite(wz)
    bias = float(np.median(wz[still])) if int(still.sum()) >= 10 else 0.0
    r_w = turned / gnss.DIFFERENCE_BASELINE_S - bias
    if not (np.nanmax(np.abs(r_w)) >= MIN_TURN_RATE_RAD_S):
        return 0.0, math.inf
    fit = _huber_fit(np.column_stack([X, r_w**2 / X[:, 0], -r_w]), y, per_baseline)
    if fit is None:
        return 0.0, math.inf
    var = float(fit[1][-1, -1])
    if not (math.isfinite(var) and var >= 0.0 and math.isfinite(fit[0][-1])):
        return 0.0, math.inf
    return float(fit[0][-1]), math.sqrt(var)
