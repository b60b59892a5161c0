"""Fused sideslip estimator: one error-aware filter/smoother over every sensor the drive has.

None of the five papers combines their strengths; this method does, in one extended Kalman
filter (``fused_filter``, causal) and its Rauch-Tung-Striebel smoother (``fused``, off-line,
the toolkit's best estimate).

State (10): x = [e, n (CG position, ENU, m), psi (yaw, rad), v_x, v_y (CG velocity in the
heading frame, m/s), b_g (gyro z bias, rad/s), c_y (lateral specific-force offset: g sin(bank)
+ accelerometer y bias, m/s^2), c_x (longitudinal offset: -g sin(pitch) + accelerometer x bias,
m/s^2), s_w (wheel-speed scale factor, -), K (slip gain, s^2/m), s_g (gyro scale factor, -),
p_e, p_n (GNSS position error, Gauss-Markov, m)].

Process model (kinematics of a rigid body in the plane, IMU as input):
    e' = v_x cos psi - v_y sin psi,    n' = v_x sin psi + v_y cos psi
    psi' = r = (w_z cos(roll) + w_y,m sin(roll)) / cos(pitch)     (Euler rates, seed 000 eq 3)
                                       w_z = (w_z,m - b_g)(1 - s_g)   (seed 001: the scale factor
                                       is what breaks a kinematic filter through turns; it
                                       acts on the true rate, so a large raw bias does not
                                       alias into it)
    v_x' = a_x,m - c_x + r v_y
    v_y' = a_y,m - c_y - g k_phi a_y,m - r v_x      (k_phi: suspension roll per lateral accel)
    b_g', c_y', c_x', s_w', K', s_g' = white noise (random walks)
    p_e' = -p_e / tau + w,  p_n' = -p_n / tau + w   (receiver position error is correlated over
                                                      about a minute; white-noise updates at
                                                      10 Hz would over-trust it)
The suspension-roll term uses the sign convention of the package: the accelerometer reads
a_y + g sin(roll) with roll = bank + roll_sus, roll_sus ~ k_phi a_y (seed 003 eq 43).

Measurements:
    wheel speed      v_w = s_w v_x                      (mean of rear wheels, else wheels/CAN)
    GNSS Doppler     [v_e, v_n] at the antenna = v + omega x l (roll/pitch rates from the
                     gyro: a roof antenna 1.3 m up sees roll rate x 1.3 m, as large as v_y)
    GNSS position    [e, n] at the antenna + [p_e, p_n]  (innovation-gated against multipath)
    slip relation    0 = v_y - l_r r + K f_y v_x + noise (seed 000 eqs 5-14: rear-axle slip
                     [noise adapted on-line: inflated while its normalised innovations exceed
                     1, i.e. where the tyres leave their linear range]
                     beta_r = (v_y - l_r r)/v_x = -K f_y, with f_y = a_y,m (1 - g k_phi) the
                     tyre lateral force per mass: the accelerometer reading less the suspension
                     roll's gravity term, so road bank is included as seed 000 eq 14 asks.
                     K is *identified on-line* from GNSS in curves, starting from the vehicle
                     file's m l_f / (L c_r) with a wide prior; the noise grows with
                     |K f_y v_x| (30 %) to carry tyre nonlinearity)
    standstill       v_x = 0, v_y = 0, r = 0 when the wheels stand (gyro bias observable)

Roll and pitch come from the offsets: bank = asin(c_y/g), roll = bank + k_phi f_y, pitch =
asin(-c_x/g).  They absorb the accelerometer biases (b_ay/g rad of roll per m/s^2), which cannot
be told apart from a constant road crossfall without a second attitude reference.

Everything is linearised about the current estimate (EKF), discretised by first-order Euler at
the IMU rate, and stored for the RTS backward pass; memory is O(N) (10x10 per row).  Offline,
the smoother uses every GNSS sample on both sides of an outage, which is why it beats filters.
The slip relation is an assumption of linear rear-tyre behaviour: near the friction limit it
under-predicts slip, which the GNSS velocity corrects when it is there.  The yaw-acceleration
part of the rear-axle force balance (F_yr L = m l_f a_y - I_z r') was tried and left out: with
the tyres' relaxation lag it made transients worse (step steer 0.03 -> 0.08 deg RMSE).  A
front-axle relation with the steering angle (v_y = v_x (delta - delta_0) - l_f r - K_f f_y v_x,
with steering offset and front slip gain as states) was tried too and left out: over ten
scenarios the mean error rose from 0.048 to 0.057 deg (slalom on mu 0.25: 0.075 -> 0.125), the
step steer gained 0.003 deg.  Steering-led transients remain the model-based methods' ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.methods.registry import SPEED, register
from sideslip.signals import gnss_course, speed_raw
from sideslip.vehicle import G, Vehicle

NX = 13
IE, IN, IPSI, IVX, IVY, IBG, ICY, ICX, ISW, IK, ISG, IPE, IPN = range(NX)


@dataclass(frozen=True)
class FusedNoise:
    """Noise settings (1-sigma), SI units; defaults for MEMS IMU, automotive wheel speeds and a
    u-blox M8-class receiver.  ``*_psd`` are continuous random-walk densities per sqrt(s)."""

    accel_vrw: float = 0.1  # m/s/sqrt(s): velocity random walk (accelerometer noise, vibration,
    #                            unmodelled roll transients)
    gyro_arw: float = 5e-4  # rad/sqrt(s): angle random walk (consumer MEMS: 1e-4 to 5e-4)
    gyro_noise: float = 0.003  # rad/s per sample: for the standstill yaw-rate update
    gyro_bias_psd: float = 2e-5  # rad/s/sqrt(s)
    cy_psd: float = 0.2  # m/s^2/sqrt(s): bank changes along the road (5 deg over 50 m at 20 m/s)
    cx_psd: float = 0.1  # m/s^2/sqrt(s): grade changes
    sw_psd: float = 1e-5  # 1/sqrt(s): wheel-speed scale factor drift
    k_psd: float = 2e-6  # s^2/m/sqrt(s): slip gain drift
    sg_psd: float = 1e-5  # 1/sqrt(s): gyro scale-factor drift
    wheel_sigma: float = 0.05  # m/s
    gnss_vel_sigma: float = 0.1  # m/s, used when the drive has no gnss_vel_std
    gnss_pos_sigma: float = 0.5  # m, white part, used when the drive has no gnss_pos_std
    gnss_gm_sigma: float = 1.5  # m, correlated part of the GNSS position error (per axis)
    gnss_gm_tau_s: float = 60.0  # s, its correlation time
    slip_sigma: float = 0.02  # m/s floor on the slip-relation residual (in v_y)
    slip_rel: float = 0.3  # relative error of the linear slip relation
    gate_chi2: float = 16.0  # chi^2 beyond which a GNSS update is down-weighted (Huber)
    standstill_speed: float = 0.05  # m/s: wheels slower than this stand still
    force_tau_s: float = 0.15  # s: low-pass of the lateral force in the slip relation
    k_curve_accel: float = 1.0  # m/s^2: K is learned only where |f_y| exceeds this
    adapt_tau_s: float = 1.0  # s: time constant of the slip relation's adaptive noise


@numba.njit(cache=True)
def _scalar_update(x, P, h, y, rvar, ph):
    """Kalman update with one scalar measurement row ``h`` (innovation ``y``, variance
    ``rvar``); ``ph`` is a work buffer.  Sequential scalar updates are exact for a diagonal R
    and need no matrix inverse.  Returns the normalised innovation squared y^2 / S."""
    n = x.size
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += P[i, j] * h[j]
        ph[i] = acc
    s = rvar
    for i in range(n):
        s += h[i] * ph[i]
    for i in range(n):
        x[i] += ph[i] * (y / s)
    for i in range(n):
        gi = ph[i] / s
        for j in range(n):
            P[i, j] -= gi * ph[j]
    return y * y / s


@numba.njit(cache=True)
def _block_update(x, P, h0, h1, y0, y1, rvar, gate, ph0, ph1, xb):
    """Two-row update with R = rvar I, robust to outliers; returns True when not down-weighted.

    The squared Mahalanobis distance d2 of the innovation is computed on the 2x2 block; beyond
    ``gate`` the noise is inflated by d2 / gate (a Huber-type weight): a multipath jump of many
    sigma barely moves the state, while a run of moderately surprising fixes (after a turn with
    a wrong scale factor) still pulls the filter back instead of being thrown away.
    """
    n = x.size
    for i in range(n):
        a = 0.0
        b = 0.0
        for j in range(n):
            a += P[i, j] * h0[j]
            b += P[i, j] * h1[j]
        ph0[i] = a
        ph1[i] = b
    s00 = rvar
    s01 = 0.0
    s11 = rvar
    for i in range(n):
        s00 += h0[i] * ph0[i]
        s01 += h0[i] * ph1[i]
        s11 += h1[i] * ph1[i]
    det = s00 * s11 - s01 * s01
    d2 = (s11 * y0 * y0 - 2.0 * s01 * y0 * y1 + s00 * y1 * y1) / det
    ok = True
    if d2 > gate:
        rvar = rvar * d2 / gate
        ok = False
    for i in range(n):
        xb[i] = x[i]
    _scalar_update(x, P, h0, y0, rvar, ph0)
    dy = 0.0
    for i in range(n):
        dy += h1[i] * (x[i] - xb[i])
    _scalar_update(x, P, h1, y1 - dy, rvar, ph0)
    return ok


@numba.njit(cache=True)
def _attitude(x, fy, k_phi):
    """Body roll (bank from c_y plus suspension roll k_phi f_y) and pitch from c_x, rad."""
    sb = min(max(x[ICY] / G, -0.6), 0.6)
    sp = min(max(-x[ICX] / G, -0.6), 0.6)
    return math.asin(sb) + k_phi * fy, math.asin(sp)


@numba.njit(cache=True)
def _yaw_rate(x, wz, wy, fy, k_phi):
    """Heading rate psi' = (w_y sin(roll) + w_z cos(roll)) / cos(pitch) (seed 000 eq 3) with the
    z gyro corrected for bias and scale factor; returns (psi', d/db_g, d/ds_g)."""
    roll, pitch = _attitude(x, fy, k_phi)
    cr, sr, cp = math.cos(roll), math.sin(roll), math.cos(pitch)
    wz_true = (wz - x[IBG]) * (1.0 - x[ISG])
    r = (wz_true * cr + wy * sr) / cp
    return r, -(1.0 - x[ISG]) * cr / cp, -(wz - x[IBG]) * cr / cp


# Non-zero columns of each row of the transition Jacobian F (identity elsewhere).
_F_ROWS = np.array(
    [
        [IE, IPSI, IVX, IVY, -1, -1],
        [IN, IPSI, IVX, IVY, -1, -1],
        [IPSI, IBG, ISG, -1, -1, -1],
        [IVX, IVY, IBG, ISG, ICX, -1],
        [IVY, IVX, IBG, ISG, ICY, -1],
        [IBG, -1, -1, -1, -1, -1],
        [ICY, -1, -1, -1, -1, -1],
        [ICX, -1, -1, -1, -1, -1],
        [ISW, -1, -1, -1, -1, -1],
        [IK, -1, -1, -1, -1, -1],
        [ISG, -1, -1, -1, -1, -1],
        [IPE, -1, -1, -1, -1, -1],
        [IPN, -1, -1, -1, -1, -1],
    ],
    dtype=np.int64,
)


@numba.njit(cache=True)
def _f_times(F, P, out):
    """out = F P using the sparse rows of F listed in _F_ROWS (no allocation)."""
    for i in range(NX):
        for j in range(NX):
            acc = 0.0
            for m in range(6):
                col = _F_ROWS[i, m]
                if col < 0:
                    break
                acc += F[i, col] * P[col, j]
            out[i, j] = acc


@numba.njit(cache=True)
def _predict(x, P, xn, Pn, F, tmp, dt, wz, wy, fy, ax, ay, q, k_phi, accel_vrw, gyro_arw, gm_tau):
    """One Euler step of the process model into ``xn``, ``Pn`` (and its Jacobian ``F``).

    F P F' uses the sparsity of F (at most 5 non-zeros a row): O(NX^2), no allocation.
    """
    r, dr_db, dr_ds = _yaw_rate(x, wz, wy, fy, k_phi)
    c, s = math.cos(x[IPSI]), math.sin(x[IPSI])
    vx, vy = x[IVX], x[IVY]
    F[:, :] = 0.0
    for i in range(NX):
        F[i, i] = 1.0
    F[IE, IPSI] = dt * (-vx * s - vy * c)
    F[IE, IVX] = dt * c
    F[IE, IVY] = -dt * s
    F[IN, IPSI] = dt * (vx * c - vy * s)
    F[IN, IVX] = dt * s
    F[IN, IVY] = dt * c
    F[IPSI, IBG] = dt * dr_db
    F[IPSI, ISG] = dt * dr_ds
    F[IVX, IVY] = dt * r
    F[IVX, IBG] = dt * vy * dr_db
    F[IVX, ISG] = dt * vy * dr_ds
    F[IVX, ICX] = -dt
    F[IVY, IVX] = -dt * r
    F[IVY, IBG] = -dt * vx * dr_db
    F[IVY, ISG] = -dt * vx * dr_ds
    F[IVY, ICY] = -dt
    F[IPE, IPE] = 1.0 - dt / gm_tau
    F[IPN, IPN] = 1.0 - dt / gm_tau
    for i in range(NX):
        xn[i] = x[i]
    xn[IPE] -= dt * x[IPE] / gm_tau
    xn[IPN] -= dt * x[IPN] / gm_tau
    xn[IE] += dt * (vx * c - vy * s)
    xn[IN] += dt * (vx * s + vy * c)
    xn[IPSI] += dt * r
    xn[IVX] += dt * (ax - x[ICX] + r * vy)
    xn[IVY] += dt * (ay * (1.0 - G * k_phi) - x[ICY] - r * vx)
    _f_times(F, P, tmp)  # tmp = F P
    # Pn = tmp F'
    for i in range(NX):
        for j in range(NX):
            acc = 0.0
            for m in range(6):
                col = _F_ROWS[j, m]
                if col < 0:
                    break
                acc += tmp[i, col] * F[j, col]
            Pn[i, j] = acc
    for i in range(NX):
        Pn[i, i] += q[i] * dt
    # gyro noise enters psi, v_x, v_y through r; accelerometer noise through v_x, v_y
    Pn[IPSI, IPSI] += gyro_arw**2 * dt
    Pn[IVX, IVX] += (accel_vrw**2 + (vy * gyro_arw) ** 2) * dt
    Pn[IVY, IVY] += (accel_vrw**2 + (vx * gyro_arw) ** 2) * dt


@numba.njit(cache=True)
def _run(
    t,
    wz,
    wx,
    wy,
    ax,
    ay,
    fy_lp,
    vw,
    ve,
    vn,
    vstd,
    ge,
    gn,
    pstd,
    x0,
    P0,
    q,
    lever,
    lr,
    k_phi,
    noise,
    smooth,
):
    """Forward EKF over all rows, then (``smooth``) the RTS backward pass.

    Only the filtered x and P are stored (O(N) memory, NX x NX per row); the backward pass
    recomputes each prediction and its Jacobian from the filtered state, which is exact
    because the prediction is a deterministic function of it.
    """
    n = t.size
    xs = np.zeros((n, NX))
    # the smoother needs every filtered covariance; the filter keeps only what it outputs
    Ps = np.zeros((n if smooth else 1, NX, NX))
    var = np.zeros((n, NX))
    cov_vxvy = np.zeros(n)
    x = x0.copy()
    P = P0.copy()
    xn = np.zeros(NX)
    Pn = np.zeros((NX, NX))
    F = np.zeros((NX, NX))
    tmp = np.zeros((NX, NX))
    h0 = np.zeros(NX)
    h1 = np.zeros(NX)
    ph0 = np.zeros(NX)
    ph1 = np.zeros(NX)
    xb = np.zeros(NX)
    wheel_sigma, slip_sigma, slip_rel, gate, still = noise[0], noise[1], noise[2], noise[3], noise[4]
    accel_vrw, gyro_arw, k_curve = noise[5], noise[6], noise[7]
    gyro_noise, gm_tau, adapt_tau = noise[8], noise[9], noise[10]
    slip_infl = 1.0
    t_slip = -1e308
    accepted = 0
    rejected = 0
    lx, ly, lz = lever[0], lever[1], lever[2]
    for k in range(n):
        if k > 0:
            _predict(
                x,
                P,
                xn,
                Pn,
                F,
                tmp,
                t[k] - t[k - 1],
                wz[k - 1],
                wy[k - 1],
                fy_lp[k - 1],
                ax[k - 1],
                ay[k - 1],
                q,
                k_phi,
                accel_vrw,
                gyro_arw,
                gm_tau,
            )
            x[:] = xn
            P[:, :] = Pn
        r, dr_db, dr_ds = _yaw_rate(x, wz[k], wy[k], fy_lp[k], k_phi)
        if math.isfinite(vw[k]) and abs(vw[k]) < still:
            # ---- standstill: zero velocity and zero yaw rate
            h0[:] = 0.0
            h0[IVX] = 1.0
            _scalar_update(x, P, h0, -x[IVX], 1e-4, ph0)
            h0[:] = 0.0
            h0[IVY] = 1.0
            _scalar_update(x, P, h0, -x[IVY], 1e-4, ph0)
            r, dr_db, dr_ds = _yaw_rate(x, wz[k], wy[k], fy_lp[k], k_phi)
            h0[:] = 0.0
            h0[IBG] = dr_db
            h0[ISG] = dr_ds
            _scalar_update(x, P, h0, -r, gyro_noise**2, ph0)
        elif math.isfinite(vw[k]):
            # ---- wheel speed
            h0[:] = 0.0
            h0[IVX] = x[ISW]
            h0[ISW] = x[IVX]
            _scalar_update(x, P, h0, vw[k] - x[ISW] * x[IVX], wheel_sigma**2, ph0)
            # ---- slip relation (linear rear tyre), at the wheel-speed rate
            vx = x[IVX]
            if vx > 1.0:
                r, dr_db, dr_ds = _yaw_rate(x, wz[k], wy[k], fy_lp[k], k_phi)
                fy = fy_lp[k]  # tyre lateral force / m, low-passed (seed 000 eq 14)
                hval = x[IVY] - lr * r + x[IK] * fy * vx
                h0[:] = 0.0
                h0[IVY] = 1.0
                h0[IBG] = -lr * dr_db
                h0[ISG] = -lr * dr_ds
                h0[IVX] = x[IK] * fy
                # K learns only in curves: a noisy regressor near zero would bias it towards
                # zero (errors in variables); seed 000 also fits K on curves only.
                if abs(fy) > k_curve:
                    h0[IK] = fy * vx
                sig = slip_sigma + slip_rel * abs(x[IK] * fy * vx)
                nis = _scalar_update(x, P, h0, -hval, sig * sig * slip_infl, ph0)
                # adaptive noise: where the linear-tyre relation disagrees with the rest of
                # the data (tyres near the friction limit), its variance grows until the
                # normalised innovations average 1 again (time constant adapt_tau seconds)
                a = min(1.0, (t[k] - t_slip) / adapt_tau) if t_slip > -1e300 else 0.0
                slip_infl = min(max(slip_infl * math.exp(a * (min(nis, 25.0) - 1.0)), 1.0), 400.0)
                t_slip = t[k]
        # ---- GNSS Doppler velocity at the antenna
        if math.isfinite(ve[k]) and math.isfinite(vn[k]):
            r, dr_db, dr_ds = _yaw_rate(x, wz[k], wy[k], fy_lp[k], k_phi)
            c, s = math.cos(x[IPSI]), math.sin(x[IPSI])
            # antenna velocity = v + omega x lever (roll and pitch rates from the gyro)
            vxa = x[IVX] - r * ly + wy[k] * lz
            vya = x[IVY] + r * lx - wx[k] * lz
            h0[:] = 0.0
            h1[:] = 0.0
            h0[IPSI] = -vxa * s - vya * c
            h0[IVX] = c
            h0[IVY] = -s
            h0[IBG] = -(ly * c + lx * s) * dr_db
            h0[ISG] = -(ly * c + lx * s) * dr_ds
            h1[IPSI] = vxa * c - vya * s
            h1[IVX] = s
            h1[IVY] = c
            h1[IBG] = (lx * c - ly * s) * dr_db
            h1[ISG] = (lx * c - ly * s) * dr_ds
            y0 = ve[k] - (vxa * c - vya * s)
            y1 = vn[k] - (vxa * s + vya * c)
            if _block_update(x, P, h0, h1, y0, y1, vstd[k] ** 2, gate, ph0, ph1, xb):
                accepted += 1
            else:
                rejected += 1
        # ---- GNSS position at the antenna
        if math.isfinite(ge[k]) and math.isfinite(gn[k]):
            c, s = math.cos(x[IPSI]), math.sin(x[IPSI])
            h0[:] = 0.0
            h1[:] = 0.0
            h0[IE] = 1.0
            h1[IN] = 1.0
            h0[IPE] = 1.0
            h1[IPN] = 1.0
            h0[IPSI] = -lx * s - ly * c
            h1[IPSI] = lx * c - ly * s
            y0 = ge[k] - (x[IE] + lx * c - ly * s + x[IPE])
            y1 = gn[k] - (x[IN] + lx * s + ly * c + x[IPN])
            if _block_update(x, P, h0, h1, y0, y1, pstd[k] ** 2, gate, ph0, ph1, xb):
                accepted += 1
            else:
                rejected += 1
        for i in range(NX):
            for j in range(i + 1, NX):  # keep P symmetric against round-off
                v = 0.5 * (P[i, j] + P[j, i])
                P[i, j] = v
                P[j, i] = v
        xs[k] = x
        if smooth:
            Ps[k] = P
        for i in range(NX):
            var[k, i] = P[i, i]
        cov_vxvy[k] = P[IVX, IVY]
    if smooth:
        L = np.zeros((NX, NX))
        B = np.zeros((NX, NX))
        D = np.zeros((NX, NX))
        dx = np.zeros(NX)
        for k in range(n - 2, -1, -1):
            _predict(
                xs[k],
                Ps[k],
                xn,
                Pn,
                F,
                tmp,
                t[k + 1] - t[k],
                wz[k],
                wy[k],
                fy_lp[k],
                ax[k],
                ay[k],
                q,
                k_phi,
                accel_vrw,
                gyro_arw,
                gm_tau,
            )
            # smoother gain C = P_k F' Pn^{-1}: solve Pn C' = F P_k by Cholesky (Pn is SPD)
            _cholesky(Pn, L)
            _f_times(F, Ps[k], B)  # B = F P_k
            _cho_solve(L, B)  # B <- C'
            for i in range(NX):
                dx[i] = xs[k + 1, i] - xn[i]
            for i in range(NX):
                acc = 0.0
                for j in range(NX):
                    acc += B[j, i] * dx[j]
                xs[k, i] += acc
            for i in range(NX):  # D = (P_{k+1} - Pn)
                for j in range(NX):
                    D[i, j] = Ps[k + 1, i, j] - Pn[i, j]
            for i in range(NX):  # tmp = C D
                for j in range(NX):
                    acc = 0.0
                    for m in range(NX):
                        acc += B[m, i] * D[m, j]
                    tmp[i, j] = acc
            for i in range(NX):  # P_k += tmp C'
                for j in range(i, NX):
                    acc = 0.0
                    for m in range(NX):
                        acc += tmp[i, m] * B[m, j]
                    Ps[k, i, j] += acc
                    if j != i:
                        Ps[k, j, i] = Ps[k, i, j]
        for k in range(n):
            for i in range(NX):
                var[k, i] = Ps[k, i, i]
            cov_vxvy[k] = Ps[k, IVX, IVY]
    return xs, var, cov_vxvy, accepted, rejected


@numba.njit(cache=True)
def _cholesky(A, L):
    """Lower Cholesky factor of the SPD matrix A into L (jitter-guarded)."""
    n = A.shape[0]
    L[:, :] = 0.0
    for j in range(n):
        s = A[j, j]
        for m in range(j):
            s -= L[j, m] * L[j, m]
        L[j, j] = math.sqrt(max(s, 1e-300))
        for i in range(j + 1, n):
            s = A[i, j]
            for m in range(j):
                s -= L[i, m] * L[j, m]
            L[i, j] = s / L[j, j]


@numba.njit(cache=True)
def _cho_solve(L, B):
    """Solve (L L') X = B in place of B (all columns)."""
    n = L.shape[0]
    for c in range(B.shape[1]):
        for i in range(n):
            s = B[i, c]
            for m in range(i):
                s -= L[i, m] * B[m, c]
            B[i, c] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = B[i, c]
            for m in range(i + 1, n):
                s -= L[m, i] * B[m, c]
            B[i, c] = s / L[i, i]


@numba.njit(cache=True)
def _low_pass(t, x, tau):
    """Causal first-order low-pass with time constant ``tau`` (s)."""
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, x.size):
        a = min(1.0, (t[k] - t[k - 1]) / tau)
        y[k] = y[k - 1] + a * (x[k] - y[k - 1])
    return y


