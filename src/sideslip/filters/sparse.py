"""Compiled Kalman kernels for filters with a sparse transition Jacobian and robust updates.

Used by the fused estimator's loop (per row of an hour-long drive, so nothing allocates):

* :func:`predict_sparse`  ``P- = F P F' + diag(q)`` using the non-zero columns of each row of
  ``F`` (``rows[i]`` lists them, -1 pads): O(n^2 w) instead of O(n^3) for ``w`` non-zeros a row.
* :func:`update_scalar_sym` one scalar measurement, ``P+ = P - (P h')(P h')' / S`` written
  symmetrically: algebraically the Joseph form ``(I - k h) P (I - k h)' + r k k'`` with
  ``k = P h' / S`` (expand it: the two cross terms and ``S k k'`` collapse to
  ``-P h' h P / S``), in O(n^2) where the product form :func:`sideslip.filters.kalman.
  update_scalar_nb` costs O(n^3); the filter loop re-symmetrises and floors the diagonal.
* :func:`robust_scalar`, :func:`robust_pair` Huber-type down-weighting (Huber 1964; Zhang,
  *Robust estimation*, 1997): where the normalised innovation squared ``d2`` exceeds ``gate``
  the measurement variance is multiplied by ``d2 / gate``, so one outlier of many sigma
  barely moves the state while a run of moderately surprising measurements still pulls it.
  They return the NIS before down-weighting (the consistency test's input).
* :func:`pack_upper` / :func:`unpack_upper` store a symmetric matrix's upper triangle in
  float32 (half the memory of float64, half again for the triangle): the RTS smoother's
  stored covariances.
* :func:`cholesky`, :func:`cho_solve_columns` a small dense Cholesky for the RTS gain.
* :func:`rts_step` one Rauch-Tung-Striebel backward step (Rauch, Tung, Striebel 1965;
  Simon, *Optimal State Estimation*, 2006, eq. 9.99): ``C = P F' P-^{-1}``,
  ``x_s = x + C (x_s,next - x-)``, ``P_s = P + C (P_s,next - P-) C'``.

Each kernel has a plain-numpy reference in the tests (``tests/filters/test_sparse.py``).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray


@numba.njit(cache=True)
def predict_sparse(P: NDArray, F: NDArray, rows: NDArray, q: NDArray, Pn: NDArray, tmp: NDArray) -> None:
    """``Pn = F P F' + diag(q)`` with ``F``'s non-zero columns per row in ``rows``."""
    n = P.shape[0]
    w = rows.shape[1]
    cnt = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        while c < w and rows[i, c] >= 0:
            c += 1
        cnt[i] = c
    for i in range(n):  # tmp = F P
        ci = cnt[i]
        if ci == 1:
            col = rows[i, 0]
            f = F[i, col]
            for j in range(n):
                tmp[i, j] = f * P[col, j]
            continue
        for j in range(n):
            acc = 0.0
            for m in range(ci):
                col = rows[i, m]
                acc += F[i, col] * P[col, j]
            tmp[i, j] = acc
    for j in range(n):  # Pn = tmp F' (symmetric: computed for i <= j, mirrored)
        cj = cnt[j]
        for i in range(j + 1):
            acc = 0.0
            for m in range(cj):
                col = rows[j, m]
                acc += tmp[i, col] * F[j, col]
            Pn[i, j] = acc
            Pn[j, i] = acc
    for i in range(n):
        Pn[i, i] += q[i]


@numba.njit(cache=True)
def update_scalar_sym(x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, ph: NDArray) -> float:
    """In place scalar update (module docstring); ``ph`` a work vector; returns S."""
    n = x.size
    for i in range(n):
        acc = 0.0
        for j in range(n):
            hj = h[j]
            if hj != 0.0:
                acc += P[i, j] * hj
        ph[i] = acc
    s = r
    for i in range(n):
        s += h[i] * ph[i]
    g = innov / s
    for i in range(n):
        x[i] += ph[i] * g
    for i in range(n):
        a = ph[i] / s
        for j in range(i, n):
            v = P[i, j] - a * ph[j]
            P[i, j] = v
            P[j, i] = v
    return s


@numba.njit(cache=True)
def innovation_variance(P: NDArray, h: NDArray, r: float) -> float:
    """``S = h P h' + r`` (sparse in h)."""
    n = h.size
    s = r
    for i in range(n):
        if h[i] != 0.0:
            acc = 0.0
            for j in range(n):
                acc += P[i, j] * h[j]
            s += h[i] * acc
    return s


