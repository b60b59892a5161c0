"""The fused estimator's compiled loop: forward EKF over the filter's nodes, RTS backward pass.

Nodes are drive rows taken every ``stride`` rows (the smoother's step, e.g. 40 ms on a 100 Hz
drive; every row for the causal filter).  The prediction from node j to node j+1 uses the mean
of the IMU samples between them; each node then takes, in order, the wheel-speed (or standstill)
update, the rear- and front-axle force relations, and every GNSS epoch stamped since the
previous node (with its age, see :func:`sideslip.models.fused_measurements.gnss_position`).
Models: :mod:`sideslip.models.fused_process`, :mod:`sideslip.models.fused_measurements`;
kernels: :mod:`sideslip.filters.sparse`.

Storage: the filtered state (float64) and, for the smoother, the filtered covariance's upper
triangle in float32 per node; the backward pass recomputes each prediction (a deterministic
function of the filtered state) instead of storing it.  Memory and time are linear in the
drive's length.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sideslip.filters.sparse import (
    pack_upper,
    predict_sparse,
    robust_pair,
    robust_scalar,
    rts_step,
    unpack_upper,
)
from sideslip.models.fused_measurements import (
    A_NF,
    A_NR,
    front_axle_force,
    gnss_position,
    gnss_velocity,
    rear_axle_force,
    standstill_yaw_rate,
    wheel_speed,
)
from sideslip.models.fused_process import ICX, IMU, ISF, ISR, IVX, IVY, U_AX, process_into
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
    C_WHEEL_SLIP_STIFFNESS,
) = range(23)
N_CFG = 23

# innovation channels recorded per node (NIS, NaN where none)
K_WHEEL, K_REAR, K_FRONT, K_GNSS_VEL, K_GNSS_POS = range(5)
N_CHANNELS = 5


@numba.njit(cache=True)
def _predict(x, P, u, dt, cfg, q, rows, xn, Pn, F, dr, qk, tmp):
    process_into(x, u, dt, cfg[C_K_PHI], cfg[C_GM_TAU], xn, F, dr)
    vx, vy = x[IVX], x[IVY]
    for i in range(x.size):
        qk[i] = q[i] * dt
    arw2 = cfg[C_GYRO_ARW] ** 2
    vrw2 = cfg[C_ACCEL_VRW] ** 2
    qk[2] += arw2 * dt  # gyro noise enters psi, v_x, v_y through r
    qk[IVX] += (vrw2 + vy * vy * arw2) * dt
    qk[IVY] += (vrw2 + vx * vx * arw2) * dt
    predict_sparse(P, F, rows, qk, Pn, tmp)


@numba.njit(cache=True)
def _adapt(infl, nis, dt, cfg):
    """Adaptive variance factor of an axle relation: grows while its NIS exceeds 1, decays
    back to 1 otherwise (time constant C_ADAPT_TAU)."""
    a = min(1.0, dt / cfg[C_ADAPT_TAU])
    return min(max(infl * math.exp(a * (min(nis, 25.0) - 1.0)), 1.0), cfg[C_ADAPT_MAX])


@numba.njit(cache=True)
def _gate_learning(h, P, i_k, i_mu, f, f_limit, steady, cfg):
    """Zero the Jacobian entries an axle relation must not learn from; returns the variance
    that the relation gains instead.

    The stiffness is learned beyond C_STIFF_CURVE only (a noisy regressor near zero biases
    it: errors in variables) and, in the causal filter, only in quasi-steady cornering (at
    turn-in and turn-out the tyres' relaxation lag would be taken for a soft tyre); mu only
    near the limit (the curve's bend).  Where the stiffness is withheld in a transient, its
    current uncertainty enters the relation's variance (the diagonal part of a consider
    parameter, Schmidt 1966): a relation with an unlearned stiffness is as uncertain as that
    stiffness, not as certain as a known one (file 30 % soft, causal filter: cr_step_steer
    beta RMSE 0.29 -> 0.17 deg, 2-sigma share 0.82 -> 1.00).  Below C_STIFF_CURVE the term is
    negligible (the force, and so the stiffness's effect, is small) and is left out."""
    r_con = 0.0
    if abs(f) < cfg[C_STIFF_CURVE]:
        h[i_k] = 0.0
    elif not steady:
        r_con += h[i_k] * h[i_k] * P[i_k, i_k]
        h[i_k] = 0.0
    if abs(f) < cfg[C_MU_UTIL] * f_limit:
        h[i_mu] = 0.0
    return r_con


@numba.njit(cache=True)
def run_nodes(
    tn,
    U,
    vw,
    f_front,
    f_rear,
    delta,
    mu_floor,
    steady,
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
    """Forward EKF over the nodes and (``smooth``) the RTS pass; see the module docstring.

    Returns ``(xs, var, cov_vxvy, nis, counts)``: states (N, nx), their variances, the
    v_x-v_y covariance, the NIS per channel (N, N_CHANNELS), and counts
    ``[gnss accepted, gnss down-weighted, axle accepted, axle down-weighted]``.
    """
    N = tn.size
    nx = x0.size
    npk = nx * (nx + 1) // 2
    xs = np.zeros((N, nx))
    Ps = np.zeros((N if smooth else 1, npk), dtype=np.float32)
    var = np.zeros((N, nx))
    cov_vxvy = np.zeros(N)
    nis = np.full((N, N_CHANNELS), np.nan)
    counts = np.zeros(4, dtype=np.int64)
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
    ph0 = np.zeros(nx)
    ph1 = np.zeros(nx)
    xb = np.zeros(nx)
    infl_r = 1.0
    infl_f = 1.0
    gate = cfg[C_GATE]
    gi = 0
    ng = g_node.size
    t_vel_ok = tn[0]
    t_pos_ok = tn[0]
    for k in range(N):
        if k > 0:
            _predict(x, P, U[k - 1], tn[k] - tn[k - 1], cfg, q, rows, xn, Pn, F, dr, qk, tmp)
            x[:] = xn
            P[:, :] = Pn
        dtk = tn[k] - tn[k - 1] if k > 0 else 0.0
        u = U[k]
        if math.isfinite(vw[k]) and abs(vw[k]) < cfg[C_STILL_SPEED]:
            # ---- standstill: zero velocity and zero yaw rate
            h[:] = 0.0
            h[IVX] = 1.0
            robust_scalar(x, P, -x[IVX], h, 1e-4, 1e300, ph0)
            h[:] = 0.0
            h[IVY] = 1.0
            robust_scalar(x, P, -x[IVY], h, 1e-4, 1e300, ph0)
            r = standstill_yaw_rate(x, u, cfg[C_K_PHI], h, dr)
            robust_scalar(x, P, -r, h, cfg[C_GYRO_NOISE] ** 2, 1e300, ph0)
        elif math.isfinite(vw[k]):
            hv = wheel_speed(x, h)
            # wheel slip and rolling-radius changes are relative to the speed; driving and
            # braking slip grows with the longitudinal force, slip ratio a_x / (g C_k) for a
            # normalised longitudinal slip stiffness C_k (Pacejka 2012, sec. 1.3: C_Fk / F_z
            # about 15-20; race lap: -3.5 % braking at 8 m/s^2, +6 % driving at 5 m/s^2)
            slip = abs(u[U_AX] - x[ICX]) / (G * cfg[C_WHEEL_SLIP_STIFFNESS])
            sig_w = cfg[C_WHEEL_SIGMA] + abs(vw[k]) * (cfg[C_WHEEL_REL] + slip)
            d2, ok = robust_scalar(x, P, vw[k] - hv, h, sig_w * sig_w, gate, ph0)
            nis[k, K_WHEEL] = d2
        # the axle relations' error is a model error correlated over C_AXLE_TAU seconds, not
        # white noise: their variance is quoted per C_AXLE_TAU and scaled by C_AXLE_TAU / dt,
        # so that the information per second does not depend on the node rate
        rate_scale = cfg[C_AXLE_TAU] / max(dtk, 1e-3) if k > 0 else 1.0
        if x[IVX] > cfg[C_AXLE_MIN_SPEED]:
            # ---- axle force relations (brush model): the tyres' word on the slip angles
            if math.isfinite(f_rear[k]):
                hv = rear_axle_force(x, u, cfg[C_K_PHI], axle, h, dr)
                lim = max(x[IMU], 0.05) * axle[A_NR]
                r_con = _gate_learning(h, P, ISR, IMU, f_rear[k], lim, steady[k], cfg)
                sig = cfg[C_FORCE_SIGMA] + cfg[C_FORCE_REL] * abs(f_rear[k])
                r_ax = (sig * sig * rate_scale + r_con) * infl_r
                d2, ok = robust_scalar(x, P, f_rear[k] - hv, h, r_ax, gate, ph0)
                nis[k, K_REAR] = d2
                counts[2 if ok else 3] += 1
                infl_r = _adapt(infl_r, d2, dtk, cfg)
            if math.isfinite(f_front[k]) and math.isfinite(delta[k]):
                hv = front_axle_force(x, u, delta[k], cfg[C_K_PHI], axle, h, dr)
                lim = max(x[IMU], 0.05) * axle[A_NF]
                r_con = _gate_learning(h, P, ISF, IMU, f_front[k], lim, steady[k], cfg)
                sig = cfg[C_FORCE_SIGMA] + cfg[C_FORCE_REL] * abs(f_front[k])
                r_ax = (sig * sig * rate_scale + r_con) * infl_f
                d2, ok = robust_scalar(x, P, f_front[k] - hv, h, r_ax, gate, ph0)
                nis[k, K_FRONT] = d2
                counts[2 if ok else 3] += 1
                infl_f = _adapt(infl_f, d2, dtk, cfg)
        if x[IMU] < mu_floor[k]:
            # ---- the road transmits the measured acceleration: mu >= |a| / g (estimate
            # projection onto the constraint, Simon 2010, IET Control Theory Appl. 4(8))
            h[:] = 0.0
            h[IMU] = 1.0
            robust_scalar(x, P, mu_floor[k] - x[IMU], h, cfg[C_MU_FLOOR_SIGMA] ** 2, 1e300, ph0)
        # ---- GNSS epochs stamped since the previous node
        while gi < ng and g_node[gi] == k:
            if math.isfinite(g_ve[gi]) and math.isfinite(g_vn[gi]):
                he, hn = gnss_velocity(x, u, cfg[C_K_PHI], lever, H2, dr)
                # a run of rejected epochs longer than C_GNSS_RESET means the filter, not the
                # receiver, is wrong: the next epoch is taken at full weight
                g_gate = cfg[C_GATE_GNSS] if tn[k] - t_vel_ok < cfg[C_GNSS_RESET] else 1e300
                d2, ok = robust_pair(
                    x, P, H2, g_ve[gi] - he, g_vn[gi] - hn, g_vstd[gi] ** 2, g_gate, ph0, ph1, xb
                )
                if ok:
                    t_vel_ok = tn[k]
                nis[k, K_GNSS_VEL] = d2 if not math.isfinite(nis[k, K_GNSS_VEL]) else nis[k, K_GNSS_VEL] + d2
                counts[0 if ok else 1] += 1
            if math.isfinite(g_e[gi]) and math.isfinite(g_n[gi]):
                he, hn = gnss_position(x, u, cfg[C_K_PHI], lever, g_age[gi], H2)
                # an unidentified latency and lever arm are position noise (speed x latency)
                r_pos = g_pstd[gi] ** 2 + cfg[C_POS_LEVER] ** 2 + (x[IVX] * cfg[C_POS_LATENCY]) ** 2
                g_gate = cfg[C_GATE_GNSS] if tn[k] - t_pos_ok < cfg[C_GNSS_RESET] else 1e300
                d2, ok = robust_pair(x, P, H2, g_e[gi] - he, g_n[gi] - hn, r_pos, g_gate, ph0, ph1, xb)
                if ok:
                    t_pos_ok = tn[k]
                nis[k, K_GNSS_POS] = d2 if not math.isfinite(nis[k, K_GNSS_POS]) else nis[k, K_GNSS_POS] + d2
                counts[0 if ok else 1] += 1
            gi += 1
        for i in range(nx):  # floor the variances against round-off
            if P[i, i] < 1e-18:
                P[i, i] = 1e-18
        xs[k] = x
        if smooth:
            pack_upper(P, Ps[k])
        for i in range(nx):
            var[k, i] = P[i, i]
        cov_vxvy[k] = P[IVX, IVY]
    if smooth and N > 1:
        L = np.zeros((nx, nx))
        B = np.zeros((nx, nx))
        D = np.zeros((nx, nx))
        Pk = np.zeros((nx, nx))
        Ps_next = np.zeros((nx, nx))
        xk = np.zeros(nx)
        unpack_upper(Ps[N - 1], Ps_next)
        for k in range(N - 2, -1, -1):
            unpack_upper(Ps[k], Pk)
            xk[:] = xs[k]
            _predict(xk, Pk, U[k], tn[k + 1] - tn[k], cfg, q, rows, xn, Pn, F, dr, qk, tmp)
            rts_step(xk, Pk, xn, Pn, F, rows, xs[k + 1], Ps_next, L, B, D, tmp)
            xs[k] = xk
            for i in range(nx):
                var[k, i] = max(Pk[i, i], 1e-18)
            cov_vxvy[k] = Pk[IVX, IVY]
            Ps_next[:, :] = Pk
    return xs, var, cov_vxvy, nis, counts
