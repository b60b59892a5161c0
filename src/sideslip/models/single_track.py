"""Linear single-track (bicycle) model in sideslip beta and yaw rate r.

States x = [beta (rad), r (rad/s)]; inputs u = [delta (front road-wheel angle, rad),
bank (road bank, rad, roll sign)]; outputs y = [r (rad/s), a_y (gravity-free lateral
acceleration, m/s^2)].  Cornering stiffness per axle (N/rad); seed 003 writes the same
model per tyre (C_axle = 2 C_tyre), seed 002 per axle (digest, and tests/models).

    m V (beta' + r) = F_yf + F_yr - m g sin(bank)               (seed 001 eq 1, bank sign ours)
    I_z r'          = lf F_yf - lr F_yr
    F_yf = cf (delta - beta - lf r / V),  F_yr = cr (-beta + lr r / V)

Seed 001 writes "+ m g sin(phi_b)" with the opposite bank sign; here bank > 0 lowers the road's
right edge, so gravity pulls towards -y.  The accelerometer on a body rolled by ``roll`` reads
a_y + g sin(roll) (package conventions), i.e. the tyre forces / m when roll = bank.

Valid for small slip angles (linear tyres, |a_y| below about 0.4 g) and V > 0; callers at low
speed pass ``v_min`` (the matrices use max(|V|, v_min)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import expm

from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]
V_MIN = 1.0  # m/s: default lower clamp of the speed in the model matrices


@dataclass(frozen=True)
class SingleTrack:
    """Continuous-time matrices at one speed: x' = A x + B u, y = C x + D u."""

    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray
    speed: float


def continuous(vehicle: Vehicle, speed: float, v_min: float = V_MIN) -> SingleTrack:
    """Matrices of the linear single-track model at longitudinal speed ``speed`` (m/s)."""
    A, B, C, D = continuous_arrays(vehicle, np.array([speed]), v_min)
    return SingleTrack(A[0], B[0], C[0], D[0], float(max(abs(speed), v_min)))


@numba.njit(cache=True)
def single_track_row(
    m: float, iz: float, lf: float, lr: float, cf: float, cr: float, v: float,
    A: NDArray, B: NDArray, C: NDArray, D: NDArray,
) -> None:  # fmt: skip
    """The model's matrices at one (already clamped) speed ``v`` into the 2x2 ``A``, ``B``,
    ``C``, ``D`` (the one implementation: :func:`continuous_arrays` and compiled loops call it)."""
    A[0, 0] = -(cf + cr) / (m * v)
    A[0, 1] = (cr * lr - cf * lf) / (m * v**2) - 1.0
    A[1, 0] = (cr * lr - cf * lf) / iz
    A[1, 1] = -(cf * lf**2 + cr * lr**2) / (iz * v)
    B[0, 0] = cf / (m * v)
    B[0, 1] = -G / v
    B[1, 0] = cf * lf / iz
    B[1, 1] = 0.0
    C[0, 0] = 0.0
    C[0, 1] = 1.0
    C[1, 0] = -(cf + cr) / m
    C[1, 1] = (cr * lr - cf * lf) / (m * v)
    D[0, 0] = 0.0
    D[0, 1] = 0.0
    D[1, 0] = cf / m
    D[1, 1] = -G


@numba.njit(cache=True)
def _arrays(m: float, iz: float, lf: float, lr: float, cf: float, cr: float, v: NDArray) -> tuple:
    n = v.size
    A = np.empty((n, 2, 2))
    B = np.empty((n, 2, 2))
    C = np.empty((n, 2, 2))
    D = np.empty((n, 2, 2))
    for k in range(n):
        single_track_row(m, iz, lf, lr, cf, cr, v[k], A[k], B[k], C[k], D[k])
    return A, B, C, D


def continuous_arrays(
    vehicle: Vehicle, speed: ArrayLike, v_min: float = V_MIN
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Vectorised :func:`continuous`: arrays A, B, C, D of shape (N, 2, 2) for N speeds."""
    v = np.ascontiguousarray(np.maximum(np.abs(np.asarray(speed, dtype=float)), v_min).ravel())
    A, B, C, D = _arrays(
        float(vehicle.mass), float(vehicle.yaw_inertia), float(vehicle.lf), float(vehicle.lr),
        float(vehicle.cf), float(vehicle.cr), v,
    )  # fmt: skip
    return A, B, C, D


def discretise(A: ArrayLike, B: ArrayLike, dt: float) -> tuple[FloatArray, FloatArray]:
    """Exact zero-order-hold discretisation: A_d = exp(A dt), B_d = int_0^dt exp(A s) ds B."""
    a = np.asarray(A, dtype=float)
    b = np.asarray(B, dtype=float)
    nx, nu = a.shape[0], b.shape[1]
    M = np.zeros((nx + nu, nx + nu))
    M[:nx, :nx] = a
    M[:nx, nx:] = b
    E = expm(M * dt)
    return E[:nx, :nx], E[:nx, nx:]


def van_loan(A: ArrayLike, Qc: ArrayLike, dt: float) -> tuple[FloatArray, FloatArray]:
    """Van Loan (1978): A_d and the exact discrete process noise Q_d = int exp(As) Qc exp(A's) ds.

    ``Qc`` is the continuous white-noise spectral density of x' = A x + w (already G Q G').
    """
    a = np.asarray(A, dtype=float)
    q = np.asarray(Qc, dtype=float)
    n = a.shape[0]
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -a
    M[:n, n:] = q
    M[n:, n:] = a.T
    E = expm(M * dt)
    Ad = E[n:, n:].T
    Qd = Ad @ E[:n, n:]
    return Ad, 0.5 * (Qd + Qd.T)


def yaw_rate_gain(vehicle: Vehicle, speed: float) -> float:
    """Steady-state r/delta = V / (L + K_us V^2), 1/s, with K_us from the tyres."""
    return speed / (vehicle.wheelbase + vehicle.understeer_gradient_tyres * speed**2)


def sideslip_gain(vehicle: Vehicle, speed: float) -> float:
    """Steady-state beta/delta = (lr - m lf V^2 / (L cr)) / (L + K_us V^2), rad/rad."""
    L = vehicle.wheelbase
    num = vehicle.lr - vehicle.mass * vehicle.lf * speed**2 / (L * vehicle.cr)
    return num / (L + vehicle.understeer_gradient_tyres * speed**2)


def steady_state(model: SingleTrack) -> FloatArray:
    """Steady-state state gain -A^{-1} B (2 x 2: rows beta, r; columns delta, bank)."""
    return np.asarray(-np.linalg.solve(model.A, model.B), dtype=float)
