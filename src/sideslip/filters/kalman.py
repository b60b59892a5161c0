"""The package's compiled Kalman kernels: the only Kalman numerics the filters in ``methods/`` run.

Every kernel works in place on caller-owned arrays, so a loop over an hour-long drive allocates
nothing; the allocating forms (``predict_nb``, ``update_scalar_nb``, ``cholesky_nb``,
``update_robust_scalar_nb``, ``rts_smooth_nb``) wrap them for code outside hot loops.  Each
kernel has a plain-numpy reference in :mod:`sideslip.filters.reference` and a test that they
agree (``tests/filters/test_kalman.py``); NIS, steady state and the residual whiteness tests
are in :mod:`sideslip.filters.diagnostics`.

Notation (Simon, *Optimal State Estimation*, 2006, ch. 5 and 9; seed 001 eqs 2-3):

    time update         x- = F x+ + G u,          P- = F P+ F' + Q
    measurement update  S = H P- H' + R,  K = P- H' S^-1,  x+ = x- + K (z - H x-)
                        P+ = (I - K H) P- (I - K H)' + K R K'      (Joseph form)
    NIS                 nu' S^-1 nu ~ chi2(m) for a consistent filter
    RTS (backward)      C = P+ F' (P-_next)^-1,  x_s = x+ + C (x_s,next - x-_next),
                        P_s = P+ + C (P_s,next - P-_next) C'   (Rauch, Tung, Striebel 1965)

Kernels:

* predict: :func:`predict_ws_nb` (dense F), :func:`predict_rows_ws_nb` (the Jacobian of a
  nonlinear model with few non-zeros per row, listed in ``rows``: O(n^2 w) for w non-zeros a
  row instead of O(n^3)), :func:`predict_sparse_nb` (the same, finding the non-zeros itself);
* update: :func:`update_scalar_ws_nb` (Joseph form, one scalar), :func:`update_vector_nb` (any
  SPD R, whitened and processed as scalars), :func:`update_robust_scalar_ws_nb` (chi-square
  gate, Huber weight and NIS-proportional variance inflation) and
  :func:`update_robust_pair_ws_nb` (a two-row measurement, e.g. a GNSS fix, weighted on its
  2-D Mahalanobis distance);
* smoother: :func:`rts_step_ws_nb` (one backward step, sparse F) = :func:`rts_gain_ws_nb`
  (from the forward pass alone) + :func:`rts_update_ws_nb` (the recursion), :func:`rts_smooth_nb`;
* linear algebra and storage: :func:`cholesky_ws_nb`, :func:`cho_solve_rows_ws_nb`,
  :func:`pack_upper_nb` / :func:`unpack_upper_nb` (a symmetric matrix's upper triangle, e.g. in
  float32: a quarter of the memory of the full float64 matrix).

Each O(n^2) or O(n^3) kernel is a thin dispatcher over an inlined body ``_<kernel>_n`` that takes
the size as an argument: for the sizes in :data:`NX_UNROLLED` it passes a literal, so the
compiler unrolls and vectorises the fixed-length loops (the same operations in the same order,
so results are bit-identical to the general loop; measured 30-40 % faster on the RTS step).

The Joseph form keeps P symmetric positive semi-definite under round-off, which matters when a
filter runs for an hour at 100 Hz.  Scratch space: :func:`workspace` gives a buffer every
update and predict kernel accepts; :func:`rts_workspace` the smoother's.  The kernels are
compiled without ``fastmath``: with re-association or FMA contraction allowed, a kernel
inlined into a freshly compiled caller and the same kernel loaded from numba's cache round
differently, so two processes could give results differing in the last bit (measured: no
speed gain from the flags on these 15-state kernels).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from sideslip.filters.diagnostics import (  # noqa: F401  (the names methods import from here)
    normalised_innovations,
    steady_state,
    whiteness,
)

# State sizes for which every O(n^2)/O(n^3) kernel is compiled with ``n`` as a literal, so
# LLVM unrolls and vectorises its fixed-length loops (the fused estimator's 15 and 18 states):
# the same arithmetic in the same order, 30-40 % faster.  Other sizes take the general loop.
NX_UNROLLED = (15, 18)


def workspace(n: int) -> NDArray:
    """A scratch buffer of shape (n + 5, n) that every predict/update kernel here accepts."""
    return np.zeros((n + 5, n))


def rts_workspace(n: int) -> NDArray:
    """Scratch space of :func:`rts_step_ws_nb`: three (n, n) matrices."""
    return np.zeros((3, n, n))


# ------------------------------------------------------------------------------------------
# predict
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def predict_ws_nb(
    x: NDArray, P: NDArray, F: NDArray, Q: NDArray, Gu: NDArray, work: NDArray
) -> None:
    """In place ``x <- F x + Gu``, ``P <- F P F' + Q`` (``Gu`` the already-multiplied input);
    ``work`` at least (n + 2, n) (:func:`workspace`)."""
    n = x.size
    for i in range(n):
        acc = Gu[i]
        for j in range(n):
            acc += F[i, j] * x[j]
        work[0, i] = acc
        for j in range(n):
            work[2 + i, j] = 0.0
        for k in range(n):
            f = F[i, k]
            if f != 0.0:
                for j in range(n):
                    work[2 + i, j] += f * P[k, j]
    for i in range(n):
        x[i] = work[0, i]
        for j in range(i, n):
            acc = Q[i, j]
            for k in range(n):
                acc += work[2 + i, k] * F[j, k]
            P[i, j] = acc
    for i in range(n):
        for j in range(i):
            P[i, j] = P[j, i]


@numba.njit(cache=True)
def predict_nb(x: NDArray, P: NDArray, F: NDArray, Q: NDArray, Gu: NDArray) -> None:
    """Allocating form of :func:`predict_ws_nb`."""
    predict_ws_nb(x, P, F, Q, Gu, np.zeros((x.size + 2, x.size)))


@numba.njit(cache=True)
def nonzero_columns_nb(F: NDArray, rows: NDArray) -> None:
    """``rows[i]`` <- the columns of F's non-zeros in row i, padded with -1 (``rows`` (n, n))."""
    n = F.shape[0]
    for i in range(n):
        c = 0
        for j in range(n):
            if F[i, j] != 0.0:
                rows[i, c] = j
                c += 1
        for j in range(c, rows.shape[1]):
            rows[i, j] = -1


