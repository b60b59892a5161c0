"""GNSS / wheel-speed / steering-angle EKF on the kinematic bicycle model (seed 004).

Seed 004 (GNSS/SAS/WSS integration, DGIST 2015) dead-reckons a car with the kinematic bicycle
model (eqs 2.1-2.6, :mod:`sideslip.models.kinematic`) from the rear wheel speeds (WSS) and the
steering angle (SAS), and corrects it with loosely coupled GNSS positions in an extended Kalman
filter whose error states include the wheel-speed and steering scale factors.  Two methods:

* ``ekf_wss_sas``      wheel speeds + steering + GNSS (the paper);
* ``ekf_wss_sas_imu``  the same plus the gyro yaw rate (with a bias state) - what a gyro buys.

State vector x (14), units in brackets::

    0 e, 1 n     CG position, local ENU [m]
    2 psi        yaw of the body x axis, from East counter-clockwise, unwrapped [rad]
    3 v          longitudinal speed of the rear-axle centre = v_x at the CG [m/s], signed
    4 r          yaw rate [rad/s]
    5 s_w        mean rear wheel-speed scale factor:  v_meas = (1 + s) v_true  [-]
    6 d_w        half the right-minus-left rear scale-factor difference [-]:
                 s_RL = s_w - d_w, s_RR = s_w + d_w  (tyre radius differences; our addition)
    7 k_d        steering scale factor: delta_meas = (1 + k_d) delta + b_d  [-]
    8 b_d        steering sensor offset [rad] (our addition: the paper leaves it out)
    9 K_us       understeer gradient [rad/(m/s^2)] (our addition, prior from the vehicle file)
    10 b_r       road-induced steering offset [rad], Gauss-Markov (our addition, see below)
    11 g_e, 12 g_n  GNSS position error, first-order Gauss-Markov per axis [m]
    13 b_g       gyro bias [rad/s] (``_imu`` variant; frozen at 0 otherwise)

Process model (Euler at the table rate with the mid-step heading; eqs 2.1 and 2.4, signs
re-derived)::

    e' = v cos(psi) - lr r sin(psi),  n' = v sin(psi) + lr r cos(psi),  psi' = r
    v' = w_a,  r' = w_r  (random walks: speed and yaw rate follow the sensors below)
    s_w, d_w, k_d, b_d, K_us, b_g: slow random walks
    b_r' = -b_r / tau_road + w,  g' = -g / tau_gnss + w

Measurements, each used on the rows where its sensor has a fresh sample (a finite cell; the
contract never repeats an old sample), as sequential scalar updates::

    v_RL = (1 + s_w - d_w)(v - r T_r/2),  v_RR = (1 + s_w + d_w)(v + r T_r/2)   eqs 2.5/2.6
    0    = r - v tan(delta_c - b_r) / (L + K_us v^2)                            eq 2.2 (+)
           delta_c = (delta_meas - b_d) / (1 + k_d)
    wz   = r + b_g                                                               (_imu only)
    [gnss_e, gnss_n] = [e, n] + [g_e, g_n] + R(psi) [x_ant, y_ant]               GNSS, gated

Eqs 2.5/2.6 are the paper's *inputs* (speed and yaw rate from the mean and difference of the
rear wheels); here they are written as per-wheel measurements of the speed and yaw-rate states,
which is the same information at the wheel-speed rate but also (i) makes the scale factors and
the gyro bias observable against each other, not only against GNSS, (ii) survives a missing
wheel sample.  Speed and yaw rate carry large process noise, so the states track the sensors
within a few samples: the prediction is effectively driven by the wheel speeds and steering.

Why the additions (each found necessary on simulated drives, and each present on real cars):

* d_w: the paper's eq 2.6 divides a wheel-speed difference by the track, so a 0.5 %
  left/right tyre-radius difference is a yaw-rate error of 0.06 rad/s at 10 m/s - far more
  than any other error.  GNSS heading and the steering make it observable.
* K_us: eq 2.2 (kinematic) over-predicts the yaw rate at speed by (L + K_us v^2)/L; a fixed
  steering scale factor then absorbs an average of that and is biased by several percent.
  With turns at one speed only the product (1 + k_d)(L + K_us v^2) is observable, so the
  vehicle file's K_us is the prior (1-sigma 30 %; 0.0025 +- 0.0015 when the file cannot give
  it).  With K_us = 0 and b_r = 0 the model is the paper's eq 2.2.
* b_r: to drive straight on a road banked or crowned by sin(phi) a driver holds
  delta = K_us g sin(phi) (steady single-track balance) with no yaw rate.  Eq 2.2 reads that
  as a yaw rate (0.005 rad/s at 17 m/s on a 2 deg bank, 8 deg of heading in 30 s).  b_r is a
  Gauss-Markov state with 1-sigma K_us g 0.025 (2.5 % crown) and a 30 s correlation time.

Sideslip output: eq 2.3, beta = atan(lr tan(delta_c) / L) with the corrected steering angle
(atan, not atan2, so reversing keeps the same value: v_y / v_x = lr tan(delta)/L for both
signs of v).  ``beta_std`` combines the steering-calibration covariance with the kinematic
model's own error, the rear-axle slip angle ~ k_slip |a_y| (k_slip = m lf / (L cr), the
vehicle's slip gain when the file gives it, else 0.005 s^2/m; a_y ~ v r).

Model error stated as noise (sensor-grade numbers, not fitted to any drive): eq 2.2 keeps a
floor of 0.02 rad/s plus 5 % of its value (yaw lag behind the steering, nonlinear tyres);
eq 2.4 assumes no rear-axle slip, so the lateral-velocity error v alpha_r ~ v k_slip |a_y| is
process noise on the lateral position with a 2 s correlation time.  The GNSS error is 90 %
Gauss-Markov (tau 60 s) and 45 % white of the receiver's ``gnss_pos_std`` (1.5 m when the
drive has none): standalone code positions drift, and treating them as white would make the
filter over-confident in its heading.

Paper equations re-derived (see :mod:`sideslip.models.kinematic`): eq 2.6 sign
(r = (v_RR - v_RL)/T_r, ISO), eq 2.4 sign (v_y = +lr r), eq 2.1 (rotation by psi, not
psi + beta).  The paper's 50 Hz / 1 Hz rates are whatever the drive has.

Initial alignment (offline): the first >= 30 m of dead reckoning (eq 2.5 and the steering yaw
rate, eq 2.2; unknown heading 0) is fitted to the GNSS fixes of that stretch by a 2-D rotation and
translation (Kabsch); this gives the yaw and position at the first row, and the filter runs
causally from there.  A drive that never travels 30 m keeps yaw 0 with a 1-sigma of pi.

Robustness: standstill (wheels read 0; v -> 0, r -> 0; the gyro bias is observed there),
reversing (signed wheel speeds drive v < 0; a drive whose wheel speeds are never negative is
taken to report magnitudes: each stretch of motion between standstills starts forward, and once
the wheels have counted ``direction_distance`` and a GNSS fix agrees with that distance, a
displacement against the heading at the start of the stretch flips it to reverse, mirroring
the speed, yaw rate, heading change and position change dead-reckoned so far and widening
their covariance), GNSS outages
(dead reckoning, covariance grows), multipath (fixes whose 2-dof innovation NIS exceeds the
99.9 % chi-square bound are rejected; after ``max_rejects`` rejections in a row the next fix is
accepted after widening the position covariance, so a real jump is not refused forever), NaN
gaps in any sensor (no update; the covariance grows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip import typical
from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.methods.registry import register
from sideslip.models.kinematic import (
    cg_velocity,
    enu_rate,
    kinematic_beta,
    lever_arm_enu,
    rear_axle_speed,
    rear_axle_yaw_rate,
    steer_yaw_rate,
)
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

# state indices
E, N, PSI, V, R, SW, DW, KD, BD, KU, BR, GE, GN, BG = range(14)
NX = 14
STATE_NAMES = ("e", "n", "yaw", "v", "r", "wheel_scale_factor", "wheel_scale_factor_diff",
               "steer_scale_factor", "steer_offset", "understeer_gradient", "road_steer_offset",
               "gnss_bias_e", "gnss_bias_n", "gyro_bias")

# GNSS row flags in EkfResult.gnss_flag
GNSS_NONE, GNSS_USED, GNSS_REJECTED, GNSS_FORCED = 0, 1, 2, 3

CHI2_2DOF_999 = 13.815510557964274  # 99.9 % quantile of chi-square with 2 degrees of freedom
ALIGN_DISTANCE_M = 30.0  # travel needed for the initial heading alignment
ALIGN_WINDOW_S = 60.0  # GNSS fixes used for the alignment: at most this long before it ends


class EkfTuning(NamedTuple):
    """Noise and initial uncertainty of the EKF, all 1-sigma, SI units.

    Sensor grades of a production car and a code-phase GNSS receiver, not fitted to any drive:
    CAN wheel speeds (noise + quantisation + slip), CAN steering angle, a MEMS gyro (its bias
    prior wide enough for an uncalibrated phone), single-frequency standalone GNSS (about 1 m
    error drifting over a minute).
    """

    wheel_noise: float = 0.03  # per wheel sample, m/s
    wheel_noise_rel: float = 0.001  # extra per-sample wheel error per m/s of speed (slip), -
    wheel_zero_band: float = 0.1  # wheel sensors read 0 below about this speed, m/s
    steer_noise: float = 1.0e-3  # road-wheel angle noise incl. compliance, rad
    steer_rate_floor: float = 0.02  # eq 2.2 yaw-rate error floor (yaw lag, road crown), rad/s
    steer_rate_rel: float = 0.05  # eq 2.2 relative yaw-rate error (tyre nonlinearity, lag), -
    understeer_gradient: float = 0.0025  # prior when the vehicle file cannot give it, rad/(m/s^2)
    init_understeer_rel: float = 0.3  # prior 1-sigma of the vehicle file's K_us, fraction
    init_understeer_min: float = 3.0e-4  # floor of that 1-sigma, rad/(m/s^2)
    init_understeer_default: float = 1.5e-3  # prior 1-sigma when the file cannot give K_us
    road_bank: float = 0.025  # road crown / bank (sin) behind the road steering offset, -
    road_tau: float = 30.0  # its correlation time along the drive, s
    understeer_walk: float = 1.0e-6  # rad/(m/s^2)/sqrt(s)
    slip_gain: float = 0.005  # rear slip per lateral acceleration when not derivable, s^2/m
    slip_corr_time: float = 2.0  # correlation time of the kinematic lateral-velocity error, s
    lateral_floor: float = 0.05  # floor of that lateral-velocity error, m/s
    gyro_noise: float = 0.005  # per gyro sample, rad/s
    accel_psd: float = 4.0  # speed random walk (2 m/s^2 of unmodelled acceleration), (m/s^2)^2 s
    yaw_accel_psd: float = 0.25  # yaw-rate random walk (|r'| < 0.5 rad/s^2), (rad/s^2)^2 s
    wheel_sf_walk: float = 1.0e-5  # scale-factor random walks, 1/sqrt(s)
    steer_sf_walk: float = 1.0e-5
    steer_offset_walk: float = 1.0e-5  # sensor offset drift (0.6 mrad per hour), rad/sqrt(s)
    gyro_bias_walk: float = 5.0e-5  # rad/s/sqrt(s)
    gnss_std: float = 1.5  # GNSS horizontal 1-sigma per axis when the drive has no gnss_pos_std, m
    gnss_gm_fraction: float = 0.9  # share of that 1-sigma that is slow (Gauss-Markov), -
    gnss_white_fraction: float = 0.45  # share that is white from fix to fix, -
    gnss_tau: float = 60.0  # Gauss-Markov time constant of the GNSS error, s
    gnss_roll_angle: float = 0.05  # roll/pitch that moves a high antenna sideways, rad
    gate_chi2: float = CHI2_2DOF_999  # innovation gate on GNSS fixes (NIS, 2 dof)
    max_rejects: float = 5.0  # consecutive rejected fixes after which the next one is forced
    direction_distance: float = 2.5  # GNSS travel that decides forward/reverse (unsigned), m
    init_speed: float = 0.5  # initial 1-sigma of v, m/s
    init_yaw_rate: float = 0.1  # rad/s
    init_wheel_sf: float = 0.02  # -
    init_wheel_sf_diff: float = 0.01  # -
    init_steer_sf: float = 0.1  # -
    init_steer_offset: float = 0.01  # rad
    init_gyro_bias: float = 0.05  # rad/s (3 deg/s: uncalibrated consumer MEMS, e.g. a phone)


class _Consts(NamedTuple):
    """Vehicle and tuning numbers passed to the compiled loop."""

    lr: float
    wheelbase: float
    track_rear: float
    ant_x: float
    ant_y: float
    ant_z: float
    slip_gain: float
    road_std: float
    wheels_unsigned: bool
    gnss_white_default: float
    gnss_gm_std: float
    use_gyro: bool
    tuning: EkfTuning


@dataclass(frozen=True)
class EkfResult:
    """Filter output on the drive's time base (N rows).

    ``x`` (N, 14) states after the updates of each row (see module docstring and
    ``STATE_NAMES``), ``var`` (N, 14) their variances, ``cov_en`` (N,) the e-n covariance
    (for the error ellipse), ``beta`` and ``beta_var`` the kinematic sideslip (eq 2.3) and
    its variance, ``gnss_flag`` (N,) int8 GNSS_NONE/USED/REJECTED/FORCED, ``align`` the
    initial-alignment summary.
    """

    x: FloatArray
    var: FloatArray
    cov_en: FloatArray
    beta: FloatArray
    beta_var: FloatArray
    gnss_flag: NDArray[np.int8]
    align: dict[str, Any]


# ------------------------------------------------------------------------------------------
# compiled filter
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _scalar_update(x: FloatArray, P: FloatArray, h: FloatArray, nu: float, r_var: float) -> None:
    """x += K nu, P -= K S K' for one scalar measurement with row ``h`` and noise ``r_var``."""
    nx = x.size
    ph = P @ h
    s = h @ ph + r_var
    if not s > 0.0:
        return
    for i in range(nx):
        x[i] += ph[i] * nu / s
    for i in range(nx):
        for j in range(nx):
            P[i, j] -= ph[i] * ph[j] / s
    for i in range(nx):  # keep P symmetric with a non-negative diagonal
        if P[i, i] < 1e-30:
            P[i, i] = 1e-30
        for j in range(i):
            m = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = m
            P[j, i] = m


