"""Generic, stateless linear Kalman-filter numerics: the only Kalman code of the package.

Plain functions in the GTSAM style: every call takes the state and covariance and returns new
ones; nothing is configured by assigning attributes.  Two flavours of the same equations:

* numpy functions (:func:`predict`, :func:`update_joseph`, :func:`update_robust_scalar`,
  :func:`nis`, :func:`rts_smooth`, :func:`cholesky`) for any dimension, used outside hot loops
  and as the references the compiled kernels are tested against;
* numba kernels for recursive loops over a drive, in place: :func:`predict_nb` (dense F),
  :func:`predict_sparse_nb` (the Jacobian of a nonlinear model, mostly identity),
  :func:`update_scalar_nb` (Joseph form), :func:`update_vector_nb` (any SPD R, whitened and
  processed as scalar updates -- algebraically the batch update, no matrix inversion),
  :func:`update_robust_scalar_nb` (chi-square gate + Huber weight, returns the weight),
  :func:`cholesky_nb` and :func:`rts_smooth_nb`; :func:`predict_ws_nb` and
  :func:`update_scalar_ws_nb` are the same steps with caller-owned scratch space, so a loop
  over a drive allocates nothing.

Notation (Simon, *Optimal State Estimation*, 2006, ch. 5 and 9; seed 001 eqs 2-3):

    time update         x- = F x+ + G u,          P- = F P+ F' + Q
    measurement update  S = H P- H' + R,  K = P- H' S^-1,  x+ = x- + K (z - H x-)
                        P+ = (I - K H) P- (I - K H)' + K R K'      (Joseph form)
    NIS                 nu' S^-1 nu ~ chi2(m) for a consistent filter

The Joseph form keeps P symmetric positive semi-definite under round-off, which matters when a
filter runs for an hour at 100 Hz.  Steady-state covariances come from the discrete algebraic
Riccati equation (:func:`steady_state`), and the residual diagnostics (normalised innovations,
Ljung-Box whiteness test) from :func:`normalised_innovations` and :func:`whiteness`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import linalg, stats

FloatArray = NDArray[np.float64]


# ------------------------------------------------------------------------------------------
# numpy versions
# ------------------------------------------------------------------------------------------
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
    gate_nis: float = math.inf, huber_sigmas: float = math.inf,
) -> tuple[FloatArray, FloatArray, float, float, float]:  # fmt: skip
    """numpy reference of :func:`update_robust_scalar_nb`: ``(x+, P+, S, nis, weight)``."""
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
    xn, Pn, _, _ = update_joseph(x, P, [float(h @ x) + innov], h[None, :], [[r / w]])
    return xn, Pn, s, nis, w


def nis(innov: ArrayLike, S: ArrayLike) -> FloatArray:
    """Normalised innovation squared ``nu' S^-1 nu`` (Bar-Shalom et al. 2001, eq 5.4.1-2).

    Scalars: ``innov`` (N,), ``S`` (N,) give (N,); vectors: ``innov`` (N, m), ``S`` (N, m, m)
    give (N,).  NaN where there was no update (NaN innovation or S <= 0).
    """
    nu = np.asarray(innov, dtype=float)
    s = np.asarray(S, dtype=float)
    if nu.ndim == s.ndim:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(s > 0, nu * nu / np.where(s > 0, s, 1.0), np.nan)
    out = np.full(nu.shape[0], np.nan)
    ok = np.isfinite(nu).all(axis=1) & np.isfinite(s).all(axis=(1, 2))
    if ok.any():
        sol = np.linalg.solve(s[ok], nu[ok][..., None])[..., 0]
        out[ok] = np.sum(nu[ok] * sol, axis=1)
    return out


def cholesky(A: ArrayLike) -> FloatArray:
    """numpy reference of :func:`cholesky_nb` (positive-definite A)."""
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


# ------------------------------------------------------------------------------------------
# numba kernels (in place, for recursive loops)
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def predict_nb(x: NDArray, P: NDArray, F: NDArray, Q: NDArray, Gu: NDArray) -> None:
    """In place: ``x <- F x + Gu``, ``P <- F P F' + Q`` (``Gu`` the already-multiplied input).

    Written as explicit loops (no temporaries but two small work arrays) for the per-row use.
    """
    n = x.size
    xn = np.empty(n)
    FP = np.empty((n, n))
    for i in range(n):
        acc = Gu[i]
        for j in range(n):
            acc += F[i, j] * x[j]
        xn[i] = acc
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += F[i, k] * P[k, j]
            FP[i, j] = acc
    for i in range(n):
        x[i] = xn[i]
        for j in range(i, n):
            acc = Q[i, j]
            for k in range(n):
                acc += FP[i, k] * F[j, k]
            P[i, j] = acc
    for i in range(n):
        for j in range(i):
            P[i, j] = P[j, i]


@numba.njit(cache=True, inline="always")
def predict_ws_nb(
    x: NDArray, P: NDArray, F: NDArray, Q: NDArray, Gu: NDArray, work: NDArray
) -> None:
    """:func:`predict_nb` with caller-owned scratch ``work`` of shape (2 n + 2, n) (the shape
    :func:`update_scalar_ws_nb` needs, so one buffer serves both): explicit loops, no
    allocation (the per-row use in compiled filter loops)."""
    n = x.size
    for i in range(n):
        acc = Gu[i]
        for j in range(n):
            acc += F[i, j] * x[j]
        work[0, i] = acc
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += F[i, k] * P[k, j]
            work[2 + i, j] = acc
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
def predict_sparse_nb(x: NDArray, P: NDArray, x_next: NDArray, F: NDArray, Q: NDArray) -> None:
    """In place: ``x <- x_next``, ``P <- F P F' + Q`` for a Jacobian close to the identity.

    For the Jacobian of a nonlinear process model (``x_next = f(x, u, dt)`` computed by the
    model), which is mostly the identity: with F = I + D and D sparse,
    F P F' = A + A D' with A = P + D P, so the cost is O(n^2 + nnz(D) n) instead of O(n^3).
    """
    n = x.size
    rows = np.empty(n * n, dtype=np.int64)
    cols = np.empty(n * n, dtype=np.int64)
    vals = np.empty(n * n)
    nnz = 0
    for i in range(n):
        for k in range(n):
            d = F[i, k] - 1.0 if i == k else F[i, k]
            if d != 0.0:
                rows[nnz] = i
                cols[nnz] = k
                vals[nnz] = d
                nnz += 1
    A = P.copy()  # A = P + D P
    for e in range(nnz):
        i, k, d = rows[e], cols[e], vals[e]
        for j in range(n):
            A[i, j] += d * P[k, j]
    for i in range(n):  # P = A + A D' + Q
        for j in range(n):
            P[i, j] = A[i, j] + Q[i, j]
    for e in range(nnz):
        j, k, d = rows[e], cols[e], vals[e]
        for i in range(n):
            P[i, j] += A[i, k] * d
    for i in range(n):
        x[i] = x_next[i]
        for j in range(i + 1, n):
            m = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = m
            P[j, i] = m


@numba.njit(cache=True)
def update_scalar_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float
) -> float:
    """In place Joseph-form update with one scalar measurement; returns S = h P h' + r.

    ``innov`` is ``z - h x`` computed by the caller (so that angle measurements can be wrapped
    to [-pi, pi) first).  The covariance is the Joseph product
    (I - k h) P (I - k h)' + r k k' with k = P h' / S, which for a symmetric P expands to
    P - k (Ph)' - (Ph) k' + S k k' for any gain k (Simon 2006, eq 5.19); it is evaluated
    elementwise on the upper triangle and mirrored, so P stays exactly symmetric, in O(n^2),
    skipping the zero entries of ``h``.  A non-positive S (no information, or a broken
    prior) leaves x and P unchanged.
    """
    n = x.size
    ph = np.zeros(n)
    for j in range(n):
        hj = h[j]
        if hj != 0.0:
            for i in range(n):
                ph[i] += P[i, j] * hj
    s = r
    for i in range(n):
        s += h[i] * ph[i]
    if not s > 0.0:
        return s
    k = ph / s
    for i in range(n):
        x[i] += k[i] * innov
    for i in range(n):
        ki, phi = k[i], ph[i]
        for j in range(i, n):
            m = P[i, j] - ki * ph[j] - phi * k[j] + s * ki * k[j]
            P[i, j] = m
            P[j, i] = m
    return s


@numba.njit(cache=True, inline="always")
def update_scalar_ws_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, work: NDArray
) -> float:
    """:func:`update_scalar_nb` with caller-owned scratch ``work`` (at least 2 rows of n):
    row 0 holds P h', row 1 the gain; the same expanded Joseph form, no allocation."""
    n = x.size
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += P[i, j] * h[j]
        work[0, i] = acc
    s = r
    for i in range(n):
        s += h[i] * work[0, i]
    if not s > 0.0:
        return s
    for i in range(n):
        work[1, i] = work[0, i] / s
        x[i] += work[1, i] * innov
    for i in range(n):
        ki, phi = work[1, i], work[0, i]
        for j in range(i, n):
            m = P[i, j] - ki * work[0, j] - phi * work[1, j] + s * ki * work[1, j]
            P[i, j] = m
            P[j, i] = m
    return s


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
def update_robust_scalar_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, gate_nis: float,
    huber_sigmas: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Gated, Huber-weighted scalar update; returns ``(S, nis, weight)``.

    ``nis = innov^2 / S`` with S the prior innovation variance.  A measurement with
    ``nis > gate_nis`` is rejected (weight 0, x and P unchanged).  Otherwise its noise is
    inflated to ``r / w`` with the Huber weight ``w`` of :func:`huber_weight_nb` (1 for
    ``huber_sigmas = inf``), i.e. one iteration of the iteratively reweighted Kalman update
    (Karlgaard & Schaub, J. Guid. Control Dyn. 30(6), 2007, sec. III).
    """
    n = x.size
    s = r
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += P[i, j] * h[j]
        s += h[i] * acc
    if not s > 0.0:
        return s, math.nan, 0.0
    nis = innov * innov / s
    if nis > gate_nis:
        return s, nis, 0.0
    w = huber_weight_nb(nis, huber_sigmas)
    update_scalar_nb(x, P, innov, h, r / w)
    return s, nis, w


@numba.njit(cache=True)
def cholesky_nb(A: NDArray) -> NDArray:
    """Lower-triangular L with L L' = A for a small symmetric positive-definite A
    (Cholesky-Banachiewicz).  A non-positive pivot (A not positive definite) is set to 0 with
    its column, so a semi-definite A gives a valid factor of its positive part."""
    n = A.shape[0]
    L = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            acc = A[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = math.sqrt(acc) if acc > 0.0 else 0.0
            elif L[j, j] > 0.0:
                L[i, j] = acc / L[j, j]
    return L


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
    for i in range(m):
        # innovation of component i after the earlier ones: z_w,i - Hw_i (x - x_start)
        nu = zw[i]
        for c in range(x.size):
            nu -= Hw[i, c] * (x[c] - x0[c])
        update_scalar_nb(x, P, nu, np.ascontiguousarray(Hw[i]), 1.0)
    return S


@numba.njit(cache=True)
def rts_smooth_nb(
    x_post: NDArray, P_post: NDArray, x_prior: NDArray, P_prior: NDArray, F: NDArray
) -> tuple[NDArray, NDArray]:
    """Rauch-Tung-Striebel smoother (numba); see :func:`rts_smooth` for the arrays."""
    n, m = x_post.shape
    xs = x_post.copy()
    Ps = P_post.copy()
    for k in range(n - 2, -1, -1):
        Pp = P_prior[k + 1]
        # C = P_k F' Pp^-1, via the Cholesky factor of the (SPD) predicted covariance
        L = cholesky_nb(Pp)
        PF = P_post[k] @ F[k + 1].T
        C = np.empty((m, m))
        for r in range(m):
            y = np.empty(m)
            for i in range(m):  # L y = PF[r]
                acc = PF[r, i]
                for j in range(i):
                    acc -= L[i, j] * y[j]
                y[i] = acc / L[i, i] if L[i, i] > 0.0 else 0.0
            for i in range(m - 1, -1, -1):  # L' c = y
                acc = y[i]
                for j in range(i + 1, m):
                    acc -= L[j, i] * C[r, j]
                C[r, i] = acc / L[i, i] if L[i, i] > 0.0 else 0.0
        xs[k] = x_post[k] + C @ (xs[k + 1] - x_prior[k + 1])
        D = Ps[k + 1] - Pp
        Pk = P_post[k] + C @ D @ C.T
        Ps[k] = 0.5 * (Pk + Pk.T)
    return xs, Ps


# ------------------------------------------------------------------------------------------
# steady state
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteadyState:
    """Steady-state Kalman filter of a time-invariant system.

    ``P_prior`` = P- (before a measurement update), ``P_post`` = P+ (after), ``K`` the gain
    (n, m), ``S`` the innovation covariance (m, m).
    """

    P_prior: FloatArray
    P_post: FloatArray
    K: FloatArray
    S: FloatArray


def steady_state(F: ArrayLike, H: ArrayLike, Q: ArrayLike, R: ArrayLike) -> SteadyState:
    """Solve the discrete algebraic Riccati equation of the filter

        P- = F P- F' - F P- H' (H P- H' + R)^-1 H P- F' + Q,

    (scipy's control-form DARE applied to the dual pair (F', H')), then
    ``P+ = (I - K H) P-`` with ``K = P- H' S^-1``.  Requires (F, H) detectable and
    (F, Q^1/2) stabilisable.
    """
    F = np.asarray(F, dtype=float)
    H = np.atleast_2d(np.asarray(H, dtype=float))
    Q = np.asarray(Q, dtype=float)
    R = np.atleast_2d(np.asarray(R, dtype=float))
    Pm = linalg.solve_discrete_are(F.T, H.T, Q, R)
    Pm = 0.5 * (Pm + Pm.T)
    S = H @ Pm @ H.T + R
    K = linalg.solve(S, H @ Pm, assume_a="pos").T
    ikh = np.eye(F.shape[0]) - K @ H
    Pp = ikh @ Pm @ ikh.T + K @ R @ K.T
    return SteadyState(Pm, 0.5 * (Pp + Pp.T), K, S)


# ------------------------------------------------------------------------------------------
# residual diagnostics
# ------------------------------------------------------------------------------------------
def normalised_innovations(innov: ArrayLike, S: ArrayLike) -> FloatArray:
    """Scalar innovations divided by their predicted 1-sigma ``sqrt(S)``; NaN stays NaN.

    For a consistent filter these are zero-mean, unit-variance and white (seed 001, sec. V:
    "the residuals should be white noise with the following variances").
    """
    nu = np.asarray(innov, dtype=float)
    s = np.asarray(S, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(s > 0, nu / np.sqrt(np.where(s > 0, s, 1.0)), np.nan)


def autocorrelation(x: ArrayLike, max_lag: int) -> FloatArray:
    """Sample autocorrelation rho_1..rho_max_lag of a series (finite values only, mean removed)."""
    v = np.asarray(x, dtype=float)
    v = v[np.isfinite(v)]
    n = v.size
    out = np.zeros(max_lag)
    if n <= max_lag + 1:
        return out
    v = v - v.mean()
    c0 = float(v @ v)
    if c0 <= 0.0:
        return out
    for k in range(1, max_lag + 1):
        out[k - 1] = float(v[k:] @ v[:-k]) / c0
    return out


@dataclass(frozen=True)
class Whiteness:
    """Result of the Ljung-Box portmanteau test on one residual sequence.

    ``q``: Ljung-Box statistic Q = n (n+2) sum_k rho_k^2 / (n-k), k = 1..lags (chi-squared
    with ``lags`` degrees of freedom for white noise); ``p_value``; ``white``: p >= alpha;
    ``rho``: the autocorrelations; ``colour``: sum_k rho_k^2, a size-free measure of colour
    (about lags/n for white noise) useful to compare two vehicle files on the same drive;
    ``frac_outside``: share of |rho_k| above the 95 % white-noise bound 1.96/sqrt(n);
    ``nis_mean``: mean squared normalised innovation (1 for a consistent filter).
    """

    n: int
    lags: int
    q: float
    p_value: float
    white: bool
    rho: FloatArray
    colour: float
    frac_outside: float
    nis_mean: float

    def as_dict(self) -> dict[str, float | int | bool | list[float]]:
        return {
            "n": self.n,
            "lags": self.lags,
            "ljung_box_q": self.q,
            "p_value": self.p_value,
            "white": self.white,
            "autocorr": [float(r) for r in self.rho],
            "colour": self.colour,
            "frac_autocorr_outside_95": self.frac_outside,
            "nis_mean": self.nis_mean,
        }


def whiteness(normalised: ArrayLike, lags: int = 20, alpha: float = 0.05) -> Whiteness:
    """Ljung-Box whiteness test of normalised innovations (finite values only).

    Fewer than ``lags + 2`` samples gives an inconclusive result (``white`` True, p = 1).
    """
    v = np.asarray(normalised, dtype=float)
    v = v[np.isfinite(v)]
    n = int(v.size)
    if n < lags + 2:
        return Whiteness(n, lags, 0.0, 1.0, True, np.zeros(lags), 0.0, 0.0,
                         float(np.mean(v**2)) if n else 0.0)  # fmt: skip
    rho = autocorrelation(v, lags)
    k = np.arange(1, lags + 1)
    q = float(n * (n + 2) * np.sum(rho**2 / (n - k)))
    p = float(stats.chi2.sf(q, lags))
    bound = 1.96 / np.sqrt(n)
    return Whiteness(
        n, lags, q, p, bool(p >= alpha), rho, float(np.sum(rho**2)),
        float(np.mean(np.abs(rho) > bound)), float(np.mean(v**2)),
    )  # fmt: skip
