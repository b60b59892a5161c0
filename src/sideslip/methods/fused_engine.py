"""The fused estimator's compiled loop: forward EKF over the filter's nodes, RTS backward pass.

Nodes are drive rows taken every ``stride`` rows (``FusedSettings.step_s``, 50 ms: every fifth
row of a 100 Hz drive, every row of a 20 Hz one) and every GNSS epoch's row.  The inputs
``U`` (2, N, m) are built by ``sideslip.methods.fused._node_inputs``: the prediction from node
j to node j+1 uses ``U[0, j]``, the mean of the IMU samples over the step (rectangle or
trapezoidal rule), the updates at node j ``U[1, j]``.  Each node then takes, in order, the
wheel-speed (or standstill) update, the rear- and front-axle force relations, and every GNSS
epoch stamped since the previous node (with its age, see
:func:`sideslip.models.fused_measurements.gnss_position`; each Doppler epoch first checked
against the inertial propagation, :func:`_doppler_check`).
Models: :mod:`sideslip.models.fused_process`, :mod:`sideslip.models.fused_measurements`;
kernels: :mod:`sideslip.filters.kalman`.

Storage: the filtered state (float64) and, for the smoother, the filtered covariance's upper
triangle in float32 per node; the backward pass recomputes each prediction (a deterministic
function of the filtered state) instead of storing it.  Memory and time are linear in the
drive's length.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sideslip.filters.consider import robust_consider_nb
from sideslip.filters.kalman import (
    pack_upper_nb,
    predict_rows_ws_nb,
    rts_gain_ws_nb,
    rts_update_ws_nb,
    unpack_upper_nb,
    update_robust_pair_ws_nb,
    update_robust_scalar_ws_nb,
)
from sideslip.gnss import gauss_markov_nb
from sideslip.methods.fused_updates import wheel_slip_ratio
from sideslip.models.fused_measurements import (
    A_CR,
    A_LF,
    A_LR,
    A_NF,
    A_NR,
    A_SHAPE,
    SCALE_MAX,
    SCALE_MIN,
    front_axle_force,
    gnss_position,
    gnss_velocity,
    rear_axle_force,
    rear_axle_velocity,
    standstill_yaw_rate,
    wheel_speed,
)
from sideslip.models.fused_process import (
    IBG,
    ICX,
    ICY,
    IE,
    IMU,
    IN,
    IPE,
    IPN,
    IPSI,
    ISF,
    ISG,
    ISR,
    IVX,
    IVY,
    U_AX,
    U_FY,
    U_QAX,
    U_QLAT,
    U_QWX,
    U_QWZ,
    U_WX,
    U_WZ,
    process_into,
    suspension_factor,
    yaw_rate,
)  # fmt: skip
from sideslip.vehicle import G

# indices of the loop's configuration vector (filled by sideslip.methods.fused)
(
    C_WHEEL_SIGMA,
    C_STILL_SPEED,
    C_GYRO_NOISE,
    C_ACCEL_VRW,
    C_GYRO_ARW,
    C_GM_TAU,
    C_GATE,
    C_FORCE_SIGMA,
    C_FORCE_REL,
    C_ADAPT_TAU,
    C_AXLE_MIN_SPEED,
    C_K_PHI,
    C_STIFF_CURVE,
    C_ADAPT_MAX,
    C_MU_UTIL,
    C_MU_FLOOR_SIGMA,
    C_GATE_GNSS,
    C_GNSS_RESET,
    C_AXLE_TAU,
    C_POS_LEVER,
    C_POS_LATENCY,
    C_WHEEL_REL,
    C_GM_SIGMA,
    C_WHEEL_SLIP_STIFFNESS,
) = range(24)
C_ADAPT_MIN = 24  # the adaptive axle noise's smallest factor
C_VCHECK_ACCEL = 25  # m/s^2: drift of the IMU-carried check velocity (0: no check)
C_VCHECK_GATE = 26  # chi^2 (2 dof) of the check
C_VCHECK_TAU = 27  # s: how long a disagreement keeps the receiver suspect
C_POS_BIAS_FIXES = 28  # fixes one unidentified latency / lever-arm offset spans (variance factor)
ROLL_MODEL_SLACK_RAD = 0.035  # roll a file's suspension model may miss (2 deg): not a bank change
C_VCHECK_RAMP_TAU = 29  # s: how long after a bank change the check allows for c_y's lag
C_LOW_SPEED_SIGMA = 30  # m/s: the rear axle's sideways velocity below C_AXLE_MIN_SPEED (0: off)
C_CG_SIGMA = 31  # m: the file's l_r uncertainty, in that relation
C_SUSPECT_HOLD = 32  # 1: the tyres learn nothing while the Doppler check rejects a run of epochs
C_SCALE_PROJECT = 33  # 1: a stiffness scale past its bounds is projected back onto them
# 1: the longitudinal input is the speed's rate v_x' (a drive without ax), not the specific
# force a_x = v_x' - r v_y: v_x's prediction then has no r v_y term (see _predict)
C_AX_SPEED_RATE = 34
N_CFG = 35

# the states whose variance is kept at every node (the outputs' sigmas, the beta_std terms,
# mu's params, the gyro bias's test against the steering's zero); ``VAR_COLUMN[state]`` is
# its column in the node variances.  The full diagonal is returned for the last node only.
VAR_STATES = np.array([IE, IN, IPSI, IVX, IVY, ISR, IMU, IBG], dtype=np.int64)
VAR_COLUMN = {int(state): m for m, state in enumerate(VAR_STATES)}

# innovation channels recorded per node (NIS, NaN where none)
K_WHEEL, K_REAR, K_FRONT, K_GNSS_VEL, K_GNSS_POS = range(5)
N_CHANNELS = 5
# a heading whose sigma exceeds this (rad) is beyond the linear range of the Doppler's
# velocity relation (the rotation by a 15 deg error leaves 3.4 % of the speed out of its
# first-order term); a Doppler epoch then first turns the heading onto its course, less the
# state's own sideslip (:func:`_align_heading`)
HEADING_ALIGN_SIGMA_RAD = math.radians(15.0)


@numba.njit(cache=True)
def _predict(x, P, u, dt, cfg, q, rows, xn, Pn, F, dr, qk, tmp):
    process_into(x, u, dt, cfg[C_K_PHI], cfg[C_GM_TAU], xn, F, dr)
    vx, vy = x[IVX], x[IVY]
    # the speed's rate as the longitudinal input already holds r v_y (it is v_x' itself, not
    # the specific force): the process model's r v_y term would count it twice, and in every
    # turn v_x's prediction would miss by r v_y, which the wheel updates then put partly
    # into v_y (urban_course without ax and GNSS: beta RMSE 0.130 deg against 0.054 with ax)
    coupling = 0.0 if cfg[C_AX_SPEED_RATE] > 0.0 else 1.0
    if coupling == 0.0:
        xn[IVX] -= dt * (u[U_WZ] - x[IBG]) * (1.0 - x[ISG]) * vy
        F[IVX, IVY] = 0.0
        F[IVX, IBG] = 0.0
        F[IVX, ISG] = 0.0
    for i in range(x.size):
        qk[i] = q[i] * dt
    arw2 = cfg[C_GYRO_ARW] ** 2
    vrw2 = cfg[C_ACCEL_VRW] ** 2
    qk[2] += arw2 * dt  # gyro noise enters psi, v_x, v_y through r
    qk[IVX] += (vrw2 + coupling * vy * vy * arw2) * dt
    qk[IVY] += (vrw2 + vx * vx * arw2) * dt
    if u.size > U_QLAT:  # inputs filled across a gap (sideslip.methods.input_gaps)
        q_r = u[U_QWZ]
        qk[2] += q_r * dt
        qk[IVX] += (coupling * vy * vy * q_r + u[U_QAX]) * dt
        qk[IVY] += u[U_QLAT] * dt
        qk[ICY] += G * G * u[U_QWX] * dt  # the roll gyro drives the bank (c_y)
        # the same fill errors move the position within the step: a velocity error growing
        # as a random walk over dt leaves dt^3 / 3 of its density in the position (a logger's
        # 2 s pause in a slalom: the heading held wrong puts the track metres off, and the
        # first fixes after it were gated out as outliers)
        q_pos = ((vx * vx + vy * vy) * q_r + u[U_QAX] + u[U_QLAT]) * dt * dt * dt / 3.0
        qk[IE] += q_pos
        qk[IN] += q_pos
    _, q_gm = gauss_markov_nb(dt, cfg[C_GM_TAU], cfg[C_GM_SIGMA])  # GNSS position error
    qk[IPE] += q_gm
    qk[IPN] += q_gm
    predict_rows_ws_nb(P, F, rows, qk, Pn, tmp)


@numba.njit(cache=True)
def _robust(x, P, innov, h, r, inflate_nis, work):
    """Scalar update whose variance grows with its NIS beyond ``inflate_nis``; returns
    ``(NIS, taken at full weight)``."""
    _, d2, w = update_robust_scalar_ws_nb(x, P, innov, h, r, math.inf, math.inf, inflate_nis, work)
    return d2, w >= 1.0


@numba.njit(cache=True)
def _adapt(infl, nis, dt, cfg):
    """Adaptive variance factor of an axle relation: grows while its NIS exceeds 1, shrinks
    while it is below 1 (time constant C_ADAPT_TAU), within [C_ADAPT_MIN, C_ADAPT_MAX]."""
    a = min(1.0, dt / cfg[C_ADAPT_TAU])
    return min(max(infl * math.exp(a * (min(nis, 25.0) - 1.0)), cfg[C_ADAPT_MIN]), cfg[C_ADAPT_MAX])


@numba.njit(cache=True)
def _align_heading(x, P, y_e, y_n, min_speed):
    """Turn the heading of ``x`` so that the CG's velocity over ground has the course of the
    Doppler velocity ``y_e, y_n`` (m/s, at the CG), where the heading's variance in ``P``
    exceeds :data:`HEADING_ALIGN_SIGMA_RAD` squared and both speeds exceed ``min_speed``; the
    state's sideslip and the covariance stay as they are.  Returns whether it turned.

    An extended Kalman filter linearises the Doppler relation at the predicted heading; with a
    heading tens of degrees off the first-order term is wrong, and one update moved the slip
    instead (after a 2 s pause of the logger in a slalom at the limit, fused_filter: heading
    sigma 54 deg before the first epoch, v_y 2.8 -> -17 m/s in that update, the heading's
    sigma 2 deg and its error 30 deg after two more).  The course is what the Doppler measures
    without linearisation, so the heading is first set to the course less the state's slip,
    and the update then runs where its linearisation holds; the heading's variance is kept,
    and the split between heading and slip is left to the following updates (the coarse
    heading alignment from the GNSS velocity of an INS in motion: Groves 2013, *Principles of
    GNSS, Inertial, and Multisensor Integrated Navigation Systems*, sec. 14.2.4)."""
    if P[IPSI, IPSI] <= HEADING_ALIGN_SIGMA_RAD**2:
        return False
    ve, vn = _nav_velocity(x)
    if y_e * y_e + y_n * y_n <= min_speed * min_speed or ve * ve + vn * vn <= min_speed * min_speed:
        return False
    d = math.atan2(y_n, y_e) - math.atan2(vn, ve)
    x[IPSI] += math.atan2(math.sin(d), math.cos(d))
    return True


# the rear slip beyond full sliding at which a force under half the limit contradicts the
# state (the brush curve is flat from 1 x z_sl), and how long the contradiction must last
# before v_y is moved onto the curve (the causal force low-pass lags a slalom's reversals by
# its time constant, and a lagging force there is no contradiction)
SLIDE_CONTRADICTION = 1.2
SLIDE_PERSIST_S = 0.5


@numba.njit(cache=True)
def _rear_slip_target(x, u, f_rear, axle, k_phi, dr):
    """The ``v_y`` (m/s) that puts the rear slip of ``x`` on the brush curve at the measured
    rear-axle force ``f_rear`` (m/s^2 per mass), where the state contradicts that force: its
    rear slip past :data:`SLIDE_CONTRADICTION` times full sliding while the force is under half
    the axle's limit; NaN where it does not (or for another curve shape).

    Past full sliding the relation's slope is 0: an extended Kalman filter linearised there
    takes nothing from the tyres, however far the force reads from the limit.  After a pause
    of the logger in a slalom at the limit without GNSS the held lateral reading left v_y
    2.5 m/s off (rear slip 8.5 deg, past the 4 deg of full sliding), and on the straight after
    it (force 0, the prediction at the limit) the adaptive axle noise rose to its cap, v_y
    drifted on with the accelerometer's offset to 5 m/s and beta to 18 deg off (fused 6.9 deg
    RMSE, 79 % inside 2 sigma).  The curve is inverted in closed form for the brush model
    (F = F_max (1 - (1 - |z| / z_sl)^3) sign z, z_sl = 3 F_max / C: Pacejka 2012 sec. 3.2.2);
    :func:`forward_nodes` moves ``v_y`` there once the contradiction has lasted
    :data:`SLIDE_PERSIST_S` and the move lies within 3 sigma of ``v_y``, the covariance kept."""
    if axle[A_SHAPE] != 0.0:
        return math.nan
    vx = x[IVX]
    lim = max(x[IMU], 0.05) * axle[A_NR]
    if abs(f_rear) >= 0.5 * lim:
        return math.nan
    c = min(max(x[ISR], SCALE_MIN), SCALE_MAX) * axle[A_CR]
    r = yaw_rate(x, u, k_phi, dr)
    z_sl = 3.0 * lim / c
    z = -(x[IVY] - axle[A_LR] * r) / vx
    if abs(z) < SLIDE_CONTRADICTION * z_sl:
        return math.nan
    u_f = 1.0 - (1.0 - abs(f_rear) / lim) ** (1.0 / 3.0)
    return axle[A_LR] * r - math.copysign(u_f * z_sl, f_rear) * vx


@numba.njit(cache=True)
def _nav_velocity(x):
    """The CG's velocity over ground ``[v_e, v_n]`` (m/s) of state ``x``."""
    c, s = math.cos(x[IPSI]), math.sin(x[IPSI])
    return x[IVX] * c - x[IVY] * s, x[IVX] * s + x[IVY] * c


