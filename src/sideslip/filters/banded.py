"""Linear least squares on a Markov chain of states: banded normal equations, O(N).

The problem (a linear Gaussian factor graph over a chain of states x_0 .. x_{N-1}, each of
dimension ``nx``) is

    minimise  (x_0 - x0)' Lam0 (x_0 - x0)                                   prior factor
            + sum_k  sum_m  w[k, m] (h[k, m] . x_k - z[k, m])^2              unary factors
            + sum_k  sum_i  wq[k, i] (x_{k+1} - F_k x_k - g_k)_i^2           dynamic factors

with weights w = 1/sigma^2 (a weight of 0 removes a factor, e.g. a missing sample).  Every
factor touches at most two consecutive states, so with the variables ordered
[x_0, x_1, ...] the normal matrix H = J' W J is symmetric positive definite and banded with
lower bandwidth p = 2 nx - 1.  It is stored in LAPACK's lower band form ``ab[d, j] = H[j + d, j]``
(shape (p + 1, N nx)); no N x N matrix is ever formed.  Time and memory are O(N nx p^2) and
O(N nx p).

Functions
---------
* :func:`assemble_chain` -- the normal equations (band + right-hand side), numba-compiled.
* :func:`solve_chain` -- banded Cholesky (compiled, LAPACK's ``pbtf2`` algorithm) and the solution.
* :func:`selected_inverse` -- the band of H^{-1} (Takahashi et al. 1973 recursion on the
  Cholesky factor), giving marginal covariances without a dense inverse.
* :func:`fixed_lag_chain` -- a fixed-lag smoother on the same factors: a sliding window
  reduced onto its first state by block elimination from its far end, whose oldest state is
  then marginalised exactly (Schur complement) into the next window's prior.
* :func:`cholesky_band`, :func:`solve_band` -- the numba banded Cholesky (whole chains and windows).

Prior convention: the prior is given in information form ``(Lam0, eta0)`` with
``eta0 = Lam0 x0``; this is what marginalisation produces.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@numba.njit(cache=True)
def assemble_chain(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    Lam0: FloatArray,
    eta0: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Banded normal equations of the chain problem (module docstring).

    Parameters
    ----------
    F : (N-1, nx, nx) transition matrices, ``x_{k+1} = F_k x_k + g_k + noise``.
    g : (N-1, nx) known input terms of the transition.
    wq : (N-1, nx) weights 1/sigma^2 of the dynamic residual components (diagonal noise).
    Hu : (N, M, nx) rows of the unary (measurement) factors of each state.
    zu : (N, M) their measured values.
    wu : (N, M) their weights 1/sigma^2; 0 where a factor is absent.
    Lam0 : (nx, nx) prior information matrix on x_0.
    eta0 : (nx,) prior information vector (Lam0 x0).

    Returns
    -------
    ab : (2 nx, N nx) lower band form of H, ``ab[d, j] = H[j + d, j]``.
    rhs : (N nx,) right-hand side J' W b.
    """
    N = Hu.shape[0]
    nx = Hu.shape[2]
    ab = np.empty((2 * nx, N * nx))
    rhs = np.empty(N * nx)
    _assemble_into(ab, rhs, F, g, wq, Hu, zu, wu, Lam0, eta0)  # zeroes them first
    return ab, rhs


@numba.njit(cache=True)
def _assemble_into(
    ab: FloatArray,
    rhs: FloatArray,
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    Lam0: FloatArray,
    eta0: FloatArray,
) -> None:
    """:func:`assemble_chain` into preallocated (zeroed here) ``ab`` and ``rhs``."""
    N = Hu.shape[0]
    nx = Hu.shape[2]
    ab[:, :] = 0.0
    rhs[:] = 0.0
    # prior on x_0
    for i in range(nx):
        rhs[i] += eta0[i]
        for j in range(i + 1):
            ab[i - j, j] += Lam0[i, j]
    add_chain_factors(ab, rhs, F[: N - 1], g, wq, Hu, zu, wu, 0, 0)


