"""The simulator's truth model: a nonlinear two-track vehicle with roll, on a 3-D road.

This is deliberately richer than any estimator's model (never the linear single-track model):

* Planar motion (longitudinal, lateral, yaw) of the whole vehicle, four wheels at their track
  positions, front steering (parallel, no Ackermann), per-tyre Pacejka Magic Formula forces
  with load sensitivity and a friction-ellipse combined slip (:mod:`sideslip.simulate.tyre`);
  drive forces are limited to what the friction circle leaves beside the lateral force
  (traction control), brake forces likewise but keep at least 30 % of the peak (ABS).
* Normal loads with longitudinal load transfer ``m f_x h_cg / L`` and lateral load transfer per
  axle: the suspension roll moment ``k phi + d phi'`` split by the roll-stiffness distribution
  (``front_roll_share``, default 55 %) plus the geometric part through the roll centre
  ``m_axle f_y h_rc``.  Load transfer uses the specific forces filtered with a time constant
  ``tau_load`` (avoids an algebraic loop; physically the load builds up with the pitch/roll
  motion).
* Roll of the sprung mass (seed 003 eq 41, generalised to a banked road and with the gravity
  moment of the displaced CG)::

      I_r phi'' = m h f_y - d phi' - k phi + m g_n h sin(phi)

  where ``h`` = cg_height - roll_axis_height, ``f_y`` the lateral specific force in the road
  plane (tyre lateral forces / m, = a_y cos(bank) + g sin(bank)) and ``g_n = g cos(bank)
  cos(grade)``.  Steady state: ``phi_sus = m h f_y / (k - m g h)`` (slightly more than seed 003
  eq 43's ``m h a_y / k``).  Body roll = bank + phi_sus.  A small suspension pitch
  ``-pitch_gain f_x`` (first-order lag) is added to the road pitch ``-grade``.
* Road bank and grade: in the road plane the tyres and air act, gravity pulls with
  ``-g sin(bank)`` laterally and ``-g sin(grade)`` longitudinally.  States are horizontal (the
  heading frame of :class:`~sideslip.simulate.truth.Truth`): with ``f`` the specific force in the
  road plane, ``a_y = (f_y - g sin(bank)) / cos(bank)`` and ``a_x = (f_x - g sin(grade)) /
  cos(grade)`` (vertical acceleration neglected in this projection); the normal load is
  ``m (g cos(bank) cos(grade) - a_y sin(bank))``.
* Wheel speeds ``(v_long + kappa |v_long|) / cos(grade)``: the wheel-centre speed along the
  wheel heading (yaw rate times half-track and steer included) plus the longitudinal tyre slip
  the wheel's drive / brake force needs, measured along the road surface.
* Low speed: slip angles ``-atan(v_lat / sqrt(v_long^2 + v_min^2))`` stay finite at standstill
  and turn the tyres into stiff dampers below ~``v_min`` (kinematic rolling); brake forces are
  regularised by ``v / sqrt(v^2 + 0.1^2)``; when the driver holds the brake at rest the vehicle
  is held exactly (static friction).  Reversing works with open-loop plans.

State vector x (15): E, N (m, CG in ENU), yaw (rad), vx, vy (m/s, heading frame), r (rad/s),
phi_sus (rad), phi_sus' (rad/s), delta (road-wheel steer, rad), f_x, f_y filtered (m/s^2),
pitch_sus (rad), driver integrals (lateral offset m s, speed m), driver speed command (m/s).
Integration: classical RK4 at a step of at most 2.5 ms (smaller for stiff tyres at v_min),
output every ``dt``; the loop is compiled with numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

from sideslip.simulate.driver import OpenLoopPlan, PathPlan, Plan, ou_noise
from sideslip.simulate.road import Road
from sideslip.simulate.truth import Truth
from sideslip.simulate.tyre import (
    TyreShape,
    combined_lateral,
    friction_peak,
    lateral_force,
    longitudinal_slip,
)
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]

REQUIRED = (
    "mass", "yaw_inertia", "lf", "lr", "cf", "cr", "track_front", "track_rear", "cg_height",
    "roll_axis_height", "roll_stiffness", "roll_damping", "roll_inertia",
)  # fmt: skip


@dataclass(frozen=True)
class ModelOptions:
    """Truth-model settings that a vehicle file does not carry.

    front_roll_share   share of the roll stiffness (and damping) on the front axle
    drive_front        share of the drive force on the front axle (0: RWD, 1: FWD)
    brake_front        share of the brake force on the front axle
    power_per_mass     engine power per vehicle mass, W/kg
    brake_max          deceleration limit of the brakes, m/s^2 (tyres limit further)
    cda                drag area C_d A, m^2;  crr  rolling-resistance coefficient
    v_min              slip-angle regularisation speed, m/s
    tau_load           time constant of the load-transfer specific forces, s
    pitch_gain         suspension pitch per longitudinal specific force, rad/(m/s^2)
    tau_pitch          its time constant, s
    tyre               Magic Formula shape factors
    """

    front_roll_share: float = 0.55
    drive_front: float = 1.0
    brake_front: float = 0.65
    power_per_mass: float = 100.0
    brake_max: float = 9.0
    cda: float = 0.7
    crr: float = 0.012
    v_min: float = 0.5
    tau_load: float = 0.05
    pitch_gain: float = math.radians(1.5) / G
    tau_pitch: float = 0.12
    tyre: TyreShape = field(default_factory=TyreShape)


# ---- parameter vector indices --------------------------------------------------------------
(P_M, P_IZ, P_LF, P_LR, P_TF, P_TR, P_HCG, P_HRC, P_K, P_D, P_IR, P_CAF, P_CAR, P_KUS,
 P_FRS, P_DF, P_BF, P_POWER, P_BMAX, P_CDA, P_CRR, P_VMIN, P_TAUL, P_PG, P_TAUP,
 P_CY, P_EY, P_PLOAD, P_PMU, P_CX, P_CK,
 P_TPREV, P_KE, P_KD, P_KI, P_SKP, P_SKI, P_STAU, P_SPREV, P_SRATE, P_STAUS, P_SLIM,
 P_STOPDEC, P_AACC, P_ADEC, P_MODE, P_LEN, P_KR) = range(48)  # fmt: skip
N_PARAMS = 48

# road rows
R_E, R_N, R_H, R_K, R_B, R_G, R_MU, R_Z, R_DB, R_DG, R_V = range(11)
N_ROAD = 11
# time-table rows (on the output grid)
T_STEER, T_SPEED, T_NOISE = range(3)
# states
(X_E, X_N, X_YAW, X_VX, X_VY, X_R, X_PHI, X_PHID, X_DELTA, X_FX, X_FY, X_PITCH, X_IE, X_IV,
 X_VCMD) = range(15)  # fmt: skip
N_STATES = 15
# aux outputs of the derivative
(A_AX, A_AY, A_WS0, A_WS1, A_WS2, A_WS3, A_SDOT, A_S, A_EY, A_BANK, A_GRADE, A_MU, A_DB, A_DG,
 A_Z, A_FY, A_ALF, A_ALR, A_VT) = range(19)  # fmt: skip
N_AUX = 19
# output columns
(O_T, O_E, O_N, O_U, O_YAW, O_PITCH, O_ROLL, O_ROLLSUS, O_BANK, O_GRADE, O_VX, O_VY, O_R,
 O_AX, O_AY, O_UDOT, O_WX, O_WY, O_WZ, O_WS0, O_WS1, O_WS2, O_WS3, O_STEER, O_MU, O_S, O_EY,
 O_VCMD, O_HELD, O_FY, O_ALF, O_ALR, O_VT) = range(33)  # fmt: skip
N_OUT = 33


@njit(cache=True)
def _road_at(R: FloatArray, s: float, ds: float, out: FloatArray) -> None:
    m = R.shape[1]
    x = s / ds
    if x <= 0.0:
        i, f = 0, 0.0
    elif x >= m - 1:
        i, f = m - 2, 1.0
    else:
        i = int(x)
        f = x - i
    for k in range(R.shape[0]):
        out[k] = R[k, i] + f * (R[k, i + 1] - R[k, i])


@njit(cache=True)
def _row_at(R: FloatArray, row: int, s: float, ds: float) -> float:
    m = R.shape[1]
    x = s / ds
    if x <= 0.0:
        return R[row, 0]
    if x >= m - 1:
        return R[row, m - 1]
    i = int(x)
    f = x - i
    return R[row, i] + f * (R[row, i + 1] - R[row, i])


@njit(cache=True)
def _table_at(T: FloatArray, row: int, t: float, dtab: float) -> float:
    """A time table's row at time t (uniform step dtab): the same interpolation as _row_at."""
    return _row_at(T, row, t, dtab)