@numba.njit(cache=True)
def _doppler_check(chk, t, y_e, y_n, var_g, fy, cfg):
    """Check a Doppler epoch (CG velocity ``y_e, y_n`` with per-axis variance ``var_g``)
    against the IMU; returns the factor on ``var_g`` (1: taken as the receiver says).

    ``chk = [v_e, v_n, variance at anchor, anchor time, suspect variance, its time,
    consecutive disagreeing epochs, roll gyro angle since the anchor, f_y at the anchor, roll
    gyro angle since the start, its low-pass less the suspension roll]`` (:func:`_track_road_roll`).

    The anchor is the velocity of the last epoch that agreed with the inertial propagation,
    carried forward by the process model's own velocity changes (:func:`forward_nodes`), so
    neither the tyres nor the wheels enter it.  Its variance grows as a velocity random walk
    plus an acceleration offset (``C_ACCEL_VRW``, ``C_VCHECK_ACCEL``: accelerometer offset,
    gravity through roll and bank the model misses), and with gravity through the roll the
    body turned since the anchor less the suspension roll the model carries (``fy`` the
    node's low-passed lateral force, ``k_phi fy`` its roll): on a bank ramp the offset state
    c_y lags the road, and without this term the check took the GNSS, which was right, for
    the culprit (banked_turn, 25 deg: a run of 40 epochs rejected).

    An epoch outside the chi^2 gate ``C_VCHECK_GATE`` disagrees with the accelerometers,
    which a multipath burst does and a wrong tyre model does not: its variance grows to
    cover its distance from the anchor.  Multipath persists while the reflecting geometry
    lasts: after two or more disagreeing epochs in a row (a burst; a lone spike is one
    epoch's business) their excess stays on the following epochs, fading with
    ``C_VCHECK_TAU``, so that the tail of a burst, once the anchor's own variance has grown
    to admit it, is not taken for white noise.  A run of disagreeing epochs ends when the
    anchor's variance covers it (a wrong anchor cannot hold the filter for long).
    Innovation-based detection of GNSS faults against the inertial solution: Groves 2013,
    *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, sec. 17.4.
    """
    if cfg[C_VCHECK_ACCEL] <= 0.0:
        return 1.0
    if not math.isfinite(chk[3]):  # the first epoch anchors
        chk[0], chk[1], chk[2], chk[3], chk[7], chk[8] = y_e, y_n, var_g, t, 0.0, fy
        return 1.0
    dt = max(t - chk[3], 0.0)
    d_bank = chk[7] - cfg[C_K_PHI] * (fy - chk[8])  # roll not carried by the model, rad
    # the road's roll over the last C_VCHECK_RAMP_TAU seconds: after a bank ramp the offset
    # state c_y still lags at the anchor, and "since the anchor" misses that
    recent = abs(chk[9] - cfg[C_K_PHI] * fy - chk[10]) if math.isfinite(chk[10]) else 0.0
    recent = max(recent - ROLL_MODEL_SLACK_RAD, 0.0)
    off = cfg[C_VCHECK_ACCEL] + G * max(abs(d_bank), recent)
    var_c = chk[2] + cfg[C_ACCEL_VRW] ** 2 * dt + (off * dt) ** 2
    de, dn = y_e - chk[0], y_n - chk[1]
    dist2 = de * de + dn * dn
    suspect = 0.0
    if math.isfinite(chk[5]):
        suspect = chk[4] * math.exp(-max(t - chk[5], 0.0) / cfg[C_VCHECK_TAU])
    if dist2 <= cfg[C_VCHECK_GATE] * (var_g + var_c):
        chk[0], chk[1], chk[2], chk[3], chk[7], chk[8] = y_e, y_n, var_g, t, 0.0, fy
        chk[6] = 0.0
        return 1.0 + suspect / var_g
    excess = 0.5 * dist2  # per axis
    chk[6] += 1.0
    if chk[6] >= 2.0:
        chk[4], chk[5] = max(excess, suspect), t
    return 1.0 + max(excess, suspect) / var_g


