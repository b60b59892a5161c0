"""Plain-numpy Kalman steps: the references the compiled kernels of
:mod:`sideslip.filters.kalman` are tested against, and the versions to use outside hot loops.

Plain functions in the GTSAM style: every call takes the state and covariance and returns new
ones.  Notation and equations: see :mod:`sideslip.filters.kalman`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import linalg

FloatArray = NDArray[np.float64]


def predict(
    x: ArrayLike,
    P: ArrayLike,
    F: ArrayLike,
    Q: ArrayLike,
    G: ArrayLike | None = None,
    u: ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Time update ``x- = F x + G u``, ``P- = F P F' + Q``; returns ``(x-, P-)``."""
    x = np.asarray(x, dtype=float)
    F = np.asarray(F, dtype=float)
    xp = F @ x
    if G is not None and u is not None:
        xp = xp + np.asarray(G, dtype=float) @ np.asarray(u, dtype=float)
    Pp = F @ np.asarray(P, dtype=float) @ F.T + np.asarray(Q, dtype=float)
    return xp, 0.5 * (Pp + Pp.T)


def update_joseph(
    x: ArrayLike, P: ArrayLike, z: ArrayLike, H: ArrayLike, R: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Measurement update in Joseph form; returns ``(x+, P+, innovation, S)``.

    ``z`` (m,), ``H`` (m, n), ``R`` (m, m).  The innovation ``z - H x`` is returned as computed
    (callers that measure angles wrap ``z`` beforehand, see :func:`update_scalar_nb`).
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    H = np.atleast_2d(np.asarray(H, dtype=float))
    R = np.atleast_2d(np.asarray(R, dtype=float))
    z = np.atleast_1d(np.asarray(z, dtype=float))
    innov = z - H @ x
    S = H @ P @ H.T + R
    K = linalg.solve(S, H @ P, assume_a="pos").T
    ikh = np.eye(x.size) - K @ H
    Pn = ikh @ P @ ikh.T + K @ R @ K.T
    return x + K @ innov, 0.5 * (Pn + Pn.T), innov, S


def update_robust_scalar(
    x: ArrayLike, P: ArrayLike, innov: float, h: ArrayLike, r: float,
    gate_nis: float = math.inf, huber_sigmas: float = math.inf, inflate_nis: float = math.inf,
) -> tuple[FloatArray, FloatArray, float, float, float]:  # fmt: skip
    """Reference of :func:`sideslip.filters.kalman.update_robust_scalar_ws_nb`:
    ``(x+, P+, S, nis, weight)``; the measurement variance used is ``r / weight``."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    h = np.asarray(h, dtype=float)
    s = float(h @ P @ h + r)
    if not s > 0.0:
        return x.copy(), P.copy(), s, math.nan, 0.0
    nis = innov * innov / s
    if nis > gate_nis:
        return x.copy(), P.copy(), s, nis, 0.0
    z = math.sqrt(nis)
    w = 1.0 if z <= huber_sigmas else huber_sigmas / z
    if nis > inflate_nis:
        w *= inflate_nis / nis
    xn, Pn, _, _ = update_joseph(x, P, [float(h @ x) + innov], h[None, :], [[r / w]])
    return xn, Pn, s, nis, w


def update_robust_pair(
    x: ArrayLike, P: ArrayLike, H: ArrayLike, innov: ArrayLike, r: float, inflate_nis: float
) -> tuple[FloatArray, FloatArray, float]:
    """Reference of :func:`sideslip.filters.kalman.update_robust_pair_ws_nb`: a two-row
    measurement with ``R = r I`` whose variance is scaled by ``d2 / inflate_nis`` where its
    Mahalanobis distance ``d2`` exceeds ``inflate_nis``; returns ``(x+, P+, d2)``."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    H = np.asarray(H, dtype=float)
    nu = np.asarray(innov, dtype=float)
    S = H @ P @ H.T + r * np.eye(2)
    d2 = float(nu @ np.linalg.solve(S, nu))
    rr = r if d2 <= inflate_nis else r * d2 / inflate_nis
    xn, Pn, _, _ = update_joseph(x, P, H @ x + nu, H, rr * np.eye(2))
    return xn, Pn, d2


def cholesky(A: ArrayLike) -> FloatArray:
    """Reference of :func:`sideslip.filters.kalman.cholesky_nb` (positive-definite A)."""
    return np.asarray(np.linalg.cholesky(np.asarray(A, dtype=float)), dtype=float)


def rts_smooth(
    x_post: ArrayLike, P_post: ArrayLike, x_prior: ArrayLike, P_prior: ArrayLike, F: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Rauch-Tung-Striebel fixed-interval smoother (Rauch, Tung & Striebel, AIAA J. 3(8),
    1965; Simon 2006, eqs 9.120-9.124), numpy reference.

    ``x_post`` (N, n), ``P_post`` (N, n, n): filtered estimates after each row's update;
    ``x_prior``/``P_prior``: the predictions of each row (row 0 unused); ``F`` (N, n, n): the
    transition from row k-1 to k (row 0 unused).  Backwards from the last row:

        C_k = P+_k F'_{k+1} (P-_{k+1})^-1
        x^s_k = x+_k + C_k (x^s_{k+1} - x-_{k+1}),  P^s_k = P+_k + C_k (P^s_{k+1} - P-_{k+1}) C_k'

    Returns ``(x_smoothed, P_smoothed)``.
    """
    xp = np.asarray(x_post, dtype=float)
    Pp = np.asarray(P_post, dtype=float)
    xm = np.asarray(x_prior, dtype=float)
    Pm = np.asarray(P_prior, dtype=float)
    Fa = np.asarray(F, dtype=float)
    xs = xp.copy()
    Ps = Pp.copy()
    for k in range(xp.shape[0] - 2, -1, -1):
        C = linalg.solve(Pm[k + 1], Fa[k + 1] @ Pp[k], assume_a="pos").T
        xs[k] = xp[k] + C @ (xs[k + 1] - xm[k + 1])
        Pk = Pp[k] + C @ (Ps[k + 1] - Pm[k + 1]) @ C.T
        Ps[k] = 0.5 * (Pk + Pk.T)
    return xs, Ps