def _initial_state(drive: Drive, vehicle: Vehicle, vw: NDArray) -> tuple[NDArray, NDArray, float]:
    x0 = np.zeros(NX)
    P0 = np.zeros((NX, NX))
    rows, course, _ = gnss_course(drive, min_speed=3.0)
    x0[IPSI] = course[0] if rows.size else 0.0
    if "gnss_e" in drive:
        ok = np.flatnonzero(np.isfinite(drive["gnss_e"]) & np.isfinite(drive["gnss_n"]))
        if ok.size:
            x0[IE], x0[IN] = drive["gnss_e"][ok[0]], drive["gnss_n"][ok[0]]
    first_v = vw[np.isfinite(vw)]
    x0[IVX] = float(first_v[0]) if first_v.size else 0.0
    x0[ISW] = 1.0
    k_prior = vehicle.slip_gain_k if not vehicle.missing(["mass", "lf", "lr", "cr"]) else 0.005
    if not math.isfinite(k_prior) or k_prior <= 0:
        k_prior = 0.005
    x0[IK] = k_prior
    # gyro bias prior 0.1 rad/s (5.7 deg/s): raw phone gyros carry several deg/s (comma2k19: 3.9)
    sig = [10.0, 10.0, math.radians(10.0), 1.0, 0.5, 0.1, 0.5, 0.5, 0.02, 0.6 * k_prior, 0.02, 1.5, 1.5]
    P0[np.arange(NX), np.arange(NX)] = np.square(sig)
    return x0, P0, k_prior