@numba.njit(cache=True, nogil=True)
def new_doppler_check():
    """A fresh state of :func:`_doppler_check` (its docstring lists the 11 entries): no
    anchor, nothing suspect, no roll tracked yet.  The one constructor of that state, so a
    caller cannot hand the check a shorter array (it reads every entry unchecked)."""
    chk = np.zeros(11)
    chk[3] = chk[5] = chk[10] = np.nan
    return chk


@numba.njit(cache=True, nogil=True)
def _track_road_roll(chk, dt, fy, cfg):
    """Low-pass (time constant ``C_VCHECK_RAMP_TAU``) of the road's roll angle, the roll gyro
    integrated (``chk[9]``) less the suspension's roll ``k_phi f_y``, into ``chk[10]``; their
    difference is the bank change the offset state c_y may not have followed yet."""
    road = chk[9] - cfg[C_K_PHI] * fy
    if not math.isfinite(chk[10]) or cfg[C_VCHECK_RAMP_TAU] <= 0.0:
        chk[10] = road
        return
    a = min(dt / cfg[C_VCHECK_RAMP_TAU], 1.0)
    chk[10] += a * (road - chk[10])


@numba.njit(cache=True)
def _project_scales(x, P):
    """Move a stiffness scale that an update took past :data:`SCALE_MIN` / :data:`SCALE_MAX`
    back onto the bound, and the states correlated with it as a measurement of the scale at
    the bound would (estimate projection with the weight P^-1, Simon 2010, IET Control Theory
    Appl. 4(8), sec. 2.3); the covariance is kept, so the scale stays free to move back.

    The axle relations hold a scale at its bound (their Jacobian in it is 0 beyond), so a
    scale left beyond it by an early update never learned again: the causal filter started
    at 40 m/s on the Revs lap took the rear scale below 0.5 within its first second, where
    v_y was still its prior's, and kept it there for the whole clip."""
    for j in (ISR, ISF):
        bound = SCALE_MIN if x[j] < SCALE_MIN else (SCALE_MAX if x[j] > SCALE_MAX else x[j])
        if bound == x[j] or P[j, j] <= 0.0:
            continue
        step = (bound - x[j]) / P[j, j]
        for i in range(x.size):
            x[i] += P[i, j] * step
        x[j] = bound