@njit(cache=True)
def _project(R: FloatArray, ds: float, s_ref: float, e: float, n: float) -> float:
    """One Newton step of the projection of (e, n) on the path, from s_ref."""
    h = _row_at(R, R_H, s_ref, ds)
    de = e - _row_at(R, R_E, s_ref, ds)
    dn = n - _row_at(R, R_N, s_ref, ds)
    s = s_ref + de * math.cos(h) + dn * math.sin(h)
    length = (R.shape[1] - 1) * ds
    if s < 0.0:
        s = 0.0
    elif s > length:
        s = length
    return s


@njit(cache=True)
def _clip(v: float, lo: float, hi: float) -> float:
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


@njit(cache=True)
def _deriv(
    x: FloatArray,
    t: float,
    s_ref: float,
    held: bool,
    dwelling: bool,
    stop_s: float,
    P: FloatArray,
    R: FloatArray,
    ds: float,
    T: FloatArray,
    dtab: float,
    xdot: FloatArray,
    aux: FloatArray,
    rd: FloatArray,
) -> None:
    g = 9.80665
    m = P[P_M]
    lf = P[P_LF]
    lr = P[P_LR]
    wb = lf + lr
    e_pos = x[X_E]
    n_pos = x[X_N]
    yaw = x[X_YAW]
    vx = x[X_VX]
    vy = x[X_VY]
    r = x[X_R]
    phi = x[X_PHI]
    phid = x[X_PHID]
    delta = x[X_DELTA]
    fxf = x[X_FX]
    fyf = x[X_FY]
    vcmd = x[X_VCMD]

    # ---- road under the vehicle ---------------------------------------------------------
    s_loc = _project(R, ds, s_ref, e_pos, n_pos)
    _road_at(R, s_loc, ds, rd)
    th = rd[R_H]
    kap = rd[R_K]
    bank = rd[R_B]
    grade = rd[R_G]
    mu = rd[R_MU]
    cth = math.cos(th)
    sth = math.sin(th)
    ey = -(e_pos - rd[R_E]) * sth + (n_pos - rd[R_N]) * cth
    cyaw = math.cos(yaw)
    syaw = math.sin(yaw)
    v_e = vx * cyaw - vy * syaw
    v_n = vx * syaw + vy * cyaw
    denom = 1.0 - kap * ey
    if denom < 0.2:
        denom = 0.2
    sdot = (v_e * cth + v_n * sth) / denom
    eydot = -v_e * sth + v_n * cth
    cb = math.cos(bank)
    sb = math.sin(bank)
    cgr = math.cos(grade)
    sgr = math.sin(grade)

    # ---- driver: steering -----------------------------------------------------------------
    mode = int(P[P_MODE])
    noise = _table_at(T, T_NOISE, t, dtab)
    throttle = 1.0
    if mode == 0:
        vfw = vx if vx > 0.0 else 0.0
        kap_p = _row_at(R, R_K, s_loc + vfw * P[P_TPREV], ds)
        vfb = abs(vx) if abs(vx) > 3.0 else 3.0
        kap_des = kap_p - (P[P_KE] * ey + P[P_KD] * eydot + P[P_KI] * x[X_IE]) / (vfb * vfb)
        dcmd = math.atan(wb * kap_des) + P[P_KUS] * (vx * vx * kap_des + g * sb)
        r_ref = vx * kap_des
        dcmd += P[P_KR] * (r_ref - r)
        # oversteer: the yaw rate exceeds the path's by more than 0.03 rad/s (or turns the
        # wrong way): the driver lifts the throttle (a stability-control rule)
        if r * r_ref >= 0.0:
            excess = abs(r) - abs(r_ref) - 0.03
        else:
            excess = abs(r) - 0.03
        if excess > 0.0:
            throttle = 1.0 - excess / 0.05
            if throttle < 0.0:
                throttle = 0.0
    else:
        dcmd = _table_at(T, T_STEER, t, dtab)
    dcmd = _clip(dcmd + noise, -P[P_SLIM], P[P_SLIM])
    ddot = _clip((dcmd - delta) / P[P_STAUS], -P[P_SRATE], P[P_SRATE])

    # ---- driver: speed ----------------------------------------------------------------------
    if mode == 0:
        look = vx * P[P_SPREV]
        if look < 3.0:
            look = 3.0
        vt = _row_at(R, R_V, s_loc + look, ds)
        if dwelling:
            vt = 0.0
        elif stop_s < 1e17:
            d = stop_s - s_loc - 0.5
            cap = math.sqrt(2.0 * P[P_STOPDEC] * d) if d > 0.0 else 0.0
            if cap < vt:
                vt = cap
    else:
        vt = _table_at(T, T_SPEED, t, dtab)
    vcd = _clip((vt - vcmd) / P[P_STAU], -P[P_ADEC], P[P_AACC])

    ay_est = (fyf - g * sb) / cb
    n_tot = m * (g * cb * cgr - ay_est * sb)
    if n_tot < 0.1 * m * g:
        n_tot = 0.1 * m * g
    sgn_v = vx / math.sqrt(vx * vx + 0.01)
    f_rr = P[P_CRR] * n_tot * sgn_v
    f_aero = 0.5 * 1.2 * P[P_CDA] * vx * abs(vx)
    f_dem = m * (vcd + P[P_SKP] * (vcmd - vx) + P[P_SKI] * x[X_IV]) + f_rr + f_aero + m * g * sgr
    direction = 1.0
    if vcmd < -0.01 or (vcmd <= 0.01 and vx < 0.0):
        direction = -1.0
    f_drive = 0.0
    f_brake = 0.0
    if f_dem * direction >= 0.0:
        vpow = abs(vx) if abs(vx) > 2.0 else 2.0
        fmax = P[P_POWER] / vpow
        f_drive = _clip(f_dem, -fmax, fmax) * throttle
    else:
        f_brake = min(abs(f_dem), P[P_BMAX] * m)
    if abs(vt) < 1e-6 and abs(vcmd) < 0.1:
        # at rest or stopping: the driver holds the brake pedal
        f_drive = 0.0
        if f_brake < 0.2 * m * g:
            f_brake = 0.2 * m * g

    # ---- normal loads -------------------------------------------------------------------------
    hcg = P[P_HCG]
    hrc = P[P_HRC]
    h_roll = hcg - hrc
    nf = n_tot * lr / wb - m * fxf * hcg / wb
    nr = n_tot * lf / wb + m * fxf * hcg / wb
    roll_mom = P[P_K] * phi + P[P_D] * phid
    dff = (P[P_FRS] * roll_mom + m * lr / wb * hrc * fyf) / P[P_TF]
    dfr = ((1.0 - P[P_FRS]) * roll_mom + m * lf / wb * hrc * fyf) / P[P_TR]
    fz0f = 0.5 * m * g * lr / wb
    fz0r = 0.5 * m * g * lf / wb

    sum_fx = 0.0
    sum_fy = 0.0
    mz = 0.0
    alf = 0.0
    alr = 0.0
    for i in range(4):
        front = i < 2
        left = i % 2 == 0
        if front:
            xi = lf
            yi = 0.5 * P[P_TF] if left else -0.5 * P[P_TF]
            fz = 0.5 * nf - dff if left else 0.5 * nf + dff
            fz0 = fz0f
            ca0 = P[P_CAF]
            dl = delta
            share_d = 0.5 * P[P_DF]
            share_b = 0.5 * P[P_BF]
        else:
            xi = -lr
            yi = 0.5 * P[P_TR] if left else -0.5 * P[P_TR]
            fz = 0.5 * nr - dfr if left else 0.5 * nr + dfr
            fz0 = fz0r
            ca0 = P[P_CAR]
            dl = 0.0
            share_d = 0.5 * (1.0 - P[P_DF])
            share_b = 0.5 * (1.0 - P[P_BF])
        if fz < 0.0:
            fz = 0.0
        vxi = vx - r * yi
        vyi = vy + r * xi
        cd = math.cos(dl)
        sd = math.sin(dl)
        vlong = vxi * cd + vyi * sd
        vlat = -vxi * sd + vyi * cd
        alpha = -math.atan(vlat / math.sqrt(vlong * vlong + P[P_VMIN] * P[P_VMIN]))
        peak = friction_peak(fz, mu, fz0, P[P_PMU])
        fy0 = lateral_force(alpha, fz, peak, ca0, fz0, P[P_CY], P[P_EY], P[P_PLOAD])
        # traction control / ABS with lateral priority: the drive force takes only what the
        # friction circle leaves beside the lateral force; braking keeps at least 30 %.
        cap = 0.95 * peak
        lat = abs(fy0) if abs(fy0) < cap else cap
        room = math.sqrt(cap * cap - lat * lat)
        fx_drive = _clip(f_drive * share_d, -room, room)
        room_b = room if room > 0.3 * cap else 0.3 * cap
        fx_brake = _clip(f_brake * share_b, 0.0, room_b)
        fxi = fx_drive - fx_brake * vlong / math.sqrt(vlong * vlong + 0.01)
        fyi = combined_lateral(fy0, fxi, peak)
        fxb = fxi * cd - fyi * sd
        fyb = fxi * sd + fyi * cd
        sum_fx += fxb
        sum_fy += fyb
        mz += xi * fyb - yi * fxb
        kappa = longitudinal_slip(fxi, fz, peak, P[P_CX], P[P_CK])
        aux[A_WS0 + i] = (vlong + kappa * abs(vlong)) / cgr
        if front:
            alf += 0.5 * alpha
        else:
            alr += 0.5 * alpha

    # ---- accelerations ----------------------------------------------------------------------------
    fx = (sum_fx - f_rr - f_aero) / m
    fy = sum_fy / m
    if held:
        fx = g * sgr
        fy = g * sb
    ax_h = (fx - g * sgr) / cgr
    ay_h = (fy - g * sb) / cb
    rdot = mz / P[P_IZ]
    if held:
        ax_h = 0.0
        ay_h = 0.0
        rdot = 0.0
        xdot[X_E] = 0.0
        xdot[X_N] = 0.0
        xdot[X_VX] = 0.0
        xdot[X_VY] = 0.0
    else:
        xdot[X_E] = v_e
        xdot[X_N] = v_n
        xdot[X_VX] = ax_h + r * vy
        xdot[X_VY] = ay_h - r * vx
    xdot[X_YAW] = r
    xdot[X_R] = rdot
    g_n = g * cb * cgr
    xdot[X_PHI] = phid
    xdot[X_PHID] = (m * h_roll * fy - P[P_D] * phid - P[P_K] * phi + m * g_n * h_roll * math.sin(phi)) / P[
        P_IR
    ]
    xdot[X_DELTA] = ddot
    xdot[X_FX] = (fx - fxf) / P[P_TAUL]
    xdot[X_FY] = (fy - fyf) / P[P_TAUL]
    xdot[X_PITCH] = (-P[P_PG] * fxf - x[X_PITCH]) / P[P_TAUP]
    xdot[X_IE] = ey if (mode == 0 and vx > 2.0) else 0.0
    xdot[X_IV] = 0.0 if held else vcmd - vx
    xdot[X_VCMD] = vcd

    aux[A_AX] = ax_h
    aux[A_AY] = ay_h
    aux[A_SDOT] = 0.0 if held else sdot
    aux[A_S] = s_loc
    aux[A_EY] = ey
    aux[A_BANK] = bank
    aux[A_GRADE] = grade
    aux[A_MU] = mu
    aux[A_DB] = rd[R_DB]
    aux[A_DG] = rd[R_DG]
    aux[A_Z] = rd[R_Z]
    aux[A_FY] = fy
    aux[A_ALF] = alf
    aux[A_ALR] = alr
    aux[A_VT] = vt