@numba.njit(cache=True)
def transition(
    x: FloatArray, dt: float, lr: float, a_gm: float, a_road: float
) -> tuple[FloatArray, FloatArray]:
    """One Euler step of the process model: (x_next, jac) with the nonzero Jacobian entries.

    ``jac`` = [dE/dpsi, dE/dv, dE/dr, dN/dpsi, dN/dv, dN/dr]; further dpsi/dr = dt,
    d(g_e, g_n) = a_gm and d(b_r) = a_road on the diagonal (see :func:`transition_matrix`).
    The heading of the step is its mid-point psi + r dt / 2.
    """
    psi_m = x[PSI] + 0.5 * dt * x[R]
    cs = math.cos(psi_m)
    sn = math.sin(psi_m)
    v = x[V]
    r = x[R]
    vx, vy = cg_velocity(v, r, lr)  # eq 2.4
    de, dn = enu_rate(vx, vy, psi_m)  # eq 2.1
    xn = x.copy()
    xn[E] += dt * de
    xn[N] += dt * dn
    xn[PSI] += dt * r
    xn[GE] *= a_gm
    xn[GN] *= a_gm
    xn[BR] *= a_road
    jac = np.empty(6)
    jac[0] = dt * (-v * sn - lr * r * cs)
    jac[1] = dt * cs
    jac[2] = dt * (-lr * sn - 0.5 * dt * (v * sn + lr * r * cs))
    jac[3] = dt * (v * cs - lr * r * sn)
    jac[4] = dt * sn
    jac[5] = dt * (lr * cs + 0.5 * dt * (v * cs - lr * r * sn))
    return xn, jac