@numba.njit(cache=True)
def _gate_learning(h, i_k, i_mu, f, f_limit, steady, cfg):
    """Zero the Jacobian entries an axle relation must not learn from; returns whether the
    stiffness ``i_k`` is a consider parameter of this update.

    The stiffness is learned beyond C_STIFF_CURVE only (a noisy regressor near zero biases
    it: errors in variables) and, in the causal filter, only in quasi-steady cornering (at
    turn-in and turn-out the tyres' relaxation lag would be taken for a soft tyre); mu only
    near the limit (the curve's bend).  Where the stiffness is withheld in a transient, it is
    a consider parameter of the update (Schmidt-Kalman, :mod:`sideslip.methods.fused_updates`):
    its uncertainty enters the innovation variance and its cross-covariances are kept, so a
    relation with an unlearned stiffness is as uncertain as that stiffness, and the error the
    stiffness causes is the same in every update of the transient instead of white (file 30 %
    soft, causal filter: cr_step_steer beta RMSE 0.29 -> 0.17 deg with its variance alone
    added to each update, 0.17 -> 0.08 with the cross-covariances).  Below C_STIFF_CURVE the
    stiffness's effect is small and it is left out."""
    consider = False
    if abs(f) < cfg[C_STIFF_CURVE]:
        h[i_k] = 0.0
    elif not steady:
        consider = True
    if abs(f) < cfg[C_MU_UTIL] * f_limit:
        h[i_mu] = 0.0
    return consider