@numba.njit(cache=True)
def add_chain_factors(
    ab: FloatArray,
    rhs: FloatArray,
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    first_state: int,
    first_unary: int,
) -> None:
    """Add one chunk of the chain factors to the banded normal equations ``ab``, ``rhs`` of
    the whole chain (layout and arithmetic of :func:`assemble_chain`, which
    calls it for the whole chain; without the prior, which the caller adds first).

    Local row k is state ``first_state + k``; the unary factors of the rows from
    ``first_unary`` on and every dynamic factor of ``F`` (k to k + 1) are added.  A chunk that
    adds the unary factors of states a .. b-1 and the dynamic factors a-1 .. b-2 (those into
    its states) adds to each entry in the same order as one assembly of the whole chain (the
    unary factors of a state, then the dynamic factor into it, then the one out of it), so
    the sums are bit-identical however the chain is chunked.
    """
    N = Hu.shape[0]
    M = Hu.shape[1]
    nx = Hu.shape[2]
    for k in range(first_unary, N):
        o = (first_state + k) * nx
        for m in range(M):
            w = wu[k, m]
            if w == 0.0:
                continue
            for i in range(nx):
                hi = Hu[k, m, i]
                rhs[o + i] += w * hi * zu[k, m]
                for j in range(i + 1):
                    ab[i - j, o + j] += w * hi * Hu[k, m, j]
    for k in range(F.shape[0]):
        o = (first_state + k) * nx
        o1 = o + nx
        for c in range(nx):
            w = wq[k, c]
            for i in range(nx):
                fi = F[k, c, i]
                rhs[o + i] -= w * fi * g[k, c]
                for j in range(i + 1):
                    ab[i - j, o + j] += w * fi * F[k, c, j]
                ab[o1 + c - (o + i), o + i] -= w * fi
            ab[0, o1 + c] += w
            rhs[o1 + c] += w * g[k, c]


def solve_chain(
    ab: FloatArray, rhs: FloatArray, overwrite: bool = False
) -> tuple[FloatArray, FloatArray]:
    """Solve H x = rhs for SPD banded H; returns ``(x, cb)`` with cb the lower Cholesky band.

    The compiled :func:`cholesky_band` and its substitutions (the algorithm of LAPACK's
    unblocked ``pbtf2``, which ``pbtrf`` uses at these bandwidths; no library call per column).
    ``ab`` and ``rhs`` are left unchanged unless ``overwrite`` (then ``cb`` is ``ab`` and ``x``
    is ``rhs``, no copies).  Raises ``numpy.linalg.LinAlgError`` if H is not positive definite
    (an unobservable state: give every state a prior or a dynamic factor).
    """
    cb = ab if overwrite else np.array(ab, dtype=float, order="C")
    if not cholesky_band(cb):
        raise np.linalg.LinAlgError("banded normal matrix is not positive definite")
    x = rhs if overwrite else np.array(rhs, dtype=float)
    _solve_band_inplace(cb, x)
    return x, cb


@numba.njit(cache=True)
def cholesky_band(ab: FloatArray) -> bool:
    """In-place lower banded Cholesky (same layout as LAPACK ``pbtrf``); False if not SPD."""
    p = ab.shape[0] - 1
    n = ab.shape[1]
    for j in range(n):
        d = ab[0, j]
        if not d > 0.0:
            return False
        ljj = np.sqrt(d)
        ab[0, j] = ljj
        m = min(p, n - 1 - j)
        for i in range(1, m + 1):
            ab[i, j] /= ljj
        for c in range(1, m + 1):
            lc = ab[c, j]
            for i in range(c, m + 1):
                ab[i - c, j + c] -= ab[i, j] * lc
    return True


@numba.njit(cache=True)
def solve_band(cb: FloatArray, rhs: FloatArray) -> FloatArray:
    """Solve L L' x = rhs with L the lower Cholesky band from :func:`cholesky_band`."""
    y = rhs.copy()
    _solve_band_inplace(cb, y)
    return y


