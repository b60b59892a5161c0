"""The simulator's truth model: a nonlinear two-track vehicle with roll, on a 3-D road.

This is deliberately richer than any estimator's model (never the linear single-track model):

* Planar motion (longitudinal, lateral, yaw) of the whole vehicle, four wheels at their track
  positions, front steering (parallel, no Ackermann), per-tyre Pacejka Magic Formula forces
  with load sensitivity and a friction-ellipse combined slip (:mod:`sideslip.simulate.tyre`),
  optionally built over a relaxation length of travel (``ModelOptions.relaxation_m``: each
  tyre's slip angle through a first-order lag of that length over its speed; 0 by default);
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

State vector x (19): E, N (m, CG in ENU), yaw (rad), vx, vy (m/s, heading frame), r (rad/s),
phi_sus (rad), phi_sus' (rad/s), delta (road-wheel steer, rad), f_x, f_y filtered (m/s^2),
pitch_sus (rad), driver integrals (lateral offset m s, speed m), driver speed command (m/s),
and the four tyres' lagged slip angles (rad; constant 0 without relaxation).
Integration: classical RK4 at a step of at most 2.5 ms (smaller for stiff tyres at v_min),
output every ``dt``; the loop is compiled with numba.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from sideslip.simulate.driver import OpenLoopPlan, PathPlan, Plan, ou_noise
from sideslip.simulate.model_layout import (
    N_ROAD,
    R_B,
    R_DB,
    R_DG,
    R_E,
    R_G,
    R_H,
    R_K,
    R_MU,
    R_N,
    R_V,
    R_Z,
    T_NOISE,
    T_SPEED,
    T_STEER,
    Diagnostics,
    clip,
    project_on_path,
    road_at,
    road_matrix,
    row_at,
    table_at,
)  # fmt: skip
from sideslip.simulate.model_params import ModelOptions, ModelParams, internal_step, model_params
from sideslip.simulate.road import Road
from sideslip.simulate.truth import Truth
from sideslip.simulate.tyre import (
    combined_lateral,
    friction_peak,
    lateral_force,
    longitudinal_slip,
)
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

REQUIRED = (
    "mass", "yaw_inertia", "lf", "lr", "cf", "cr", "track_front", "track_rear", "cg_height",
    "roll_axis_height", "roll_stiffness", "roll_damping", "roll_inertia",
)  # fmt: skip


# states
(X_E, X_N, X_YAW, X_VX, X_VY, X_R, X_PHI, X_PHID, X_DELTA, X_FX, X_FY, X_PITCH, X_IE, X_IV,
 X_VCMD, X_ALPHA0) = range(16)  # fmt: skip
N_STATES = 19  # X_ALPHA0 .. X_ALPHA0 + 3: each tyre's lagged slip angle (relaxation)
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
def _deriv(
    x: FloatArray,
    t: float,
    s_ref: float,
    held: bool,
    dwelling: bool,
    stop_s: float,
    P: ModelParams,
    R: FloatArray,
    ds: float,
    T: FloatArray,
    dtab: float,
    xdot: FloatArray,
    aux: FloatArray,
    rd: FloatArray,
) -> None:
    g = 9.80665
    m = P.mass
    lf = P.lf
    lr = P.lr
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
    s_loc = project_on_path(R, ds, s_ref, e_pos, n_pos)
    road_at(R, s_loc, ds, rd)
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
    mode = int(P.open_loop)
    noise = table_at(T, T_NOISE, t, dtab)
    throttle = 1.0
    if mode == 0:
        vfw = vx if vx > 0.0 else 0.0
        kap_p = row_at(R, R_K, s_loc + vfw * P.preview_s, ds)
        vfb = abs(vx) if abs(vx) > 3.0 else 3.0
        feedback = P.lateral_gain_offset * ey + P.lateral_gain_rate * eydot + P.lateral_ki * x[X_IE]
        kap_des = kap_p - feedback / (vfb * vfb)
        dcmd = math.atan(wb * kap_des) + P.understeer_gradient * (vx * vx * kap_des + g * sb)
        r_ref = vx * kap_des
        dcmd += P.yaw_rate_gain * (r_ref - r)
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
        dcmd = table_at(T, T_STEER, t, dtab)
    dcmd = clip(dcmd + noise, -P.steer_limit, P.steer_limit)
    ddot = clip((dcmd - delta) / P.steer_tau, -P.steer_rate_max, P.steer_rate_max)

    # ---- driver: speed ----------------------------------------------------------------------
    if mode == 0:
        look = vx * P.speed_preview_s
        if look < 3.0:
            look = 3.0
        vt = row_at(R, R_V, s_loc + look, ds)
        if dwelling:
            vt = 0.0
        elif stop_s < 1e17:
            d = stop_s - s_loc - 0.5
            cap = math.sqrt(2.0 * P.stop_decel * d) if d > 0.0 else 0.0
            if cap < vt:
                vt = cap
    else:
        vt = table_at(T, T_SPEED, t, dtab)
    vcd = clip((vt - vcmd) / P.speed_tau, -P.a_dec, P.a_acc)

    ay_est = (fyf - g * sb) / cb
    n_tot = m * (g * cb * cgr - ay_est * sb)
    if n_tot < 0.1 * m * g:
        n_tot = 0.1 * m * g
    sgn_v = vx / math.sqrt(vx * vx + 0.01)
    f_rr = P.crr * n_tot * sgn_v
    f_aero = 0.5 * 1.2 * P.cda * vx * abs(vx)
    f_dem = m * (vcd + P.speed_kp * (vcmd - vx) + P.speed_ki * x[X_IV]) + f_rr + f_aero + m * g * sgr
    direction = 1.0
    if vcmd < -0.01 or (vcmd <= 0.01 and vx < 0.0):
        direction = -1.0
    f_drive = 0.0
    f_brake = 0.0
    if f_dem * direction >= 0.0:
        vpow = abs(vx) if abs(vx) > 2.0 else 2.0
        fmax = P.power_w / vpow
        f_drive = clip(f_dem, -fmax, fmax) * throttle
    else:
        f_brake = min(abs(f_dem), P.brake_max * m)
    if abs(vt) < 1e-6 and abs(vcmd) < 0.1:
        # at rest or stopping: the driver holds the brake pedal
        f_drive = 0.0
        if f_brake < 0.2 * m * g:
            f_brake = 0.2 * m * g

    # ---- normal loads -------------------------------------------------------------------------
    hcg = P.cg_height
    hrc = P.roll_axis_height
    h_roll = hcg - hrc
    nf = n_tot * lr / wb - m * fxf * hcg / wb
    nr = n_tot * lf / wb + m * fxf * hcg / wb
    roll_mom = P.roll_stiffness * phi + P.roll_damping * phid
    dff = (P.front_roll_share * roll_mom + m * lr / wb * hrc * fyf) / P.track_front
    dfr = ((1.0 - P.front_roll_share) * roll_mom + m * lf / wb * hrc * fyf) / P.track_rear
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
            yi = 0.5 * P.track_front if left else -0.5 * P.track_front
            fz = 0.5 * nf - dff if left else 0.5 * nf + dff
            fz0 = fz0f
            ca0 = P.cornering_stiffness_tyre_front
            dl = delta
            share_d = 0.5 * P.drive_front
            share_b = 0.5 * P.brake_front
        else:
            xi = -lr
            yi = 0.5 * P.track_rear if left else -0.5 * P.track_rear
            fz = 0.5 * nr - dfr if left else 0.5 * nr + dfr
            fz0 = fz0r
            ca0 = P.cornering_stiffness_tyre_rear
            dl = 0.0
            share_d = 0.5 * (1.0 - P.drive_front)
            share_b = 0.5 * (1.0 - P.brake_front)
        if fz < 0.0:
            fz = 0.0
        vxi = vx - r * yi
        vyi = vy + r * xi
        cd = math.cos(dl)
        sd = math.sin(dl)
        vlong = vxi * cd + vyi * sd
        vlat = -vxi * sd + vyi * cd
        v_reg = math.sqrt(vlong * vlong + P.v_min * P.v_min)
        alpha = -math.atan(vlat / v_reg)
        alpha_force = alpha
        if P.relaxation_m > 0.0:
            # the force follows the slip over one relaxation length of travel (Pacejka 2012,
            # sec. 7.2, the first-order lag of the single contact point model)
            alpha_force = x[X_ALPHA0 + i]
            xdot[X_ALPHA0 + i] = v_reg / P.relaxation_m * (alpha - alpha_force)
        else:
            xdot[X_ALPHA0 + i] = 0.0
        peak = friction_peak(fz, mu, fz0, P.tyre_mu_load)
        fy0 = lateral_force(alpha_force, fz, peak, ca0, fz0, P.tyre_c_y, P.tyre_e_y, P.tyre_load_exponent)
        # traction control / ABS with lateral priority: the drive force takes only what the
        # friction circle leaves beside the lateral force; braking keeps at least 30 %.
        cap = 0.95 * peak
        lat = abs(fy0) if abs(fy0) < cap else cap
        room = math.sqrt(cap * cap - lat * lat)
        fx_drive = clip(f_drive * share_d, -room, room)
        room_b = room if room > 0.3 * cap else 0.3 * cap
        fx_brake = clip(f_brake * share_b, 0.0, room_b)
        fxi = fx_drive - fx_brake * vlong / math.sqrt(vlong * vlong + 0.01)
        fyi = combined_lateral(fy0, fxi, peak)
        fxb = fxi * cd - fyi * sd
        fyb = fxi * sd + fyi * cd
        sum_fx += fxb
        sum_fy += fyb
        mz += xi * fyb - yi * fxb
        kappa = longitudinal_slip(fxi, fz, peak, P.tyre_c_x, P.tyre_slip_stiffness)
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
    rdot = mz / P.yaw_inertia
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
    roll_moment = m * h_roll * fy - P.roll_damping * phid - P.roll_stiffness * phi
    xdot[X_PHID] = (roll_moment + m * g_n * h_roll * math.sin(phi)) / P.roll_inertia
    xdot[X_DELTA] = ddot
    xdot[X_FX] = (fx - fxf) / P.tau_load
    xdot[X_FY] = (fy - fyf) / P.tau_load
    xdot[X_PITCH] = (-P.pitch_gain * fxf - x[X_PITCH]) / P.tau_pitch
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
    P: ModelParams,
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
    mode = int(P.open_loop)
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
        row[O_U] = aux[A_Z] + P.cg_height
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
            s_ref = project_on_path(R, ds, s_ref, x[X_E], x[X_N])
            x[X_IE] = clip(x[X_IE], -3.0, 3.0)
            x[X_IV] = clip(x[X_IV], -3.0, 3.0)
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
                vt = table_at(T, T_SPEED, t_new, dtab)
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
    R = road_matrix(road, plan)
    P = model_params(vehicle, plan, options, road.length)
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


__all__ = [
    "Diagnostics", "ModelOptions", "ModelParams", "internal_step", "model_params", "simulate_truth",
    "simulate_truth_full",
]  # fmt: skip
