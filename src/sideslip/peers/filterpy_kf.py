"""Peer: FilterPy's ``KalmanFilter`` running the seed-001 MKF on the same data, for
cross-checks and the speed ratio of ``sideslip bench``.

The problem (discretised model table, inputs, measurements, prior) is assembled by
:func:`sideslip.methods.mkf.mkf_problem`, so only the recursion differs: FilterPy's
``predict(u, B, F, Q)`` and ``update(z, R, H)`` (Joseph form) per row, with the same order of
scalar updates as ours (standstill pseudo-measurement r = 0, gyro, GNSS course).  The course
innovation is wrapped to [-pi, pi) as ours by passing z = H x + wrap(nu - H x).

``run(drive, vehicle) -> beta`` (rad, N).  Needs the optional extra ``filterpy``: importing
this module raises ImportError without it (the benchmark then skips the peer).
"""

from __future__ import annotations

import numpy as np
from filterpy.kalman import KalmanFilter
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.methods.mkf import SIGMA_ZERO_RATE, MkfProblem, mkf_problem
from sideslip.vehicle import Vehicle

PEER_FOR = ("mkf",)
NAME = "filterpy"


def run_problem(prob: MkfProblem) -> NDArray[np.float64]:
    """States (N, 4) of FilterPy's KalmanFilter on an assembled MKF problem."""
    n = prob.u.shape[0]
    kf = KalmanFilter(dim_x=4, dim_z=1, dim_u=2)
    kf.x = prob.x0.reshape(4, 1).copy()
    kf.P = prob.P0.copy()
    h_r = np.array([[0.0, 1.0, 0.0, 0.0]])
    h_g = np.array([[0.0, 1.0, 0.0, 1.0]])
    r_zero = np.array([[SIGMA_ZERO_RATE**2]])
    out = np.empty((n, 4))
    for k in range(n):
        if k > 0:
            j = prob.idx[k]
            kf.predict(u=prob.u[k - 1].reshape(2, 1), B=prob.Bd[j], F=prob.Ad[j], Q=prob.Qd[j])
        if prob.zero_rate[k]:
            kf.update(np.array([[0.0]]), R=r_zero, H=h_r)
        g = prob.gyro[k]
        if np.isfinite(g):
            kf.update(np.array([[g]]), R=np.array([[prob.gyro_var[k]]]), H=h_g)
        c = prob.course[k]
        if np.isfinite(c):
            h_c = np.array([[1.0, prob.hr[k], 1.0, 0.0]])
            pred = float((h_c @ kf.x)[0, 0])
            z = pred + (c - pred + np.pi) % (2.0 * np.pi) - np.pi
            kf.update(np.array([[z]]), R=np.array([[prob.course_var[k]]]), H=h_c)
        out[k] = kf.x[:, 0]
    return out


def run(drive: Drive, vehicle: Vehicle) -> NDArray[np.float64]:
    """Sideslip beta (rad) of the seed-001 MKF run by FilterPy."""
    return run_problem(mkf_problem(drive, vehicle))[:, 0]
