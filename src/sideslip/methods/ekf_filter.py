"""The compiled recursion of seed 004's GNSS / wheel-speed / steering EKF
(:mod:`sideslip.methods.ekf_positioning` documents the filter; the models are in
:mod:`sideslip.models.kinematic_ekf`, the Kalman steps in :mod:`sideslip.filters.kalman`)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.filters.kalman import update_scalar_ws_nb
from sideslip.gnss import gauss_markov_nb
from sideslip.models.kinematic import kinematic_beta, lever_arm_enu
from sideslip.models.kinematic_ekf import (
    BD,
    BG,
    BR,
    DW,
    GE,
    GN,
    KD,
    KU,
    NX,
    PSI,
    SW,
    E,
    N,
    R,
    V,
    gnss_model_into,
    gyro_model_into,
    propagate_covariance,
    steer_corrected,
    steer_denominator,
    steer_model_into,
    transition_into,
    wheel_model_into,
)

FloatArray = NDArray[np.float64]

# States stored on every row (the estimate's series and K_us, which scales the bank term of
# beta_std), in this column order: the first five columns are also the state indices E, N,
# PSI, V, R.  The other calibration states (scale factors, offsets, road and GNSS errors) are
# reported at the end of the drive only, so the loop keeps their final value (``x_final``,
# ``var_final``) instead of a row each: 112 B/row for states and variances, not 224.
ROW_STATES = (E, N, PSI, V, R, KU, BG)
ROW_COLUMN = {state: col for col, state in enumerate(ROW_STATES)}

# GNSS row flags in EkfResult.gnss_flag
GNSS_NONE, GNSS_USED, GNSS_REJECTED, GNSS_FORCED = 0, 1, 2, 3


class LoopTuning(NamedTuple):
    """The tuning numbers the compiled loop reads (numba takes named tuples, not dataclasses)."""

    wheel_sigma_m_s: float
    wheel_sigma_rel: float
    wheel_zero_band_m_s: float
    steer_sigma_rad: float
    steer_yaw_rate_sigma_rad_s: float
    steer_yaw_rate_sigma_rel: float
    understeer_walk_per_sqrt_s: float
    slip_tau_s: float
    lateral_velocity_sigma_m_s: float
    gyro_sigma_rad_s: float
    accel_psd_m2_s3: float
    yaw_accel_psd_rad2_s3: float
    wheel_scale_walk_per_sqrt_s: float
    steer_scale_walk_per_sqrt_s: float
    steer_offset_walk_rad_sqrt_s: float
    gyro_bias_walk_rad_s_sqrt_s: float
    gnss_white_fraction: float
    gnss_tau_s: float
    road_tau_s: float
    gnss_roll_sigma_rad: float
    gnss_gate_nis: float
    gnss_max_rejects: float
    direction_distance_m: float


class LoopConsts(NamedTuple):
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
    tuning: LoopTuning


# ------------------------------------------------------------------------------------------
# compiled filter
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def process_noise(
    Q: FloatArray, x: FloatArray, dt: float, c: LoopConsts, q_gm: float, q_road: float
) -> None:
    """Discrete process noise Q over ``dt`` (14 x 14): random walks of v, r and the
    calibration states, the exact Gauss-Markov variances of the GNSS error and road offset
    (:func:`sideslip.gnss.gauss_markov_nb`: ``q_gm``/``q_road`` given by the caller), and
    the kinematic model's lateral-velocity error (rear slip ~ k_slip a_y, 2 tau_slip sigma^2
    dt across the heading).  Written into ``Q``, whose other entries stay zero."""
    tu = c.tuning
    Q[V, V] = tu.accel_psd_m2_s3 * dt
    Q[R, R] = tu.yaw_accel_psd_rad2_s3 * dt
    Q[SW, SW] = tu.wheel_scale_walk_per_sqrt_s**2 * dt
    Q[DW, DW] = tu.wheel_scale_walk_per_sqrt_s**2 * dt
    Q[KD, KD] = tu.steer_scale_walk_per_sqrt_s**2 * dt
    Q[BD, BD] = tu.steer_offset_walk_rad_sqrt_s**2 * dt
    Q[KU, KU] = tu.understeer_walk_per_sqrt_s**2 * dt
    if c.use_gyro:
        Q[BG, BG] = tu.gyro_bias_walk_rad_s_sqrt_s**2 * dt
    Q[GE, GE] = q_gm
    Q[GN, GN] = q_gm
    Q[BR, BR] = q_road
    psi_m = x[PSI] + 0.5 * dt * x[R]
    cs = math.cos(psi_m)
    sn = math.sin(psi_m)
    v = x[V]
    sig_lat = c.slip_gain * abs(v * x[R]) * abs(v)
    q_lat = 2.0 * tu.slip_tau_s * (sig_lat**2 + tu.lateral_velocity_sigma_m_s**2) * dt
    q_lon = 2.0 * tu.slip_tau_s * tu.lateral_velocity_sigma_m_s**2 * dt
    Q[E, E] = q_lat * sn * sn + q_lon * cs * cs
    Q[N, N] = q_lat * cs * cs + q_lon * sn * sn
    Q[E, N] = (q_lon - q_lat) * sn * cs
    Q[N, E] = Q[E, N]


class Workspace(NamedTuple):
    """Scratch arrays of one run of :func:`ekf_loop`, allocated once instead of on every row:
    the process noise ``Q``, the product F P (``tmp``), the two rows of a scalar update
    (``work``: P h' and the gain), the predicted state ``xn`` and Jacobian ``F``, and the
    measurement Jacobian rows (``h`` for the wheel, steering and gyro updates, ``he``, ``hn``
    for GNSS)."""

    Q: FloatArray
    tmp: FloatArray
    work: FloatArray
    xn: FloatArray
    F: FloatArray
    h: FloatArray
    he: FloatArray
    hn: FloatArray


@numba.njit(cache=True)
def workspace() -> Workspace:
    """A fresh :class:`Workspace` for the 14-state filter."""
    return Workspace(np.zeros((NX, NX)), np.empty((NX, NX)), np.zeros((2, NX)), np.empty(NX),
                     np.empty((NX, NX)), np.zeros(NX), np.zeros(NX), np.zeros(NX))


@numba.njit(cache=True)
def _predict(x: FloatArray, P: FloatArray, dt: float, c: LoopConsts, ws: Workspace) -> None:
    """Propagate x and P over dt with the process model and its sparse Jacobian:
    P <- F P F' + (Q + Q')/2 (:func:`sideslip.models.kinematic_ekf.propagate_covariance`),
    in the caller's workspace."""
    tu = c.tuning
    a_gm, q_gm = gauss_markov_nb(dt, tu.gnss_tau_s, c.gnss_gm_std)
    a_road, q_road = gauss_markov_nb(dt, tu.road_tau_s, c.road_std)
    process_noise(ws.Q, x, dt, c, q_gm, q_road)  # at the step's start state, as the Euler step
    transition_into(x, dt, c.lr, a_gm, a_road, ws.xn, ws.F)
    propagate_covariance(P, ws.F, ws.Q, ws.tmp)
    for i in range(NX):
        x[i] = ws.xn[i]