@njit(cache=True)
def _run(
    x0: FloatArray,
    s0: float,
    P: FloatArray,
    R: FloatArray,
    ds: float,
    T: FloatArray,
    dtab: float,
    stop_s: FloatArray,
    stop_dwell: FloatArray,
    n_out: int,
    n_sub: int,
) -> FloatArray:
    out = np.zeros((n_out, N_OUT))
    x = x0.copy()
    xt = np.zeros(N_STATES)
    k1 = np.zeros(N_STATES)
    k2 = np.zeros(N_STATES)
    k3 = np.zeros(N_STATES)
    k4 = np.zeros(N_STATES)
    aux = np.zeros(N_AUX)
    rd = np.zeros(N_ROAD)
    h = dtab / n_sub
    s_ref = s0
    held = False
    dwelling = False
    k_stop = 0
    n_stops = stop_s.shape[0]
    dwell_end = 0.0
    mode = int(P[P_MODE])
    for j in range(n_out):
        t = j * dtab
        pending = stop_s[k_stop] if k_stop < n_stops else 1e18
        _deriv(x, t, s_ref, held, dwelling, pending, P, R, ds, T, dtab, k1, aux, rd)
        roll_sus = x[X_PHI]
        roll = aux[A_BANK] + roll_sus
        pitch = -aux[A_GRADE] + x[X_PITCH]
        roll_dot = aux[A_DB] * aux[A_SDOT] + x[X_PHID]
        pitch_dot = -aux[A_DG] * aux[A_SDOT] + k1[X_PITCH]
        yaw_dot = x[X_R]
        sphi = math.sin(roll)
        cphi = math.cos(roll)
        sth = math.sin(pitch)
        cth = math.cos(pitch)
        row = out[j]
        row[O_T] = t
        row[O_E] = x[X_E]
        row[O_N] = x[X_N]
        row[O_U] = aux[A_Z] + P[P_HCG]
        row[O_YAW] = x[X_YAW]
        row[O_PITCH] = pitch
        row[O_ROLL] = roll
        row[O_ROLLSUS] = roll_sus
        row[O_BANK] = aux[A_BANK]
        row[O_GRADE] = aux[A_GRADE]
        row[O_VX] = x[X_VX]
        row[O_VY] = x[X_VY]
        row[O_R] = x[X_R]
        row[O_AX] = aux[A_AX]
        row[O_AY] = aux[A_AY]
        row[O_UDOT] = math.tan(aux[A_GRADE]) * aux[A_SDOT]
        row[O_WX] = roll_dot - yaw_dot * sth
        row[O_WY] = pitch_dot * cphi + yaw_dot * sphi * cth
        row[O_WZ] = -pitch_dot * sphi + yaw_dot * cphi * cth
        for i in range(4):
            row[O_WS0 + i] = 0.0 if held else aux[A_WS0 + i]
        row[O_STEER] = x[X_DELTA]
        row[O_MU] = aux[A_MU]
        row[O_S] = aux[A_S]
        row[O_EY] = aux[A_EY]
        row[O_VCMD] = x[X_VCMD]
        row[O_HELD] = 1.0 if held else 0.0
        row[O_FY] = aux[A_FY]
        row[O_ALF] = aux[A_ALF]
        row[O_ALR] = aux[A_ALR]
        row[O_VT] = aux[A_VT]
        if j == n_out - 1:
            break
        for sub in range(n_sub):
            tt = t + sub * h
            pending = stop_s[k_stop] if k_stop < n_stops else 1e18
            _deriv(x, tt, s_ref, held, dwelling, pending, P, R, ds, T, dtab, k1, aux, rd)
            for q in range(N_STATES):
                xt[q] = x[q] + 0.5 * h * k1[q]
            _deriv(xt, tt + 0.5 * h, s_ref, held, dwelling, pending, P, R, ds, T, dtab, k2, aux, rd)
            for q in range(N_STATES):
                xt[q] = x[q] + 0.5 * h * k2[q]
            _deriv(xt, tt + 0.5 * h, s_ref, held, dwelling, pending, P, R, ds, T, dtab, k3, aux, rd)
            for q in range(N_STATES):
                xt[q] = x[q] + h * k3[q]
            _deriv(xt, tt + h, s_ref, held, dwelling, pending, P, R, ds, T, dtab, k4, aux, rd)
            for q in range(N_STATES):
                x[q] += h / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q])
            s_ref = _project(R, ds, s_ref, x[X_E], x[X_N])
            x[X_IE] = _clip(x[X_IE], -3.0, 3.0)
            x[X_IV] = _clip(x[X_IV], -3.0, 3.0)
            t_new = tt + h
            hold_request = False
            if mode == 0:
                if dwelling:
                    if t_new >= dwell_end:
                        dwelling = False
                        k_stop += 1
                elif k_stop < n_stops:
                    d = stop_s[k_stop] - s_ref
                    if d < 1.5 and abs(x[X_VX]) < 0.05 and x[X_VCMD] < 0.1:
                        dwelling = True
                        dwell_end = t_new + stop_dwell[k_stop]
                    elif d < -3.0:
                        k_stop += 1
                hold_request = dwelling
            else:
                vt = _table_at(T, T_SPEED, t_new, dtab)
                hold_request = abs(vt) < 1e-9 and abs(x[X_VCMD]) < 0.05
            if hold_request and abs(x[X_VX]) < 0.05 and abs(x[X_VY]) < 0.05:
                held = True
                x[X_VX] = 0.0
                x[X_VY] = 0.0
                x[X_R] = 0.0
                x[X_IV] = 0.0
            else:
                held = False
    return out