def _roll_gain(vehicle: Vehicle) -> float:
    """k_phi = m h / (k - m g h), rad per m/s^2 (steady suspension roll), 0 if unknown."""
    if vehicle.missing(["mass", "cg_height", "roll_axis_height", "roll_stiffness"]):
        return 0.0
    h = vehicle.cg_height - vehicle.roll_axis_height
    denom = vehicle.roll_stiffness - vehicle.mass * G * h
    return vehicle.mass * h / denom if denom > 0 else 0.0


def fuse(drive: Drive, vehicle: Vehicle, smooth: bool, noise: FusedNoise | None = None) -> Estimate:
    """Run the fused EKF (and RTS smoother when ``smooth``); see module docstring."""
    nz = noise or FusedNoise()
    t = drive.t
    n = len(drive)

    def col(name: str, fill: float = 0.0) -> NDArray:
        if name not in drive:
            return np.full(n, fill)
        v = drive[name].copy()
        bad = ~np.isfinite(v)
        if bad.any():  # hold the last IMU sample across gaps (an input, not a measurement)
            idx = np.where(~bad, np.arange(n), 0)
            np.maximum.accumulate(idx, out=idx)
            v = np.where(bad, v[idx], v)
            v[~np.isfinite(v)] = fill
        return v

    wz, ax, ay = col("wz"), col("ax"), col("ay")
    wx, wy = col("wx"), col("wy")
    raw = speed_raw(drive)
    # signed: a drive whose wheel speeds carry the sign reverses correctly; one with magnitudes
    # only is taken as driving forwards (GNSS then disagrees, and the Huber weights limit harm)
    vw = np.full(n, np.nan) if raw is None else raw
    ve = drive["gnss_ve"] if "gnss_ve" in drive else np.full(n, np.nan)
    vn = drive["gnss_vn"] if "gnss_vn" in drive else np.full(n, np.nan)
    ge = drive["gnss_e"] if "gnss_e" in drive else np.full(n, np.nan)
    gn = drive["gnss_n"] if "gnss_n" in drive else np.full(n, np.nan)
    vstd = drive["gnss_vel_std"] if "gnss_vel_std" in drive else np.full(n, nz.gnss_vel_sigma)
    pstd = drive["gnss_pos_std"] if "gnss_pos_std" in drive else np.full(n, nz.gnss_pos_sigma)
    vstd = np.where(np.isfinite(vstd) & (vstd > 0), np.maximum(vstd, 0.02), nz.gnss_vel_sigma)
    pstd = np.where(np.isfinite(pstd) & (pstd > 0), np.maximum(pstd, 0.2), nz.gnss_pos_sigma)
    x0, P0, k_prior = _initial_state(drive, vehicle, vw)
    q = np.zeros(NX)
    q[IBG] = nz.gyro_bias_psd**2
    q[ICY] = nz.cy_psd**2
    q[ICX] = nz.cx_psd**2
    q[ISW] = nz.sw_psd**2
    q[IK] = nz.k_psd**2
    q[ISG] = nz.sg_psd**2
    q[IPE] = q[IPN] = 2.0 * nz.gnss_gm_sigma**2 / nz.gnss_gm_tau_s
    q[IE] = q[IN] = 1e-4
    q[IPSI] = 0.0  # gyro noise is added inside the prediction
    lever = np.array(vehicle.gnss_xyz, dtype=float)  # antenna from the CG, vehicle axes
    lr = vehicle.lr
    k_phi = _roll_gain(vehicle)
    params = np.array(
        [
            nz.wheel_sigma,
            nz.slip_sigma,
            nz.slip_rel,
            nz.gate_chi2,
            nz.standstill_speed,
            nz.accel_vrw,
            nz.gyro_arw,
            nz.k_curve_accel,
            nz.gyro_noise,
            nz.gnss_gm_tau_s,
            nz.adapt_tau_s,
        ]
    )
    fy_lp = _low_pass(t, ay * (1.0 - G * _roll_gain(vehicle)), nz.force_tau_s)
    xs, var, cov_vxvy, acc, rej = _run(
        t,
        wz,
        wx,
        wy,
        ax,
        ay,
        fy_lp,
        vw,
        ve,
        vn,
        vstd,
        ge,
        gn,
        pstd,
        x0,
        P0,
        q,
        lever,
        lr,
        k_phi,
        params,
        smooth,
    )
    vx, vy = xs[:, IVX], xs[:, IVY]
    speed2 = np.maximum(vx**2 + vy**2, 1e-6)
    beta = np.arctan2(vy, np.maximum(np.abs(vx), 1e-3))
    moving = np.abs(vx) > 0.5
    beta = np.where(moving, beta, 0.0)
    # beta = atan2(v_y, v_x): gradient [-v_y, v_x] / |v|^2
    jx, jy = -vy / speed2, vx / speed2
    var_b = jx**2 * var[:, IVX] + jy**2 * var[:, IVY] + 2 * jx * jy * cov_vxvy
    beta_std = np.where(moving, np.sqrt(np.maximum(var_b, 0.0)), math.radians(5.0))
    beta_std = np.minimum(beta_std, math.radians(30.0))
    bank = np.arcsin(np.clip(xs[:, ICY] / G, -0.6, 0.6))
    roll = bank + k_phi * fy_lp
    pitch = np.arcsin(np.clip(-xs[:, ICX] / G, -0.6, 0.6))
    r = ((wz - xs[:, IBG]) * (1.0 - xs[:, ISG]) * np.cos(roll) + wy * np.sin(roll)) / np.cos(pitch)
    sd = np.sqrt(np.maximum(var, 0.0))
    series = {
        "beta": beta,
        "beta_std": beta_std,
        "r": r,
        "yaw": xs[:, IPSI],
        "yaw_std": sd[:, IPSI],
        "e": xs[:, IE],
        "n": xs[:, IN],
        "e_std": sd[:, IE],
        "n_std": sd[:, IN],
        "vx": vx,
        "vy": vy,
        "gyro_bias": xs[:, IBG],
        "roll": roll,
        "bank": bank,
        "pitch": pitch,
    }
    return Estimate(
        "fused" if smooth else "fused_filter",
        t,
        series,
        {
            "slip_gain_k_s2pm": float(xs[-1, IK]) if not smooth else float(np.median(xs[:, IK])),
            "slip_gain_k_sigma": float(sd[-1, IK]),
            "slip_gain_k_prior": k_prior,
            "wheel_speed_scale_factor": float(np.median(xs[:, ISW])),
            "gyro_bias_final_radps": float(xs[-1, IBG]),
            "gyro_scale_factor": float(np.median(xs[:, ISG])),
            "roll_gain_rad_per_mps2": k_phi,
            "gnss_updates_accepted": int(acc),
            "gnss_updates_downweighted": int(rej),
            "smoothed": smooth,
        },
    )


# GNSS: Doppler velocity or positions (or both); ax, wx, wy used when present.  Without any
# GNSS the filter would rest on the vehicle file's slip gain alone: the model-based methods are
# better there, so fused then leaves the drive to them.
COLUMNS = ("wz", "ay", SPEED, ("gnss_ve", "gnss_e"))
PAPER = "this toolkit (fuses seeds 000, 001, 004 ideas)"


@register(
    "fused",
    columns=COLUMNS,
    vehicle_params=("lr",),
    summary="EKF + RTS smoother: IMU, wheel speed, GNSS Doppler/position, on-line slip gain K",
    paper=PAPER,
)
def fused(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Off-line best estimate: forward EKF and RTS smoother (see module docstring)."""
    return fuse(drive, vehicle, smooth=True)


@register(
    "fused_filter",
    columns=COLUMNS,
    vehicle_params=("lr",),
    summary="causal EKF of `fused` (real-time form)",
    paper=PAPER,
)
def fused_filter(drive: Drive, vehicle: Vehicle) -> Estimate:
    """Causal form of :func:`fused`: the forward EKF only."""
    return fuse(drive, vehicle, smooth=False)