@numba.njit(inline="always")
def _sparse_times_ws_nb_n(F: NDArray, rows: NDArray, P: NDArray, out: NDArray, n: int) -> None:
    """:func:`sparse_times_ws_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    w = rows.shape[1]
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.0
        for m in range(w):
            col = rows[i, m]
            if col < 0:
                break
            f = F[i, col]
            for j in range(n):
                out[i, j] += f * P[col, j]


@numba.njit(cache=True)
def sparse_times_ws_nb(F: NDArray, rows: NDArray, P: NDArray, out: NDArray) -> None:
    """``out = F P`` using only the non-zero columns of each row of F (``rows[i]`` lists
    them, -1 pads)."""
    n = P.shape[0]
    if n == NX_UNROLLED[0]:
        _sparse_times_ws_nb_n(F, rows, P, out, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _sparse_times_ws_nb_n(F, rows, P, out, NX_UNROLLED[1])
    else:
        _sparse_times_ws_nb_n(F, rows, P, out, n)


@numba.njit(inline="always")
def _predict_rows_ws_nb_n(
    P: NDArray, F: NDArray, rows: NDArray, q: NDArray, Pn: NDArray, tmp: NDArray, n: int
) -> None:
    """:func:`predict_rows_ws_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    w = rows.shape[1]
    sparse_times_ws_nb(F, rows, P, tmp)  # tmp = F P
    for j in range(n):  # Pn = tmp F' (symmetric: computed for i <= j, mirrored)
        for i in range(j + 1):
            acc = 0.0
            for m in range(w):
                col = rows[j, m]
                if col < 0:
                    break
                acc += tmp[i, col] * F[j, col]
            Pn[i, j] = acc
            Pn[j, i] = acc
    for i in range(n):
        Pn[i, i] += q[i]


@numba.njit(cache=True)
def predict_rows_ws_nb(
    P: NDArray, F: NDArray, rows: NDArray, q: NDArray, Pn: NDArray, tmp: NDArray
) -> None:
    """``Pn = F P F' + diag(q)`` using only the non-zero columns of each row of F (``rows[i]``
    lists them, -1 pads); ``tmp`` (n, n) scratch.  The caller sets ``x- = f(x, u, dt)``."""
    n = P.shape[0]
    if n == NX_UNROLLED[0]:
        _predict_rows_ws_nb_n(P, F, rows, q, Pn, tmp, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _predict_rows_ws_nb_n(P, F, rows, q, Pn, tmp, NX_UNROLLED[1])
    else:
        _predict_rows_ws_nb_n(P, F, rows, q, Pn, tmp, n)


@numba.njit(cache=True)
def predict_sparse_nb(x: NDArray, P: NDArray, x_next: NDArray, F: NDArray, Q: NDArray) -> None:
    """In place ``x <- x_next``, ``P <- F P F' + Q`` for a Jacobian with few non-zeros a row
    (a nonlinear model's: ``x_next = f(x, u, dt)`` computed by the model); finds the non-zeros
    and runs :func:`predict_rows_ws_nb`."""
    n = x.size
    rows = np.empty((n, n), dtype=np.int64)
    nonzero_columns_nb(F, rows)
    Pn = np.empty((n, n))
    predict_rows_ws_nb(P, F, rows, np.zeros(n), Pn, np.empty((n, n)))
    for i in range(n):
        x[i] = x_next[i]
        for j in range(i, n):
            v = Pn[i, j] + 0.5 * (Q[i, j] + Q[j, i])
            P[i, j] = v
            P[j, i] = v


# ------------------------------------------------------------------------------------------
# measurement updates
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def update_scalar_ws_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, work: NDArray
) -> float:
    """In place Joseph-form update with one scalar measurement; returns S = h P h' + r.

    ``innov`` is ``z - h x`` computed by the caller (so that angle measurements can be wrapped
    to [-pi, pi) first).  The covariance is the Joseph product (I - k h) P (I - k h)' + r k k'
    with k = P h' / S, which for a symmetric P expands to P - k (Ph)' - (Ph) k' + S k k' for
    any gain k (Simon 2006, eq 5.19); it is evaluated elementwise on the upper triangle and
    mirrored, so P stays exactly symmetric, in O(n^2), skipping the zero entries of ``h``.
    ``work`` (at least 2 rows of n) holds P h' and the gain.  A non-positive S (no
    information, or a broken prior) leaves x and P unchanged.
    """
    s = cross_covariance_nb(P, h, r, work)
    if not s > 0.0:
        return s
    for i in range(x.size):
        work[1, i] = work[0, i] / s
        x[i] += work[1, i] * innov
    joseph_rank1_nb(P, work, s)
    return s


@numba.njit(inline="always")
def _cross_covariance_nb_n(P: NDArray, h: NDArray, r: float, work: NDArray, n: int) -> float:
    """:func:`cross_covariance_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    for i in range(n):
        work[0, i] = 0.0
    for j in range(n):
        hj = h[j]
        if hj != 0.0:
            for i in range(n):
                work[0, i] += P[j, i] * hj  # P symmetric: row j = column j
    s = r
    for i in range(n):
        s += h[i] * work[0, i]
    return s