def _param_vector(vehicle: Vehicle, plan: Plan, options: ModelOptions, length: float) -> FloatArray:
    gains = plan.gains
    p = np.zeros(N_PARAMS)
    p[P_M] = vehicle.mass
    p[P_IZ] = vehicle.yaw_inertia
    p[P_LF] = vehicle.lf
    p[P_LR] = vehicle.lr
    p[P_TF] = vehicle.track_front
    p[P_TR] = vehicle.track_rear
    p[P_HCG] = vehicle.cg_height
    p[P_HRC] = vehicle.roll_axis_height
    p[P_K] = vehicle.roll_stiffness
    p[P_D] = vehicle.roll_damping
    p[P_IR] = vehicle.roll_inertia
    p[P_CAF] = 0.5 * vehicle.cf
    p[P_CAR] = 0.5 * vehicle.cr
    kus = vehicle.understeer_gradient
    p[P_KUS] = kus if math.isfinite(kus) else vehicle.understeer_gradient_tyres
    p[P_FRS] = options.front_roll_share
    p[P_DF] = options.drive_front
    p[P_BF] = options.brake_front
    p[P_POWER] = options.power_per_mass * vehicle.mass
    p[P_BMAX] = options.brake_max
    p[P_CDA] = options.cda
    p[P_CRR] = options.crr
    p[P_VMIN] = options.v_min
    p[P_TAUL] = options.tau_load
    p[P_PG] = options.pitch_gain
    p[P_TAUP] = options.tau_pitch
    tyre = options.tyre
    p[P_CY] = tyre.c_y
    p[P_EY] = tyre.e_y
    p[P_PLOAD] = tyre.load_exponent
    p[P_PMU] = tyre.mu_load
    p[P_CX] = tyre.c_x
    p[P_CK] = tyre.slip_stiffness
    p[P_TPREV] = gains.preview_s
    p[P_KE] = gains.lateral_omega**2
    p[P_KD] = 2.0 * gains.lateral_zeta * gains.lateral_omega
    p[P_KI] = gains.lateral_ki
    p[P_KR] = gains.yaw_rate_gain
    p[P_SKP] = gains.speed_kp
    p[P_SKI] = gains.speed_ki
    p[P_STAU] = gains.speed_tau
    p[P_SPREV] = gains.speed_preview_s
    p[P_SRATE] = math.radians(gains.handwheel_rate_deg) / vehicle.steering_ratio
    p[P_STAUS] = gains.steer_tau
    p[P_SLIM] = gains.steer_limit
    p[P_STOPDEC] = gains.stop_decel
    p[P_AACC] = plan.a_acc
    p[P_ADEC] = plan.a_dec
    p[P_MODE] = 0.0 if isinstance(plan, PathPlan) else 1.0
    p[P_LEN] = length
    return p