@numba.njit(cache=True)
def transition_matrix(
    x: FloatArray, dt: float, lr: float, a_gm: float, a_road: float
) -> FloatArray:
    """The dense 14 x 14 Jacobian F of :func:`transition` (for tests and readers)."""
    _, jac = transition(x, dt, lr, a_gm, a_road)
    F = np.eye(NX)
    F[E, PSI], F[E, V], F[E, R] = jac[0], jac[1], jac[2]
    F[N, PSI], F[N, V], F[N, R] = jac[3], jac[4], jac[5]
    F[PSI, R] = dt
    F[GE, GE] = a_gm
    F[GN, GN] = a_gm
    F[BR, BR] = a_road
    return F


@numba.njit(cache=True)
def wheel_model(x: FloatArray, side: int, track_rear: float) -> tuple[float, FloatArray]:
    """Predicted rear wheel speed (side 0: left, 1: right) and its Jacobian row (eqs 2.5/2.6).

    v_RL = (1 + s_w - d_w)(v - r T_r/2),  v_RR = (1 + s_w + d_w)(v + r T_r/2).
    """
    sgn = -1.0 if side == 0 else 1.0
    g = 1.0 + x[SW] + sgn * x[DW]
    u = x[V] + sgn * 0.5 * track_rear * x[R]
    h = np.zeros(NX)
    h[V] = g
    h[R] = sgn * 0.5 * track_rear * g
    h[SW] = u
    h[DW] = sgn * u
    return g * u, h