@numba.njit(cache=True)
def cross_covariance_nb(P: NDArray, h: NDArray, r: float, work: NDArray) -> float:
    """``work[0] = P h'`` (skipping the zero entries of ``h``); returns S = h P h' + r."""
    n = P.shape[0]
    if n == NX_UNROLLED[0]:
        return _cross_covariance_nb_n(P, h, r, work, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        return _cross_covariance_nb_n(P, h, r, work, NX_UNROLLED[1])
    return _cross_covariance_nb_n(P, h, r, work, n)


@numba.njit(inline="always")
def _joseph_rank1_nb_n(P: NDArray, work: NDArray, s: float, n: int) -> None:
    """:func:`joseph_rank1_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    for i in range(n):
        ki, phi = work[1, i], work[0, i]
        for j in range(i, n):
            m = P[i, j] - ki * work[0, j] - phi * work[1, j] + s * ki * work[1, j]
            P[i, j] = m
            P[j, i] = m


@numba.njit(cache=True)
def joseph_rank1_nb(P: NDArray, work: NDArray, s: float) -> None:
    """The Joseph covariance of a scalar update with any gain ``k = work[1]`` (``work[0]`` =
    P h', ``s`` = S): ``P - k (Ph)' - (Ph) k' + S k k'`` (Simon 2006, eq 5.19), on the upper
    triangle and mirrored, in place."""
    n = P.shape[0]
    if n == NX_UNROLLED[0]:
        _joseph_rank1_nb_n(P, work, s, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _joseph_rank1_nb_n(P, work, s, NX_UNROLLED[1])
    else:
        _joseph_rank1_nb_n(P, work, s, n)


@numba.njit(cache=True)
def update_scalar_nb(x: NDArray, P: NDArray, innov: float, h: NDArray, r: float) -> float:
    """Allocating form of :func:`update_scalar_ws_nb`."""
    return update_scalar_ws_nb(x, P, innov, h, r, np.zeros((2, x.size)))


@numba.njit(inline="always")
def _innovation_variance_nb_n(P: NDArray, h: NDArray, r: float, n: int) -> float:
    """:func:`innovation_variance_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    s = r
    for i in range(n):
        if h[i] != 0.0:
            acc = 0.0
            for j in range(n):
                acc += P[i, j] * h[j]
            s += h[i] * acc
    return s


@numba.njit(cache=True)
def innovation_variance_nb(P: NDArray, h: NDArray, r: float) -> float:
    """``S = h P h' + r``, skipping the zero entries of ``h``."""
    n = h.size
    if n == NX_UNROLLED[0]:
        return _innovation_variance_nb_n(P, h, r, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        return _innovation_variance_nb_n(P, h, r, NX_UNROLLED[1])
    return _innovation_variance_nb_n(P, h, r, n)


@numba.njit(cache=True)
def huber_weight_nb(nis: float, threshold: float) -> float:
    """Huber weight of a scalar residual with normalised size ``sqrt(nis)``: 1 inside
    ``threshold`` (in sigmas), ``threshold / |z|`` beyond it (Huber 1964; Zoubir et al.,
    *Robust Estimation in Signal Processing*, IEEE SPM 2012, eq 23)."""
    z = math.sqrt(max(nis, 0.0))
    if z <= threshold:
        return 1.0
    return threshold / z


@numba.njit(cache=True)
def robust_weight_nb(nis: float, huber_sigmas: float, inflate_nis: float) -> float:
    """Weight of a measurement of normalised innovation squared ``nis``: the Huber weight
    (:func:`huber_weight_nb`) times ``inflate_nis / nis`` where ``nis > inflate_nis``.

    The second factor scales the measurement variance by ``nis / inflate_nis`` (Zhang, *Image
    Vis. Comput.* 15, 1997, sec. 3: an inverse-square IRLS weight): one outlier of many sigma
    barely moves the state while a run of moderately surprising measurements still pulls it.
    ``inf`` for either threshold switches that factor off."""
    w = huber_weight_nb(nis, huber_sigmas)
    if nis > inflate_nis:
        w *= inflate_nis / nis
    return w


@numba.njit(cache=True)
def update_robust_scalar_ws_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, gate_nis: float,
    huber_sigmas: float, inflate_nis: float, work: NDArray,
) -> tuple[float, float, float]:  # fmt: skip
    """Gated, robustly weighted scalar update; returns ``(S, nis, weight)``.

    ``nis = innov^2 / S`` with S the prior innovation variance.  A measurement with
    ``nis > gate_nis`` is rejected (weight 0, x and P unchanged).  Otherwise its variance is
    ``r / w`` with ``w`` from :func:`robust_weight_nb`: one iteration of the iteratively
    reweighted Kalman update (Karlgaard & Schaub, J. Guid. Control Dyn. 30(6), 2007, sec. III).
    """
    s = innovation_variance_nb(P, h, r)
    if not s > 0.0:
        return s, math.nan, 0.0
    nis = innov * innov / s
    if nis > gate_nis:
        return s, nis, 0.0
    w = robust_weight_nb(nis, huber_sigmas, inflate_nis)
    update_scalar_ws_nb(x, P, innov, h, r / w, work)
    return s, nis, w


@numba.njit(cache=True)
def update_robust_scalar_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, gate_nis: float,
    huber_sigmas: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Allocating form of :func:`update_robust_scalar_ws_nb` without variance inflation."""
    return update_robust_scalar_ws_nb(
        x, P, innov, h, r, gate_nis, huber_sigmas, math.inf, np.zeros((2, x.size))
    )


@numba.njit(inline="always")
def _update_robust_pair_ws_nb_n(
    x: NDArray, P: NDArray, H: NDArray, y0: float, y1: float, r: float, inflate_nis: float,
    work: NDArray, n: int,
) -> float:  # fmt: skip
    """:func:`update_robust_pair_ws_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    for i in range(n):
        a = 0.0
        b = 0.0
        for j in range(n):
            a += P[i, j] * H[0, j]
            b += P[i, j] * H[1, j]
        work[2, i] = a
        work[3, i] = b
    s00 = r
    s01 = 0.0
    s11 = r
    for i in range(n):
        s00 += H[0, i] * work[2, i]
        s01 += H[0, i] * work[3, i]
        s11 += H[1, i] * work[3, i]
    det = s00 * s11 - s01 * s01
    if not det > 0.0:
        return math.nan
    d2 = (s11 * y0 * y0 - 2.0 * s01 * y0 * y1 + s00 * y1 * y1) / det
    rr = r if d2 <= inflate_nis else r * d2 / inflate_nis
    for i in range(n):
        work[4, i] = x[i]
    update_scalar_ws_nb(x, P, y0, H[0], rr, work)
    dy = 0.0
    for i in range(n):
        dy += H[1, i] * (x[i] - work[4, i])
    update_scalar_ws_nb(x, P, y1 - dy, H[1], rr, work)
    return d2


@numba.njit(cache=True)
def update_robust_pair_ws_nb(
    x: NDArray, P: NDArray, H: NDArray, y0: float, y1: float, r: float, inflate_nis: float,
    work: NDArray,
) -> float:  # fmt: skip
    """Two-row update (rows ``H[0]``, ``H[1]``, innovations ``y0``, ``y1``, ``R = r I``) whose
    variance is scaled by ``d2 / inflate_nis`` where the 2-D Mahalanobis distance ``d2`` of the
    innovation exceeds ``inflate_nis`` (:func:`robust_weight_nb`'s second factor); returns
    ``d2``.  Processed as two sequential Joseph scalar updates (R diagonal: the batch update).
    ``work`` at least (5, n) (:func:`workspace`)."""
    n = x.size
    if n == NX_UNROLLED[0]:
        return _update_robust_pair_ws_nb_n(x, P, H, y0, y1, r, inflate_nis, work, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        return _update_robust_pair_ws_nb_n(x, P, H, y0, y1, r, inflate_nis, work, NX_UNROLLED[1])
    return _update_robust_pair_ws_nb_n(x, P, H, y0, y1, r, inflate_nis, work, n)


@numba.njit(cache=True)
def update_vector_nb(x: NDArray, P: NDArray, innov: NDArray, H: NDArray, R: NDArray) -> NDArray:
    """In place Joseph-form update with a vector measurement of any (SPD) noise ``R``
    (m, m); returns the prior innovation covariance S = H P H' + R (m, m).

    The measurement is whitened by the Cholesky factor of R (z' = L^-1 z, H' = L^-1 H,
    R' = I), which makes its components independent, then processed as m sequential scalar
    updates: algebraically the batch update, without inverting S.
    """
    m = innov.size
    S = H @ P @ H.T + R
    L = cholesky_nb(R)
    Hw = np.empty_like(H)
    zw = np.empty(m)
    for i in range(m):  # forward substitution L [zw Hw] = [innov H]
        acc = innov[i]
        row = H[i].copy()
        for j in range(i):
            acc -= L[i, j] * zw[j]
            row -= L[i, j] * Hw[j]
        zw[i] = acc / L[i, i]
        Hw[i] = row / L[i, i]
    x0 = x.copy()
    work = np.zeros((2, x.size))
    for i in range(m):
        # innovation of component i after the earlier ones: z_w,i - Hw_i (x - x_start)
        nu = zw[i]
        for c in range(x.size):
            nu -= Hw[i, c] * (x[c] - x0[c])
        update_scalar_ws_nb(x, P, nu, np.ascontiguousarray(Hw[i]), 1.0, work)
    return S


# ------------------------------------------------------------------------------------------
# linear algebra, storage
# ------------------------------------------------------------------------------------------
@numba.njit(inline="always")
def _cholesky_ws_nb_n(A: NDArray, L: NDArray, n: int) -> None:
    """:func:`cholesky_ws_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    for i in range(n):
        for j in range(n):
            L[i, j] = 0.0
    for i in range(n):
        for j in range(i + 1):
            acc = A[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = math.sqrt(acc) if acc > 0.0 else 0.0
            elif L[j, j] > 0.0:
                L[i, j] = acc / L[j, j]


@numba.njit(cache=True)
def cholesky_ws_nb(A: NDArray, L: NDArray) -> None:
    """Lower-triangular ``L`` with L L' = A for a small symmetric positive-definite A
    (Cholesky-Banachiewicz), in place of ``L``.  A non-positive pivot (A not positive
    definite) is set to 0 with its column, so a semi-definite A gives a valid factor of its
    positive part."""
    n = A.shape[0]
    if n == NX_UNROLLED[0]:
        _cholesky_ws_nb_n(A, L, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _cholesky_ws_nb_n(A, L, NX_UNROLLED[1])
    else:
        _cholesky_ws_nb_n(A, L, n)


@numba.njit(cache=True)
def cholesky_nb(A: NDArray) -> NDArray:
    """Allocating form of :func:`cholesky_ws_nb`."""
    L = np.zeros_like(A)
    cholesky_ws_nb(A, L)
    return L


@numba.njit(inline="always")
def _cho_solve_rows_ws_nb_n(L: NDArray, B: NDArray, n: int, m: int) -> None:
    """:func:`cho_solve_rows_ws_nb` for ``n`` states and ``m`` columns."""
    for i in range(n):  # L Y = B
        for k in range(i):
            f = L[i, k]
            if f != 0.0:
                for c in range(m):
                    B[i, c] -= f * B[k, c]
        d = L[i, i]
        inv = 1.0 / d if d > 0.0 else 0.0
        for c in range(m):
            B[i, c] *= inv
    for i in range(n - 1, -1, -1):  # L' X = Y
        for k in range(i + 1, n):
            f = L[k, i]
            if f != 0.0:
                for c in range(m):
                    B[i, c] -= f * B[k, c]
        d = L[i, i]
        inv = 1.0 / d if d > 0.0 else 0.0
        for c in range(m):
            B[i, c] *= inv


@numba.njit(cache=True)
def cho_solve_rows_ws_nb(L: NDArray, B: NDArray) -> None:
    """Solve ``(L L') X = B`` for every column of ``B`` at once, in place of ``B``; a zero
    pivot (semi-definite factor) gives a zero row.  Row-oriented: the inner loops run along
    B's contiguous rows."""
    n = L.shape[0]
    m = B.shape[1]
    if n == m == NX_UNROLLED[0]:
        _cho_solve_rows_ws_nb_n(L, B, NX_UNROLLED[0], NX_UNROLLED[0])
    elif n == m == NX_UNROLLED[1]:
        _cho_solve_rows_ws_nb_n(L, B, NX_UNROLLED[1], NX_UNROLLED[1])
    else:
        _cho_solve_rows_ws_nb_n(L, B, n, m)


@numba.njit(inline="always")
def _pack_upper_nb_n(P: NDArray, out: NDArray, n: int) -> None:
    """:func:`pack_upper_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    k = 0
    for i in range(n):
        for j in range(i, n):
            out[k] = P[i, j]
            k += 1


@numba.njit(cache=True)
def pack_upper_nb(P: NDArray, out: NDArray) -> None:
    """Upper triangle of the symmetric ``P`` (row by row) into ``out`` (float32 or 64)."""
    n = P.shape[0]
    if n == NX_UNROLLED[0]:
        _pack_upper_nb_n(P, out, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _pack_upper_nb_n(P, out, NX_UNROLLED[1])
    else:
        _pack_upper_nb_n(P, out, n)


@numba.njit(inline="always")
def _unpack_upper_nb_n(packed: NDArray, P: NDArray, n: int) -> None:
    """:func:`unpack_upper_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    k = 0
    for i in range(n):
        for j in range(i, n):
            v = float(packed[k])
            P[i, j] = v
            P[j, i] = v
            k += 1


@numba.njit(cache=True)
def unpack_upper_nb(packed: NDArray, P: NDArray) -> None:
    """Inverse of :func:`pack_upper_nb` (float64 ``P``, both triangles)."""
    n = P.shape[0]
    if n == NX_UNROLLED[0]:
        _unpack_upper_nb_n(packed, P, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _unpack_upper_nb_n(packed, P, NX_UNROLLED[1])
    else:
        _unpack_upper_nb_n(packed, P, n)


# ------------------------------------------------------------------------------------------
# Rauch-Tung-Striebel smoother
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def rts_gain_ws_nb(P: NDArray, Pn: NDArray, F: NDArray, rows: NDArray, B: NDArray, L: NDArray) -> None:
    """The transposed RTS gain ``B = C' = Pn^-1 F P`` of the step from the filtered ``P`` at k
    to its prediction ``Pn`` at k+1 (Jacobian ``F``, non-zero columns per row in ``rows`` as
    :func:`predict_rows_ws_nb`), from the Cholesky factor of Pn (``L`` scratch; no inverse).
    It depends on the forward pass only, so a smoother may compute it ahead of the backward
    recursion (:func:`rts_update_ws_nb`)."""
    cholesky_ws_nb(Pn, L)
    sparse_times_ws_nb(F, rows, P, B)  # B = F P
    cho_solve_rows_ws_nb(L, B)


@numba.njit(inline="always")
def _rts_update_ws_nb_n(
    x: NDArray, P: NDArray, xn: NDArray, Pn: NDArray, B: NDArray, xs_next: NDArray,
    Ps_next: NDArray, T: NDArray, n: int,
) -> None:  # fmt: skip
    """:func:`rts_update_ws_nb` for ``n`` states (unrolled where ``n`` is a literal)."""
    for m in range(n):  # x += C dx = B' dx
        d = xs_next[m] - xn[m]
        for i in range(n):
            x[i] += B[m, i] * d
    for i in range(n):  # T = D B with D = Ps_next - Pn (symmetric)
        for j in range(n):
            T[i, j] = 0.0
        for m in range(n):
            d = Ps_next[i, m] - Pn[i, m]
            for j in range(n):
                T[i, j] += d * B[m, j]
    for m in range(n):  # P += B' T = C D C' (upper triangle)
        for i in range(n):
            b = B[m, i]
            for j in range(i, n):
                P[i, j] += b * T[m, j]
    for i in range(n):
        for j in range(i):
            P[i, j] = P[j, i]


@numba.njit(cache=True)
def rts_update_ws_nb(
    x: NDArray, P: NDArray, xn: NDArray, Pn: NDArray, B: NDArray, xs_next: NDArray,
    Ps_next: NDArray, T: NDArray,
) -> None:  # fmt: skip
    """The RTS recursion with the gain ``B = C'`` of :func:`rts_gain_ws_nb`, in place of the
    filtered ``x``, ``P`` at k: ``x += C (xs_next - xn)``, ``P += C (Ps_next - Pn) C'`` (upper
    triangle, mirrored); ``T`` (n, n) scratch."""
    n = x.size
    if n == NX_UNROLLED[0]:
        _rts_update_ws_nb_n(x, P, xn, Pn, B, xs_next, Ps_next, T, NX_UNROLLED[0])
    elif n == NX_UNROLLED[1]:
        _rts_update_ws_nb_n(x, P, xn, Pn, B, xs_next, Ps_next, T, NX_UNROLLED[1])
    else:
        _rts_update_ws_nb_n(x, P, xn, Pn, B, xs_next, Ps_next, T, n)


@numba.njit(cache=True)
def rts_step_ws_nb(
    x: NDArray,
    P: NDArray,
    xn: NDArray,
    Pn: NDArray,
    F: NDArray,
    rows: NDArray,
    xs_next: NDArray,
    Ps_next: NDArray,
    work: NDArray,
) -> None:
    """One RTS step in place of ``x``, ``P`` (filtered at k -> smoothed at k).

    ``xn``, ``Pn``: the prediction from (x, P) to k+1 with Jacobian ``F`` (non-zero columns
    per row in ``rows``, as :func:`predict_rows_ws_nb`); ``xs_next``, ``Ps_next``: the smoothed
    state at k+1; ``work`` (3, n, n) (:func:`rts_workspace`).  :func:`rts_gain_ws_nb` then
    :func:`rts_update_ws_nb`.
    """
    rts_gain_ws_nb(P, Pn, F, rows, work[1], work[0])
    rts_update_ws_nb(x, P, xn, Pn, work[1], xs_next, Ps_next, work[2])


@numba.njit(cache=True)
def rts_smooth_nb(
    x_post: NDArray, P_post: NDArray, x_prior: NDArray, P_prior: NDArray, F: NDArray
) -> tuple[NDArray, NDArray]:
    """Rauch-Tung-Striebel fixed-interval smoother over stored filter output (see
    :func:`sideslip.filters.reference.rts_smooth` for the arrays): :func:`rts_step_ws_nb`
    backwards from the last row with a dense F."""
    N, n = x_post.shape
    xs = x_post.copy()
    Ps = P_post.copy()
    rows = np.empty((n, n), dtype=np.int64)
    for i in range(n):
        for j in range(n):
            rows[i, j] = j
    work = np.zeros((3, n, n))
    for k in range(N - 2, -1, -1):
        Pk = np.ascontiguousarray(P_post[k]).copy()
        xk = x_post[k].copy()
        rts_step_ws_nb(
            xk, Pk, x_prior[k + 1], P_prior[k + 1], np.ascontiguousarray(F[k + 1]), rows,
            xs[k + 1], Ps[k + 1], work,
        )  # fmt: skip
        xs[k] = xk
        Ps[k] = Pk
    return xs, Ps
