"""Array layouts of the compiled truth model and its interpolation kernels.

Rows of the road matrix (``R_*``, sampled every ``ds`` m of arc length), of the time table
(``T_*``, on the output grid), the state vector (``X_*``), the derivative's auxiliary outputs
(``A_*``) and the output table (``O_*``) of :mod:`sideslip.simulate.vehicle_model`, and the
linear interpolation along those tables (compiled with numba).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from sideslip.simulate.driver import PathPlan, Plan
from sideslip.simulate.road import Road

FloatArray = NDArray[np.float64]

# road rows
R_E, R_N, R_H, R_K, R_B, R_G, R_MU, R_Z, R_DB, R_DG, R_V = range(11)
N_ROAD = 11
# time-table rows (on the output grid)
T_STEER, T_SPEED, T_NOISE = range(3)
@njit(cache=True)
def road_at(R: FloatArray, s: float, ds: float, out: FloatArray) -> None:
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
def row_at(R: FloatArray, row: int, s: float, ds: float) -> float:
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
def table_at(T: FloatArray, row: int, t: float, dtab: float) -> float:
    """A time table's row at time t (uniform step dtab): the same interpolation as row_at."""
    return row_at(T, row, t, dtab)


@njit(cache=True)
def project_on_path(R: FloatArray, ds: float, s_ref: float, e: float, n: float) -> float:
    """One Newton step of the projection of (e, n) on the path, from s_ref."""
    h = row_at(R, R_H, s_ref, ds)
    de = e - row_at(R, R_E, s_ref, ds)
    dn = n - row_at(R, R_N, s_ref, ds)
    s = s_ref + de * math.cos(h) + dn * math.sin(h)
    length = (R.shape[1] - 1) * ds
    if s < 0.0:
        s = 0.0
    elif s > length:
        s = length
    return s


@njit(cache=True)
def clip(v: float, lo: float, hi: float) -> float:
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v



def road_matrix(road: Road, plan: Plan) -> FloatArray:
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
