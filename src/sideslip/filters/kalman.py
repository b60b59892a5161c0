"""Generic, stateless linear Kalman-filter numerics.

Plain functions in the GTSAM style: every call takes the state and covariance and returns new
ones; nothing is configured by assigning attributes.  Two flavours of the same equations:

* numpy functions (:func:`predict`, :func:`update_joseph`) for any dimension, used outside
  hot loops and by tests;
* numba kernels (:func:`predict_nb`, :func:`update_scalar_nb`, and their ``_ws_nb`` forms
  that take caller-owned scratch space so a loop over a drive allocates nothing) for
  recursive loops over a drive: a vector measurement with independent noise components is
  processed as a sequence of scalar updates, which is algebraically the same as the batch
  update and needs no matrix inversion.

Notation (Simon, *Optimal State Estimation*, ch. 5; seed 001 eqs 2-3):

    time update         x- = F x+ + G u,          P- = F P+ F' + Q
    measurement update  S = H P- H' + R,  K = P- H' S^-1,  x+ = x- + K (z - H x-)
                        P+ = (I - K H) P- (I - K H)' + K R K'      (Joseph form)

The Joseph form keeps P symmetric positive semi-definite under round-off, which matters when a
filter runs for an hour at 100 Hz.  Steady-state covariances come from the discrete algebraic
Riccati equation (:func:`steady_state`), and the residual diagnostics (normalised innovations,
Ljung-Box whiteness test) from :func:`normalised_innovations` and :func:`whiteness`.
"""

from __future__ import annotations

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


# ------------------------------------------------------------------------------------------
# numba kernels (in place, for recursive loops)
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def predict_nb(x: NDArray, P: NDArray, F: NDArray, Q: NDArray, Gu: NDArray) -> None:
    """In place: ``x <- F x + Gu``, ``P <- F P F' + Q`` (``Gu`` the already-multiplied input).

    Allocates its scratch space; loops over many rows use :func:`predict_ws_nb`.
    """
    n = x.size
    predict_ws_nb(x, P, F, Q, Gu, np.empty((2 * n + 2, n)))


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
def update_scalar_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float
) -> float:
    """In place Joseph-form update with one scalar measurement; returns S = h P h' + r.

    ``innov`` is ``z - h x`` computed by the caller (so that angle measurements can be wrapped
    to [-pi, pi) first).  The covariance is the Joseph product (I - k h) P (I - k h)' + r k k'
    with k = P h' / S, formed as products (not expanded), so it stays positive semi-definite
    under round-off and for any gain.  Allocates its scratch space; loops over many rows use
    :func:`update_scalar_ws_nb`.
    """
    n = x.size
    return update_scalar_ws_nb(x, P, innov, h, r, np.empty((2 * n + 2, n)))


@numba.njit(cache=True, inline="always")
def update_scalar_ws_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, work: NDArray
) -> float:
    """:func:`update_scalar_nb` with caller-owned scratch ``work`` of shape (2 n + 2, n):
    rows 0-1 P h' and the gain, rows 2 .. n+1 (I - k h), rows n+2 .. 2n+1 (I - k h) P."""
    n = x.size
    s = r
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += P[i, j] * h[j]
        work[0, i] = acc
        s += h[i] * acc
    for i in range(n):
        work[1, i] = work[0, i] / s
        x[i] += work[1, i] * innov
    for i in range(n):
        for j in range(n):
            work[2 + i, j] = (1.0 if i == j else 0.0) - work[1, i] * h[j]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for c in range(n):
                acc += work[2 + i, c] * P[c, j]
            work[2 + n + i, j] = acc
    # P = (I - k h) P (I - k h)' + r k k'
    for i in range(n):
        for j in range(i + 1):
            acc = r * work[1, i] * work[1, j]
            for c in range(n):
                acc += work[2 + n + i, c] * work[2 + j, c]
            P[i, j] = acc
            P[j, i] = acc
    return s


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