@numba.njit(cache=True)
def steer_corrected(delta_m: float, k: float, b: float) -> float:
    """Road-wheel angle from the sensor: (delta_meas - b_d) / (1 + k_d), clamped to +-1.2 rad."""
    d = (delta_m - b) / (1.0 + k)
    return min(max(d, -1.2), 1.2)


@numba.njit(cache=True)
def steer_denominator(v: float, kus: float, wheelbase: float) -> float:
    """L + K_us v^2, kept above L/2 (an oversteering K_us < 0 must not make it vanish)."""
    return max(wheelbase + kus * v * v, 0.5 * wheelbase)


@numba.njit(cache=True)
def steer_model(x: FloatArray, delta_m: float, wheelbase: float) -> tuple[float, FloatArray]:
    """Residual h = r - v tan(delta_c - b_r) / (L + K_us v^2) (measured as 0), Jacobian row.

    Eq 2.2 (K_us = 0, b_r = 0) extended by the understeer gradient and the road-induced
    steering offset b_r = K_us g sin(bank) (the steering a driver holds to go straight on a
    banked or crowned road), so that the steering calibration is not biased by tyre slip.
    """
    k1 = 1.0 + x[KD]
    d_sensor = steer_corrected(delta_m, x[KD], x[BD])
    dc = d_sensor - x[BR]
    tn = math.tan(dc)
    sec2 = 1.0 + tn * tn
    v = x[V]
    kv2 = x[KU] * v * v
    den = steer_denominator(v, x[KU], wheelbase)
    clamped = wheelbase + kv2 < 0.5 * wheelbase
    h = np.zeros(NX)
    h[R] = 1.0
    if clamped:
        h[V] = -tn / den
    else:
        h[V] = -tn * (wheelbase - kv2) / (den * den)
        h[KU] = v * tn * v * v / (den * den)
    h[KD] = v * sec2 * d_sensor / (k1 * den)
    h[BD] = v * sec2 / (k1 * den)
    h[BR] = v * sec2 / den
    return x[R] - v * tn / den, h


@numba.njit(cache=True)
def gnss_model(
    x: FloatArray, ant_x: float, ant_y: float
) -> tuple[float, float, FloatArray, FloatArray]:
    """Predicted antenna (e, n) = CG + GNSS error + R(psi) lever arm, and the Jacobian rows."""
    de, dn = lever_arm_enu(x[PSI], ant_x, ant_y)
    he = np.zeros(NX)
    hn = np.zeros(NX)
    he[E] = 1.0
    he[GE] = 1.0
    he[PSI] = -dn  # d/dpsi (ax cos - ay sin) = -(ax sin + ay cos)
    hn[N] = 1.0
    hn[GN] = 1.0
    hn[PSI] = de
    return x[E] + x[GE] + de, x[N] + x[GN] + dn, he, hn


@numba.njit(cache=True)
def _predict(
    x: FloatArray, P: FloatArray, dt: float, c: _Consts, a_gm: float, a_road: float
) -> None:
    """Propagate x and P over dt; P = F P F' + Q with F applied by its nonzero entries."""
    tu = c.tuning
    xn, jac = transition(x, dt, c.lr, a_gm, a_road)
    psi_m = x[PSI] + 0.5 * dt * x[R]
    cs = math.cos(psi_m)
    sn = math.sin(psi_m)
    v = x[V]
    r = x[R]
    x[:] = xn
    f_epsi, f_ev, f_er, f_npsi, f_nv, f_nr = jac[0], jac[1], jac[2], jac[3], jac[4], jac[5]
    nx = x.size
    A = P.copy()  # A = F P
    for j in range(nx):
        A[E, j] = P[E, j] + f_epsi * P[PSI, j] + f_ev * P[V, j] + f_er * P[R, j]
        A[N, j] = P[N, j] + f_npsi * P[PSI, j] + f_nv * P[V, j] + f_nr * P[R, j]
        A[PSI, j] = P[PSI, j] + dt * P[R, j]
        A[GE, j] = a_gm * P[GE, j]
        A[GN, j] = a_gm * P[GN, j]
        A[BR, j] = a_road * P[BR, j]
    for i in range(nx):  # P = A F'
        P[i, :] = A[i, :]
        P[i, E] = A[i, E] + f_epsi * A[i, PSI] + f_ev * A[i, V] + f_er * A[i, R]
        P[i, N] = A[i, N] + f_npsi * A[i, PSI] + f_nv * A[i, V] + f_nr * A[i, R]
        P[i, PSI] = A[i, PSI] + dt * A[i, R]
        P[i, GE] = a_gm * A[i, GE]
        P[i, GN] = a_gm * A[i, GN]
        P[i, BR] = a_road * A[i, BR]
    # process noise
    P[V, V] += tu.accel_psd * dt
    P[R, R] += tu.yaw_accel_psd * dt
    P[SW, SW] += tu.wheel_sf_walk**2 * dt
    P[DW, DW] += tu.wheel_sf_walk**2 * dt
    P[KD, KD] += tu.steer_sf_walk**2 * dt
    P[BD, BD] += tu.steer_offset_walk**2 * dt
    P[KU, KU] += tu.understeer_walk**2 * dt
    if c.use_gyro:
        P[BG, BG] += tu.gyro_bias_walk**2 * dt
    q_gm = c.gnss_gm_std**2 * (1.0 - a_gm * a_gm)
    P[GE, GE] += q_gm
    P[GN, GN] += q_gm
    P[BR, BR] += c.road_std**2 * (1.0 - a_road * a_road)
    # kinematic lateral-velocity error (rear slip ~ k_slip a_y), lateral direction (-sn, cs)
    sig_lat = c.slip_gain * abs(v * r) * abs(v)
    q_lat = 2.0 * tu.slip_corr_time * (sig_lat**2 + tu.lateral_floor**2) * dt
    q_lon = 2.0 * tu.slip_corr_time * tu.lateral_floor**2 * dt
    P[E, E] += q_lat * sn * sn + q_lon * cs * cs
    P[N, N] += q_lat * cs * cs + q_lon * sn * sn
    P[E, N] += (q_lon - q_lat) * sn * cs
    P[N, E] = P[E, N]