@numba.njit(cache=True, nogil=True)
def forward_nodes(
    tn,
    U,
    vw,
    f_front,
    f_rear,
    delta,
    mu_floor,
    steady,
    force_var,
    g_node,
    g_age,
    g_e,
    g_n,
    g_pstd,
    g_ve,
    g_vn,
    g_vstd,
    x0,
    P0,
    q,
    rows,
    axle,
    lever,
    cfg,
    smooth,
):
    """Forward EKF over the nodes; see the module docstring.

    Returns ``(xs, Ps, var, var_last, cov_vxvy, nis, counts, doppler_ll)``: filtered states (N, nx),
    (``smooth``) their covariances' packed float32 upper triangles (N, nx (nx + 1) / 2), the
    variances of :data:`VAR_STATES` (N, len), the last node's whole diagonal (nx), the v_x-v_y
    covariance, the NIS per channel (N, N_CHANNELS), and counts
    ``[gnss accepted, gnss down-weighted, axle accepted, axle down-weighted]``, and
    ``doppler_ll = [sum over Doppler epochs of log det S + min(d2, gate), epochs]``: the
    prediction-error decomposition of the Doppler velocities' likelihood (-2 log L less a
    constant; Schweppe 1965, IEEE Trans. Inf. Theory 11(1)), each epoch's Mahalanobis
    distance capped at the GNSS gate (Huber-type: a multipath epoch counts as an outlier, not
    as evidence for more process noise).
    """
    N = tn.size
    nx = x0.size
    npk = nx * (nx + 1) // 2
    xs = np.zeros((N, nx))
    Ps = np.zeros((N if smooth else 1, npk), dtype=np.float32)
    var = np.zeros((N, VAR_STATES.size))
    var_last = np.zeros(nx)
    cov_vxvy = np.zeros(N)
    nis = np.full((N, N_CHANNELS), np.nan)
    counts = np.zeros(4, dtype=np.int64)
    doppler_ll = np.zeros(2)
    x = x0.copy()
    P = P0.copy()
    xn = np.zeros(nx)
    Pn = np.zeros((nx, nx))
    F = np.zeros((nx, nx))
    tmp = np.zeros((nx, nx))
    dr = np.zeros(nx)
    qk = np.zeros(nx)
    h = np.zeros(nx)
    H2 = np.zeros((2, nx))
    work = np.zeros((nx + 5, nx))  # sideslip.filters.kalman.workspace
    keep = np.ones(nx)  # gain factors of the axle updates: 0 for a consider stiffness
    infl_r = 1.0
    infl_f = 1.0
    gate = cfg[C_GATE]
    gi = 0
    ng = g_node.size
    t_vel_ok = tn[0]
    t_pos_ok = tn[0]
    chk = new_doppler_check()  # _doppler_check's state
    slide_since = math.nan  # since when the state's rear slip contradicts the force (s)
    for k in range(N):
        if k > 0:
            _predict(x, P, U[0, k - 1], tn[k] - tn[k - 1], cfg, q, rows, xn, Pn, F, dr, qk, tmp)
            # the Doppler check follows the inertial prediction only, not the updates
            ve0, vn0 = _nav_velocity(x)
            ve1, vn1 = _nav_velocity(xn)
            chk[0] += ve1 - ve0
            chk[1] += vn1 - vn0
            if U.shape[2] > U_QLAT:  # a gap's fill error moves the carried velocity too
                uq = U[0, k - 1]
                chk[2] += (x[IVX] ** 2 * uq[U_QWZ] + uq[U_QAX] + uq[U_QLAT]) * (tn[k] - tn[k - 1])
            chk[7] += U[0, k - 1, U_WX] * (tn[k] - tn[k - 1])
            chk[9] += U[0, k - 1, U_WX] * (tn[k] - tn[k - 1])
            _track_road_roll(chk, tn[k] - tn[k - 1], U[1, k, U_FY], cfg)
            x[:] = xn
            P[:, :] = Pn
        dtk = tn[k] - tn[k - 1] if k > 0 else 0.0
        u = U[1, k]
        still = math.isfinite(vw[k]) and abs(vw[k]) < cfg[C_STILL_SPEED]
        if still:
            # ---- standstill: zero velocity and zero yaw rate
            h[:] = 0.0
            h[IVX] = 1.0
            _robust(x, P, -x[IVX], h, 1e-4, 1e300, work)
            h[:] = 0.0
            h[IVY] = 1.0
            _robust(x, P, -x[IVY], h, 1e-4, 1e300, work)
            r = standstill_yaw_rate(x, u, cfg[C_K_PHI], h, dr)
            _robust(x, P, -r, h, cfg[C_GYRO_NOISE] ** 2, 1e300, work)
        elif math.isfinite(vw[k]):
            hv = wheel_speed(x, h)
            # wheel slip and rolling-radius changes are relative to the speed; driving and
            # braking slip grows with the longitudinal force, slip ratio a_x / (g C_k) for a
            # normalised longitudinal slip stiffness C_k (Pacejka 2012, sec. 1.3: C_Fk / F_z
            # about 15-20; race lap: -3.5 % braking at 8 m/s^2, +6 % driving at 5 m/s^2)
            # (a_x the estimated longitudinal acceleration, the reading less the offset c_x);
            # below C_AXLE_MIN_SPEED a slip ratio is as ill-defined as a slip angle (a wheel
            # pulling away; parking drive: a pull-away with the term had beta 1.1 -> 6.6 deg).
            # In corners the driving force also overcomes the front axle's cornering drag and
            # the slip grows with the rear's secant compliance (combined slip, brush model:
            # sideslip.methods.fused_updates), where the rear force stands above the axle
            # relation's noise floor C_FORCE_SIGMA (below it a slip-over-force secant is noise)
            slip = 0.0
            if abs(vw[k]) > cfg[C_AXLE_MIN_SPEED]:
                slip = abs(u[U_AX] - x[ICX]) / (G * cfg[C_WHEEL_SLIP_STIFFNESS])
                if abs(f_rear[k]) > cfg[C_FORCE_SIGMA] and x[IVX] > cfg[C_AXLE_MIN_SPEED]:
                    r_k = yaw_rate(x, u, cfg[C_K_PHI], dr)
                    slip = wheel_slip_ratio(
                        u[U_AX] - x[ICX], f_rear[k], (x[IVY] - axle[A_LR] * r_k) / x[IVX],
                        (x[IVY] + axle[A_LF] * r_k) / x[IVX], axle[A_LR] / axle[A_LF],
                        cfg[C_WHEEL_SLIP_STIFFNESS],
                    )  # fmt: skip
            sig_w = cfg[C_WHEEL_SIGMA] + abs(vw[k]) * (cfg[C_WHEEL_REL] + slip)
            d2, ok = _robust(x, P, vw[k] - hv, h, sig_w * sig_w, gate, work)
            nis[k, K_WHEEL] = d2
        # the axle relations' error is a model error correlated over C_AXLE_TAU seconds, not
        # white noise: their variance is quoted per C_AXLE_TAU and scaled by C_AXLE_TAU / dt,
        # so that the information per second does not depend on the node rate
        rate_scale = cfg[C_AXLE_TAU] / max(dtk, 1e-3) if k > 0 else 1.0
        if x[IVX] <= cfg[C_AXLE_MIN_SPEED] and cfg[C_LOW_SPEED_SIGMA] > 0.0 and not still:
            # ---- walking pace and reversing: the rear axle rolls, it hardly slides sideways;
            # v_y - l_r r = -|v_x| f_r / C_r (the slip angle's relation times |v_x|)
            hv = rear_axle_velocity(x, u, cfg[C_K_PHI], axle, h, dr)
            c_r = min(max(x[ISR], SCALE_MIN), SCALE_MAX) * axle[A_CR]
            f_r = f_rear[k] if math.isfinite(f_rear[k]) else 0.0
            sig = (
                cfg[C_LOW_SPEED_SIGMA]
                + abs(x[IVX]) * (cfg[C_FORCE_SIGMA] + cfg[C_FORCE_REL] * abs(f_r)) / c_r
                + cfg[C_CG_SIGMA] * abs(yaw_rate(x, u, cfg[C_K_PHI], dr))
            )
            d2, ok = _robust(x, P, -abs(x[IVX]) * f_r / c_r - hv, h, sig * sig * rate_scale, gate, work)
            nis[k, K_REAR] = d2
        # while the Doppler check rejects a run of epochs (a burst, from its second epoch)
        # the tyres' stiffness and mu are consider parameters of the axle relations: the
        # course error of a burst the check cannot separate from the vehicle's motion is
        # then not learned as a tyre property (cr_limit_ramp seed 11, file 30 % soft: beta
        # RMSE 2.02 -> 0.34 deg)
        suspect = cfg[C_SUSPECT_HOLD] > 0.0 and chk[6] >= 2.0
        if x[IVX] > cfg[C_AXLE_MIN_SPEED]:
            # ---- axle force relations (brush model): the tyres' word on the slip angles
            if math.isfinite(f_rear[k]):
                vy_curve = _rear_slip_target(x, u, f_rear[k], axle, cfg[C_K_PHI], dr)
                if not math.isfinite(vy_curve):
                    slide_since = math.nan
                elif not math.isfinite(slide_since):
                    slide_since = tn[k]
                elif tn[k] - slide_since >= SLIDE_PERSIST_S and (vy_curve - x[IVY]) ** 2 <= 9.0 * P[IVY, IVY]:
                    x[IVY] = vy_curve
                    slide_since = math.nan
                hv = rear_axle_force(x, u, cfg[C_K_PHI], axle, h, dr)
                lim = max(x[IMU], 0.05) * axle[A_NR]
                consider = _gate_learning(h, ISR, IMU, f_rear[k], lim, steady[k], cfg)
                sig = cfg[C_FORCE_SIGMA] + cfg[C_FORCE_REL] * abs(f_rear[k])
                r_ax = (sig * sig + force_var[k]) * rate_scale * infl_r
                held = suspect and h[ISR] != 0.0
                if consider or held:
                    keep[ISR] = 0.0
                    if held:
                        keep[IMU] = 0.0
                    d2, ok = robust_consider_nb(x, P, f_rear[k] - hv, h, r_ax, gate, keep, work)
                    keep[ISR] = 1.0
                    keep[IMU] = 1.0
                else:
                    d2, ok = _robust(x, P, f_rear[k] - hv, h, r_ax, gate, work)
                nis[k, K_REAR] = d2
                counts[2 if ok else 3] += 1
                infl_r = _adapt(infl_r, d2, dtk, cfg)
            if math.isfinite(f_front[k]) and math.isfinite(delta[k]):
                hv = front_axle_force(x, u, delta[k], cfg[C_K_PHI], axle, h, dr)
                lim = max(x[IMU], 0.05) * axle[A_NF]
                consider = _gate_learning(h, ISF, IMU, f_front[k], lim, steady[k], cfg)
                sig = cfg[C_FORCE_SIGMA] + cfg[C_FORCE_REL] * abs(f_front[k])
                r_ax = (sig * sig + force_var[k]) * rate_scale * infl_f
                held = suspect and h[ISF] != 0.0
                if consider or held:
                    keep[ISF] = 0.0
                    if held:
                        keep[IMU] = 0.0
                    d2, ok = robust_consider_nb(x, P, f_front[k] - hv, h, r_ax, gate, keep, work)
                    keep[ISF] = 1.0
                    keep[IMU] = 1.0
                else:
                    d2, ok = _robust(x, P, f_front[k] - hv, h, r_ax, gate, work)
                nis[k, K_FRONT] = d2
                counts[2 if ok else 3] += 1
                infl_f = _adapt(infl_f, d2, dtk, cfg)
        if x[IMU] < mu_floor[k]:
            # ---- the road transmits the measured acceleration: mu >= |a| / g (estimate
            # projection onto the constraint, Simon 2010, IET Control Theory Appl. 4(8))
            h[:] = 0.0
            h[IMU] = 1.0
            _robust(x, P, mu_floor[k] - x[IMU], h, cfg[C_MU_FLOOR_SIGMA] ** 2, 1e300, work)
        # ---- GNSS epochs stamped since the previous node
        while gi < ng and g_node[gi] == k:
            if math.isfinite(g_ve[gi]) and math.isfinite(g_vn[gi]):
                he, hn = gnss_velocity(x, u, cfg[C_K_PHI], lever, H2, dr)
                ve_cg, vn_cg = _nav_velocity(x)
                # a heading beyond the relation's linear range is first turned onto the course
                y_e, y_n = g_ve[gi] - (he - ve_cg), g_vn[gi] - (hn - vn_cg)
                if _align_heading(x, P, y_e, y_n, cfg[C_AXLE_MIN_SPEED]):
                    he, hn = gnss_velocity(x, u, cfg[C_K_PHI], lever, H2, dr)
                    ve_cg, vn_cg = _nav_velocity(x)
                # the epoch against the inertial check, at the CG (less the antenna's lever
                # velocity, which the model predicts)
                infl = _doppler_check(
                    chk, tn[k], g_ve[gi] - (he - ve_cg), g_vn[gi] - (hn - vn_cg), g_vstd[gi] ** 2,
                    u[U_FY], cfg,
                )  # fmt: skip
                # a run of rejected epochs longer than C_GNSS_RESET means the filter, not the
                # receiver, is wrong: the next epoch is taken at full weight
                g_gate = cfg[C_GATE_GNSS] if tn[k] - t_vel_ok < cfg[C_GNSS_RESET] else 1e300
                r_vel = g_vstd[gi] ** 2 * infl
                doppler_ll[0] += _log_det_pair(P, H2, r_vel)
                d2 = update_robust_pair_ws_nb(x, P, H2, g_ve[gi] - he, g_vn[gi] - hn, r_vel, g_gate, work)
                doppler_ll[0] += min(d2, cfg[C_GATE_GNSS])
                doppler_ll[1] += 1.0
                ok = d2 <= g_gate
                if ok:
                    t_vel_ok = tn[k]
                nis[k, K_GNSS_VEL] = d2 if not math.isfinite(nis[k, K_GNSS_VEL]) else nis[k, K_GNSS_VEL] + d2
                counts[0 if ok else 1] += 1
            if math.isfinite(g_e[gi]) and math.isfinite(g_n[gi]):
                he, hn = gnss_position(x, u, cfg[C_K_PHI], lever, g_age[gi], H2)
                g_gate = cfg[C_GATE_GNSS] if tn[k] - t_pos_ok < cfg[C_GNSS_RESET] else 1e300
                y_e, y_n = g_e[gi] - he, g_n[gi] - hn
                r_pos = g_pstd[gi] ** 2
                if cfg[C_POS_BIAS_FIXES] > 0.0:
                    y_e, y_n = _position_bias_whiten(x, H2, y_e, y_n, r_pos, cfg)
                    r_pos = 1.0
                d2 = update_robust_pair_ws_nb(x, P, H2, y_e, y_n, r_pos, g_gate, work)
                ok = d2 <= g_gate
                if ok:
                    t_pos_ok = tn[k]
                nis[k, K_GNSS_POS] = d2 if not math.isfinite(nis[k, K_GNSS_POS]) else nis[k, K_GNSS_POS] + d2
                counts[0 if ok else 1] += 1
            gi += 1
        if cfg[C_SCALE_PROJECT] > 0.0:
            _project_scales(x, P)
        for i in range(nx):  # floor the variances against round-off
            if P[i, i] < 1e-18:
                P[i, i] = 1e-18
        xs[k] = x
        if smooth:
            pack_upper_nb(P, Ps[k])
        for m in range(VAR_STATES.size):
            var[k, m] = P[VAR_STATES[m], VAR_STATES[m]]
        cov_vxvy[k] = P[IVX, IVY]
    for i in range(nx):
        var_last[i] = P[i, i]
    return xs, Ps, var, var_last, cov_vxvy, nis, counts, doppler_ll


