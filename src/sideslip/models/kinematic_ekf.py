"""Process and measurement models of seed 004's GNSS / wheel-speed / steering EKF, as plain
compiled functions: a process model ``(x, u, dt, ...) -> (x_next, F)`` and measurement models
``(x, ...) -> (h, H)`` with analytic Jacobians (tested against central finite differences).

State vector x (14), units in brackets (see :mod:`sideslip.methods.ekf_positioning`)::

    0 e, 1 n     CG position, local ENU [m]
    2 psi        yaw of the body x axis, from East counter-clockwise, unwrapped [rad]
    3 v          longitudinal speed of the rear-axle centre = v_x at the CG [m/s], signed
    4 r          yaw rate [rad/s]
    5 s_w        mean rear wheel-speed scale factor:  v_meas = (1 + s) v_true  [-]
    6 d_w        half the right-minus-left rear scale-factor difference [-]
    7 k_d        steering scale factor: delta_meas = (1 + k_d) delta + b_d  [-]
    8 b_d        steering sensor offset [rad]
    9 K_us       understeer gradient [rad/(m/s^2)]
    10 b_r       road-induced steering offset [rad], Gauss-Markov
    11 g_e, 12 g_n  GNSS position error, first-order Gauss-Markov per axis [m]
    13 b_g       gyro bias [rad/s]

Process model (Euler with the mid-step heading; seed 004 eqs 2.1 and 2.4, signs re-derived)::

    e' = v cos(psi) - lr r sin(psi),  n' = v sin(psi) + lr r cos(psi),  psi' = r
    v, r, s_w, d_w, k_d, b_d, K_us, b_g: random walks (their noise is the caller's Q)
    b_r, g_e, g_n: Gauss-Markov, multiplied by phi = exp(-dt / tau) per step

Measurement models::

    v_RL = (1 + s_w - d_w)(v - r T_r/2),  v_RR = (1 + s_w + d_w)(v + r T_r/2)   eqs 2.5/2.6
    0    = r - v tan(delta_c - b_r) / (L + K_us v^2),  delta_c = (delta_m - b_d)/(1 + k_d)
                                                                              eq 2.2 (+)
    wz   = r + b_g
    [gnss_e, gnss_n] = [e, n] + [g_e, g_n] + R(psi) [x_ant, y_ant]
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.models.kinematic import cg_velocity, enu_rate, lever_arm_enu

FloatArray = NDArray[np.float64]

# state indices
E, N, PSI, V, R, SW, DW, KD, BD, KU, BR, GE, GN, BG = range(14)
NX = 14
STATE_NAMES = ("e", "n", "yaw", "v", "r", "wheel_scale_factor", "wheel_scale_factor_diff",
               "steer_scale_factor", "steer_offset", "understeer_gradient", "road_steer_offset",
               "gnss_bias_e", "gnss_bias_n", "gyro_bias")  # fmt: skip
NO_INPUT = np.zeros(0)  # the process model has no input: speed and yaw rate are states


@numba.njit(cache=True)
def transition_into(x: FloatArray, dt: float, lr: float, phi_gnss: float, phi_road: float,
                    xn: FloatArray, F: FloatArray) -> None:
    """:func:`transition` writing ``x_next`` into ``xn`` (NX) and F into ``F`` (NX x NX)
    instead of allocating them (the filter loop calls it on every row)."""
    psi_m = x[PSI] + 0.5 * dt * x[R]
    cs = math.cos(psi_m)
    sn = math.sin(psi_m)
    v = x[V]
    r = x[R]
    vx, vy = cg_velocity(v, r, lr)  # eq 2.4
    de, dn = enu_rate(vx, vy, psi_m)  # eq 2.1
    for i in range(NX):
        xn[i] = x[i]
        for j in range(NX):
            F[i, j] = 1.0 if i == j else 0.0
    xn[E] += dt * de
    xn[N] += dt * dn
    xn[PSI] += dt * r
    xn[GE] *= phi_gnss
    xn[GN] *= phi_gnss
    xn[BR] *= phi_road
    F[E, PSI] = dt * (-v * sn - lr * r * cs)
    F[E, V] = dt * cs
    F[E, R] = dt * (-lr * sn - 0.5 * dt * (v * sn + lr * r * cs))
    F[N, PSI] = dt * (v * cs - lr * r * sn)
    F[N, V] = dt * sn
    F[N, R] = dt * (lr * cs + 0.5 * dt * (v * cs - lr * r * sn))
    F[PSI, R] = dt
    F[GE, GE] = phi_gnss
    F[GN, GN] = phi_gnss
    F[BR, BR] = phi_road


@numba.njit(cache=True)
def transition(
    x: FloatArray, u: FloatArray, dt: float, lr: float, phi_gnss: float, phi_road: float
) -> tuple[FloatArray, FloatArray]:
    """One Euler step of the process model: ``(x_next, F)`` with the 14 x 14 Jacobian F.

    ``u``: no input (pass :data:`NO_INPUT`); ``lr`` (m) CG to rear axle; ``phi_gnss``,
    ``phi_road``: the Gauss-Markov factors exp(-dt/tau) of the GNSS error and the road
    steering offset (:func:`sideslip.gnss.gauss_markov`).  The heading of the step is its
    mid-point psi + r dt / 2.
    """
    xn = np.empty(NX)
    F = np.empty((NX, NX))
    transition_into(x, dt, lr, phi_gnss, phi_road, xn, F)
    return xn, F


@numba.njit(cache=True)
def propagate_covariance(P: FloatArray, F: FloatArray, Q: FloatArray, tmp: FloatArray) -> None:
    """In place P <- F P F' + (Q + Q')/2 for a Jacobian F of :func:`transition`'s pattern.

    F is the identity but for rows e, n (columns e, psi, v, r), psi (psi, r) and the
    Gauss-Markov diagonal (g_e, g_n, b_r); only those entries are read.  The sums run in the
    order of :func:`sideslip.filters.kalman.predict_sparse_nb` (non-zero columns ascending),
    so the result is that kernel's (tested) without its search for the non-zeros.
    ``tmp`` (NX x NX) is scratch; P stays exactly symmetric.
    """
    for i in range(NX):  # tmp = F P
        for j in range(NX):
            tmp[i, j] = P[i, j]
    f_ep, f_ev, f_er = F[E, PSI], F[E, V], F[E, R]
    f_np, f_nv, f_nr = F[N, PSI], F[N, V], F[N, R]
    f_pr = F[PSI, R]
    for j in range(NX):
        tmp[E, j] = F[E, E] * P[E, j] + f_ep * P[PSI, j] + f_ev * P[V, j] + f_er * P[R, j]
        tmp[N, j] = F[N, N] * P[N, j] + f_np * P[PSI, j] + f_nv * P[V, j] + f_nr * P[R, j]
        tmp[PSI, j] = F[PSI, PSI] * P[PSI, j] + f_pr * P[R, j]
        tmp[GE, j] = F[GE, GE] * P[GE, j]
        tmp[GN, j] = F[GN, GN] * P[GN, j]
        tmp[BR, j] = F[BR, BR] * P[BR, j]
    for j in range(NX):  # P = tmp F' + (Q + Q')/2, upper triangle mirrored
        for i in range(j + 1):
            if j == E:
                acc = tmp[i, E] * F[E, E] + tmp[i, PSI] * f_ep + tmp[i, V] * f_ev + tmp[i, R] * f_er
            elif j == N:
                acc = tmp[i, N] * F[N, N] + tmp[i, PSI] * f_np + tmp[i, V] * f_nv + tmp[i, R] * f_nr
            elif j == PSI:
                acc = tmp[i, PSI] * F[PSI, PSI] + tmp[i, R] * f_pr
            elif j == GE or j == GN or j == BR:
                acc = tmp[i, j] * F[j, j]
            else:
                acc = tmp[i, j]
            v = acc + 0.5 * (Q[i, j] + Q[j, i])
            P[i, j] = v
            P[j, i] = v


@numba.njit(cache=True)
def wheel_model_into(x: FloatArray, side: int, track_rear: float, h: FloatArray) -> float:
    """:func:`wheel_model` writing the Jacobian row into ``h`` (NX); returns the prediction."""
    sgn = -1.0 if side == 0 else 1.0
    g = 1.0 + x[SW] + sgn * x[DW]
    u = x[V] + sgn * 0.5 * track_rear * x[R]
    h[:] = 0.0
    h[V] = g
    h[R] = sgn * 0.5 * track_rear * g
    h[SW] = u
    h[DW] = sgn * u
    return g * u


@numba.njit(cache=True)
def wheel_model(x: FloatArray, side: int, track_rear: float) -> tuple[float, FloatArray]:
    """Predicted rear wheel speed (side 0: left, 1: right) and its Jacobian row (eqs 2.5/2.6).

    v_RL = (1 + s_w - d_w)(v - r T_r/2),  v_RR = (1 + s_w + d_w)(v + r T_r/2).
    """
    h = np.zeros(NX)
    return wheel_model_into(x, side, track_rear, h), h


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
def steer_model_into(x: FloatArray, delta_m: float, wheelbase: float, h: FloatArray) -> float:
    """:func:`steer_model` writing the Jacobian row into ``h`` (NX); returns the residual."""
    k1 = 1.0 + x[KD]
    d_sensor = steer_corrected(delta_m, x[KD], x[BD])
    dc = d_sensor - x[BR]
    tn = math.tan(dc)
    sec2 = 1.0 + tn * tn
    v = x[V]
    kv2 = x[KU] * v * v
    den = steer_denominator(v, x[KU], wheelbase)
    clamped = wheelbase + kv2 < 0.5 * wheelbase
    h[:] = 0.0
    h[R] = 1.0
    if clamped:
        h[V] = -tn / den
    else:
        h[V] = -tn * (wheelbase - kv2) / (den * den)
        h[KU] = v * tn * v * v / (den * den)
    h[KD] = v * sec2 * d_sensor / (k1 * den)
    h[BD] = v * sec2 / (k1 * den)
    h[BR] = v * sec2 / den
    return x[R] - v * tn / den


@numba.njit(cache=True)
def steer_model(x: FloatArray, delta_m: float, wheelbase: float) -> tuple[float, FloatArray]:
    """Residual h = r - v tan(delta_c - b_r) / (L + K_us v^2) (measured as 0), Jacobian row.

    Eq 2.2 (K_us = 0, b_r = 0) extended by the understeer gradient and the road-induced
    steering offset b_r = K_us g sin(bank) (the steering a driver holds to go straight on a
    banked or crowned road), so that the steering calibration is not biased by tyre slip.
    """
    h = np.zeros(NX)
    return steer_model_into(x, delta_m, wheelbase, h), h


@numba.njit(cache=True)
def gyro_model_into(x: FloatArray, h: FloatArray) -> float:
    """:func:`gyro_model` writing the Jacobian row into ``h`` (NX); returns the prediction."""
    h[:] = 0.0
    h[R] = 1.0
    h[BG] = 1.0
    return x[R] + x[BG]


@numba.njit(cache=True)
def gyro_model(x: FloatArray) -> tuple[float, FloatArray]:
    """Predicted gyro yaw rate r + b_g and its Jacobian row."""
    h = np.zeros(NX)
    return gyro_model_into(x, h), h


@numba.njit(cache=True)
def gnss_model_into(x: FloatArray, ant_x: float, ant_y: float, he: FloatArray, hn: FloatArray
                    ) -> tuple[float, float]:
    """:func:`gnss_model` writing the Jacobian rows into ``he``, ``hn`` (NX each)."""
    de, dn = lever_arm_enu(x[PSI], ant_x, ant_y)
    he[:] = 0.0
    hn[:] = 0.0
    he[E] = 1.0
    he[GE] = 1.0
    he[PSI] = -dn  # d/dpsi (ax cos - ay sin) = -(ax sin + ay cos)
    hn[N] = 1.0
    hn[GN] = 1.0
    hn[PSI] = de
    return x[E] + x[GE] + de, x[N] + x[GN] + dn


@numba.njit(cache=True)
def gnss_model(
    x: FloatArray, ant_x: float, ant_y: float
) -> tuple[float, float, FloatArray, FloatArray]:
    """Predicted antenna (e, n) = CG + GNSS error + R(psi) lever arm, and the Jacobian rows."""
    he = np.zeros(NX)
    hn = np.zeros(NX)
    pred_e, pred_n = gnss_model_into(x, ant_x, ant_y, he, hn)
    return pred_e, pred_n, he, hn