@numba.njit(cache=True)
def _ekf_loop(
    t: FloatArray,
    v_rl: FloatArray,
    v_rr: FloatArray,
    steer: FloatArray,
    wz: FloatArray,
    gnss_e: FloatArray,
    gnss_n: FloatArray,
    gnss_std: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
    c: _Consts,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int8]]:
    tu = c.tuning
    n_rows = t.size
    xs = np.empty((n_rows, NX))
    vs = np.empty((n_rows, NX))
    cov_en = np.empty(n_rows)
    beta = np.zeros(n_rows)
    beta_var = np.zeros(n_rows)
    flags = np.zeros(n_rows, dtype=np.int8)
    x = x0.copy()
    P = P0.copy()
    L = c.wheelbase
    tr = c.track_rear
    lf = L - c.lr
    rejects = 0
    delta_m = 0.0  # latest steering sample (held for the beta output)
    have_steer = False
    # unsigned wheel speeds: direction of the current moving stretch (+1 forward, -1 reverse)
    direction = 1.0
    decided = True
    stretch_e = 0.0
    stretch_n = 0.0
    stretch_psi = 0.0
    stretch_dist = 0.0  # wheel odometry since the stretch began, m
    for k in range(n_rows):
        if k > 0:
            dt = t[k] - t[k - 1]
            stretch_dist += abs(x[V]) * dt
            _predict(x, P, dt, c, math.exp(-dt / tu.gnss_tau), math.exp(-dt / tu.road_tau))
        # --- direction of travel when the wheel sensors report magnitudes only --------------
        if c.wheels_unsigned and math.isfinite(v_rl[k]) and math.isfinite(v_rr[k]):
            if v_rl[k] == 0.0 and v_rr[k] == 0.0:
                decided = False  # standing: the next stretch may go either way
                direction = 1.0
                stretch_e, stretch_n, stretch_psi = x[E], x[N], x[PSI]
                stretch_dist = 0.0
        # --- rear wheel speeds (eqs 2.5/2.6 as per-wheel measurements) --------------------
        for side in range(2):
            z = v_rl[k] if side == 0 else v_rr[k]
            if not math.isfinite(z):
                continue
            z = direction * z
            pred, h = wheel_model(x, side, tr)
            rv = tu.wheel_noise**2 + (tu.wheel_noise_rel * pred) ** 2
            if z == 0.0:
                rv += tu.wheel_zero_band**2  # the sensor reads 0 anywhere below a few pulses
            _scalar_update(x, P, h, z - pred, rv)
        # --- steering: eq 2.2 as a yaw-rate pseudo-measurement ------------------------------
        if math.isfinite(steer[k]):
            delta_m = steer[k]
            have_steer = True
            k1 = 1.0 + x[KD]
            dc = steer_corrected(delta_m, x[KD], x[BD]) - x[BR]
            v = x[V]
            den = steer_denominator(v, x[KU], L)
            pred, h = steer_model(x, delta_m, L)
            sec2 = 1.0 + math.tan(dc) ** 2
            r_s = v * math.tan(dc) / den
            rv = (v * sec2 * tu.steer_noise / (k1 * den)) ** 2 + tu.steer_rate_floor**2
            rv += (tu.steer_rate_rel * r_s) ** 2  # tyre nonlinearity, yaw transients
            _scalar_update(x, P, h, 0.0 - pred, rv)
        # --- gyro ---------------------------------------------------------------------------
        if c.use_gyro and math.isfinite(wz[k]):
            h = np.zeros(NX)
            h[R] = 1.0
            h[BG] = 1.0
            _scalar_update(x, P, h, wz[k] - x[R] - x[BG], tu.gyro_noise**2)
        # --- GNSS position, gated -----------------------------------------------------------
        if math.isfinite(gnss_e[k]) and math.isfinite(gnss_n[k]):
            sw = gnss_std[k] * tu.gnss_white_fraction if math.isfinite(gnss_std[k]) else -1.0
            if not sw > 0.0:
                sw = c.gnss_white_default
            rv = sw * sw + (c.ant_z * tu.gnss_roll_angle) ** 2
            pred_e, pred_n, he, hn = gnss_model(x, c.ant_x, c.ant_y)
            if c.wheels_unsigned and not decided:
                # antenna displacement since the stretch began, along the heading of then
                ae, an = lever_arm_enu(x[PSI], c.ant_x, c.ant_y)
                de = gnss_e[k] - ae - stretch_e
                dn = gnss_n[k] - an - stretch_n
                moved = math.sqrt(de * de + dn * dn)
                # decide on a fix that agrees with the wheel odometry (not on a multipath jump)
                agree = abs(moved - stretch_dist) < max(1.5, 0.3 * stretch_dist)
                if stretch_dist > tu.direction_distance and agree:
                    decided = True
                    if de * math.cos(stretch_psi) + dn * math.sin(stretch_psi) < 0.0:
                        # reversing: mirror what the stretch dead-reckoned so far
                        direction = -1.0
                        moved2 = (x[E] - stretch_e) ** 2 + (x[N] - stretch_n) ** 2
                        turned = x[PSI] - stretch_psi
                        x[E] = 2.0 * stretch_e - x[E]
                        x[N] = 2.0 * stretch_n - x[N]
                        x[PSI] = stretch_psi - turned
                        x[V] = -x[V]
                        x[R] = -x[R]
                        P[E, E] += moved2
                        P[N, N] += moved2
                        P[PSI, PSI] += turned * turned
                    pred_e, pred_n, he, hn = gnss_model(x, c.ant_x, c.ant_y)
            nu_e = gnss_e[k] - pred_e
            nu_n = gnss_n[k] - pred_n
            pe = P @ he
            pn = P @ hn
            s_ee = he @ pe + rv
            s_nn = hn @ pn + rv
            s_en = he @ pn
            det = s_ee * s_nn - s_en * s_en
            nis = (s_nn * nu_e * nu_e - 2.0 * s_en * nu_e * nu_n + s_ee * nu_n * nu_n) / det
            if nis <= tu.gate_chi2:
                flags[k] = GNSS_USED
                rejects = 0
            elif rejects >= tu.max_rejects:
                # persistent disagreement: believe GNSS, widen the position covariance
                flags[k] = GNSS_FORCED
                rejects = 0
                P[E, E] += nu_e * nu_e
                P[N, N] += nu_n * nu_n
            else:
                flags[k] = GNSS_REJECTED
                rejects += 1
            if flags[k] != GNSS_REJECTED:
                _scalar_update(x, P, he, nu_e, rv)
                pred_e, pred_n, he, hn = gnss_model(x, c.ant_x, c.ant_y)
                _scalar_update(x, P, hn, gnss_n[k] - pred_n, rv)
        # --- store --------------------------------------------------------------------------
        xs[k] = x
        for i in range(NX):
            vs[k, i] = P[i, i]
        cov_en[k] = P[E, N]
        if have_steer:
            k1 = 1.0 + x[KD]
            dc = steer_corrected(delta_m, x[KD], x[BD])
            tn = math.tan(dc)
            q = c.lr * tn / L
            beta[k] = kinematic_beta(dc, lf, c.lr)
            dbeta = (c.lr / L) * (1.0 + tn * tn) / (1.0 + q * q)
            j_k = -dc / k1
            j_b = -1.0 / k1
            var_dc = (j_k * j_k * P[KD, KD] + 2.0 * j_k * j_b * P[KD, BD] + j_b * j_b * P[BD, BD]
                      + tu.steer_noise**2)
            slip = c.slip_gain * abs(x[V] * x[R])
            beta_var[k] = dbeta * dbeta * var_dc + slip * slip
        else:
            beta_var[k] = (c.lr / L * 0.5) ** 2  # no steering yet: +-0.5 rad of road wheel
    return xs, vs, cov_en, beta, beta_var, flags