@numba.njit(cache=True, nogil=True)
def _log_det_pair(P, H, r):
    """``log det (H P H' + r I)`` of a two-row measurement ``H`` (2, nx)."""
    nx = P.shape[0]
    s00 = s01 = s11 = 0.0
    for i in range(nx):
        if H[0, i] == 0.0 and H[1, i] == 0.0:
            continue
        a0 = 0.0
        a1 = 0.0
        for j in range(nx):
            a0 += P[i, j] * H[0, j]
            a1 += P[i, j] * H[1, j]
        s00 += H[0, i] * a0
        s01 += H[1, i] * a0
        s11 += H[1, i] * a1
    s00 += r
    s11 += r
    return math.log(max(s00 * s11 - s01 * s01, 1e-300))


@numba.njit(cache=True, nogil=True)
def _position_bias_whiten(x, H, y_e, y_n, r_white, cfg):
    """An unidentified receiver latency and antenna lever arm as position noise: whitens the
    fix's innovation (``H`` in place) to unit variance, returns the whitened pair.

    A latency tau moves the fix by v tau along the track and an antenna misplaced along the
    body by l_x the same way; a sideways misplacement l_y moves it across.  Both are offsets
    that stay for many fixes, not white noise: counted as white at every fix of a fast
    receiver, they let a turn's hundreds of fixes pin an along-track offset to centimetres,
    and the estimator bends the slip to explain it.  Their variance (``C_POS_LATENCY`` s
    times the speed, and ``C_POS_LEVER`` m, 1-sigma each) is on both axes once, as white
    noise (a slow receiver's fixes are each their own draw), and beyond that the along-track
    part (latency and l_x) on the along-track axis and l_y's on the cross-track axis again
    ``C_POS_BIAS_FIXES - 1`` times, the number of fixes one offset spans (the usual inflation
    that lets correlated errors be processed as white); the receiver's white part
    ``r_white`` (m^2) on both.  The track direction is the state's velocity (its heading when
    slow)."""
    c, s = math.cos(x[IPSI]), math.sin(x[IPSI])
    ve = x[IVX] * c - x[IVY] * s
    vn = x[IVX] * s + x[IVY] * c
    v = math.hypot(ve, vn)
    if v > 0.5:
        ca, sa = ve / v, vn / v
    else:
        ca, sa = c, s
    extra = max(cfg[C_POS_BIAS_FIXES] - 1.0, 0.0)
    lever2 = cfg[C_POS_LEVER] ** 2
    along2 = lever2 + (v * cfg[C_POS_LATENCY]) ** 2
    sd_a = math.sqrt(r_white + along2 + extra * along2)
    sd_c = math.sqrt(r_white + along2 + extra * lever2)
    y_a = (ca * y_e + sa * y_n) / sd_a
    y_c = (-sa * y_e + ca * y_n) / sd_c
    for j in range(H.shape[1]):
        h_e, h_n = H[0, j], H[1, j]
        H[0, j] = (ca * h_e + sa * h_n) / sd_a
        H[1, j] = (-sa * h_e + ca * h_n) / sd_c
    return y_a, y_c


@numba.njit(cache=True, nogil=True)
def smoother_gains(k0, k1, xs, Ps, U, tn, cfg, q, rows, XN, PN, B):
    """For nodes k0 <= k < k1: the prediction (``XN``, ``PN``) from the filtered node k to
    k+1 and the transposed RTS gain ``B`` (:func:`sideslip.filters.kalman.rts_gain_ws_nb`),
    stored at k - k0.  Depends on the forward pass only (runs beside the recursion)."""
    nx = xs.shape[1]
    Pk = np.zeros((nx, nx))
    xk = np.zeros(nx)
    F = np.zeros((nx, nx))
    tmp = np.zeros((nx, nx))
    L = np.zeros((nx, nx))
    dr = np.zeros(nx)
    qk = np.zeros(nx)
    for k in range(k0, k1):
        j = k - k0
        unpack_upper_nb(Ps[k], Pk)
        xk[:] = xs[k]
        _predict(xk, Pk, U[0, k], tn[k + 1] - tn[k], cfg, q, rows, XN[j], PN[j], F, dr, qk, tmp)
        rts_gain_ws_nb(Pk, PN[j], F, rows, B[j], L)