@numba.njit(cache=True)
def _solve_band_inplace(cb: FloatArray, y: FloatArray) -> None:
    p = cb.shape[0] - 1
    n = cb.shape[1]
    for j in range(n):
        y[j] /= cb[0, j]
        m = min(p, n - 1 - j)
        for i in range(1, m + 1):
            y[j + i] -= cb[i, j] * y[j]
    for j in range(n - 1, -1, -1):
        s = y[j]
        m = min(p, n - 1 - j)
        for i in range(1, m + 1):
            s -= cb[i, j] * y[j + i]
        y[j] = s / cb[0, j]


@numba.njit(cache=True)
def selected_inverse(cb: FloatArray) -> FloatArray:
    """Band of S = H^{-1} from the lower Cholesky band of H (Takahashi recursion).

    Returns ``sb`` with ``sb[d, j] = S[j + d, j]`` for d <= p: the marginal variances are
    ``sb[0]`` and the covariances of neighbouring variables the other rows.  Uses only the band
    (``S_ij`` for |i - j| <= p depends only on band entries of S and L), so O(N p^2).

    Recursion, for j = n-1 .. 0 with L's column j below the diagonal (rows j+1 .. j+p):
        S_ij = -(1/L_jj) sum_k L_kj S_ik           (i = j+1 .. j+p)
        S_jj = 1/L_jj^2 - (1/L_jj) sum_k L_kj S_kj
    """
    sb = np.zeros(cb.shape)
    _selected_inverse_into(cb, sb)
    return sb


@numba.njit(cache=True)
def _selected_inverse_into(cb: FloatArray, sb: FloatArray) -> None:
    p = cb.shape[0] - 1
    n = cb.shape[1]
    for j in range(n - 1, -1, -1):
        m = min(p, n - 1 - j)
        ljj = cb[0, j]
        for a in range(1, m + 1):
            i = j + a
            s = 0.0
            for c in range(1, m + 1):
                k = j + c
                if i >= k:
                    sik = sb[i - k, k]
                else:
                    sik = sb[k - i, i]
                s += cb[c, j] * sik
            sb[a, j] = -s / ljj
        s = 0.0
        for c in range(1, m + 1):
            s += cb[c, j] * sb[c, j]
        sb[0, j] = 1.0 / (ljj * ljj) - s / ljj