def _road_matrix(road: Road, plan: Plan) -> FloatArray:
    R = np.zeros((N_ROAD, road.s.size))
    R[R_E] = road.e
    R[R_N] = road.n
    R[R_H] = road.heading
    R[R_K] = road.curvature
    R[R_B] = road.bank
    R[R_G] = road.grade
    R[R_MU] = road.mu
    R[R_Z] = road.elevation
    R[R_DB] = np.gradient(road.bank, road.ds)
    R[R_DG] = np.gradient(road.grade, road.ds)
    R[R_V] = plan.v_profile if isinstance(plan, PathPlan) else 0.0
    return R


def internal_step(vehicle: Vehicle, options: ModelOptions, dt: float) -> int:
    """Number of RK4 sub-steps per output step: step <= 2.5 ms and <= 1.5 / lambda_max.

    lambda_max bounds the fastest eigenvalue, that of the tyre lateral / yaw damping at the
    regularisation speed v_min: (cf + cr) / (m v_min) and (cf lf^2 + cr lr^2) / (I_z v_min).
    """
    v = options.v_min
    lam_lat = (vehicle.cf + vehicle.cr) / (vehicle.mass * v)
    lam_yaw = (vehicle.cf * vehicle.lf**2 + vehicle.cr * vehicle.lr**2) / (vehicle.yaw_inertia * v)
    lam = max(lam_lat, lam_yaw, 1.0 / options.tau_load)
    h = min(0.0025, 1.5 / lam)
    return max(1, math.ceil(dt / h - 1e-9))