@numba.njit(cache=True, nogil=True)
def smoother_recursion(k0, k1, xs, Ps, XN, PN, B, Ps_next, var, cov_vxvy):
    """The RTS recursion from node k1 - 1 down to k0 with the gains of :func:`smoother_gains`;
    ``xs[k1]`` and ``Ps_next`` hold the smoothed node k1 on entry, node k0 on return.
    Writes the smoothed states into ``xs``, the variances of :data:`VAR_STATES` into ``var``
    and the v_x-v_y covariance."""
    nx = xs.shape[1]
    Pk = np.zeros((nx, nx))
    xk = np.zeros(nx)
    T = np.zeros((nx, nx))
    for k in range(k1 - 1, k0 - 1, -1):
        j = k - k0
        unpack_upper_nb(Ps[k], Pk)
        xk[:] = xs[k]
        rts_update_ws_nb(xk, Pk, XN[j], PN[j], B[j], xs[k + 1], Ps_next, T)
        xs[k] = xk
        for m in range(VAR_STATES.size):
            var[k, m] = max(Pk[VAR_STATES[m], VAR_STATES[m]], 1e-18)
        cov_vxvy[k] = Pk[IVX, IVY]
        Ps_next[:, :] = Pk


SMOOTHER_CHUNK = 2048  # nodes per block of gains (about 7 MB of float64 at 15 states)


def run_nodes(
    tn, U, vw, f_front, f_rear, delta, mu_floor, steady, force_var, g_node, g_age, g_e, g_n, g_pstd,
    g_ve, g_vn, g_vstd, x0, P0, q, rows, axle, lever, cfg, smooth,
):  # fmt: skip
    """Forward EKF (:func:`forward_nodes`, same arguments) and, when ``smooth``, the RTS
    smoother; returns ``(xs, var, var_last, cov_vxvy, nis, counts)`` (as :func:`forward_nodes`;
    the last node's smoothed covariance is its filtered one).

    The smoother runs backwards in blocks of :data:`SMOOTHER_CHUNK` nodes: the gains of the
    next (earlier) block are computed on a second thread while this block's recursion runs
    (both compiled without the GIL); the arithmetic, and so the result, is the same as one
    sequential pass."""
    from concurrent.futures import ThreadPoolExecutor

    xs, Ps, var, var_last, cov_vxvy, nis, counts, _ = forward_nodes(
        tn, U, vw, f_front, f_rear, delta, mu_floor, steady, force_var, g_node, g_age, g_e, g_n, g_pstd,
        g_ve, g_vn, g_vstd, x0, P0, q, rows, axle, lever, cfg, smooth,
    )  # fmt: skip
    N, nx = xs.shape
    if not smooth or N < 2:
        return xs, var, var_last, cov_vxvy, nis, counts
    Ps_next = np.zeros((nx, nx))
    unpack_upper_nb(Ps[N - 1], Ps_next)
    bounds = [(max(k1 - SMOOTHER_CHUNK, 0), k1) for k1 in range(N - 1, 0, -SMOOTHER_CHUNK)]

    def gains(block: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k0, k1 = block
        m = k1 - k0
        XN, PN, B = np.empty((m, nx)), np.empty((m, nx, nx)), np.empty((m, nx, nx))
        smoother_gains(k0, k1, xs, Ps, U, tn, cfg, q, rows, XN, PN, B)
        return XN, PN, B

    with ThreadPoolExecutor(max_workers=1) as pool:
        pending = pool.submit(gains, bounds[0])
        for i, (k0, k1) in enumerate(bounds):
            XN, PN, B = pending.result()
            if i + 1 < len(bounds):
                pending = pool.submit(gains, bounds[i + 1])
            smoother_recursion(k0, k1, xs, Ps, XN, PN, B, Ps_next, var, cov_vxvy)
    return xs, var, var_last, cov_vxvy, nis, counts


@numba.njit(cache=True)
def doppler_residuals(xs, U, g_node, g_ve, g_vn, lever, cfg):
    """Distance (m/s) of each Doppler epoch from the antenna velocity that the node states
    ``xs`` (the smoothed ones) predict at its node; NaN where the epoch has no Doppler
    (:mod:`sideslip.methods.fused_bursts`)."""
    nx = xs.shape[1]
    out = np.full(g_node.size, np.nan)
    H2 = np.zeros((2, nx))
    dr = np.zeros(nx)
    for gi in range(g_node.size):
        if math.isfinite(g_ve[gi]) and math.isfinite(g_vn[gi]):
            k = g_node[gi]
            he, hn = gnss_velocity(xs[k], U[1, k], cfg[C_K_PHI], lever, H2, dr)
            out[gi] = math.hypot(g_ve[gi] - he, g_vn[gi] - hn)
    return out


@numba.njit(cache=True)
def block_means(idx, cols, t, n_inputs, trapezoid):
    """Node inputs, shape (N, len(cols)): for node j the rows [idx[j], idx[j+1]) (the last
    node: its rows to the end).  Columns from ``n_inputs`` on take the plain mean of those
    rows.  The first ``n_inputs`` columns, signals sampled at their rows' times ``t``, take
    their mean over the time [t[idx[j]], t[idx[j+1]]] the node propagates over: each row
    standing for the interval after it (rectangle rule) or, with ``trapezoid``, each
    interval the mean of its two end rows; weighted by the intervals' lengths, so that a
    pause of the logger inside a step counts for its duration, not as one row."""
    N = idx.size
    n = cols[0].size
    m = len(cols)
    U = np.empty((N, m))
    for j in range(N):
        lo = idx[j]
        hi = idx[j + 1] if j + 1 < N else n
        timed = j + 1 < N and t[hi] > t[lo]
        for c in range(m):
            col = cols[c]
            acc = 0.0
            if c < n_inputs and timed:
                for i in range(lo, hi):
                    dt = t[i + 1] - t[i]
                    acc += dt * (0.5 * (col[i] + col[i + 1]) if trapezoid else col[i])
                U[j, c] = acc / (t[hi] - t[lo])
            else:
                for i in range(lo, hi):
                    acc += col[i]
                U[j, c] = acc / max(hi - lo, 1)
    return U


@numba.njit(cache=True)
def interp_rows(j, w, V):
    """Linear interpolation of node series ``V`` (m, N) to the rows: row i lies between nodes
    ``j[i]`` and ``j[i] + 1`` at fraction ``w[i]`` (``w`` 0 at or before the first node, 1 at
    or after the last); returns (m, rows)."""
    m, N = V.shape
    out = np.empty((m, j.size))
    for i in range(j.size):
        a = j[i]
        b = min(a + 1, N - 1)
        f = w[i]
        for c in range(m):
            va = V[c, a]
            out[c, i] = va + f * (V[c, b] - va)
    return out


@numba.njit(cache=True)
def row_outputs(
    t, vx, vy, bias_g, wz, wy, fy_lp, j, w, aux, k_phi, l_r, use_tyre, tyre_rel, tyre_floor,
    relaxation_m, std_moving_max, std_still, force_lag_s=0.0,
):  # fmt: skip
    """Per-row outputs of the fused estimator in one pass (see ``sideslip.methods.fused``):
    ``(beta, beta_std, r, roll, bank, pitch)``, rad and rad/s.

    ``vx``, ``vy``, ``bias_g`` are per row; the other state terms are node series ``aux``
    (rows in the order of ``sideslip.methods.fused.AUX_KEYS``: var v_x, var v_y, cov v_x v_y,
    the consistency inflation, c_y, c_x, s_g, s_r, var s_r), read at row i between nodes
    ``j[i]`` and ``j[i] + 1`` at fraction ``w[i]`` (0: the node itself).

    beta = atan2(v_y, |v_x|) where |v_x| > 0.5 m/s (0 otherwise); its variance from the
    gradient of atan2 and the (v_x, v_y) covariance, times the consistency inflation, plus
    (``use_tyre``) the tyre relation's error on the rear slip angle
    ``(tyre_rel alpha_r)^2 + tyre_floor^2``, the learned rear stiffness's relative uncertainty
    on it ``(sqrt(var_sr) / max(s_r, 0.2) alpha_r)^2`` and the lag of the force the relations
    read: alpha_r less alpha_r through a first-order lag of time constant
    ``relaxation_m / |v_x| + force_lag_s`` (the tyres' relaxation, the slip the force follows,
    and the causal low-pass of the measured force, s; ``tau |d alpha_r / dt|`` on a ramp,
    without differentiating the yaw gyro's noise in alpha_r row by row).  Roll = bank (from
    c_y) + k_phi * f_y; r the Euler yaw rate through roll and pitch."""
    n = t.size
    N = aux.shape[1]
    beta = np.empty(n)
    beta_std = np.empty(n)
    r = np.empty(n)
    roll = np.empty(n)
    bank = np.empty(n)
    pitch = np.empty(n)
    alpha = np.empty(n)
    a = np.empty(aux.shape[0])
    relaxed = np.empty(n)
    for i in range(n):
        alpha[i] = -(vy[i] - l_r * (wz[i] - bias_g[i])) / max(abs(vx[i]), 1.0)
        # the slip the force the relations read follows: the tyres' first-order lag over
        # relaxation_m of travel, and the force's own low-pass
        if i == 0 or (relaxation_m <= 0.0 and force_lag_s <= 0.0):
            relaxed[i] = alpha[i]
        else:
            tau = relaxation_m / max(abs(vx[i]), 1.0) + force_lag_s
            k = 1.0 - math.exp(-(t[i] - t[i - 1]) / tau)
            relaxed[i] = relaxed[i - 1] + k * (alpha[i] - relaxed[i - 1])
    for i in range(n):
        j0 = j[i]
        j1 = min(j0 + 1, N - 1)
        for c in range(a.size):
            a[c] = aux[c, j0] + w[i] * (aux[c, j1] - aux[c, j0])
        var_vx, var_vy, cov_vxvy, inflation, c_y, c_x, s_g, s_r, var_sr = (
            a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8]
        )
        s2 = max(vx[i] * vx[i] + vy[i] * vy[i], 1e-6)
        jx = -vy[i] / s2
        jy = vx[i] / s2
        vb = (jx * jx * var_vx + jy * jy * var_vy + 2.0 * jx * jy * cov_vxvy) * inflation
        if use_tyre:
            vb += (tyre_rel * alpha[i]) ** 2 + tyre_floor**2
        rel_k = math.sqrt(max(var_sr, 0.0)) / max(s_r, 0.2)
        vb += (rel_k * alpha[i]) ** 2
        lag = alpha[i] - relaxed[i]
        vb += lag * lag
        if abs(vx[i]) > 0.5:
            beta[i] = math.atan2(vy[i], max(abs(vx[i]), 1e-3))
            beta_std[i] = min(math.sqrt(max(vb, 0.0)), std_moving_max)
        else:
            beta[i] = 0.0
            beta_std[i] = min(std_still, std_moving_max)
        bk = math.asin(min(max(c_y / G, -0.6), 0.6))
        rl = bk + k_phi * fy_lp[i]
        pt = math.asin(min(max(-c_x / G, -0.6), 0.6))
        bank[i] = bk
        roll[i] = rl
        pitch[i] = pt
        r[i] = ((wz[i] - bias_g[i]) * (1.0 - s_g) * math.cos(rl) + wy[i] * math.sin(rl)) / math.cos(pt)
    return beta, beta_std, r, roll, bank, pitch