# ------------------------------------------------------------------------------------------
# initial alignment
# ------------------------------------------------------------------------------------------
def _held(values: FloatArray) -> FloatArray:
    """Linear interpolation over NaN (held at the ends); zeros when the column is empty."""
    ok = np.isfinite(values)
    if not ok.any():
        return np.zeros_like(values)
    idx = np.arange(values.size)
    return np.interp(idx, idx[ok], values[ok])


def initial_alignment(
    t: FloatArray,
    v_rl: FloatArray,
    v_rr: FloatArray,
    steer: FloatArray,
    gnss_e: FloatArray,
    gnss_n: FloatArray,
    vehicle: Vehicle,
) -> dict[str, Any]:
    """Yaw and CG position at the first row by fitting dead reckoning to GNSS fixes.

    Dead reckoning with speed from eq 2.5 and yaw rate from the steering, eq 2.2 (the rear-wheel
    difference, eq 2.6, is not used here: an uncalibrated 0.5 % left/right tyre-radius
    difference is a yaw-rate error of 0.06 rad/s at 10 m/s), heading 0 at row 0, gives a track
    in a frame rotated by the unknown initial yaw.  Once it has travelled ``ALIGN_DISTANCE_M``,
    the rotation theta and translation c that best map the dead-reckoned antenna track onto
    the GNSS fixes (least squares, 2-D Kabsch) give yaw0 = theta and the CG at row 0 = c.
    Without steering samples eq 2.6 is used.  Returns a dict with ``ok``, ``yaw0``,
    ``yaw0_std``, ``e0``, ``n0``, ``t_aligned``, ``residual_m``.
    """
    fixes = np.flatnonzero(np.isfinite(gnss_e) & np.isfinite(gnss_n))
    out: dict[str, Any] = {"ok": False, "yaw0": 0.0, "yaw0_std": math.pi, "t_aligned": None,
                           "residual_m": None}
    if fixes.size == 0:
        out.update(e0=0.0, n0=0.0)
        return out
    out.update(e0=float(gnss_e[fixes[0]]), n0=float(gnss_n[fixes[0]]))
    v = rear_axle_speed(_held(v_rl), _held(v_rr))
    if np.isfinite(steer).any():
        r = steer_yaw_rate(v, _held(steer), vehicle.wheelbase)
    else:
        r = rear_axle_yaw_rate(_held(v_rl), _held(v_rr), vehicle.track_rear)
    dt = np.diff(t, prepend=t[0])
    psi = np.cumsum(r * dt)
    de, dn = enu_rate(v, vehicle.lr * r, psi)
    pe = np.cumsum(de * dt)
    pn = np.cumsum(dn * dt)
    ax, ay = vehicle.gnss_xyz[0], vehicle.gnss_xyz[1]
    oe, on = lever_arm_enu(psi, ax, ay)
    ae, an = pe + oe, pn + on  # dead-reckoned antenna track, heading frame of row 0
    travelled = np.hypot(ae[fixes] - ae[fixes[0]], an[fixes] - an[fixes[0]])
    far = np.flatnonzero(travelled >= ALIGN_DISTANCE_M)
    if far.size == 0:
        return out
    j1 = fixes[far[0]]
    use = fixes[(fixes <= j1) & (t[fixes] >= t[j1] - ALIGN_WINDOW_S)]
    a = np.column_stack([ae[use], an[use]])
    b = np.column_stack([gnss_e[use], gnss_n[use]])
    a_c = a - a.mean(axis=0)
    b_c = b - b.mean(axis=0)
    cross = np.sum(a_c[:, 0] * b_c[:, 1] - a_c[:, 1] * b_c[:, 0])
    dot = np.sum(a_c[:, 0] * b_c[:, 0] + a_c[:, 1] * b_c[:, 1])
    theta = math.atan2(cross, dot)
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    shift = b.mean(axis=0) - rot @ a.mean(axis=0)
    resid = b - (a @ rot.T + shift)
    rms = float(np.sqrt(np.mean(np.sum(resid**2, axis=1)) / 2.0))
    spread = float(np.sqrt(np.mean(np.sum(a_c**2, axis=1))))
    # heading 1-sigma: fit noise over the spread of the track, GNSS drift over the stretch
    # (about 1 m over 30 m), and the dead-reckoned heading change's error (steering scale
    # and understeer, 10 %), at least 1 deg.
    turn = float(np.max(psi[: j1 + 1]) - np.min(psi[: j1 + 1]))
    yaw_std = math.hypot(
        rms / max(spread * math.sqrt(use.size), 1e-3), 1.0 / ALIGN_DISTANCE_M, 0.1 * turn
    )
    out.update(
        ok=True,
        yaw0=float(math.atan2(math.sin(theta), math.cos(theta))),
        yaw0_std=max(yaw_std, math.radians(1.0)),
        e0=float(shift[0]),
        n0=float(shift[1]),
        t_aligned=float(t[j1]),
        residual_m=rms,
    )
    return out