@numba.njit(cache=True)
def fixed_lag_chain(
    F: FloatArray,
    g: FloatArray,
    wq: FloatArray,
    Hu: FloatArray,
    zu: FloatArray,
    wu: FloatArray,
    Lam0: FloatArray,
    eta0: FloatArray,
    lag: int,
    n_out: int = -1,
) -> tuple[FloatArray, FloatArray, FloatArray, bool, FloatArray, FloatArray]:
    """Fixed-lag smoother on the chain problem: state k estimated from the data up to k + lag.

    A window holds the states s .. s+lag (``lag`` dynamic steps, as the paper's window of 5
    samples after its prior block), with the prior on x_s and all factors inside the window.
    Its normal equations are block tridiagonal; they are reduced onto x_s by eliminating the
    window's states from its far end, x_{s+lag} .. x_{s+1} (block Gaussian elimination, each
    step a Schur complement of an nx x nx block), which leaves the marginal information of
    x_s: its mean and marginal covariance, with no full solve or selected inverse of the
    window.  Then x_s is marginalised out exactly: the factors touching it (its prior, its
    unary factors, the dynamic factor s -> s+1) are reduced by a Schur complement to a
    Gaussian prior ``(Lam, eta)`` on x_{s+1}.  Since the problem is linear, this equals the
    batch solution of the data up to s + lag; lag = 0 is the Kalman filter, lag >= N-1 the
    batch smoother.  Each factor's information blocks are formed once per row, so a window
    costs O(lag nx^3).  Memory is O(N nx^2) for those blocks besides the inputs/outputs.

    Streaming: with ``n_out`` < N only the first ``n_out`` states are output (the inputs must
    then reach max(lag, 1) rows beyond them, or the end of the drive), and the returned prior
    ``(Lam, eta)`` on state ``n_out`` continues the smoother on the next chunk; chunked and
    whole runs give identical results.  ``n_out = -1`` (default) outputs all N states.

    Returns ``(x, var, cov, ok, Lam, eta)``: (n_out, nx) estimates, (n_out, nx) marginal
    variances, (n_out, nx - 1) covariances of neighbouring components (cov[k, i] between
    components i + 1 and i of state k; for nx = 2 the whole off-diagonal), False if a window
    was not positive definite (then the remaining rows repeat the last estimate), and the
    prior on the next state.
    """
    N = Hu.shape[0]
    M = Hu.shape[1]
    nx = Hu.shape[2]
    if n_out < 0 or n_out > N:
        n_out = N
    x_out = np.zeros((n_out, nx))
    var_out = np.zeros((n_out, nx))
    cov_out = np.zeros((n_out, max(nx - 1, 0)))
    Lam = Lam0.copy()
    eta = eta0.copy()
    # information blocks of each row's factors, for the rows the windows reach
    last = min(N - 1, n_out - 1 + lag)
    U = np.zeros((last + 1, nx, nx))  # unary: sum_m w h h'
    u = np.zeros((last + 1, nx))  # sum_m w h z
    for k in range(last + 1):
        for m in range(M):
            w = wu[k, m]
            if w == 0.0:
                continue
            for i in range(nx):
                u[k, i] += w * Hu[k, m, i] * zu[k, m]
                for j in range(nx):
                    U[k, i, j] += w * Hu[k, m, i] * Hu[k, m, j]
    nd = min(N - 1, max(last, n_out))  # dynamic factors: the windows' and x_s's marginalisation
    WF = np.zeros((nd, nx, nx))  # dynamic k -> k+1: W F (the coupling is -W F)
    FWF = np.zeros((nd, nx, nx))  # F' W F on x_k
    Wg = np.zeros((nd, nx))  # W g on x_{k+1}
    FWg = np.zeros((nd, nx))  # F' W g on x_k (enters with a minus sign)
    for k in range(nd):
        for c in range(nx):
            Wg[k, c] = wq[k, c] * g[k, c]
            for i in range(nx):
                WF[k, c, i] = wq[k, c] * F[k, c, i]
        for i in range(nx):
            acc = 0.0
            for c in range(nx):
                acc += F[k, c, i] * Wg[k, c]
            FWg[k, i] = acc
            for j in range(nx):
                acc = 0.0
                for c in range(nx):
                    acc += F[k, c, i] * WF[k, c, j]
                FWF[k, i, j] = acc
    A = np.zeros((nx, nx))
    r = np.zeros(nx)
    X = np.zeros((nx, nx))
    A11 = np.zeros((nx, nx))
    b1 = np.zeros(nx)
    for s in range(n_out):
        e = min(s + lag, N - 1)
        # the window's far end: unary factors of x_e and the dynamic factor into it
        for i in range(nx):
            r[i] = u[e, i]
            for j in range(nx):
                A[i, j] = U[e, i, j]
        if e > s:
            for i in range(nx):
                A[i, i] += wq[e - 1, i]
                r[i] += Wg[e - 1, i]
        else:
            for i in range(nx):
                r[i] += eta[i]
                for j in range(nx):
                    A[i, j] += Lam[i, j]
        good = True
        for j in range(e, s, -1):
            # eliminate x_j onto x_{j-1}: coupling H[x_j, x_{j-1}] = -W F_{j-1}
            d = j - 1
            for i in range(nx):
                for c in range(nx):
                    X[i, c] = WF[d, i, c]
            if not _small_spd_solve(A, X, r):  # X <- A^-1 W F, r <- A^-1 r
                good = False
                break
            for i in range(nx):
                acc = u[d, i] - FWg[d, i]
                for c in range(nx):
                    acc += WF[d, c, i] * r[c]
                b1[i] = acc
                for q in range(nx):
                    acc = U[d, i, q] + FWF[d, i, q]
                    for c in range(nx):
                        acc -= WF[d, c, i] * X[c, q]
                    A11[i, q] = acc
            if d > s:  # the dynamic factor into x_{j-1}, else the prior on x_s
                for i in range(nx):
                    A11[i, i] += wq[d - 1, i]
                    b1[i] += Wg[d - 1, i]
            else:
                for i in range(nx):
                    b1[i] += eta[i]
                    for q in range(nx):
                        A11[i, q] += Lam[i, q]
            for i in range(nx):
                r[i] = b1[i]
                for q in range(nx):
                    A[i, q] = 0.5 * (A11[i, q] + A11[q, i])
        if good:  # marginal of x_s: mean A^-1 r, covariance A^-1
            for i in range(nx):
                for c in range(nx):
                    X[i, c] = 1.0 if i == c else 0.0
            good = _small_spd_solve(A, X, r)
        if not good:
            for k in range(s, n_out):
                x_out[k] = x_out[max(s - 1, 0)]
                var_out[k] = var_out[max(s - 1, 0)]
                cov_out[k] = cov_out[max(s - 1, 0)]
            return x_out, var_out, cov_out, False, Lam, eta
        for i in range(nx):
            x_out[s, i] = r[i]
            var_out[s, i] = X[i, i]
        for i in range(nx - 1):
            cov_out[s, i] = 0.5 * (X[i + 1, i] + X[i, i + 1])
        if s == N - 1:
            break
        # Marginalise x_s: information of (x_s, x_{s+1}) from the factors touching x_s:
        #   A11 = Lam + sum w h h' + F' W F,  A12 = -F' W,  A22 = W
        #   b1  = eta + sum w h z - F' W g,   b2  = W g
        # -> prior on x_{s+1}:  Lam' = W - (W F) A11^-1 (W F)',  eta' = W g + (W F) A11^-1 b1
        for i in range(nx):
            b1[i] = eta[i] + u[s, i] - FWg[s, i]
            for j in range(nx):
                A11[i, j] = Lam[i, j] + U[s, i, j] + FWF[s, i, j]
        # solve A11 [X | y] = [(W F)' | b1] by a small dense Cholesky (A11 is SPD)
        for i in range(nx):
            for j in range(nx):
                X[i, j] = WF[s, j, i]
        if not _small_spd_solve(A11, X, b1):
            for k in range(s + 1, n_out):
                x_out[k] = x_out[s]
                var_out[k] = var_out[s]
                cov_out[k] = cov_out[s]
            return x_out, var_out, cov_out, False, Lam, eta
        for i in range(nx):
            acc = Wg[s, i]
            for c in range(nx):
                acc += WF[s, i, c] * b1[c]
            eta[i] = acc
            for j in range(i + 1):
                acc = 0.0
                for c in range(nx):
                    acc += WF[s, i, c] * X[c, j]
                v = (wq[s, i] if i == j else 0.0) - acc
                Lam[i, j] = v
                Lam[j, i] = v
    return x_out, var_out, cov_out, True, Lam, eta


@numba.njit(cache=True)
def _small_spd_solve(A: FloatArray, X: FloatArray, y: FloatArray) -> bool:
    """In place: A <- its Cholesky factor, X <- A^-1 X, y <- A^-1 y; False if not SPD."""
    n = A.shape[0]
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= A[j, k] * A[j, k]
        if not d > 0.0:
            return False
        A[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            v = A[i, j]
            for k in range(j):
                v -= A[i, k] * A[j, k]
            A[i, j] = v / A[j, j]
    for col in range(X.shape[1] + 1):
        for i in range(n):  # forward: L z = b
            v = y[i] if col == X.shape[1] else X[i, col]
            for k in range(i):
                v -= A[i, k] * (y[k] if col == X.shape[1] else X[k, col])
            if col == X.shape[1]:
                y[i] = v / A[i, i]
            else:
                X[i, col] = v / A[i, i]
        for i in range(n - 1, -1, -1):  # backward: L' x = z
            v = y[i] if col == X.shape[1] else X[i, col]
            for k in range(i + 1, n):
                v -= A[k, i] * (y[k] if col == X.shape[1] else X[k, col])
            if col == X.shape[1]:
                y[i] = v / A[i, i]
            else:
                X[i, col] = v / A[i, i]
    return True