@numba.njit(cache=True)
def robust_scalar(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, gate: float, ph: NDArray
) -> tuple[float, bool]:
    """Huber-type scalar update; returns (NIS before down-weighting, accepted unweighted)."""
    s = innovation_variance(P, h, r)
    d2 = innov * innov / s
    ok = d2 <= gate
    update_scalar_sym(x, P, innov, h, r if ok else r * d2 / gate, ph)
    return d2, ok


@numba.njit(cache=True)
def robust_pair(
    x: NDArray,
    P: NDArray,
    H: NDArray,
    y0: float,
    y1: float,
    r: float,
    gate: float,
    ph0: NDArray,
    ph1: NDArray,
    xb: NDArray,
) -> tuple[float, bool]:
    """Two-row update with ``R = r I`` (rows ``H[0]``, ``H[1]``), Huber-weighted on the 2x2
    Mahalanobis distance ``d2``; returns (d2, accepted unweighted)."""
    n = x.size
    for i in range(n):
        a = 0.0
        b = 0.0
        for j in range(n):
            a += P[i, j] * H[0, j]
            b += P[i, j] * H[1, j]
        ph0[i] = a
        ph1[i] = b
    s00 = r
    s01 = 0.0
    s11 = r
    for i in range(n):
        s00 += H[0, i] * ph0[i]
        s01 += H[0, i] * ph1[i]
        s11 += H[1, i] * ph1[i]
    det = s00 * s11 - s01 * s01
    d2 = (s11 * y0 * y0 - 2.0 * s01 * y0 * y1 + s00 * y1 * y1) / det
    ok = d2 <= gate
    rr = r if ok else r * d2 / gate
    for i in range(n):
        xb[i] = x[i]
    update_scalar_sym(x, P, y0, H[0], rr, ph0)
    dy = 0.0
    for i in range(n):
        dy += H[1, i] * (x[i] - xb[i])
    update_scalar_sym(x, P, y1 - dy, H[1], rr, ph0)
    return d2, ok


@numba.njit(cache=True)
def pack_upper(P: NDArray, out: NDArray) -> None:
    """Upper triangle of the symmetric ``P`` (row by row) into ``out`` (float32 or 64)."""
    n = P.shape[0]
    k = 0
    for i in range(n):
        for j in range(i, n):
            out[k] = P[i, j]
            k += 1


@numba.njit(cache=True)
def unpack_upper(packed: NDArray, P: NDArray) -> None:
    """Inverse of :func:`pack_upper` (float64 ``P``, both triangles)."""
    n = P.shape[0]
    k = 0
    for i in range(n):
        for j in range(i, n):
            v = float(packed[k])
            P[i, j] = v
            P[j, i] = v
            k += 1


@numba.njit(cache=True)
def cholesky(A: NDArray, L: NDArray) -> None:
    """Lower Cholesky factor of the SPD ``A`` into ``L`` (pivots floored at 1e-300)."""
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
def cho_solve_columns(L: NDArray, B: NDArray) -> None:
    """Solve ``(L L') X = B`` in place of ``B`` (every column)."""
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
def rts_step(
    x: NDArray,
    P: NDArray,
    xn: NDArray,
    Pn: NDArray,
    F: NDArray,
    rows: NDArray,
    xs_next: NDArray,
    Ps_next: NDArray,
    L: NDArray,
    B: NDArray,
    D: NDArray,
    tmp: NDArray,
) -> None:
    """One RTS step in place of ``x``, ``P`` (filtered at k -> smoothed at k).

    ``xn``, ``Pn``: the prediction from (x, P) to k+1 with Jacobian ``F`` (sparse ``rows``);
    ``xs_next``, ``Ps_next``: the smoothed state at k+1.  ``L``, ``B``, ``D``, ``tmp`` work.
    """
    n = x.size
    w = rows.shape[1]
    cholesky(Pn, L)
    for i in range(n):  # B = F P
        for j in range(n):
            acc = 0.0
            for m in range(w):
                col = rows[i, m]
                if col < 0:
                    break
                acc += F[i, col] * P[col, j]
            B[i, j] = acc
    cho_solve_columns(L, B)  # B <- Pn^-1 F P = C'
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += B[j, i] * (xs_next[j] - xn[j])
        x[i] += acc
    for i in range(n):
        for j in range(n):
            D[i, j] = Ps_next[i, j] - Pn[i, j]
    for i in range(n):  # tmp = C D
        for j in range(n):
            acc = 0.0
            for m in range(n):
                acc += B[m, i] * D[m, j]
            tmp[i, j] = acc
    for i in range(n):  # P += tmp C'
        for j in range(i, n):
            acc = 0.0
            for m in range(n):
                acc += tmp[i, m] * B[m, j]
            v = P[i, j] + acc
            P[i, j] = v
            P[j, i] = v