# ------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------
def _vehicle_model_numbers(vehicle: Vehicle, tuning: EkfTuning) -> tuple[float, float, float]:
    """Understeer gradient prior (value, 1-sigma) and rear slip gain from the vehicle file,
    or typical defaults when the file cannot give them."""
    kus = vehicle.understeer_gradient
    if math.isfinite(kus):
        kus = min(max(kus, -0.002), 0.01)
        kus_std = max(tuning.init_understeer_rel * abs(kus), tuning.init_understeer_min)
    else:
        kus = tuning.understeer_gradient
        kus_std = tuning.init_understeer_default
    slip = vehicle.mass * vehicle.lf / (vehicle.wheelbase * vehicle.cr)
    if not math.isfinite(slip) or slip <= 0.0:
        slip = tuning.slip_gain
    return kus, kus_std, min(slip, 0.05)


rear_track = typical.track_rear  # the file's rear track, else its front track, else typical


def run_ekf(
    drive: Drive, vehicle: Vehicle, use_gyro: bool, tuning: EkfTuning | None = None
) -> EkfResult:
    """Run the seed-004 EKF over a drive (see module docstring); the methods wrap this."""
    tu = tuning if tuning is not None else EkfTuning()
    vehicle.need("lf", "lr")
    if not math.isfinite(vehicle.track_rear):
        vehicle = vehicle.with_changes(track_rear=rear_track(vehicle)[0])
    t = drive.t
    nan = np.full(t.size, np.nan)
    v_rl = drive["v_rl"] if "v_rl" in drive else nan
    v_rr = drive["v_rr"] if "v_rr" in drive else nan
    steer = drive["steer"] if "steer" in drive else nan
    wz = drive["wz"] if (use_gyro and "wz" in drive) else nan
    ge = drive["gnss_e"] if "gnss_e" in drive else nan
    gn = drive["gnss_n"] if "gnss_n" in drive else nan
    gstd = drive["gnss_pos_std"] if "gnss_pos_std" in drive else nan
    fixes = np.isfinite(ge) & np.isfinite(gn)
    std_ok = np.isfinite(gstd) & (gstd > 0) & fixes
    sigma_gnss = float(np.median(gstd[std_ok])) if std_ok.any() else tu.gnss_std

    align = initial_alignment(t, v_rl, v_rr, steer, ge, gn, vehicle)
    kus, kus_std, slip = _vehicle_model_numbers(vehicle, tu)
    ant = vehicle.gnss_xyz
    consts = _Consts(
        lr=float(vehicle.lr),
        wheelbase=float(vehicle.wheelbase),
        track_rear=float(vehicle.track_rear),
        ant_x=float(ant[0]),
        ant_y=float(ant[1]),
        ant_z=float(ant[2]),
        slip_gain=float(slip),
        road_std=float(max(abs(kus), tu.understeer_gradient) * G * tu.road_bank),
        wheels_unsigned=bool(not (np.nan_to_num(v_rl) < 0.0).any()
                             and not (np.nan_to_num(v_rr) < 0.0).any()),
        gnss_white_default=float(tu.gnss_white_fraction * sigma_gnss),
        gnss_gm_std=float(tu.gnss_gm_fraction * sigma_gnss),
        use_gyro=bool(use_gyro and np.isfinite(wz).any()),
        tuning=tu,
    )
    ws = rear_axle_speed(v_rl, v_rr)
    ws_ok = np.isfinite(ws)
    x0 = np.zeros(NX)
    x0[E], x0[N], x0[PSI] = align["e0"], align["n0"], align["yaw0"]
    x0[V] = float(ws[ws_ok][0]) if ws_ok.any() else 0.0
    x0[KU] = kus
    pos_var = sigma_gnss**2 if fixes.any() else 1.0e6
    P0 = np.diag(
        [
            pos_var,
            pos_var,
            align["yaw0_std"] ** 2,
            tu.init_speed**2,
            tu.init_yaw_rate**2,
            tu.init_wheel_sf**2,
            tu.init_wheel_sf_diff**2,
            tu.init_steer_sf**2,
            tu.init_steer_offset**2,
            kus_std**2,
            consts.road_std**2,
            consts.gnss_gm_std**2,
            consts.gnss_gm_std**2,
            tu.init_gyro_bias**2 if consts.use_gyro else 0.0,
        ]
    )
    # the GNSS error and the position start fully correlated (position came from GNSS)
    P0[E, GE] = P0[GE, E] = -0.9 * consts.gnss_gm_std**2 if fixes.any() else 0.0
    P0[N, GN] = P0[GN, N] = P0[E, GE]
    xs, vs, cov_en, beta, beta_var, flags = _ekf_loop(
        t, v_rl, v_rr, steer, wz, ge, gn, gstd, x0, P0, consts
    )
    return EkfResult(xs, vs, cov_en, beta, beta_var, flags, align)