@dataclass(frozen=True)
class Diagnostics:
    """Internals of a run that the truth does not carry (for tests and tuning).

    s path arc length (m), lateral_offset from the path (m, left +), speed_command and
    speed_target (m/s), held (1 when held at rest), fy_road (lateral specific force in the
    road plane, m/s^2), alpha_front / alpha_rear (mean slip angle per axle, rad)
    """

    s: FloatArray
    lateral_offset: FloatArray
    speed_command: FloatArray
    speed_target: FloatArray
    held: FloatArray
    fy_road: FloatArray
    alpha_front: FloatArray
    alpha_rear: FloatArray


def simulate_truth_full(
    vehicle: Vehicle,
    road: Road,
    plan: Plan,
    duration_s: float,
    dt: float = 0.01,
    rng: np.random.Generator | None = None,
    options: ModelOptions | None = None,
) -> tuple[Truth, Diagnostics]:
    """Simulate ``duration_s`` of driving; truth on the uniform grid 0, dt, ..., duration_s."""
    vehicle.need(*REQUIRED)
    if not math.isfinite(vehicle.steering_ratio):
        vehicle = vehicle.with_changes(steering_ratio=16.0)
    options = options or ModelOptions()
    rng = rng if rng is not None else np.random.default_rng(0)
    n_out = round(duration_s / dt) + 1
    t = np.arange(n_out, dtype=np.float64) * dt
    table = np.zeros((3, n_out + 1))
    t_tab = np.arange(n_out + 1) * dt
    if isinstance(plan, OpenLoopPlan):
        table[T_STEER] = np.interp(t_tab, plan.t, plan.steer)
        table[T_SPEED] = np.interp(t_tab, plan.t, plan.speed)
    table[T_NOISE] = ou_noise(rng, n_out + 1, dt, math.radians(plan.steer_noise_deg), 1.0)
    R = _road_matrix(road, plan)
    P = _param_vector(vehicle, plan, options, road.length)
    if isinstance(plan, PathPlan):
        stops = [(s, d) for s, d in plan.stops]
        stops.append((road.length - 1.0, math.inf))
        stop_s = np.array([s for s, _ in stops], dtype=float)
        stop_dwell = np.array([d for _, d in stops], dtype=float)
    else:
        stop_s = np.zeros(0)
        stop_dwell = np.zeros(0)
    x0 = np.zeros(N_STATES)
    x0[X_E] = road.e[0]
    x0[X_N] = road.n[0]
    x0[X_YAW] = road.heading[0]
    x0[X_VX] = plan.v0
    x0[X_VCMD] = plan.v0
    x0[X_DELTA] = table[T_STEER, 0]
    n_sub = internal_step(vehicle, options, dt)
    out = _run(x0, 0.0, P, R, road.ds, table, dt, stop_s, stop_dwell, n_out, n_sub)

    yaw = out[:, O_YAW]
    cy, sy = np.cos(yaw), np.sin(yaw)
    acc_enu = np.empty((n_out, 3))
    acc_enu[:, 0] = out[:, O_AX] * cy - out[:, O_AY] * sy
    acc_enu[:, 1] = out[:, O_AX] * sy + out[:, O_AY] * cy
    acc_enu[:, 2] = np.gradient(out[:, O_UDOT], dt) if n_out > 1 else 0.0
    truth = Truth(
        t=t,
        e=out[:, O_E].copy(),
        n=out[:, O_N].copy(),
        u=out[:, O_U].copy(),
        yaw=yaw.copy(),
        pitch=out[:, O_PITCH].copy(),
        roll=out[:, O_ROLL].copy(),
        roll_sus=out[:, O_ROLLSUS].copy(),
        bank=out[:, O_BANK].copy(),
        grade=out[:, O_GRADE].copy(),
        vx=out[:, O_VX].copy(),
        vy=out[:, O_VY].copy(),
        r=out[:, O_R].copy(),
        ax=out[:, O_AX].copy(),
        ay=out[:, O_AY].copy(),
        acc_enu=acc_enu,
        omega_body=out[:, O_WX : O_WZ + 1].copy(),
        wheel_speed=out[:, O_WS0 : O_WS3 + 1].copy(),
        steer=out[:, O_STEER].copy(),
        mu=out[:, O_MU].copy(),
    )
    diag = Diagnostics(
        s=out[:, O_S].copy(),
        lateral_offset=out[:, O_EY].copy(),
        speed_command=out[:, O_VCMD].copy(),
        speed_target=out[:, O_VT].copy(),
        held=out[:, O_HELD].copy(),
        fy_road=out[:, O_FY].copy(),
        alpha_front=out[:, O_ALF].copy(),
        alpha_rear=out[:, O_ALR].copy(),
    )
    return truth, diag


def simulate_truth(
    vehicle: Vehicle,
    road: Road,
    plan: Plan,
    duration_s: float,
    dt: float = 0.01,
    rng: np.random.Generator | None = None,
    options: ModelOptions | None = None,
) -> Truth:
    """Truth of ``duration_s`` of driving ``plan`` on ``road`` (see :func:`simulate_truth_full`)."""
    return simulate_truth_full(vehicle, road, plan, duration_s, dt, rng, options)[0]
