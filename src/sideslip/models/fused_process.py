"""Process model of the fused estimator: planar rigid-body kinematics with the IMU as input.

State (``NX_CORE`` = 15, plus ``NX_GNSS_CAL`` = 3 when the drive has GNSS positions)::

    0  e, 1 n      CG position, local ENU, m
    2  psi         yaw (heading of the body x axis from East, counter-clockwise), rad
    3  v_x, 4 v_y  CG velocity in the heading frame (x forward, y left), m/s
    5  b_g         z-gyro bias, rad/s
    6  c_y         lateral specific-force offset g sin(bank) + accelerometer y bias, m/s^2
    7  c_x         longitudinal offset -g sin(pitch) + accelerometer x bias, m/s^2
    8  s_w         wheel-speed scale factor (measured / true), -
    9  s_g         gyro scale-factor error (w_m = w (1 + s_g)), -
    10 p_e, 11 p_n GNSS position error (first-order Gauss-Markov), m
    12 s_f, 13 s_r effective cornering stiffness of the front / rear axle over the vehicle
                   file's, -
    14 mu          road friction coefficient, -
    15 tau         GNSS latency (measurement time stamp minus epoch), s      [GNSS positions]
    16 dl_x, 17 dl_y  antenna lever-arm error in body x / y against the file, m  [GNSS positions]

Input ``u = [w_z, w_x, w_y, a_x, a_y, f_y(, b_r)]``: gyro (rad/s), accelerometer (m/s^2), the
low-passed tyre lateral force per mass ``f_y`` (m/s^2, drives the suspension-roll term) and,
optionally, the road's bank rate ``b_r`` (rad/s): the roll gyro less its bias and the
suspension's roll rate ``k_phi f_y'`` (seed 003: body roll = suspension roll + bank).

Continuous model (seed 000 eq 3 for the Euler rate; seed 003 eq 43 for the suspension roll)::

    roll  = asin(c_y / g) + k_phi f_y,   pitch = asin(-c_x / g)
    r     = ((w_z - b_g)(1 - s_g) cos(roll) + w_y sin(roll)) / cos(pitch)
    e'    = v_x cos psi - v_y sin psi,   n' = v_x sin psi + v_y cos psi,   psi' = r
    (position stepped to second order with the ENU acceleration R(psi) [v_x' - r v_y, v_y' + r v_x])
    w_b   = (w_z - b_g)(1 - s_g)           (the body's own z rate: r cos(roll) on a bank)
    v_x'  = a_x - c_x + w_b v_y,         v_y' = a_y / (1 + g k_phi) - c_y - w_b v_x
    c_y'  = g cos(bank) b_r + w          (b_r given: the bank changes only as the body rolls)
    p'    = -p / tau_gm + w              (exact discretisation exp(-dt / tau_gm))
    b_g, c_y (without b_r), c_x, s_w, s_g, s_f, s_r, mu, tau, dl = random walks

The suspension rolls by k_phi times the tyres' force per mass f (k_phi = m h / (k - m g h)
balances the roll moment of f and of gravity through the roll), and the body-fixed
accelerometer reads f plus gravity through that roll: a_y = f + g k_phi f, so
f = a_y / (1 + g k_phi) exactly (:func:`suspension_factor`; the first-order a_y (1 - g k_phi)
left (g k_phi)^2 / (1 + g k_phi) of a_y, 1-2 % of a road car's, in c_y: on CommonRoad's BMW
circle at 3.5 m/s^2 a 0.26 deg bank the road does not have).

The body velocity turns with the body z rate, not the heading rate r (d v_b / dt =
a_b - omega_b x v_b): on a 25 deg bank r v_x overstates the centripetal term by 10 %.

discretised by one Euler step of ``dt`` (the inputs are the mean over the step; the position
to second order).
``process(x, u, dt, k_phi, gm_tau)`` returns ``(x_next, F)`` with the analytic Jacobian
``F = d x_next / d x``; :data:`F_ROWS` lists the non-zero columns of each row of ``F`` (the
rest of ``F`` is the identity), which the sparse prediction uses.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.gnss import gauss_markov_nb
from sideslip.vehicle import G

NX_CORE = 15
NX_GNSS_CAL = 3
IE, IN, IPSI, IVX, IVY, IBG, ICY, ICX, ISW, ISG, IPE, IPN, ISF, ISR, IMU = range(NX_CORE)
ITAU, ILX, ILY = range(NX_CORE, NX_CORE + NX_GNSS_CAL)
U_WZ, U_WX, U_WY, U_AX, U_AY, U_FY, U_RR = range(7)
# process noise densities of the inputs' gap fills (sideslip.methods.input_gaps): yaw gyro
# (rad^2/s), roll gyro (rad^2/s), longitudinal accelerometer ((m/s)^2/s), and the lateral
# kinematic residual a_y - v w_z ((m/s)^2/s: held or interpolated together, the lateral
# reading and the yaw rate err together, a_y by about v times the rate's error in a turn, so
# v_y's error is their difference's, not the sum of both)
U_QWZ, U_QWX, U_QAX, U_QLAT = range(7, 11)
ATT_CLAMP = 0.6  # |sin| of bank / pitch beyond which the offsets are taken as sensor faults

STATE_NAMES = (
    "e", "n", "psi", "vx", "vy", "gyro_bias", "cy", "cx", "wheel_scale", "gyro_scale",
    "gnss_pe", "gnss_pn", "front_stiffness_scale", "rear_stiffness_scale", "mu",
    "gnss_latency", "lever_dx", "lever_dy",
)  # fmt: skip


def f_rows(nx: int) -> NDArray[np.int64]:
    """Non-zero columns of each row of the transition Jacobian (-1 pads), for ``nx`` states."""
    rows = -np.ones((nx, 6), dtype=np.int64)
    rows[:, 0] = np.arange(nx)
    rows[IE, 1:6] = [IPSI, IVX, IVY, ICX, ICY]
    rows[IN, 1:6] = [IPSI, IVX, IVY, ICX, ICY]
    rows[IPSI, 1:5] = [IBG, ISG, ICY, ICX]
    rows[IVX, 1:6] = [IVY, IBG, ISG, ICY, ICX]
    rows[IVY, 1:6] = [IVX, IBG, ISG, ICY, ICX]
    return rows


@numba.njit(cache=True)
def suspension_factor(k_phi: float) -> float:
    """The tyres' lateral force per mass over the accelerometer's reading, 1 / (1 + g k_phi)
    (module docstring; k_phi in rad per m/s^2 of that force)."""
    return 1.0 / (1.0 + G * k_phi)


@numba.njit(cache=True)
def attitude(x: NDArray, fy: float, k_phi: float) -> tuple[float, float, float, float]:
    """Body roll and pitch (rad) from the offsets, and d roll / d c_y, d pitch / d c_x."""
    sb = x[ICY] / G
    sp = -x[ICX] / G
    d_roll = 0.0
    d_pitch = 0.0
    if abs(sb) < ATT_CLAMP:
        d_roll = 1.0 / (G * math.sqrt(1.0 - sb * sb))
    else:
        sb = ATT_CLAMP if sb > 0 else -ATT_CLAMP
    if abs(sp) < ATT_CLAMP:
        d_pitch = -1.0 / (G * math.sqrt(1.0 - sp * sp))
    else:
        sp = ATT_CLAMP if sp > 0 else -ATT_CLAMP
    return math.asin(sb) + k_phi * fy, math.asin(sp), d_roll, d_pitch


@numba.njit(cache=True)
def yaw_rate(x: NDArray, u: NDArray, k_phi: float, dr: NDArray) -> float:
    """Heading rate r (rad/s); writes dr/dx into ``dr`` (zeros except b_g, s_g, c_y, c_x)."""
    roll, pitch, d_roll, d_pitch = attitude(x, u[U_FY], k_phi)
    cr, sr, cp = math.cos(roll), math.sin(roll), math.cos(pitch)
    w = (u[U_WZ] - x[IBG]) * (1.0 - x[ISG])
    r = (w * cr + u[U_WY] * sr) / cp
    dr[:] = 0.0
    dr[IBG] = -(1.0 - x[ISG]) * cr / cp
    dr[ISG] = -(u[U_WZ] - x[IBG]) * cr / cp
    dr[ICY] = (-w * sr + u[U_WY] * cr) / cp * d_roll
    dr[ICX] = r * math.tan(pitch) * d_pitch
    return r


@numba.njit(cache=True)
def process_into(
    x: NDArray, u: NDArray, dt: float, k_phi: float, gm_tau: float, xn: NDArray, F: NDArray, dr: NDArray
) -> None:
    """In place form of :func:`process` (``xn``, ``F`` and the work vector ``dr`` written)."""
    nx = x.size
    r = yaw_rate(x, u, k_phi, dr)
    c, s = math.cos(x[IPSI]), math.sin(x[IPSI])
    vx, vy = x[IVX], x[IVY]
    F[:, :] = 0.0
    for i in range(nx):
        F[i, i] = 1.0
        xn[i] = x[i]
    F[IE, IPSI] = dt * (-vx * s - vy * c)
    F[IE, IVX] = dt * c
    F[IE, IVY] = -dt * s
    F[IN, IPSI] = dt * (vx * c - vy * s)
    F[IN, IVX] = dt * s
    F[IN, IVY] = dt * c
    for j in (IBG, ISG, ICY, ICX):
        F[IPSI, j] = dt * dr[j]
    # the body velocity turns with the body's own z rate w_b (the gyro's), not the heading
    # rate r: on a bank phi, w_b = r cos(phi) (25 deg: 9 % less)
    w_b = (u[U_WZ] - x[IBG]) * (1.0 - x[ISG])
    F[IVX, IBG] = -dt * vy * (1.0 - x[ISG])
    F[IVX, ISG] = -dt * vy * (u[U_WZ] - x[IBG])
    F[IVY, IBG] = dt * vx * (1.0 - x[ISG])
    F[IVY, ISG] = dt * vx * (u[U_WZ] - x[IBG])
    F[IVX, IVY] = dt * w_b
    F[IVX, ICX] -= dt
    F[IVY, IVX] = -dt * w_b
    F[IVY, ICY] -= dt
    decay, _ = gauss_markov_nb(dt, gm_tau, 1.0)  # the GNSS error's Gauss-Markov factor
    F[IPE, IPE] = decay
    F[IPN, IPN] = decay
    xn[IPE] = decay * x[IPE]
    xn[IPN] = decay * x[IPN]
    # position to second order: the ENU acceleration R(psi) [a_x - c_x, a_y' - c_y] over the
    # step (a first-order step would lag the position by v dt / 2, 1 m at 40 m/s and 50 ms)
    a_x = u[U_AX] - x[ICX]
    a_y = u[U_AY] * suspension_factor(k_phi) - x[ICY]
    h2 = 0.5 * dt * dt
    xn[IE] += dt * (vx * c - vy * s) + h2 * (a_x * c - a_y * s)
    xn[IN] += dt * (vx * s + vy * c) + h2 * (a_x * s + a_y * c)
    F[IE, IPSI] += h2 * (-a_x * s - a_y * c)
    F[IN, IPSI] += h2 * (a_x * c - a_y * s)
    F[IE, ICX] = -h2 * c
    F[IN, ICX] = -h2 * s
    F[IE, ICY] = h2 * s
    F[IN, ICY] = -h2 * c
    xn[IPSI] += dt * r
    if u.size > U_RR:
        # the road's bank changes only as the body rolls: c_y' = g cos(bank) bank', with the
        # bank rate the roll gyro less the suspension's roll rate (input U_RR)
        sb = x[ICY] / G
        if abs(sb) < ATT_CLAMP:
            cb = math.sqrt(1.0 - sb * sb)
            xn[ICY] += dt * G * cb * u[U_RR]
            F[ICY, ICY] -= dt * sb / cb * u[U_RR]
        else:
            xn[ICY] += dt * G * math.sqrt(1.0 - ATT_CLAMP * ATT_CLAMP) * u[U_RR]
    xn[IVX] += dt * (u[U_AX] - x[ICX] + w_b * vy)
    xn[IVY] += dt * (u[U_AY] * suspension_factor(k_phi) - x[ICY] - w_b * vx)


@numba.njit(cache=True)
def process(x: NDArray, u: NDArray, dt: float, k_phi: float, gm_tau: float) -> tuple[NDArray, NDArray]:
    """One Euler step of the process model (module docstring): ``(x_next, F)``."""
    nx = x.size
    xn = np.empty(nx)
    F = np.empty((nx, nx))
    dr = np.empty(nx)
    process_into(x, u, dt, k_phi, gm_tau, xn, F, dr)
    return xn, F