@numba.njit(cache=True)
def propagate_rows(
    t, tn, j, V, c_y, c_x, s_g, wz, wy, ax, ay, fy_lp, k_phi, i_vx, i_vy, i_bg, i_psi, i_e, i_n,
    coupling=1.0,
):  # fmt: skip
    """The causal filter's output on every row (``sideslip.methods.fused``): the node series
    ``V`` (m, N) at the latest node ``j[i]`` at or before row i, then one Euler step of the
    process model over the gap with the row's own IMU sample: v_x, v_y, yaw (row ``i_psi``)
    and position (rows ``i_e``, ``i_n``; -1 where absent).  ``c_y``, ``c_x``, ``s_g``: node
    series of the specific-force offsets and the gyro scale error.  ``coupling``: 1 where
    ``ax`` is the specific force, 0 where it is the speed's rate (``C_AX_SPEED_RATE``: no r v_y
    term).  Returns (m, rows)."""
    m = V.shape[0]
    n = t.size
    out = np.empty((m, n))
    for i in range(n):
        a = j[i]
        for c in range(m):
            out[c, i] = V[c, a]
        dt = t[i] - tn[a]
        cy = c_y[a]
        cx = c_x[a]
        roll = math.asin(min(max(cy / G, -0.6), 0.6)) + k_phi * fy_lp[i]
        pitch = math.asin(min(max(-cx / G, -0.6), 0.6))
        w_z = (wz[i] - V[i_bg, a]) * (1.0 - s_g[a])
        r = (w_z * math.cos(roll) + wy[i] * math.sin(roll)) / math.cos(pitch)
        vx = V[i_vx, a]
        vy = V[i_vy, a]
        if i_e >= 0:  # position (with fixes), by the heading
            psi = V[i_psi, a]
            cs = math.cos(psi)
            sn = math.sin(psi)
            out[i_e, i] += dt * (vx * cs - vy * sn)
            out[i_n, i] += dt * (vx * sn + vy * cs)
        if i_psi >= 0:
            out[i_psi, i] += dt * r
        out[i_vx, i] = vx + dt * (ax[i] - cx + coupling * r * vy)
        out[i_vy, i] = vy + dt * (ay[i] * suspension_factor(k_phi) - cy - r * vx)
    return out