@numba.njit(cache=True)
def ekf_loop(
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
    c: LoopConsts,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int8],
           FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:  # fmt: skip
    tu = c.tuning
    n_rows = t.size
    n_kept = len(ROW_STATES)
    xs = np.empty((n_rows, n_kept))
    vs = np.empty((n_rows, n_kept))
    cov_en = np.empty(n_rows)
    beta = np.zeros(n_rows)
    beta_var = np.zeros(n_rows)
    flags = np.zeros(n_rows, dtype=np.int8)
    nis_steer = np.full(n_rows, np.nan)
    nis_gyro = np.full(n_rows, np.nan)
    nis_gnss = np.full(n_rows, np.nan)
    x = x0.copy()
    P = P0.copy()
    ws = workspace()
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
            _predict(x, P, dt, c, ws)
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
            h = ws.h
            pred = wheel_model_into(x, side, tr, h)
            rv = tu.wheel_sigma_m_s**2 + (tu.wheel_sigma_rel * pred) ** 2
            if z == 0.0:
                rv += tu.wheel_zero_band_m_s**2  # the sensor reads 0 anywhere below a few pulses
            update_scalar_ws_nb(x, P, z - pred, h, rv, ws.work)
        # --- steering: eq 2.2 as a yaw-rate pseudo-measurement ------------------------------
        if math.isfinite(steer[k]):
            delta_m = steer[k]
            have_steer = True
            k1 = 1.0 + x[KD]
            dc = steer_corrected(delta_m, x[KD], x[BD]) - x[BR]
            v = x[V]
            den = steer_denominator(v, x[KU], L)
            h = ws.h
            pred = steer_model_into(x, delta_m, L, h)
            sec2 = 1.0 + math.tan(dc) ** 2
            r_s = v * math.tan(dc) / den
            rv = (v * sec2 * tu.steer_sigma_rad / (k1 * den)) ** 2 + tu.steer_yaw_rate_sigma_rad_s**2
            rv += (tu.steer_yaw_rate_sigma_rel * r_s) ** 2  # tyre nonlinearity, yaw transients
            s = update_scalar_ws_nb(x, P, 0.0 - pred, h, rv, ws.work)
            nis_steer[k] = pred * pred / s if s > 0.0 else math.nan
        # --- gyro ---------------------------------------------------------------------------
        if c.use_gyro and math.isfinite(wz[k]):
            h = ws.h
            pred = gyro_model_into(x, h)
            s = update_scalar_ws_nb(x, P, wz[k] - pred, h, tu.gyro_sigma_rad_s**2, ws.work)
            nis_gyro[k] = (wz[k] - pred) ** 2 / s if s > 0.0 else math.nan
        # --- GNSS position, gated -----------------------------------------------------------
        if math.isfinite(gnss_e[k]) and math.isfinite(gnss_n[k]):
            sw = gnss_std[k] * tu.gnss_white_fraction if math.isfinite(gnss_std[k]) else -1.0
            if not sw > 0.0:
                sw = c.gnss_white_default
            rv = sw * sw + (c.ant_z * tu.gnss_roll_sigma_rad) ** 2
            he, hn = ws.he, ws.hn
            pred_e, pred_n = gnss_model_into(x, c.ant_x, c.ant_y, he, hn)
            if c.wheels_unsigned and not decided:
                # antenna displacement since the stretch began, along the heading of then
                ae, an = lever_arm_enu(x[PSI], c.ant_x, c.ant_y)
                de = gnss_e[k] - ae - stretch_e
                dn = gnss_n[k] - an - stretch_n
                moved = math.sqrt(de * de + dn * dn)
                # decide on a fix that agrees with the wheel odometry (not on a multipath jump)
                agree = abs(moved - stretch_dist) < max(1.5, 0.3 * stretch_dist)
                if stretch_dist > tu.direction_distance_m and agree:
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
                    pred_e, pred_n = gnss_model_into(x, c.ant_x, c.ant_y, he, hn)
            nu_e = gnss_e[k] - pred_e
            nu_n = gnss_n[k] - pred_n
            pe = P @ he
            pn = P @ hn
            s_ee = he @ pe + rv
            s_nn = hn @ pn + rv
            s_en = he @ pn
            det = s_ee * s_nn - s_en * s_en
            nis = (s_nn * nu_e * nu_e - 2.0 * s_en * nu_e * nu_n + s_ee * nu_n * nu_n) / det
            if nis <= tu.gnss_gate_nis:
                flags[k] = GNSS_USED
                rejects = 0
            elif rejects >= tu.gnss_max_rejects:
                # persistent disagreement: believe GNSS, widen the position covariance
                flags[k] = GNSS_FORCED
                rejects = 0
                P[E, E] += nu_e * nu_e
                P[N, N] += nu_n * nu_n
            else:
                flags[k] = GNSS_REJECTED
                rejects += 1
            nis_gnss[k] = nis
            if flags[k] != GNSS_REJECTED:
                update_scalar_ws_nb(x, P, nu_e, he, rv, ws.work)
                pred_e, pred_n = gnss_model_into(x, c.ant_x, c.ant_y, he, hn)
                update_scalar_ws_nb(x, P, gnss_n[k] - pred_n, hn, rv, ws.work)
        # --- store --------------------------------------------------------------------------
        for j in range(n_kept):
            xs[k, j] = x[ROW_STATES[j]]
            vs[k, j] = P[ROW_STATES[j], ROW_STATES[j]]
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
                      + tu.steer_sigma_rad**2)
            beta_var[k] = dbeta * dbeta * var_dc  # the slip term is added by the caller
        else:
            beta_var[k] = (c.lr / L * 0.5) ** 2  # no steering yet: +-0.5 rad of road wheel
    var_final = np.empty(NX)
    for i in range(NX):
        var_final[i] = P[i, i]
    return xs, vs, cov_en, beta, beta_var, flags, nis_steer, nis_gyro, nis_gnss, x.copy(), var_final