def _estimate(name: str, res: EkfResult, drive: Drive, vehicle: Vehicle, use_gyro: bool) -> Estimate:
    x, var = res.x, res.var
    sd = np.sqrt(np.maximum(var, 0.0))
    series = {
        "e": x[:, E],
        "n": x[:, N],
        "yaw": x[:, PSI],
        "beta": res.beta,
        "r": x[:, R],
        "vx": x[:, V],
        "vy": vehicle.lr * x[:, R],
        "e_std": sd[:, E],
        "n_std": sd[:, N],
        "yaw_std": sd[:, PSI],
        "beta_std": np.sqrt(np.maximum(res.beta_var, 0.0)),
        "vx_std": sd[:, V],
        "r_std": sd[:, R],
    }
    if use_gyro:
        series["gyro_bias"] = x[:, BG]
        series["gyro_bias_std"] = sd[:, BG]
    last = -1
    params: dict[str, Any] = {
        "wheel_scale_factor": float(x[last, SW]),
        "wheel_scale_factor_std": float(sd[last, SW]),
        "wheel_scale_factor_rl": float(x[last, SW] - x[last, DW]),
        "wheel_scale_factor_rr": float(x[last, SW] + x[last, DW]),
        "wheel_scale_factor_diff": float(x[last, DW]),
        "wheel_scale_factor_diff_std": float(sd[last, DW]),
        "steer_scale_factor": float(x[last, KD]),
        "steer_scale_factor_std": float(sd[last, KD]),
        "steer_offset": float(x[last, BD]),
        "steer_offset_std": float(sd[last, BD]),
        "understeer_gradient": float(x[last, KU]),
        "understeer_gradient_std": float(sd[last, KU]),
        "scale_factor_convention": "measured = (1 + scale_factor) * true + offset",
        "gnss_fixes_used": int(np.sum(res.gnss_flag == GNSS_USED)),
        "gnss_fixes_rejected": int(np.sum(res.gnss_flag == GNSS_REJECTED)),
        "gnss_fixes_forced": int(np.sum(res.gnss_flag == GNSS_FORCED)),
        "alignment": {k: v for k, v in res.align.items()},
        "track_rear_m": rear_track(vehicle)[0],
        "track_rear_source": rear_track(vehicle)[1],
    }
    if use_gyro:
        params["gyro_bias"] = float(x[last, BG])
        params["gyro_bias_std"] = float(sd[last, BG])
    return Estimate(name, drive.t, series, params)


_COLUMNS = ("v_rl", "v_rr", "steer", "gnss_e", "gnss_n")
_VEHICLE = ("lf", "lr")  # the rear track: see rear_track()


@register(
    "ekf_wss_sas",
    columns=_COLUMNS,
    vehicle_params=_VEHICLE,
    summary="EKF on the kinematic bicycle: rear wheel speeds + steering + GNSS (positions, "
    "scale factors)",
    paper="seed 004",
)
def ekf_wss_sas(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Seed 004's GNSS/WSS/SAS EKF (see module docstring); optional column gnss_pos_std."""
    return _estimate("ekf_wss_sas", run_ekf(drive, vehicle, False), drive, vehicle, False)


@register(
    "ekf_wss_sas_imu",
    columns=(*_COLUMNS, "wz"),
    vehicle_params=_VEHICLE,
    summary="seed 004's EKF plus the gyro yaw rate with a bias state",
    paper="seed 004 (+ gyro)",
)
def ekf_wss_sas_imu(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Seed 004's EKF with the gyro as a yaw-rate measurement (``wz = r + b_g``)."""
    return _estimate("ekf_wss_sas_imu", run_ekf(drive, vehicle, True), drive, vehicle, True)
